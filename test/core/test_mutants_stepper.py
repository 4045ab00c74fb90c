# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The stepper's start-up, history re-evaluation and orthonormalisation against independent
references (issue 12: mutants of these that no other test killed; tools/mutate.py).

References: the closed form of translation under a constant acceleration with linear damping,
v' = A - c v, piece by piece when the force changes; and eq. (10) in the world frame with
gravity and damping, integrated by scipy's DOP853 at rtol 1e-13 (nothing of rb_sim_ros's
integrator or principal-axes dynamics is used there).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from oracles import dop853 as reference
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

BODY = RigidBody(1.3, [[1.2, 0.1, 0.05], [0.1, 2.0, -0.1], [0.05, -0.1, 2.6]])
GRAVITY = np.array([0.0, 0.0, -9.81])
LINEAR_DAMPING, ANGULAR_DAMPING = 0.8, 0.6


def _dop853(start, schedule, t_end):
    """The state at t_end; schedule: (t_start, force, torque, frame) rows, each wrench held
    until the next; integrated piece by piece so that no step straddles a jump. The last
    step's state, where ``reference.solve`` interpolates: d/dt of (x, v, R row-major, omega),
    world frame, with GRAVITY and both dampings, a = F/m + g - c v,
    beta = I^-1 (tau - omega x I omega) - d omega, I = R I_body R^T."""
    y = reference.pack(start)
    bounds = [row[0] for row in schedule[1:]] + [t_end]
    for (t0, force, torque, frame), t1 in zip(schedule, bounds):
        f = reference.rhs(BODY.inertia, BODY.mass, force, torque, frame, GRAVITY,
                          LINEAR_DAMPING, ANGULAR_DAMPING)
        y = solve_ivp(f, (t0, t1), y, method='DOP853', rtol=1e-13, atol=1e-14).y[:, -1]
    return reference.unpack(y)


def _damped_translation(x0, v0, accel, c, t):
    """v' = A - c v exactly: v = v0 + (A - c v0) (1 - e^-ct) / c, x = x0 + A t / c +
    (v0 - A / c) (1 - e^-ct) / c (expm1 keeps it accurate for small c t)."""
    one_minus = -math.expm1(-c * t)
    v = v0 + (accel - c * v0) * one_minus / c
    x = x0 + accel * t / c + (v0 - accel / c) * one_minus / c
    return x, v


def _order(errors):
    return [math.log2(a / b) for a, b in zip(errors, errors[1:])]


def _stepper(dt, state, wrench=Wrench()):
    return Stepper(BODY, dt, state, wrench, gravity=GRAVITY, linear_damping=LINEAR_DAMPING,
                   angular_damping=ANGULAR_DAMPING)


DTS_ONE_STEP = (0.04, 0.02, 0.01, 0.005)


def test_first_step_from_rest_with_gravity_and_damping_has_local_order_3_and_4():
    """Start-up (no history after set_state): a_{-1} is extrapolated from a Taylor predictor,
    so the first step's local errors are O(dt^3) in v and O(dt^4) in x, as every later step's.
    Extrapolating nothing (a_{-1} = a_0) is Euler for v: O(dt^2), and O(dt^3) in x. Oracle:
    the closed form of damped translation under gravity and a world force, from rest."""
    force = np.array([0.6, -0.4, 3.0])
    accel = force / BODY.mass + GRAVITY
    x0 = np.array([0.1, -0.2, 0.3])
    ex, ev = [], []
    for dt in DTS_ONE_STEP:
        s = _stepper(dt, State(position=x0), Wrench(force=force))
        s.step(1)
        x, v = _damped_translation(x0, np.zeros(3), accel, LINEAR_DAMPING, dt)
        ex.append(np.linalg.norm(s.state.position - x))
        ev.append(np.linalg.norm(s.state.linear_velocity - v))
    assert _order(ev)[-1] == pytest.approx(3.0, abs=0.25), ev
    assert _order(ex)[-1] == pytest.approx(4.0, abs=0.3), ex


def test_first_step_of_a_damped_spinning_body_has_local_order_3_and_4():
    """The same for rotation: an asymmetric body spinning under a body-frame torque and force,
    gravity and both dampings, one step from a state without history against DOP853."""
    start = State(position=[0.1, -0.2, 0.3], rotation=so3.exp([0.3, -0.5, 0.2]),
                  linear_velocity=[0.5, -0.1, 0.2], angular_velocity=[0.8, -1.5, 1.1])
    force, torque = [0.3, -0.2, 0.6], [0.2, 0.4, -0.3]
    errors = {q: [] for q in 'xvwR'}
    for dt in DTS_ONE_STEP:
        s = _stepper(dt, start, Wrench(force, torque, 'body'))
        s.step(1)
        ref = _dop853(start, [(0.0, force, torque, 'body')], dt)
        st = s.state
        errors['x'].append(np.linalg.norm(st.position - ref.position))
        errors['v'].append(np.linalg.norm(st.linear_velocity - ref.linear_velocity))
        errors['w'].append(np.linalg.norm(st.angular_velocity - ref.angular_velocity))
        errors['R'].append(so3.angle_between(st.rotation, ref.rotation))
    for q, expected in (('v', 3), ('w', 3), ('x', 4), ('R', 4)):
        assert _order(errors[q])[-1] == pytest.approx(expected, abs=0.3), (q, errors[q])


SCHEDULE = [(k * 0.125, [1.5 * math.sin(k), 0.9 * math.cos(3 * k), 2.0 * (-1) ** k],
             [0.4 * math.cos(2 * k), 0.3 * (-1) ** k, 0.5 * math.sin(k + 1)],
             'body' if k % 2 else 'world') for k in range(16)]
DTS = (1 / 64, 1 / 128, 1 / 256)


