# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""lie3 and lie4, the higher-order members of Proof 3's family: orders measured by halving dt
against a DOP853 reference at 1e-13 (as test_convergence does for eq27), their start-up, and
what their history must do across a change of the held wrench."""

import math

import numpy as np
import pytest

from oracles import dop853 as reference
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import free_flow, multistep, so3, step_kernel
from rb_sim_ros.core.batch import BatchStepper
from support.convergence import (BODY, FORCE, global_errors, orders_of, SCHEDULE, START,
                                 state_errors, TORQUE)


def _one_step_errors(method, dts, frame='body'):
    """Errors of one step from the exact history (the k - 1 states before, from the
    reference) at t0, for each dt."""
    k = multistep.METHODS[method].steps
    t0 = 0.5
    schedule = [(0.0, FORCE, TORQUE, frame)]
    errors = []
    for dt in dts:
        times = [t0 - j * dt for j in range(k - 1, 0, -1)] + [t0, t0 + dt]
        states = reference.solve(BODY, START, schedule, t0 + dt, times=times)
        before, now, after = states[:k - 1][::-1], states[k - 1], states[k]
        s = Stepper(BODY, dt, now, Wrench(FORCE, TORQUE, frame), method=method)
        s.set_state(now, previous=before)
        s.step(1)
        errors.append(state_errors(s.state, after))
    return errors


@pytest.mark.parametrize('method, expected', [
    # v, omega: Adams-Bashforth k, local O(dt^(k+1)); x: the integral against (1 - s) of
    # the same interpolant, O(dt^(k+2)); R: the Magnus terms kept, O(dt^5) for both.
    ('lie3', {'v': 4, 'w': 4, 'x': 5, 'R': 5}),
    ('lie4', {'v': 5, 'w': 5, 'x': 6, 'R': 5}),
])
def test_local_orders_from_exact_history(method, expected):
    orders = orders_of(_one_step_errors(method, (0.08, 0.04, 0.02, 0.01)))
    for q, order in expected.items():
        assert orders[q][-1] == pytest.approx(order, abs=0.25), (q, orders)


def test_local_order_of_R_needs_the_derivative_term():
    """Without the (dt^4/24) beta' x omega term (lie3 with eq. (27)'s cross weights) R's
    local order falls from 5 to 4: the test above can tell."""
    lie3 = multistep.LIE3
    plain = multistep.Multistep('lie3-plain-cross', 3, (4, 4), lie3.velocity, lie3.position,
                                lie3.rotation, (1.0 / 12.0, 0.0, 0.0))
    multistep.METHODS[plain.name] = plain
    try:
        orders = orders_of(_one_step_errors(plain.name, (0.08, 0.04, 0.02, 0.01)))
    finally:
        del multistep.METHODS[plain.name]
    assert orders['R'][-1] == pytest.approx(4.0, abs=0.25), orders


@pytest.mark.parametrize('method, order', [('lie3', 3), ('lie4', 4)])
def test_global_order_with_a_constant_wrench(method, order):
    """From a start-up (no history), 2 s under a body-frame wrench on an asymmetric body."""
    orders = orders_of(global_errors([(0.0, FORCE, TORQUE, 'body')], 2.0,
                                     (1 / 64, 1 / 128, 1 / 256), method=method))
    for q in 'xvwR':
        assert orders[q][-1] == pytest.approx(order, abs=0.15), (q, orders)


@pytest.mark.parametrize('method, order', [('lie3', 3), ('lie4', 4)])
def test_global_order_with_a_wrench_change_every_eighth_of_a_second(method, order):
    orders = orders_of(global_errors(SCHEDULE, 2.0, (1 / 64, 1 / 128, 1 / 256), method=method))
    for q in 'xvwR':
        assert orders[q][-1] == pytest.approx(order, abs=0.15), (q, orders)


@pytest.mark.filterwarnings('ignore::rb_sim_ros.core.stepper.TurnWarning')
def test_lie4_is_fourth_order_from_0_2_rad_a_step_down():
    """Issue 28 (N16): lie4 gains energy from 0.43 rad a step on, AB4's parasitic root
    (test_energy_bound.py), not an error of its weights: torque-free at |omega| = 1 rad/s
    over 8 s, its error in R against DOP853 falls by 2^4 with each halving of the turn per
    step from 0.2 rad to 0.0125."""
    body = RigidBody(1.0, (1.0, 2.0, 2.8))
    axis = np.array([0.3, 0.8, -0.5]) / np.linalg.norm([0.3, 0.8, -0.5])
    start = State(rotation=so3.exp((0.3, -0.2, 0.5)), angular_velocity=axis)
    zero = (0.0, 0.0, 0.0)
    ref = reference.solve(body, start, [(0.0, zero, zero, 'world')], 8.0)[0]
    errors = []
    for n in (40, 80, 160, 320, 640):
        s = Stepper(body, 8.0 / n, start, method='lie4')
        s.step(n)
        errors.append({q: e for q, e in state_errors(s.state, ref).items() if q in 'wR'})
    orders = orders_of(errors)
    assert min(orders['R']) > 3.9, orders
    # omega's error (world frame) reaches its asymptotic order later: 2.3, 3.4, 3.8, 3.9.
    assert orders['w'] == sorted(orders['w']) and orders['w'][-1] > 3.85, orders


def _keep_old_history(stepper):
    """A naive multistep: the accelerations of the old wrench kept across the change."""
    row = stepper._store.state[stepper._row]
    if row[step_kernel.HISTORY] == step_kernel.HISTORY_STALE:
        row[step_kernel.HISTORY] = step_kernel.HISTORY_VALID


def _re_evaluate_kept_states(stepper):
    """eq27's way (NOTES.md 2): the kept states' accelerations evaluated again under the
    new wrench, instead of a new start-up."""
    store, row = stepper._store, stepper._row
    if store.state[row, step_kernel.HISTORY] == step_kernel.HISTORY_STALE:
        step_kernel.evaluate_history(store.state, store.params, row, stepper.method.steps)
        store.state[row, step_kernel.HISTORY] = step_kernel.HISTORY_VALID


def test_what_stale_history_would_do_to_lie4():
    """The old wrench's accelerations: first order. Evaluated again at the kept states (the
    old wrench's path, O(dt) off the new one's in omega): second order, not fourth."""
    dts = (1 / 64, 1 / 128, 1 / 256)
    naive = orders_of(global_errors(SCHEDULE, 2.0, dts, tamper=_keep_old_history,
                                    method='lie4'))
    kept = orders_of(global_errors(SCHEDULE, 2.0, dts, tamper=_re_evaluate_kept_states,
                                   method='lie4'))
    assert naive['w'][-1] == pytest.approx(1.0, abs=0.2), naive
    assert kept['w'][-1] == pytest.approx(2.0, abs=0.2), kept


def test_start_up_finds_the_states_before_to_fifth_order():
    """The start-up (RKMK4 steps back in time under the held wrench): after one step of lie4
    from a state without history, the slots hold the start and the states 1 and 2 steps
    before it; those are the reference's to O(dt^5) (one RKMK4 step: local order 5). The
    rows hold R of the principal frame, R Q."""
    t0 = 0.5
    errors = []
    for dt in (0.04, 0.02, 0.01):
        states = reference.solve(BODY, START, [(0.0, FORCE, TORQUE, 'body')], t0,
                                 times=[t0 - 2 * dt, t0 - dt, t0])
        s = Stepper(BODY, dt, states[2], Wrench(FORCE, TORQUE, 'body'), method='lie4')
        s.step(1)
        row = s._store.state[s._row]
        got = []
        for j, ref in ((2, states[1]), (3, states[0])):
            at = step_kernel.slot_column(j)
            rot = row[at + step_kernel.R:at + step_kernel.R + 9].reshape(3, 3) @ s._q.T
            omega = row[at + step_kernel.W:at + step_kernel.W + 3]
            got.append(so3.angle_between(so3.orthonormalize(rot), ref.rotation)
                       + float(np.linalg.norm(omega - ref.angular_velocity)))
        errors.append(max(got))
    slopes = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert slopes[-1] == pytest.approx(5.0, abs=0.3), (errors, slopes)


def test_previous_must_be_as_many_states_as_the_method_keeps():
    s = Stepper(BODY, 0.01, START, method='lie4')
    with pytest.raises(ValueError, match='previous must be None or 3 State'):
        s.set_state(START, previous=START)
    with pytest.raises(ValueError, match='previous must be None or 3 State'):
        s.set_state(START, previous=[START, START, 'x'])
    s.set_state(START, previous=[START, START, START])
    with pytest.raises(ValueError, match='two-step'):
        multistep.make_step(multistep.LIE4, 0.01)
    flow = Stepper(BODY, 0.01, START, method='flow2')  # keeps no history: None only
    for previous in ((), [], [START]):
        with pytest.raises(ValueError, match='previous must be None or 0 State'):
            flow.set_state(START, previous=previous)


def test_isotropic_body_under_constant_torque_is_exact_to_rounding_in_omega():
    """omega is linear in t under a constant torque on a sphere: Adams-Bashforth of any
    order integrates it exactly, from the start-up on (it is exact for a polynomial)."""
    sphere = RigidBody(1.0, [0.7, 0.7, 0.7])
    torque = np.array([0.3, -0.5, 0.4])
    w0 = np.array([1.0, 2.0, -0.5])
    for method in ('lie3', 'lie4'):
        s = Stepper(sphere, 0.01, State(angular_velocity=w0), Wrench(torque=torque),
                    method=method)
        s.step(200)
        assert np.allclose(s.state.angular_velocity, w0 + torque / 0.7 * 2.0,
                           rtol=0, atol=1e-12)


def test_batch_and_steppers_agree_bit_for_bit():
    """BatchStepper runs the same kernel rows as Stepper: lie4, with a wrench change."""
    rng = np.random.default_rng(1)
    n = 5
    moments = [np.sort(rng.uniform(0.5, 1.5, 3)) for _ in range(n)]
    w0 = rng.normal(size=(n, 3))
    b = BatchStepper(np.ones(n), np.array([np.diag(m) for m in moments]), 0.01,
                     angular_velocities=w0, method='lie4')
    ones = [Stepper(RigidBody(1.0, np.diag(m)), 0.01, State(angular_velocity=w), method='lie4')
            for m, w in zip(moments, w0)]
    torque = rng.normal(size=3)
    b.step(7)
    b.set_wrench(None, torque=torque, frame='body')
    b.step(9)
    for s in ones:
        s.step(7)
        s.set_wrench(Wrench(torque=torque, frame='body'))
        s.step(9)
    assert np.array_equal(b.angular_velocities(),
                          np.array([s.state.angular_velocity for s in ones]))


# -- the exact free flow and the splitting methods (flow2, flow4) ----------------------------

def _flow(moments, rot, omega, h):
    """free_flow of (R, omega) over h, its invariants from the state; R, omega as arrays."""
    args = (*moments, *np.asarray(rot).reshape(9), *omega)
    out = free_flow.free_flow(*moments, *free_flow.invariants(*args), *args[3:], h,
                              so3.TINY_ANGLE_SQ)
    return np.array(out[:9]).reshape(3, 3), np.array(out[9:])


def test_elliptic_functions_against_scipy():
    """sn, cn, dn and Carlson's R_F, R_J against scipy's independent implementations."""
    from scipy.special import ellipj, elliprf, elliprj
    rng = np.random.default_rng(1)
    for _ in range(300):
        m, u = rng.uniform(0.0, 1.0), rng.uniform(-4.0, 4.0)
        assert np.allclose(free_flow.sncndn(u, 1.0 - m), ellipj(u, m)[:3], rtol=0,
                           atol=3e-15)
        x, y, z, p = rng.uniform(0.0, 2.0, 4)
        assert free_flow.carlson_rf(x, y, z) == pytest.approx(elliprf(x, y, z), rel=3e-15)
        assert free_flow.carlson_rj(x, y, z, p) == pytest.approx(elliprj(x, y, z, p),
                                                                 rel=3e-15)


@pytest.mark.parametrize('case', ['asymmetric', 'about the largest', 'about the smallest',
                                  'symmetric', 'isotropic', 'steady'])
def test_free_flow_is_the_torque_free_motion_for_any_step(case):
    """Against DOP853 at 1e-13 from a general R0, steps up to 20 s (several tumbles)."""
    rng = np.random.default_rng(7)
    moments = {'symmetric': (1.2, 1.2, 1.9), 'isotropic': (1.5, 1.5, 1.5)}.get(
        case, (1.0, 1.6, 1.9))
    omega_body = {'about the largest': (0.05, 0.1, 2.0), 'about the smallest': (2.0, 0.1, 0.05),
                  'steady': (0.0, 0.0, 1.3)}.get(case, (1.0, 0.7, -1.1))
    rot = so3.exp(rng.normal(size=3))
    omega = rot @ np.array(omega_body)
    body = RigidBody(1.0, list(moments))
    for h in (1e-3, 0.37, 4.1, 20.0):
        ref = reference.solve(body, State(rotation=rot, angular_velocity=omega),
                              [(0.0, [0, 0, 0], [0, 0, 0], 'world')], h)[0]
        r1, w1 = _flow(moments, rot, omega, h)
        assert so3.angle_between(so3.orthonormalize(r1), ref.rotation) < 1e-11, h
        assert np.linalg.norm(w1 - ref.angular_velocity) < 1e-11, h
        back_r, back_w = _flow(moments, r1, w1, -h)  # and back again
        assert so3.angle_between(so3.orthonormalize(back_r), rot) < 1e-12
        assert np.linalg.norm(back_w - omega) < 1e-12


@pytest.mark.parametrize('omega_body', [(2.0, 0.0, 1.0), (-2.0, 0.0, 1.0), (2.0, 0.0, -1.0),
                                        (-2.0, 0.0, -1.0), (0.0, 1.5, 0.0)])
def test_the_separatrix_and_the_middle_axis(omega_body):
    """Moments (3, 4, 6), omega = (2, 0, 1) in the body: exactly on the separatrix
    (G^2 = H I_mid, k = 1), each branch; and a steady spin about the middle axis. One flow of
    2 s and 2000 steps of flow2, forward, against DOP853."""
    moments = (3.0, 4.0, 6.0)
    rot = so3.exp([0.4, -0.2, 0.9])
    omega = rot @ np.array(omega_body)
    body = RigidBody(1.0, list(moments))
    start = State(rotation=rot, angular_velocity=omega)
    ref = reference.solve(body, start, [(0.0, [0, 0, 0], [0, 0, 0], 'world')], 2.0)[0]
    r1, w1 = _flow(moments, rot, omega, 2.0)
    assert so3.angle_between(so3.orthonormalize(r1), ref.rotation) < 1e-11
    assert np.linalg.norm(w1 - ref.angular_velocity) < 1e-11
    s = Stepper(body, 1e-3, start, method='flow2')
    s.step(2000)
    # At the saddle u is far out (~38) and each step's precession a difference of two values
    # of that size: 2000 of them keep 1e-11 (measured 1.4e-11), not the rounding of one.
    limit = 1e-10 if omega_body[0] == 0.0 else 1e-11
    assert so3.angle_between(s.state.rotation, ref.rotation) < limit
    assert np.linalg.norm(s.state.angular_velocity - ref.angular_velocity) < limit


def test_a_torque_free_body_needs_no_small_steps():
    """flow2 at dt = 2.5 s (4 steps for 10 s of tumbling) is as exact as the reference."""
    body = RigidBody(1.0, [1.0, 2.0, 2.5])
    start = State(rotation=so3.exp([0.3, -0.5, 0.8]), angular_velocity=[1.0, 0.1, 1.5])
    ref = reference.solve(body, start, [(0.0, [0, 0, 0], [0, 0, 0], 'world')], 10.0)[0]
    for method in ('flow2', 'flow4'):
        s = Stepper(body, 2.5, start, method=method)
        s.step(4)
        assert so3.angle_between(s.state.rotation, ref.rotation) < 1e-11
        assert np.linalg.norm(s.state.angular_velocity - ref.angular_velocity) < 1e-11


def test_flow_keeps_energy_and_momentum_to_rounding():
    """1e5 torque-free steps: the invariants are held, so energy and the world angular
    momentum stay at rounding (eq27 drifts by about 1e-8 here)."""
    moments = np.array([1.0, 2.0, 2.5])
    body = RigidBody(1.0, list(moments))
    start = State(rotation=so3.exp([0.3, -0.5, 0.8]), angular_velocity=[1.0, 0.1, 1.5])

    def energy_momentum(rot, omega):
        m = moments * (rot.T @ omega)
        return float(m @ (m / moments)), rot @ m

    e0, l0 = energy_momentum(start.rotation, start.angular_velocity)
    for method in ('flow2', 'flow4'):
        s = Stepper(body, 1e-3, start, method=method)
        s.step(100_000)
        e1, l1 = energy_momentum(s.state.rotation, s.state.angular_velocity)
        assert abs(e1 - e0) / e0 < 1e-13, method
        assert np.linalg.norm(l1 - l0) / np.linalg.norm(l0) < 1e-12, method


@pytest.mark.parametrize('method, order', [('flow2', 2), ('flow4', 4)])
def test_splitting_orders_with_wrench_changes(method, order):
    """Kicks of a held wrench between exact free flows: Strang (2) and the triple jump (4);
    no history, so the order holds across the changes by construction."""
    dts = (1 / 16, 1 / 32, 1 / 64) if order == 4 else (1 / 64, 1 / 128, 1 / 256)
    for schedule in ([(0.0, FORCE, TORQUE, 'body')], SCHEDULE):
        orders = orders_of(global_errors(schedule, 2.0, dts, method=method))
        for q in 'xvwR':
            assert orders[q][-1] == pytest.approx(order, abs=0.15), (q, orders)


def test_damped_kick_is_exact_for_a_damped_sphere():
    """A sphere under a constant torque and angular damping d: omega(t) = tau / (I d)
    + (omega0 - tau / (I d)) e^(-d t), which the kick solves exactly (the free flow of a
    sphere changes nothing)."""
    sphere = RigidBody(2.0, [0.5, 0.5, 0.5])
    torque, w0, d = np.array([0.3, -0.2, 0.1]), np.array([1.0, 2.0, -0.5]), 0.7
    s = Stepper(sphere, 0.1, State(angular_velocity=w0), Wrench(torque=torque),
                method='flow2', angular_damping=d)
    s.step(30)
    limit = torque / (0.5 * d)
    assert np.allclose(s.state.angular_velocity, limit + (w0 - limit) * math.exp(-d * 3.0),
                       rtol=0, atol=1e-14)
