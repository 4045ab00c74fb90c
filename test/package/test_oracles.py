# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The stepper against closed forms and conservation laws; and the oracles themselves
(oracles/: the closed forms and the DOP853 reference that the tests and the benchmarks use)
against each other and the equations they solve."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from oracles import dop853
from oracles.free_rotation import elliptic_omega_body, flip_period, symmetric_top
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3


def _run(body, dt, t_end, state, wrench=Wrench(), method='eq27'):
    s = Stepper(body, dt, state, wrench, method=method)
    s.step(round(t_end / dt))
    return s


@pytest.mark.parametrize('frame', ['world', 'body'])
def test_constant_force_is_exact(frame):
    # A world force; or a body force on a body that does not turn: a = F/m exactly.
    body = RigidBody(2.5, [1.0, 2.0, 2.5])
    x0, v0, f = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.2]), np.array([1.0, -3.0, 2.0])
    rot = so3.exp([0.3, -0.4, 0.2])
    force = f if frame == 'world' else rot.T @ f
    s = _run(body, 1e-2, 3.0, State(x0, rot, v0), Wrench(force=force, frame=frame))
    t = s.time
    np.testing.assert_allclose(s.state.linear_velocity, v0 + f / 2.5 * t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s.state.position, x0 + v0 * t + f / 5.0 * t * t, rtol=0, atol=1e-11)
    assert so3.angle_between(s.state.rotation, rot) < 1e-13


def test_sphere_with_torque_parallel_to_omega_is_exact():
    # Isotropic inertia: no gyroscopic term, beta = tau / I constant and parallel to omega, so
    # the rotation angle is |w0| t + |beta| t^2 / 2 about a fixed axis.
    inertia = 0.4
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    w0, tau = 1.7, 0.05
    rot0 = so3.exp([0.2, 0.1, -0.3])
    s = _run(RigidBody(3.0, [inertia] * 3), 1e-2, 4.0, State(rotation=rot0,
             angular_velocity=w0 * axis), Wrench(torque=tau * axis))
    t = s.time
    beta = tau / inertia
    np.testing.assert_allclose(s.state.angular_velocity, (w0 + beta * t) * axis, atol=1e-12)
    expected = so3.exp((w0 * t + 0.5 * beta * t * t) * axis) @ rot0
    assert so3.angle_between(s.state.rotation, expected) < 1e-11


@pytest.mark.parametrize('i_3', [0.5, 1.8])  # oblate and prolate
def test_symmetric_top_against_closed_form(i_3):
    i_t, w_body, rot0 = 1.0, [0.4, -0.3, 2.0], so3.exp([0.5, 0.2, -0.1])
    body = RigidBody(1.0, [i_t, i_t, i_3])
    start = State(rotation=rot0, angular_velocity=rot0 @ np.array(w_body))
    t_end = 5.0
    errors = []
    for dt in (0.01, 0.005, 0.0025):
        s = _run(body, dt, t_end, start)
        rot, omega = symmetric_top(t_end, i_t, i_3, w_body, rot0)
        errors.append((so3.angle_between(s.state.rotation, rot),
                       np.linalg.norm(s.state.angular_velocity - omega)))
    # Small, and second order.
    assert errors[-1][0] < 1e-4 and errors[-1][1] < 1e-4
    for k in range(2):
        for q in range(2):
            assert math.log2(errors[k][q] / errors[k + 1][q]) == pytest.approx(2.0, abs=0.2)


def test_closed_form_top_solves_eulers_equations():
    # The oracle itself: R' = [omega] R by finite differences, and L = R I R^T omega constant.
    i_t, i_3, w_body, rot0 = 1.0, 1.8, [0.4, -0.3, 2.0], so3.exp([0.5, 0.2, -0.1])
    h, t = 1e-6, 0.7
    rot_m, _ = symmetric_top(t - h, i_t, i_3, w_body, rot0)
    rot_p, _ = symmetric_top(t + h, i_t, i_3, w_body, rot0)
    rot, omega = symmetric_top(t, i_t, i_3, w_body, rot0)
    np.testing.assert_allclose((rot_p - rot_m) / (2 * h), so3.hat(omega) @ rot, atol=1e-8)
    inertia = np.diag([i_t, i_t, i_3])
    l0 = rot0 @ inertia @ np.array(w_body)
    np.testing.assert_allclose(rot @ inertia @ rot.T @ omega, l0, atol=1e-12)


