# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Gravity and damping against their closed forms; specialised steps against the general one."""

import math

import numpy as np
import pytest

from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

G = np.array([0.0, 0.0, -9.81])


def _orders(errors):
    return [math.log2(a / b) for a, b in zip(errors, errors[1:])]


def test_gravity_and_linear_damping_against_closed_form():
    c, x0, v0, t_end = 0.7, np.array([0.0, 1.0, 10.0]), np.array([2.0, 0.0, 5.0]), 3.0
    v_inf = G / c
    decay = math.exp(-c * t_end)
    v_exact = v_inf + (v0 - v_inf) * decay
    x_exact = x0 + v_inf * t_end + (v0 - v_inf) * (1.0 - decay) / c
    errors = []
    for dt in (0.01, 0.005, 0.0025):
        s = Stepper(RigidBody(2.0, [0.1, 0.2, 0.25]), dt, State(x0, None, v0), gravity=G,
                    linear_damping=c)
        s.step(round(t_end / dt))
        errors.append(max(np.linalg.norm(s.state.position - x_exact),
                          np.linalg.norm(s.state.linear_velocity - v_exact)))
    assert errors[-1] < 5e-5  # |x| ~ 20 m after 3 s
    assert _orders(errors)[-1] == pytest.approx(2.0, abs=0.15)


def test_gravity_alone_is_exact():
    x0, v0 = np.array([0.0, 0.0, 100.0]), np.array([1.0, 0.0, 0.0])
    s = Stepper(RigidBody(1.0, [1.0, 1.0, 1.0]), 0.01, State(x0, None, v0), gravity=G)
    s.step(300)
    t = s.time
    np.testing.assert_allclose(s.state.position, x0 + v0 * t + 0.5 * G * t * t, atol=1e-11)


def test_angular_damping_of_a_sphere_against_closed_form():
    d, w0, t_end = 0.5, np.array([1.0, -2.0, 0.5]), 4.0
    rot0 = so3.exp([0.1, 0.2, 0.3])
    # omega(t) = w0 e^{-d t} about a fixed axis: angle |w0| (1 - e^{-d t}) / d.
    w_exact = w0 * math.exp(-d * t_end)
    rot_exact = so3.exp(w0 * (1.0 - math.exp(-d * t_end)) / d) @ rot0
    errors = []
    for dt in (0.02, 0.01, 0.005):
        s = Stepper(RigidBody(1.0, [0.3, 0.3, 0.3]), dt, State(rotation=rot0,
                    angular_velocity=w0), angular_damping=d)
        s.step(round(t_end / dt))
        errors.append(max(np.linalg.norm(s.state.angular_velocity - w_exact),
                          so3.angle_between(s.state.rotation, rot_exact)))
    assert errors[-1] < 1e-5
    assert _orders(errors)[-1] == pytest.approx(2.0, abs=0.15)


@pytest.mark.parametrize('name', ['gravity', 'damping'])
def test_bad_environment_is_refused(name):
    body = RigidBody(1.0, [1, 1, 1])
    with pytest.raises(ValueError, match=name):
        if name == 'gravity':
            Stepper(body, 0.01, gravity=(0, math.nan, 0))
        else:
            Stepper(body, 0.01, angular_damping=-1.0)


def _pair(body, state, wrench=Wrench(), **env):
    return (Stepper(body, 1e-3, state, wrench, specialize=True, **env),
            Stepper(body, 1e-3, state, wrench, specialize=False, **env))


def _run_both(pair, steps, wrenches=()):
    for s in pair:
        s.step(steps)
        for w in wrenches:
            s.set_wrench(w)
            s.step(steps)
    return [s.state for s in pair]


ASYMMETRIC = RigidBody(2.0, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.4]])


def test_frozen_rotation_is_bit_identical_in_translation():
    # No torque and omega = 0: the rotation update is skipped; x, v are the same bits.
    spec, gen = _run_both(_pair(ASYMMETRIC, State(linear_velocity=[1.0, 2.0, 3.0]),
                                Wrench(force=[0.5, -1.0, 2.0]), gravity=G,
                                linear_damping=0.3), 3000)
    assert spec.position.tolist() == gen.position.tolist()
    assert spec.linear_velocity.tolist() == gen.linear_velocity.tolist()
    assert spec.angular_velocity.tolist() == gen.angular_velocity.tolist() == [0, 0, 0]
    assert so3.angle_between(spec.rotation, gen.rotation) < 1e-15


def test_frozen_translation_is_bit_identical_in_rotation():
    spec, gen = _run_both(_pair(ASYMMETRIC, State(angular_velocity=[1.0, 2.0, 3.0]),
                                Wrench(torque=[0.01, 0.0, -0.02], frame='body')), 3000)
    assert spec.position.tolist() == gen.position.tolist() == [0, 0, 0]
    assert spec.angular_velocity.tolist() == gen.angular_velocity.tolist()
    assert spec.rotation.tolist() == gen.rotation.tolist()


def test_at_rest_costs_nothing_and_moves_nothing():
    spec, gen = _pair(ASYMMETRIC, State(position=[1, 2, 3]))
    spec.step(10_000)
    # At most the start-up evaluation of the history, once; not one step of the kernel.
    first = spec.work
    assert first['full'] == first['translation'] == 0 and first['start_up'] <= 1
    spec.step(10_000)
    assert spec.work == first  # and nothing at all once under way
    gen.step(20_000)  # the general path takes every step
    assert gen.work['full'] == 20_000
    assert spec.time == gen.time and spec.step_count == gen.step_count == 20_000
    assert spec.state.position.tolist() == gen.state.position.tolist() == [1, 2, 3]
    # And a wrench later moves it exactly as the general path does: 500 more steps at rest,
    # free, then 500 under the wrench, each one stepped.
    both = _run_both((spec, gen), 500, [Wrench(force=[1, 0, 0], torque=[0, 0.1, 0])])
    assert spec.work['full'] == 500
    assert both[0].position.tolist() == both[1].position.tolist()
    # The general path re-orthonormalised the unchanged R every 1024 steps: 1e-16 apart.
    assert so3.angle_between(both[0].rotation, both[1].rotation) < 1e-15


def test_a_body_that_does_not_turn_takes_translation_steps_only():
    spec, gen = _pair(ASYMMETRIC, State(linear_velocity=[1, 0, 0]), Wrench(force=[0, 1, 0]))
    spec.step(3000)
    gen.step(3000)
    assert spec.work['full'] == 0 and spec.work['translation'] == 3000
    assert gen.work['full'] == 3000
    assert spec.state.position.tolist() == gen.state.position.tolist()


@pytest.mark.parametrize('frame', ['world', 'body'])
def test_isotropic_specialisation_agrees_with_general(frame):
    sphere = RigidBody(1.0, [0.4, 0.4, 0.4])
    spec, gen = _run_both(_pair(sphere, State(angular_velocity=[1.0, -0.5, 2.0]),
                                Wrench(force=[1, 0, 0], torque=[0.1, 0.2, -0.1], frame=frame),
                                angular_damping=0.1), 2000,
                          [Wrench(torque=[0.0, -0.3, 0.1], frame=frame)])
    np.testing.assert_allclose(spec.angular_velocity, gen.angular_velocity, rtol=0, atol=1e-12)
    np.testing.assert_allclose(spec.position, gen.position, rtol=0, atol=1e-12)
    assert so3.angle_between(spec.rotation, gen.rotation) < 1e-12
