# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Chains of touching bodies (issue 33, item 1): an impact travels down a chain as the
sequence of ideal pairwise collisions does. Oracles: the ideal sequence (equal balls, e = 1:
each collision swaps the two velocities along the line of centres), momentum (exact: every
impulse is a pair of equal and opposite ones) and kinetic energy (kept at e = 1, never gained
at e < 1)."""

import math

import numpy as np
import pytest

from rb_sim_ros.contact import contact_solver as cs
from rb_sim_ros.contact.collision_shapes import Plane, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

R, MASS, V0 = 0.05, 0.2, 1.0
INERTIA = 0.4 * MASS * R * R


def _ball(name, position, velocity=(0.0, 0.0, 0.0)):
    return BodySpec(name, MASS, (INERTIA,) * 3, initial_position=tuple(position),
                    initial_linear_velocity=tuple(velocity), colliders=(Sphere(R),))


def _world(bodies, restitution=1.0, gravity=(0.0, 0.0, 0.0), planes=(), friction=0.0,
           bounce_threshold=0.1):
    return collision_world(bodies, 1e-3, gravity, planes=planes,
                           contact=ContactSettings(restitution=restitution, friction=friction,
                                                   sleep_time=0.0,
                                                   bounce_threshold=bounce_threshold))


def _momentum_energy(world, names):
    p, e = np.zeros(3), 0.0
    for name in names:
        s = world.state(name)
        v, w = np.asarray(s.linear_velocity), np.asarray(s.angular_velocity)
        p += MASS * v
        e += 0.5 * MASS * float(v @ v) + 0.5 * INERTIA * float(w @ w)
    return p, e


def _cradle(count, restitution=1.0):
    """``count`` balls touching in a row along x, and one more coming at them along the row
    at V0 from 2 cm away."""
    bodies = [_ball('cue', (-2 * R - 0.02, 0.0, 0.0), (V0, 0.0, 0.0))]
    bodies += [_ball(f'b{i}', (2 * R * i, 0.0, 0.0)) for i in range(count)]
    return _world(bodies, restitution), ['cue'] + [f'b{i}' for i in range(count)]


@pytest.mark.parametrize('count', [1, 2, 4])
def test_a_cradle_passes_the_impact_to_its_last_ball(count):
    """A cradle of 2, 3 and 5 balls (the cue and ``count`` touching): the last leaves with V0
    along the row, the others stay at rest, within 2% of V0; momentum to 1e-12, energy to
    1e-9."""
    world, names = _cradle(count)
    p0, e0 = _momentum_energy(world, names)
    world.step(60)  # the cue meets the first ball after 20 ms; the last is then on its way
    p, e = _momentum_energy(world, names)
    np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * MASS * V0)
    assert e == pytest.approx(e0, rel=1e-9)
    for name in names[:-1]:
        assert np.linalg.norm(world.state(name).linear_velocity) < 0.02 * V0, name
    np.testing.assert_allclose(world.state(names[-1]).linear_velocity, (V0, 0.0, 0.0),
                               rtol=0, atol=0.02 * V0)


def test_a_cradle_at_e_below_one_loses_energy_and_never_gains():
    """e = 0.8: the ideal sequence leaves the last ball with ((1 + e) / 2)^n V0 ... at most
    the energy before, every step; momentum kept."""
    world, names = _cradle(4, restitution=0.8)
    p0, e0 = _momentum_energy(world, names)
    for _ in range(60):
        world.step(1)
        p, e = _momentum_energy(world, names)
        np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * MASS * V0)
        assert e <= e0 * (1.0 + 1e-12)
    assert e < e0 * (1.0 - 1e-3)


def test_a_billiard_break_keeps_momentum_and_energy():
    """15 balls racked touching in a triangle, the cue at 3 m/s off the rack's axis: after
    the break, momentum to 1e-12 and kinetic energy to 1e-9 (e = 1, frictionless, no
    gravity, and no bounce threshold: the slowest meetings of a break, below the default
    0.1 m/s, would otherwise be plastic)."""
    bodies = [_ball('cue', (-0.5, 0.01, 0.0), (3.0, 0.0, 0.0))]
    names = ['cue']
    k = 0
    for row in range(5):
        for j in range(row + 1):
            x = row * 2 * R * math.sqrt(3) / 2
            y = (j - row / 2) * 2 * R
            bodies.append(_ball(f'r{k}', (x, y, 0.0)))
            names.append(f'r{k}')
            k += 1
    world = _world(bodies, bounce_threshold=0.0)
    p0, e0 = _momentum_energy(world, names)
    world.step(400)
    p, e = _momentum_energy(world, names)
    np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * MASS * 3.0)
    assert e == pytest.approx(e0, rel=1e-9)
    assert sum(np.linalg.norm(world.state(n).linear_velocity) > 0.1 for n in names) >= 5


def test_a_ball_dropped_on_a_resting_stack_leaves_as_the_ideal_sequence_predicts():
    """Three balls resting in a column on the ground, a fourth dropped on them from 20 cm
    (e = 1, frictionless): the ideal sequence passes its impact down the column, off the
    ground and back up, so it leaves upwards with the speed it came at and the column stays
    at rest (within 2% of that speed)."""
    h = 0.2
    bodies = [_ball(f's{i}', (0.0, 0.0, R + 2 * R * i)) for i in range(3)]
    bodies.append(_ball('drop', (0.0, 0.0, 7 * R + h)))
    world = _world(bodies, gravity=(0.0, 0.0, -9.81), planes=(Plane(),))
    speed = 0.0
    for _ in range(400):
        before = -float(world.state('drop').linear_velocity[2])
        world.step(1)
        if world.state('drop').linear_velocity[2] > 0.0:
            speed = before
            break
    assert speed == pytest.approx(math.sqrt(2 * 9.81 * h), rel=0.01)
    assert float(world.state('drop').linear_velocity[2]) == pytest.approx(speed, rel=0.02)
    for i in range(3):
        assert np.linalg.norm(world.state(f's{i}').linear_velocity) < 0.02 * speed


def _solve(body_a, body_b, point, normal, velocity, inverse_mass, inverse_inertia, warm=None,
           iterations=10):
    n = len(inverse_mass)
    bodies = cs.Bodies(np.zeros((n, 3)), np.array(velocity, float), np.zeros((n, 3)),
                       np.array(inverse_mass, float), np.array(inverse_inertia, float))
    contacts = cs.ContactArrays(np.array(body_a), np.array(body_b), np.array(point, float),
                                np.array(normal, float), np.zeros(len(body_a)))
    settings = cs.SolverSettings(restitution=1.0, friction=0.0, position_iterations=0,
                                 velocity_iterations=iterations)
    if warm is None:
        return cs.solve(contacts, bodies, settings)
    return cs.solve(contacts, bodies, settings, np.array(warm, float),
                    np.zeros((len(body_a), 3)))


def test_a_cube_landing_flat_bounces_from_its_four_corners_at_once_however_they_are_listed():
    """A cube falling flat at 1 m/s onto the ground (e = 1): its four corner contacts are one
    pair's, whether each names the cube or the ground first, so they collide together and it
    leaves at 1 m/s without turning (they were two pairs once: 0.92 m/s and 4.8 rad/s)."""
    h, mass = 0.1, 1.0
    inertia = np.eye(3) / (mass * (2 * h) ** 2 / 6)
    for split in (False, True):
        body_a, body_b, point, normal = [], [], [], []
        for x, y in ((-h, -h), (-h, h), (h, -h), (h, h)):
            point.append((x, y, -h))
            if split and x > 0:  # the cube first, the normal from it to the ground
                body_a.append(0), body_b.append(1), normal.append((0.0, 0.0, -1.0))
            else:
                body_a.append(1), body_b.append(0), normal.append((0.0, 0.0, 1.0))
        result = _solve(body_a, body_b, point, normal, [[0.0, 0.0, -1.0], [0.0, 0.0, 0.0]],
                        [1.0 / mass, 0.0], [inertia, np.zeros((3, 3))], iterations=30)
        assert result.velocity[0, 2] == pytest.approx(1.0, abs=1e-6), split
        assert np.linalg.norm(result.angular_velocity[0]) < 1e-6, split


def test_a_ball_wedged_between_two_walls_takes_no_endless_impulse():
    """A ball that fits a slot exactly, moving at 1 m/s against one wall (e = 1): no sequence
    of pairwise bounces ends (each sends it against the other wall), so the impact pass gives
    up and the contacts are solved at once: it goes back and forth, and over ten steps of
    warm starting each impulse stays within undoing the warm start's reversal and reversing
    it again (4 m v; the pass that carried on grew them to 842 N s in five), and it gains no
    energy."""
    walls = dict(point=[(-R, 0.0, 0.0), (R, 0.0, 0.0)],
                 normal=[(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)])
    inverse = [np.eye(3) / INERTIA, np.zeros((3, 3)), np.zeros((3, 3))]
    velocity = [[V0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    warm = None
    for _ in range(10):
        result = _solve([0, 0], [1, 2], walls['point'], walls['normal'], velocity,
                        [1.0 / MASS, 0.0, 0.0], inverse, warm=warm, iterations=30)
        assert np.all(result.normal_impulse <= 4.0 * MASS * V0 * (1.0 + 1e-9))
        assert np.linalg.norm(result.velocity[0]) <= V0 * (1.0 + 1e-9)
        warm, velocity = result.normal_impulse, result.velocity
