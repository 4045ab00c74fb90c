# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The energy bound of each method (issue 28, N16): up to ``TURN_BOUNDS`` rad a step a
torque-free body keeps its kinetic energy within ENERGY_TOLERANCE over ENERGY_STEPS steps, as
docs/integrators.md says; a step beyond it warns (TurnWarning), once for each body."""

from pathlib import Path
import re
import warnings

import numpy as np
import pytest

from rb_sim_ros import IntegrationError, RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import multistep, so3
from rb_sim_ros.core.batch import BatchStepper
from rb_sim_ros.core.stepper import (ENERGY_STEPS, ENERGY_TOLERANCE, step_all, TURN_BOUNDS,
                                     TurnWarning)

DOCS = Path(__file__).resolve().parents[2] / 'docs' / 'integrators.md'
START = so3.exp((0.3, -0.2, 0.5))


def _bodies(count, seed):
    """(principal moments, unit spin axis): a <= b <= c <= a + b; every third a plate
    (c = a + b), every third a near-symmetric rod (a = b / 20), the fastest nutations."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        a, b = np.sort(rng.uniform(0.2, 1.0, 2))
        if k % 3 == 0:
            c = a + b
        elif k % 3 == 1:
            a, c = 0.05 * b, b * (1.0 + 0.05 * rng.uniform())
        else:
            c = rng.uniform(b, a + b)
        axis = rng.normal(size=3)
        out.append(((float(a), float(b), float(c)), axis / np.linalg.norm(axis)))
    return out


def _energy(moments, r, w):
    """omega . R diag(moments) R^T omega / 2 (an invariant of the torque-free motion)."""
    wb = np.array(r).reshape(3, 3).T @ np.array(w)
    return 0.5 * float(np.dot(np.array(moments) * wb, wb))


def _worst_drift(method, turn, bodies, steps):
    """The largest |E_n / E_0 - 1| over the steps and bodies, each spun at |omega| dt = turn."""
    worst = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', TurnWarning)
        for moments, axis in bodies:
            s = Stepper(RigidBody(1.0, moments), dt=turn, method=method,
                        state=State(rotation=START, angular_velocity=axis))
            e0 = _energy(moments, *s.components()[1:4:2])
            energies = []
            for _ in range(steps):
                s.step(1)
                energies.append(_energy(moments, *s.components()[1:4:2]))
            worst = max(worst, float(np.max(np.abs(np.array(energies) / e0 - 1.0))))
    return worst


@pytest.mark.parametrize('method', sorted(TURN_BOUNDS))
def test_energy_is_kept_within_the_tolerance_up_to_the_bound(method):
    bodies = _bodies(9, seed=28)
    bound = TURN_BOUNDS[method]
    assert _worst_drift(method, bound, bodies, ENERGY_STEPS) <= ENERGY_TOLERANCE


@pytest.mark.parametrize('method', sorted(TURN_BOUNDS))
def test_twice_the_bound_loses_the_tolerance(method):
    # The bound says where the energy goes, not a figure far on the safe side.
    bodies = _bodies(9, seed=28)
    assert _worst_drift(method, 2.0 * TURN_BOUNDS[method], bodies, ENERGY_STEPS) > \
        ENERGY_TOLERANCE


def test_the_flows_keep_energy_at_any_turn():
    bodies = _bodies(3, seed=5)
    for method in ('flow2', 'flow4'):
        assert _worst_drift(method, 0.9, bodies, 200) < 1e-13


def test_lie4_beyond_0_43_rad_a_step_is_outside_its_stability_interval():
    # Why lie4 gains energy at 0.7 rad a step (x2 in 82 steps, issue 28): AB4, its update of
    # omega, has a root of zeta^4 - zeta^3 = i h sum b_j zeta^(3 - j) outside the unit
    # circle for h beyond about 0.43 (docs/integrators.md); the weights are lie4's own.
    def largest_root(h):
        b = multistep.LIE4.velocity
        return max(abs(np.roots([1.0, -1.0 - 1j * h * b[0], -1j * h * b[1], -1j * h * b[2],
                                 -1j * h * b[3]])))
    assert largest_root(0.42) < 1.0 < largest_root(0.44)
    assert largest_root(0.7) > 1.4  # energy x2 within a few steps of the linearised motion


def test_the_docs_quote_the_bounds_the_stepper_warns_at():
    text = DOCS.read_text()
    section = text[text.index('## Energy and the turn per step'):]
    quoted = dict(re.findall(r'^\| `([\w-]+)` \| ([0-9.]+) \|', section, re.M))
    assert {m: float(v) for m, v in quoted.items()} == TURN_BOUNDS
    said = re.search(r'within\s+(\S+)\s+of\s+the\s+energy\s+over\s+(\d+)\s+steps', section)
    assert float(said.group(1)) == ENERGY_TOLERANCE and int(said.group(2)) == ENERGY_STEPS
    assert 'python -m bench.energy_drift' in section


def _spinning(method, turn, moments=(1.0, 2.0, 2.5), dt=1e-3, torque=(0.0, 0.0, 0.0),
              axis=so3.exp((0.2, 0.4, 0.1))[0]):
    """A body turning ``turn`` rad a step about ``axis`` (world), under ``torque`` (world)."""
    return Stepper(RigidBody(1.0, moments), dt=dt, method=method,
                   state=State(angular_velocity=np.array(axis) * (turn / dt)),
                   wrench=Wrench(torque=torque))


