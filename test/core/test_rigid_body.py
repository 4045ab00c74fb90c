# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Validation at the boundary: every bad body, state or wrench is a ValueError naming the field."""

import math

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from rb_sim_ros import Frame, RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3
from rb_sim_ros.core.rigid_body import finite_floats, non_negative, rate

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
    (lambda s: s.step(10 ** 400), r'n must be an int from 0 to 2\^62'),
    (lambda s: s.step(2 ** 62 + 1), r'n must be an int from 0 to 2\^62'),
    (lambda s: s.rest(10 ** 400), r'n must be an int from 0 to 2\^62'),
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


# -- issue 11: booleans, strings and huge integers are not numbers; any quaternion length ------

@pytest.mark.parametrize('call, field', [
    (lambda: RigidBody(True, [1.0, 1.0, 1.0]), 'mass'),
    (lambda: RigidBody('1.5', [1.0, 1.0, 1.0]), 'mass'),
    (lambda: RigidBody(10 ** 400, [1.0, 1.0, 1.0]), 'mass'),
    (lambda: RigidBody(1.0, [True, True, True]), 'inertia'),
    (lambda: RigidBody(1.0, [1.0, True, 1.0]), 'inertia'),
    (lambda: RigidBody(1.0, np.array([True, True, True])), 'inertia'),
    (lambda: RigidBody(1.0, ['1', '1', '1']), 'inertia'),
    (lambda: RigidBody(1.0, [[1, 0, 0], [0, 1, False], [0, 0, 1]]), 'inertia'),
    (lambda: RigidBody(1.0, [1.0, 10 ** 400, 1.0]), 'inertia'),
    (lambda: State(position=[True, 0, 0]), 'position'),
    (lambda: State(position=['1', '2', '3']), 'position'),
    (lambda: State.from_quaternion_xyzw(quaternion_xyzw=[0, 0, 0, True]), 'quaternion_xyzw'),
    (lambda: Wrench(force=[1.0, True, 0.0]), 'force'),
    (lambda: finite_floats('gravity', [0, 0, True], 3), 'gravity'),
    (lambda: finite_floats('gravity', [0, 0, '9.81'], 3), 'gravity'),
    (lambda: finite_floats('gravity', [0, 0, -10 ** 400], 3), 'gravity must be finite'),
    (lambda: rate('linear_damping', True), 'linear_damping'),
    (lambda: rate('linear_damping', 10 ** 400), 'linear_damping'),
    (lambda: non_negative('sleep_time', 10 ** 400), 'sleep_time'),
])
def test_only_ints_and_floats_are_numbers(call, field):
    with pytest.raises(ValueError, match=field):
        call()


def test_numpy_numbers_are_numbers():
    assert RigidBody(np.float32(2.0), np.array([1, 2, 2], dtype=np.int64)).mass == 2.0
    assert finite_floats('gravity', np.array([0.0, 0.0, -9.81]), 3) == (0.0, 0.0, -9.81)


def test_inertia_near_the_largest_float_is_checked_and_named():
    assert np.array_equal(RigidBody(1.0, [1e308] * 3).inertia, np.diag([1e308] * 3))
    full = RigidBody(1.0, [[1e308, 5e307, 0], [5e307, 1e308, 0], [0, 0, 1e308]])
    np.testing.assert_allclose(full.principal_moments, [0.5e308, 1e308, 1.5e308])
    with pytest.raises(ValueError, match='^inertia must be positive definite'):
        RigidBody(1.0, [[1e308, 1e308, 0], [1e308, 1e308, 0], [0, 0, 1e308]])


QX90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # 90 degrees about x


@pytest.mark.parametrize('q, rotation', [
    ([1e200, 0, 0, 1e200], QX90),
    ([-1e-200, 0, 0, -1e-200], QX90),
    ([0, 0, 0, 5e-324], np.eye(3)),
    ([0, 3e307, 0, 4e307], [[0.28, 0.0, 0.96], [0.0, 1.0, 0.0], [-0.96, 0.0, 0.28]]),
])
def test_a_quaternion_of_any_length_is_normalised(q, rotation):
    np.testing.assert_allclose(State.from_quaternion_xyzw(quaternion_xyzw=q).rotation,
                               rotation, atol=1e-15)


@given(st.lists(st.floats(-1e3, 1e3).map(lambda c: 0.0 if abs(c) < 1e-150 else c),
                min_size=4, max_size=4).filter(any))
@settings(max_examples=200, deadline=None)
def test_scaling_first_keeps_the_bits_of_ordinary_quaternions(q):
    # The scaling is by a power of two: recordings of ordinary runs replay bit for bit.
    rotation = so3.matrix_from_quaternion_xyzw(q)
    expected = State(rotation=rotation).rotation  # with the same projection onto SO(3)
    assert np.array_equal(State.from_quaternion_xyzw(quaternion_xyzw=q).rotation, expected)
