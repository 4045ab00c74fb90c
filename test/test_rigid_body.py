# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Validation at the boundary: every bad body, state or wrench is a ValueError naming the field."""

import math

import numpy as np
import pytest

from rb_sim_ros import Frame, RigidBody, State, Stepper, Wrench
from rb_sim_ros import so3

NAN = math.nan


@pytest.mark.parametrize('mass', [0.0, -1.0, NAN, math.inf, 'heavy', None])
def test_bad_mass(mass):
    with pytest.raises(ValueError, match='mass'):
        RigidBody(mass, [1.0, 1.0, 1.0])


@pytest.mark.parametrize('inertia, why', [
    ([[1, 0.1, 0], [0, 1, 0], [0, 0, 1]], 'symmetric'),
    ([1.0, 1.0, -1.0], 'positive definite'),
    ([0.0, 0.0, 0.0], 'positive definite'),
    ([1.0, 1.0, 3.0], 'triangle'),
    ([1.0, NAN, 1.0], 'finite'),
    ([[1, 2], [3, 4]], '3x3'),
    ('round', '3x3'),
])
def test_bad_inertia(inertia, why):
    with pytest.raises(ValueError, match=f'inertia.*{why}'):
        RigidBody(1.0, inertia)


def test_full_inertia_is_accepted_and_thin_rod_limit_is_allowed():
    body = RigidBody(2.0, [[2.0, 0.5, 0.1], [0.5, 3.0, -0.2], [0.1, -0.2, 2.5]])
    assert not body.is_diagonal
    np.testing.assert_allclose(np.sort(body.principal_moments),
                               np.linalg.eigvalsh(body.inertia))
    flat_plate = RigidBody(1.0, [1.0, 2.0, 3.0])  # I1 + I2 == I3 exactly
    assert flat_plate.is_diagonal and not flat_plate.is_isotropic


@pytest.mark.parametrize('field, kwargs', [
    ('position', {'position': (0, NAN, 0)}),
    ('position', {'position': (0, 0)}),
    ('linear_velocity', {'linear_velocity': (math.inf, 0, 0)}),
    ('angular_velocity', {'angular_velocity': 'spin'}),
    ('rotation', {'rotation': np.diag([1.0, 1.0, -1.0])}),
    ('rotation', {'rotation': 2 * np.eye(3)}),
    ('rotation', {'rotation': np.full((3, 3), NAN)}),
])
def test_bad_state(field, kwargs):
    with pytest.raises(ValueError, match=field):
        State(**kwargs)


def test_bad_quaternion():
    with pytest.raises(ValueError, match='quaternion_xyzw'):
        State.from_quaternion_xyzw(quaternion_xyzw=(0, 0, 0, 0))
    with pytest.raises(ValueError, match='quaternion_xyzw'):
        State.from_quaternion_xyzw(quaternion_xyzw=(0, 0, NAN, 1))


def test_state_quaternion_accessor_round_trips():
    q = np.array([0.1, -0.7, 0.2, 0.4])
    q /= np.linalg.norm(q)
    s = State.from_quaternion_xyzw(quaternion_xyzw=q)
    np.testing.assert_allclose(s.quaternion_xyzw, q, atol=1e-15)
    assert so3.orthonormality_error(s.rotation) < 1e-15


def test_state_is_immutable():
    s = State()
    with pytest.raises(ValueError):
        s.position[0] = 1.0
    with pytest.raises(AttributeError):
        s.position = np.zeros(3)


@pytest.mark.parametrize('field, kwargs', [
    ('force', {'force': (NAN, 0, 0)}),
    ('torque', {'torque': (0, 0, -math.inf)}),
    ('torque', {'torque': (1, 2)}),
    ('frame', {'frame': 'map'}),
])
def test_bad_wrench(field, kwargs):
    with pytest.raises(ValueError, match=field):
        Wrench(**kwargs)


def test_wrench_frames_parse():
    assert Wrench(frame='BODY').frame is Frame.BODY
    assert Wrench(frame=Frame.WORLD).frame is Frame.WORLD


def _stepper():
    s = Stepper(RigidBody(1.0, [1.0, 2.0, 2.5]), 1e-3,
                State(angular_velocity=(0.1, 0.2, 0.3)), Wrench(torque=(0, 0, 0.1)))
    s.step(5)
    return s


def _snapshot(s):
    st = s.state
    return (s.step_count, s.wrench, st.position.tolist(), st.rotation.tolist(),
            st.linear_velocity.tolist(), st.angular_velocity.tolist())


@pytest.mark.parametrize('call, field', [
    (lambda s: s.step(-1), 'n'),
    (lambda s: s.step(1.5), 'n'),
    (lambda s: s.set_wrench((1, 2, 3)), 'wrench'),
    (lambda s: s.set_state('home'), 'state'),
    (lambda s: s.set_state(State(), previous=3), 'previous'),
])
def test_bad_calls_change_nothing(call, field):
    s = _stepper()
    before = _snapshot(s)
    with pytest.raises(ValueError, match=field):
        call(s)
    assert _snapshot(s) == before
    s.step(1)  # and the stepper still works


@pytest.mark.parametrize('dt', [0.0, -1e-3, NAN, math.inf, 'fast'])
def test_bad_dt(dt):
    with pytest.raises(ValueError, match='dt'):
        Stepper(RigidBody(1.0, [1, 1, 1]), dt)


def test_bad_method():
    with pytest.raises(ValueError, match='integrator'):
        Stepper(RigidBody(1.0, [1, 1, 1]), 1e-3, method='rk45')
