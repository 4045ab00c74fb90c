# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Measured orders of the Proof 3 method, by halving dt against a DOP853 reference at 1e-13."""

import math

import numpy as np
import pytest

from oracles import dop853 as reference
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import multistep, so3, step_kernel
from support.convergence import (BODY, FORCE, global_errors, orders_of, SCHEDULE, START,
                                 state_errors, TORQUE)


def _one_step_errors(advance, frame='body'):
    """Errors of one step from exact history at t0, for dt = 0.04, 0.02, 0.01, 0.005."""
    t0 = 0.3
    schedule = [(0.0, FORCE, TORQUE, frame)]
    errors = []
    for dt in (0.04, 0.02, 0.01, 0.005):
        before, now, after = reference.solve(BODY, START, schedule, t0 + dt,
                                             times=[t0 - dt, t0, t0 + dt])
        errors.append(state_errors(advance(dt, before, now, Wrench(FORCE, TORQUE, frame)), after))
    return errors


def _stepper_step(method):
    def advance(dt, before, now, wrench):
        s = Stepper(BODY, dt, now, wrench, method=method)
        s.set_state(now, previous=before)
        s.step(1)
        return s.state
    return advance


def _eq14_step(dt, before, now, wrench):
    """Eq. (14) as printed in the report (the wrong one), for contrast."""
    def beta(state):
        inertia = state.rotation @ BODY.inertia @ state.rotation.T
        tau = state.rotation @ wrench.torque
        w = state.angular_velocity
        return np.linalg.solve(inertia, tau - np.cross(w, inertia @ w))
    b, bp, w = beta(now), beta(before), now.angular_velocity
    hb, hw = so3.hat(b), so3.hat(w)
    rot = (so3.exp((w + (4 * b - bp) / 6 * dt) * dt)
           - (hb @ hw + hw @ hb) * dt ** 3 / 12) @ now.rotation
    return State(now.position, so3.orthonormalize(rot), now.linear_velocity, w)


def test_local_orders_from_exact_history():
    orders = orders_of(_one_step_errors(_stepper_step('eq27'), 'body'))
    # eq. (11)-(12): local O(dt^3); eq. (13) and the last line of eq. (27): O(dt^4).
    for q, expected in (('v', 3), ('w', 3), ('x', 4), ('R', 4)):
        assert orders[q][-1] == pytest.approx(expected, abs=0.25), (q, orders)


def test_local_orders_with_a_world_frame_force():
    # A constant world force: x and v are exact (to the reference's 1e-13), w and R as before.
    errors = _one_step_errors(_stepper_step('eq27'), 'world')
    assert max(e['x'] for e in errors) < 1e-12 and max(e['v'] for e in errors) < 1e-12
    orders = orders_of([{q: e[q] for q in 'wR'} for e in errors])
    assert orders['w'][-1] == pytest.approx(3.0, abs=0.25)
    assert orders['R'][-1] == pytest.approx(4.0, abs=0.25)


def test_local_order_of_R_falls_without_the_cross_term_or_with_eq14():
    # The same test tells the wrong updates apart (NOTES.md 1): it can fail.
    no_cross = orders_of(_one_step_errors(_stepper_step(multistep.EQ27_NO_CROSS)))
    eq14 = orders_of(_one_step_errors(_eq14_step))
    assert no_cross['R'][-1] == pytest.approx(3.0, abs=0.25)
    assert eq14['R'][-1] == pytest.approx(3.0, abs=0.25)


def test_global_order_two():
    orders = orders_of(global_errors([(0.0, FORCE, TORQUE, 'body')], 2.0, (1 / 50, 1 / 100,
                                                                           1 / 200)))
    for q in 'xvwR':
        assert orders[q][-1] == pytest.approx(2.0, abs=0.2), (q, orders)


def test_global_order_of_taylor1_is_one():
    orders = orders_of(global_errors([(0.0, FORCE, TORQUE, 'body')], 2.0,
                                     (1 / 100, 1 / 200, 1 / 400), method='taylor1'))
    for q in 'vwR':
        assert orders[q][-1] == pytest.approx(1.0, abs=0.2), (q, orders)


DTS = (1 / 64, 1 / 128, 1 / 256)


def test_global_order_two_with_a_wrench_change_every_few_steps():
    orders = orders_of(global_errors(SCHEDULE, 2.0, DTS))
    for q in 'xvwR':
        assert orders[q][-1] == pytest.approx(2.0, abs=0.2), (q, orders)


def test_stale_history_across_wrench_changes_falls_to_first_order():
    # Keep a_{n-1}, beta_{n-1} of the old wrench, as a naive multistep would (NOTES.md 2).
    def keep_stale_history(stepper):
        # The kernel's history flag: the stored a_{n-1}, beta_{n-1} taken as they are.
        row = stepper._store.state[stepper._row]
        if row[step_kernel.HISTORY] == step_kernel.HISTORY_STALE:
            row[step_kernel.HISTORY] = step_kernel.HISTORY_VALID
    orders = orders_of(global_errors(SCHEDULE, 2.0, DTS, tamper=keep_stale_history))
    assert orders['w'][-1] == pytest.approx(1.0, abs=0.2)


def test_isotropic_body_with_constant_torque_has_fourth_order_rotation():
    # NOTES.md 1: omega is linear in t, which AB2 integrates exactly, so R's error is that of
    # eq. (27) alone and falls with order 4.
    sphere = RigidBody(1.0, [0.7, 0.7, 0.7])
    torque = np.array([0.3, -0.5, 0.4])
    ref_rot = None
    errors = []
    for dt in (1 / 20, 1 / 40, 1 / 80):
        s = Stepper(sphere, dt, State(angular_velocity=[1.0, 2.0, -0.5]), Wrench(torque=torque))
        s.step(round(2.0 / dt))
        if ref_rot is None:
            ref_rot = reference.solve(sphere, State(angular_velocity=[1.0, 2.0, -0.5]),
                                      [(0.0, [0, 0, 0], torque, 'world')], 2.0)[0].rotation
        errors.append(so3.angle_between(s.state.rotation, ref_rot))
    assert math.log2(errors[-2] / errors[-1]) > 3.6
