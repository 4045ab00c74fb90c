# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The batch path against N single-body Steppers, and its refusals."""

import tracemalloc

import numpy as np
import pytest

from rb_sim_ros import IntegrationError, RigidBody, so3, State, Stepper, Wrench
from rb_sim_ros.batch import BatchStepper

DT = 1e-3


def _bodies(n, seed=0):
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.5, 3.0, n)
    inertias = []
    for k in range(n):
        moments = np.sort(rng.uniform(0.5, 1.0, 3))
        q = so3.exp(rng.normal(size=3)) if k % 2 else np.eye(3)  # half are non-diagonal
        inertias.append(q @ np.diag(moments) @ q.T)
    rotations = np.array([so3.exp(rng.normal(size=3)) for _ in range(n)])
    return (masses, np.array(inertias), rng.normal(size=(n, 3)), rotations,
            rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 2.0, rng)


def _singles(masses, inertias, x, rot, v, w):
    return [Stepper(RigidBody(m, i), DT, State(xx, rr, vv, ww))
            for m, i, xx, rr, vv, ww in zip(masses, inertias, x, rot, v, w)]


def _compare(batch, singles, tol=1e-12):
    states = [s.state for s in singles]
    np.testing.assert_allclose(batch.positions(), [s.position for s in states], atol=tol)
    np.testing.assert_allclose(batch.linear_velocities(), [s.linear_velocity for s in states],
                               atol=tol)
    np.testing.assert_allclose(batch.angular_velocities(),
                               [s.angular_velocity for s in states], atol=tol)
    np.testing.assert_allclose(batch.rotations(), [s.rotation for s in states], atol=tol)


@pytest.mark.parametrize('frame', ['world', 'body'])
def test_batch_equals_single_body_steppers(frame):
    n = 12
    masses, inertias, x, rot, v, w, rng = _bodies(n)
    batch = BatchStepper(masses, inertias, DT, x, rot, v, w, block=5)  # several blocks
    singles = _singles(masses, inertias, x, rot, v, w)
    forces, torques = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 0.1
    batch.set_wrench(forces, torques, frame)
    for s, f, t in zip(singles, forces, torques):
        s.set_wrench(Wrench(f, t, frame))
    for s in singles:
        s.step(700)
    batch.step(700)
    _compare(batch, singles)
    # A wrench change on a subset, mid-run: history re-evaluated there, as in Stepper.
    forces2, torques2 = forces.copy(), torques.copy()
    forces2[::3] *= -2.0
    torques2[1::4] = 0.3
    batch.set_wrench(forces2, torques2, frame)
    for s, f, t in zip(singles, forces2, torques2):
        s.set_wrench(Wrench(f, t, frame))
    for s in singles:
        s.step(700)  # past 1024 steps: one orthonormalisation in between
    batch.step(400)
    batch.step(300)
    _compare(batch, singles)
    assert batch.step_count == 1400 and batch.time == pytest.approx(1.4)


def test_one_body():
    masses, inertias, x, rot, v, w, _ = _bodies(1, seed=3)
    batch = BatchStepper(masses, inertias, DT, x, rot, v, w)
    (single,) = _singles(masses, inertias, x, rot, v, w)
    batch.step(50)
    single.step(50)
    _compare(batch, [single])


@pytest.mark.parametrize('kwargs, field', [
    ({'masses': [1.0, -1.0]}, 'masses'),
    ({'inertias': [[1.0, 1.0, 3.0]] * 2}, 'triangle'),
    ({'inertias': [[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]] * 2}, 'symmetric'),
    ({'inertias': np.ones((3, 3))}, 'inertias must have shape'),
    ({'dt': 0.0}, 'dt'),
    ({'positions': np.full((2, 3), np.nan)}, 'positions must be finite'),
    ({'rotations': np.full((2, 3, 3), 2.0)}, 'rotations must be rotation'),
    ({'angular_velocities': np.zeros((3, 3))}, 'angular_velocities must have shape'),
])
def test_refusals(kwargs, field):
    args = {'masses': [1.0, 2.0], 'inertias': [[1.0, 1.0, 1.0]] * 2, 'dt': DT, **kwargs}
    with pytest.raises(ValueError, match=field):
        BatchStepper(**args)


def test_bad_wrench_and_n_change_nothing():
    batch = BatchStepper([1.0, 2.0], [[1, 1, 1]] * 2, DT, angular_velocities=[[1, 0, 0]] * 2)
    before = batch.angular_velocities()
    with pytest.raises(ValueError, match='forces'):
        batch.set_wrench(np.full((2, 3), np.inf), np.zeros((2, 3)))
    with pytest.raises(ValueError, match='n must be'):
        batch.step(-1)
    np.testing.assert_array_equal(batch.angular_velocities(), before)


def test_a_blow_up_names_the_body_and_changes_nothing():
    w = np.array([[1.0, 0.0, 0.0], [1e150, 2e150, 1.0], [0.0, 1.0, 0.0]])
    batch = BatchStepper([1.0] * 3, [[1.0, 2.0, 2.5]] * 3, DT, angular_velocities=w)
    with pytest.raises(IntegrationError, match='body 1 became non-finite'):
        batch.step(100)
    np.testing.assert_array_equal(batch.angular_velocities(), w)
    assert batch.step_count == 0


def test_memory_does_not_grow_with_steps():
    masses, inertias, x, rot, v, w, _ = _bodies(200)
    batch = BatchStepper(masses, inertias, DT, x, rot, v, w)
    batch.step(10)
    tracemalloc.start()
    batch.step(10)
    _, peak_short = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    batch.step(2000)
    _, peak_long = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak_long <= peak_short * 1.5