def _turn_warnings(record):
    return [w for w in record if issubclass(w.category, TurnWarning)]


@pytest.mark.parametrize('method', sorted(TURN_BOUNDS))
def test_a_step_beyond_the_bound_warns_once_for_each_body(method):
    bound = TURN_BOUNDS[method]
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        s = _spinning(method, 1.5 * bound)
        s.step(1)
        (w,) = _turn_warnings(record)
        message = str(w.message)
        assert method in message and f'{bound:g} rad a step' in message
        assert 'docs/integrators.md' in message and 'flow2' in message
        assert w.filename == __file__  # pointed at the caller's step
        s.step(5)
        s.step(1)
        assert len(_turn_warnings(record)) == 1
        _spinning(method, 1.5 * bound).step(3)  # another body: its own warning
        assert len(_turn_warnings(record)) == 2


@pytest.mark.parametrize('method', sorted(multistep.METHODS))
def test_no_warning_within_the_bound_for_an_isotropic_body_or_a_flow(method):
    bound = TURN_BOUNDS.get(method)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        if bound is not None:
            _spinning(method, 0.9 * bound).step(50)
        _spinning(method, 0.5, moments=(2.0, 2.0, 2.0)).step(50)  # exact at any rate
        if bound is None:
            _spinning(method, 0.9).step(50)  # exact torque-free
        assert _turn_warnings(record) == []


def test_a_torque_that_spins_a_body_past_the_bound_warns_when_it_does():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        # About its major axis from 0.02 rad a step, +0.01 rad a step every 100 steps
        # (alpha = 250 / 2.5 rad/s^2): 0.1, lie4's bound, at step 800.
        s = _spinning('lie4', 0.02, torque=(0.0, 0.0, 250.0), axis=(0.0, 0.0, 1.0))
        s.step(700)
        assert _turn_warnings(record) == []
        s.step(300)
        assert len(_turn_warnings(record)) == 1


def test_step_all_and_a_batch_warn_too():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        slow, fast = _spinning('eq27', 0.01), _spinning('eq27', 0.05)
        step_all([slow, fast], 3)
        (w,) = _turn_warnings(record)
        assert 'eq27' in str(w.message) and w.filename == __file__
        rng = np.random.default_rng(3)
        omegas = rng.normal(size=(6, 3))
        omegas *= (0.5 * TURN_BOUNDS['lie3'] / 1e-3) / np.linalg.norm(omegas, axis=1)[:, None]
        omegas[[2, 4]] *= 3.0
        batch = BatchStepper(np.ones(6), [(1.0, 2.0, 2.5)] * 6, 1e-3,
                             angular_velocities=omegas, method='lie3')
        batch.step(2)
        assert len(_turn_warnings(record)) == 2
        message = str(_turn_warnings(record)[1].message)
        assert 'bodies [2, 4]' in message and 'lie3' in message
        batch.step(2)
        assert len(_turn_warnings(record)) == 2  # once for the batch
        within = BatchStepper(np.ones(6), [(1.0, 2.0, 2.5)] * 6, 1e-3,
                              angular_velocities=omegas / 3.0, method='lie3')
        within.step(10)
        assert len(_turn_warnings(record)) == 2


def test_a_step_that_fails_raises_and_does_not_warn_too():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        fast, slow = _spinning('lie4', 1.5), _spinning('lie4', 0.01)
        with pytest.raises(IntegrationError, match='faster than 1 rad a step'):
            fast.step(1)
        with pytest.raises(IntegrationError, match='faster than 1 rad a step'):
            step_all([slow, fast], 2)
        assert _turn_warnings(record) == []


def test_a_body_of_a_collision_world_warns_as_a_stepper_does():
    """The world's own kernel steps its bodies: a body spinning past eq27's bound warns once,
    one turning within it (the other ball) does not; a body with no collider, which the same
    kernel steps, warns too."""
    from rb_sim_ros.contact.collision_shapes import Sphere
    from rb_sim_ros.sim.bodies import collision_world
    from rb_sim_ros.sim.simulation import BodySpec
    dt, bound = 1e-3, TURN_BOUNDS['eq27']
    fast = BodySpec('fast', 1.0, (0.1, 0.2, 0.3), initial_angular_velocity=(
        1.5 * bound / dt, 0.1, 0.0), colliders=(Sphere(0.1),))
    slow = BodySpec('slow', 1.0, (0.1, 0.2, 0.3), initial_position=(5.0, 0.0, 0.0),
                    initial_angular_velocity=(0.5 * bound / dt, 0.0, 0.0),
                    colliders=(Sphere(0.1),))
    free = BodySpec('free', 1.0, (0.1, 0.2, 0.3), initial_position=(0.0, 5.0, 0.0),
                    initial_angular_velocity=(0.0, 1.5 * bound / dt, 0.1))
    world = collision_world((fast, slow, free), dt, (0.0, 0.0, 0.0))
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        world.step(3)
        world.step(2)
    found = _turn_warnings(record)
    assert len(found) == 2 and all('eq27' in str(w.message) for w in found)