def test_torque_free_asymmetric_body_keeps_invariants_to_second_order():
    body = RigidBody(1.0, [[1.2, 0.1, 0.05], [0.1, 2.0, -0.1], [0.05, -0.1, 2.6]])
    start = State(rotation=so3.exp([0.1, 0.7, -0.2]), angular_velocity=[0.3, 1.0, 0.5])
    e0, l0 = start.kinetic_energy(body), start.angular_momentum(body)
    drifts = []
    for dt in (0.02, 0.01, 0.005):
        s = Stepper(body, dt, start)
        worst_e = worst_l = 0.0
        for _ in range(20):
            s.step(round(1.0 / dt))
            st = s.state
            worst_e = max(worst_e, abs(st.kinetic_energy(body) - e0) / e0)
            worst_l = max(worst_l, np.linalg.norm(st.angular_momentum(body) - l0)
                          / np.linalg.norm(l0))
        drifts.append((worst_e, worst_l))
    assert drifts[-1][0] < 1e-4 and drifts[-1][1] < 1e-4
    for k in range(2):
        for q in range(2):
            assert math.log2(drifts[k][q] / drifts[k + 1][q]) > 1.7


def test_rotation_stays_orthonormal_over_long_runs():
    body = RigidBody(1.0, [1.0, 2.0, 2.9])
    s = Stepper(body, 1e-3, State(angular_velocity=[3.0, 20.0, 1.0]),
                Wrench(torque=[0.01, -0.02, 0.03], frame='body'))
    worst = 0.0
    for _ in range(20):
        s.step(10_000)
        # The raw R: State would project it onto SO(3) and hide any drift.
        worst = max(worst, so3.orthonormality_error(s.rotation()))
    assert worst < 1e-12


def test_dop853_reference_is_the_elliptic_solution_in_both_its_forms():
    """The DOP853 reference, as the tests call it (``solve``: a body and a State) and as the
    benchmarks do (``integrate``: a scene, R and omega in the world frame, or a quaternion and
    Euler's equations in the body frame), against the torque-free asymmetric body's elliptic
    omega (Landau & Lifshitz, section 37); and that omega comes back after ``flip_period``."""
    moments, w_body = (1.0, 2.0, 3.0), (1.0, 0.0, 1.5)
    rot0 = so3.exp([0.3, -0.5, 0.8])
    times = [0.25 * k for k in range(1, 9)]
    expected = elliptic_omega_body(moments, w_body, times)
    zero = [0.0, 0.0, 0.0]
    states = dop853.solve(RigidBody(1.0, list(moments)),
                          State(rotation=rot0, angular_velocity=rot0 @ np.array(w_body)),
                          [(0.0, zero, zero, 'world')], 2.0, times=times)
    for st, wb in zip(states, expected):
        assert np.linalg.norm(st.rotation.T @ st.angular_velocity - wb) < 1e-10
    scene = SimpleNamespace(name='tumble', inertia_body=np.diag(moments), rotation0=rot0,
                            omega0_world=rot0 @ np.array(w_body), omega0_body=np.array(w_body),
                            segments=lambda: [(0.0, 2.0, np.zeros(3))])
    for formulation in ('matrix', 'quaternion'):
        for (rot, w), st in zip(dop853.integrate(scene, times, formulation=formulation), states):
            assert so3.angle_between(rot, st.rotation) < 1e-10
            assert np.linalg.norm(w - st.angular_velocity) < 1e-10
    period = flip_period(moments, w_body)
    np.testing.assert_allclose(elliptic_omega_body(moments, w_body, [period])[0], w_body,
                               rtol=0, atol=1e-12)
