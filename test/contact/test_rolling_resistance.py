# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Rolling resistance and torsional friction: a ball rolls as far, and spins as long, as the
resisting moments mu_r N and mu_t N allow; couples keep momentum and never add energy."""

import dataclasses

import numpy as np
import pytest

from oracles.contact_cases import impact, momenta, random_contact_set
from rb_sim_ros.contact import contact_solver as cs
from rb_sim_ros.contact.collision_shapes import Plane, Sphere
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec, ContactSettings
from support.solver_fingerprint import solver_fingerprints


@pytest.mark.parametrize('mu_r', [0.005, 0.002])
def test_a_rolling_ball_stops_where_the_resisting_moment_says(mu_r):
    """A solid ball rolling at v0 stops after s = (1 + I / (m r^2)) v0^2 r / (2 mu_r g): its
    kinetic energy, (1/2) m v0^2 (7/5), against the work mu_r m g s / r of the moment over
    the angle s / r it turns."""
    r, m, v0, dt = 0.1, 1.0, 0.5, 1e-3
    ball = BodySpec('ball', m, (0.4 * m * r * r,) * 3, initial_position=(0.0, 0.0, r),
                    initial_linear_velocity=(v0, 0.0, 0.0),
                    initial_angular_velocity=(0.0, v0 / r, 0.0), colliders=(Sphere(r),))
    world = collision_world([ball], dt, (0.0, 0.0, -9.81), planes=(Plane(),),
                            contact=ContactSettings(friction=0.5, sleep_time=0.0,
                                                    rolling_resistance=mu_r))
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
    world = collision_world([ball], 1e-3, (0.0, 0.0, -9.81), planes=(Plane(),),
                            contact=ContactSettings(friction=0.5))
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


def test_scene_contact_settings_carry_them():
    solver = ContactSettings(rolling_resistance=0.01, torsional_friction=0.02).solver_settings(
        1e-3)
    assert (solver.rolling_resistance, solver.torsional_friction, solver.dt) == (0.01, 0.02, 1e-3)
    for name in ('rolling_resistance', 'torsional_friction'):
        with pytest.raises(ValueError, match=name):
            ContactSettings(**{name: -0.01})


def cs_rotation(rng):
    return so3.exp(rng.normal(size=3))


def _tangent_spin(result, contacts, k=0):
    t1, t2 = cs.tangent_basis(contacts.normal[k:k + 1])
    a, b = contacts.body_a[k], contacts.body_b[k]
    w = result.angular_velocity[b] - result.angular_velocity[a]
    return np.array([w @ t1[0], w @ t2[0]])


@pytest.mark.parametrize('ratio', [1.0, 6.0, 100.0])
def test_the_couple_only_shrinks_the_relative_rolling_of_uneven_bodies(ratio):
    """Across the tangent plane, w_t after = (1 - s) w_t before with 0 <= s <= 1, however
    uneven the inertia (a scalar row along w_t would turn part of it back)."""
    rng = np.random.default_rng(int(ratio))
    for _ in range(40):
        bodies, contacts, *_, settings = impact(rng, 0.0, friction=0.5, static_b=True)
        moments = np.array([1.0, 1.0 / ratio, 0.5])
        q = cs_rotation(rng)
        bodies.inverse_inertia[0] = q @ np.diag(1.0 / moments) @ q.T * 0.2
        plain = cs.solve(contacts, bodies, settings)
        for mu_r in (1e-4, 0.01, 10.0):
            rolled = cs.solve(contacts, bodies,
                              dataclasses.replace(settings, rolling_resistance=mu_r))
            before, after = _tangent_spin(plain, contacts), _tangent_spin(rolled, contacts)
            if plain.normal_impulse[0] == 0.0:
                assert np.array_equal(before, after)
                continue
            s = 1.0 - (after @ before) / (before @ before)
            assert -1e-9 <= s <= 1.0 + 1e-9, (ratio, mu_r, s)
            np.testing.assert_allclose(after, (1.0 - s) * before, atol=1e-9 * abs(before).max())


def test_many_contacts_in_one_solve_keep_momentum():
    """Eight free bodies pressed into each other at 16 random points (several colours, the
    couples applied colour by colour): linear momentum and angular momentum about a fixed
    point are what they were before the solve, with the couples as without them."""
    rng = np.random.default_rng(3)
    n, m = 8, 16
    masses = rng.uniform(0.5, 2.0, n)
    inertia_body = [np.diag(rng.uniform(0.05, 0.5, 3)) for _ in range(n)]
    rotations = [cs_rotation(rng) for _ in range(n)]
    inertia = [r @ i @ r.T for r, i in zip(rotations, inertia_body)]
    position = rng.normal(size=(n, 3))
    bodies = cs.Bodies(position, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 3.0,
                       1.0 / masses, np.array([np.linalg.inv(i) for i in inertia]))
    a = rng.integers(0, n, size=m)
    b = (a + rng.integers(1, n, size=m)) % n                # never a body with itself
    normal = rng.normal(size=(m, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    contacts = cs.ContactArrays(a, b, rng.normal(size=(m, 3)), normal, np.full(m, 0.01))
    settings = cs.SolverSettings(friction=0.5, position_iterations=0, rolling_resistance=0.05,
                                 torsional_friction=0.05)
    result = cs.solve(contacts, bodies, settings)
    plain = cs.solve(contacts, bodies, dataclasses.replace(settings, rolling_resistance=0.0,
                                                           torsional_friction=0.0))
    assert (result.normal_impulse > 0.0).sum() >= 4 and result.colours >= 2
    assert not np.array_equal(result.angular_velocity, plain.angular_velocity)

    def momenta_of(vel, ang):
        return (sum(masses[k] * vel[k] for k in range(n)),
                sum(masses[k] * np.cross(position[k] - 1.0, vel[k]) + inertia[k] @ ang[k]
                    for k in range(n)))
    p0, l0 = momenta_of(bodies.velocity, bodies.angular_velocity)
    p1, l1 = momenta_of(result.velocity, result.angular_velocity)
    np.testing.assert_allclose(p1, p0, atol=1e-12 * np.abs(p0).max())
    np.testing.assert_allclose(l1, l0, atol=1e-12 * np.abs(l0).max())


def test_a_spinning_ball_slows_as_the_torsional_moment_says():
    """A ball spinning about the vertical on the ground (Coulomb friction at its one contact
    point has no moment about that axis): I dw/dt = -mu_t m g, so w falls linearly to 0 at
    T = I w0 / (mu_t m g), and stays there."""
    r, m, w0, mu_t, dt = 0.1, 1.0, 10.0, 0.01, 1e-3
    inertia = 0.4 * m * r * r
    ball = BodySpec('ball', m, (inertia,) * 3, initial_position=(0.0, 0.0, r),
                    initial_angular_velocity=(0.0, 0.0, w0), colliders=(Sphere(r),))
    world = collision_world([ball], dt, (0.0, 0.0, -9.81), planes=(Plane(),),
                            contact=ContactSettings(friction=0.5, sleep_time=0.0,
                                                    torsional_friction=mu_t))
    stop = inertia * w0 / (mu_t * m * 9.81)
    for fraction in (0.25, 0.5, 0.75):
        world.step(round(fraction * stop / dt) - world.step_count)
        assert world.state('ball').angular_velocity[2] == pytest.approx(
            w0 * (1.0 - world.time / stop), abs=1e-9)
    world.step(round(0.5 * stop / dt))
    assert world.state('ball').angular_velocity[2] == 0.0
    free = collision_world([ball], dt, (0.0, 0.0, -9.81), planes=(Plane(),),
                           contact=ContactSettings(friction=0.5))
    free.step(500)
    assert free.state('ball').angular_velocity[2] == pytest.approx(w0, rel=1e-12)


def test_compiled_and_interpreted_couples_give_the_same_bits():
    """120 random contacts among 30 bodies and the static world, spinning fast, both couples
    on (several colours, many pressed contacts): the compiled kernel and the interpreted one
    (NUMBA_DISABLE_JIT=1) give the same bits, and the couples change the spins."""
    compiled, interpreted = solver_fingerprints('couples')
    assert compiled == interpreted
    assert compiled['couples']['colours'] > 1 and compiled['couples']['pressed'] > 20
    bodies, contacts = random_contact_set(np.random.default_rng(21), spin=3.0)
    settings = cs.SolverSettings(friction=0.6, rolling_resistance=0.02, torsional_friction=0.01)
    rolled = cs.solve(contacts, bodies, settings)
    plain = cs.solve(contacts, bodies, cs.SolverSettings(friction=0.6))
    assert not np.array_equal(rolled.angular_velocity, plain.angular_velocity)