def _run(dt, start, schedule, t_end):
    s = _stepper(dt, start)
    bounds = [row[0] for row in schedule[1:]] + [t_end]
    for (t0, force, torque, frame), t1 in zip(schedule, bounds):
        s.set_wrench(Wrench(force, torque, frame))
        s.step(round((t1 - t0) / dt))
    return s.state


def test_damped_translation_under_force_changes_is_second_order_against_the_closed_form():
    """A world force that changes every 0.125 s, gravity, linear damping: the closed form piece
    by piece. On a change a_{n-1} is evaluated again at the previous state under the new force,
    damping -c v_{n-1} included; without it each change leaves an O(dt) error in v and the
    method falls to first order."""
    start = State(position=[0.1, -0.2, 0.3], linear_velocity=[0.5, -0.1, 0.2],
                  angular_velocity=[0.8, -1.5, 1.1])
    schedule = [(t0, force, [0.0, 0.0, 0.0], 'world') for t0, force, _, _ in SCHEDULE]
    t_end = 2.0
    x, v = start.position, start.linear_velocity
    bounds = [row[0] for row in schedule[1:]] + [t_end]
    for (t0, force, _, _), t1 in zip(schedule, bounds):
        x, v = _damped_translation(x, v, np.asarray(force) / BODY.mass + GRAVITY,
                                   LINEAR_DAMPING, t1 - t0)
    ex, ev = [], []
    for dt in DTS:
        st = _run(dt, start, schedule, t_end)
        ex.append(np.linalg.norm(st.position - x))
        ev.append(np.linalg.norm(st.linear_velocity - v))
    assert ev[-1] < 1e-4 and ex[-1] < 1e-4
    assert _order(ev)[-1] == pytest.approx(2.0, abs=0.2), ev
    assert _order(ex)[-1] == pytest.approx(2.0, abs=0.2), ex


def test_damped_asymmetric_body_under_wrench_changes_is_second_order_against_dop853():
    """Forces and torques in both frames changing every 0.125 s, gravity, linear and angular
    damping, an asymmetric body: every quantity converges with order 2 to DOP853."""
    start = State(position=[0.1, -0.2, 0.3], rotation=so3.exp([0.3, -0.5, 0.2]),
                  linear_velocity=[0.5, -0.1, 0.2], angular_velocity=[0.8, -1.5, 1.1])
    t_end = 2.0
    ref = _dop853(start, SCHEDULE, t_end)
    errors = {q: [] for q in 'xvwR'}
    for dt in DTS:
        st = _run(dt, start, SCHEDULE, t_end)
        errors['x'].append(np.linalg.norm(st.position - ref.position))
        errors['v'].append(np.linalg.norm(st.linear_velocity - ref.linear_velocity))
        errors['w'].append(np.linalg.norm(st.angular_velocity - ref.angular_velocity))
        errors['R'].append(so3.angle_between(st.rotation, ref.rotation))
    for q in 'xvwR':
        assert errors[q][-1] < 1e-3, (q, errors[q])
        assert _order(errors[q])[-1] == pytest.approx(2.0, abs=0.2), (q, errors[q])


def test_a_rotation_written_off_so3_is_pulled_back_within_orthonormalize_every_steps():
    """``apply_contact`` (the collision world's write) takes R without projecting it; a product
    of rotations keeps R^T R, so only the periodic orthonormalisation can bring an R that is
    1e-7 off SO(3) back. Within ORTHONORMALIZE_EVERY steps it must be within the 1e-12 that
    test_oracles asks of long runs, and the turn must still be the closed form of a sphere
    spinning at constant omega: R(t) = exp([omega] t) R0 (to the 1e-7 it was written off)."""
    sphere = RigidBody(2.0, [0.3, 0.3, 0.3])
    omega = np.array([3.0, -1.0, 2.0])
    rot0 = so3.exp([0.2, 0.4, -0.1])
    off = rot0 + 1e-7 * np.array([[0.3, -0.5, 0.2], [0.7, 0.1, -0.4], [-0.2, 0.6, 0.5]])
    assert so3.orthonormality_error(off) > 1e-8
    s = Stepper(sphere, 1e-3)
    s.apply_contact((0.0, 0.0, 0.0), off, (0.0, 0.0, 0.0), omega)
    s.step(Stepper.ORTHONORMALIZE_EVERY)
    assert so3.orthonormality_error(s.rotation()) < 1e-12
    for _ in range(3):
        s.step(1000)
        assert so3.orthonormality_error(s.rotation()) < 1e-12
    expected = so3.exp(omega * s.time) @ rot0
    assert so3.angle_between(s.rotation(), expected) < 1e-6


def test_orthonormalisation_goes_on_after_a_spell_without_turning():
    """A body that does not turn skips the rotation update, and its orthonormalisation with it
    (R does not change). When the countdown ran out in that spell, the first turning step must
    pull R back, not wait for a countdown that has gone past zero (as it once did: R stayed
    off SO(3) for good)."""
    sphere = RigidBody(2.0, [0.3, 0.3, 0.3])
    s = Stepper(sphere, 1e-3)
    s.step(Stepper.ORTHONORMALIZE_EVERY + 100)  # at rest past the countdown
    rot0 = so3.exp([0.2, 0.4, -0.1])
    off = rot0 + 1e-7 * np.array([[0.3, -0.5, 0.2], [0.7, 0.1, -0.4], [-0.2, 0.6, 0.5]])
    s.apply_contact((0.0, 0.0, 0.0), off, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    s.step(Stepper.ORTHONORMALIZE_EVERY)  # translating, not turning: the countdown runs out
    s.set_wrench(Wrench(torque=(0.0, 0.0, 0.1)))
    s.step(10)
    assert so3.orthonormality_error(s.rotation()) < 1e-12
