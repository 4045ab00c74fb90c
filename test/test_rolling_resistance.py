# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Rolling resistance: a ball rolls as far as the resisting moment mu_r N allows; couples keep
momentum and never add energy."""

import dataclasses

import numpy as np
import pytest

from rb_sim_ros import contact_solver as cs
from rb_sim_ros.collision_shapes import Plane, Sphere
from rb_sim_ros.collision_world import CollisionWorld
from rb_sim_ros.simulation import BodySpec, ContactSettings
from test_collisions import impact, momenta


@pytest.mark.parametrize('mu_r', [0.005, 0.002])
def test_a_rolling_ball_stops_where_the_resisting_moment_says(mu_r):
    """A solid ball rolling at v0 stops after s = (1 + I / (m r^2)) v0^2 r / (2 mu_r g): its
    kinetic energy, (1/2) m v0^2 (7/5), against the work mu_r m g s / r of the moment over
    the angle s / r it turns."""
    r, m, v0, dt = 0.1, 1.0, 0.5, 1e-3
    ball = BodySpec('ball', m, (0.4 * m * r * r,) * 3, initial_position=(0.0, 0.0, r),
                    initial_linear_velocity=(v0, 0.0, 0.0),
                    initial_angular_velocity=(0.0, v0 / r, 0.0), colliders=(Sphere(r),))
    world = CollisionWorld([ball], dt, (0.0, 0.0, -9.81), friction=0.5, planes=(Plane(),),
                           rolling_resistance=mu_r, sleep_time=0.0)
    world.step(4000)
    st = world.state('ball')
    expected = 1.4 * v0 * v0 * r / (2.0 * mu_r * 9.81)
    assert st.position[0] == pytest.approx(expected, abs=2 * v0 * dt)   # measured 0.6 mm
    assert np.abs(st.linear_velocity).max() < 1e-9
    assert np.abs(st.angular_velocity).max() < 1e-9


def test_without_rolling_resistance_it_rolls_on():
    r, v0 = 0.1, 0.5
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, r),
                    initial_linear_velocity=(v0, 0.0, 0.0),
                    initial_angular_velocity=(0.0, v0 / r, 0.0), colliders=(Sphere(r),))
    world = CollisionWorld([ball], 1e-3, (0.0, 0.0, -9.81), friction=0.5, planes=(Plane(),))
    world.step(2000)
    # (The contact solve takes 0.015% of its speed in 2 s.)
    assert world.state('ball').linear_velocity[0] == pytest.approx(v0, rel=1e-3)


def test_rolling_couples_keep_momentum_and_take_energy():
    """Two free bodies pressed together at an off-centre point, spinning, with friction: the
    couple is equal and opposite, so linear momentum and angular momentum about a fixed point
    stay to rounding, and kinetic energy only falls, against the same solve without it."""
    rng = np.random.default_rng(5)
    for _ in range(50):
        bodies, contacts, masses, inertias, rots, settings = impact(rng, 0.3, friction=0.5)
        v0, w0 = bodies.velocity, bodies.angular_velocity
        plain = cs.solve(contacts, bodies, settings)
        rolled = cs.solve(contacts, bodies,
                          dataclasses.replace(settings, rolling_resistance=0.05))
        p0, l0, _ = momenta(bodies, v0, w0, masses, inertias, rots)
        p1, l1, e1 = momenta(bodies, rolled.velocity, rolled.angular_velocity, masses,
                             inertias, rots)
        _, _, e_plain = momenta(bodies, plain.velocity, plain.angular_velocity, masses,
                                inertias, rots)
        assert np.abs(p1 - p0).max() < 1e-12 * np.abs(p0).max()
        assert np.abs(l1 - l0).max() < 1e-12 * np.abs(l0).max()
        assert e1 <= e_plain * (1 + 1e-12)
        assert not np.array_equal(rolled.angular_velocity, plain.angular_velocity)


def test_scene_contact_settings_carry_it():
    assert ContactSettings(rolling_resistance=0.01).world_arguments()['rolling_resistance'] \
        == 0.01
    with pytest.raises(ValueError, match='rolling_resistance'):
        ContactSettings(rolling_resistance=-0.01)
