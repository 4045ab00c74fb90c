# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ellipsoid collider (contact/shapes/ellipsoid.py), a kind added as one module, its place
in shapes.KINDS and its rows of narrow_kernels.PAIR_TESTS: two touch where both surfaces'
normals are opposite, at the least reach of an independent minimisation; a round one
bounces as the ball does, it rests on each of its axes at that semi-axis on a plane, a box
or an ellipsoid, tipped it rocks at the frequency of its curvature without gaining energy,
scene files read it and refuse bad ones, and a run with it records and replays bit for bit.
(The protocol, its support, its drawing and its pair rows in both orders: test_shape_table,
with every kind.)"""

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from oracles.contact_cases import apexes, G, GROUND
from oracles.node_recording import record_offline
from rb_sim_ros.contact import convex_kernels as ck, narrow_kernels as nk, narrow_phase as nph
from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.collision_shapes import Plane
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.offline import replay
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec, Config

Ellipsoid = shapes.Ellipsoid
RADII = (0.3, 0.2, 0.1)
MASS = 2.0


def _inertia(radii, mass=MASS):
    a, b, c = radii
    return (mass / 5 * (b * b + c * c), mass / 5 * (a * a + c * c), mass / 5 * (a * a + b * b))


def _body(name, radii, position, rotation=np.eye(3), **kwargs):
    return BodySpec(name, MASS, _inertia(radii), initial_position=tuple(position),
                    initial_orientation_xyzw=tuple(so3.quaternion_xyzw_from_matrix(rotation)),
                    colliders=(Ellipsoid(tuple(radii)),), **kwargs)


def test_a_round_ellipsoid_bounces_to_e_squared_h_as_the_ball_does():
    """Radii (r, r, r) through the convex narrow phase: the tops after two bounces are
    e^2 h within the bound of test_collisions' ball ((1 - e^2) v dt, speculative contacts)."""
    r, e, dt, h = 0.1, 0.8, 1e-3, 0.7313
    world = collision_world([_body('egg', (r, r, r), (0.0, 0.0, r + h))], dt, G,
                            planes=GROUND, contact=ContactSettings(restitution=e))
    tops = apexes(world, 'egg', int(4.2 * math.sqrt(2 * h / 9.81) / dt) + 50)
    assert len(tops) >= 2
    previous = h
    for top in tops[:2]:
        error = (top - r) - e * e * previous
        assert -1e-5 <= error <= (1 - e * e) * math.sqrt(2 * 9.81 * previous) * dt + 1e-5
        previous = top - r


GROUNDS = {  # each with its top at z = 0
    'plane': (),
    'box': (BodySpec('ground', static=True, initial_position=(0.0, 0.0, -0.1),
                     colliders=(shapes.Box((2.0, 2.0, 0.2)),)),),
    'ellipsoid': (BodySpec('ground', static=True, initial_position=(0.0, 0.0, -0.1),
                           colliders=(Ellipsoid((2.0, 1.5, 0.1)),)),)}


@pytest.mark.parametrize('ground', sorted(GROUNDS))
@pytest.mark.parametrize('axis', [0, 1, 2])
def test_an_ellipsoid_rests_on_each_axis_at_that_semi_axis(axis, ground):
    """Each semi-axis upright (a rotation taking it to z): dropped from 2 cm on a plane, a
    box's top or a flat ellipsoid's, it comes to rest with its centre at that semi-axis above
    the ground (less the solver's slop, 0.1 mm), its axis still upright, and still."""
    turn = {0: so3.exp(np.array([0.0, -math.pi / 2, 0.0])),
            1: so3.exp(np.array([math.pi / 2, 0.0, 0.0])), 2: np.eye(3)}[axis]
    world = collision_world([_body('egg', RADII, (0.0, 0.0, RADII[axis] + 0.02), turn)]
                            + list(GROUNDS[ground]), 1e-3, G,
                            planes=GROUND if ground == 'plane' else (),
                            contact=ContactSettings(sleep_time=0.0))
    world.step(1500)
    s = world.state('egg')
    assert s.position[2] == pytest.approx(RADII[axis] - 1e-4, abs=5e-5)
    assert abs(s.position[0]) < 1e-6 and abs(s.position[1]) < 1e-6
    assert (np.asarray(s.rotation) @ np.eye(3)[axis])[2] > 1.0 - 1e-9
    assert np.linalg.norm(s.linear_velocity) < 1e-4 and np.linalg.norm(s.angular_velocity) < 1e-3


def test_a_tipped_ellipsoid_rocks_at_the_rolling_frequency_and_gains_no_energy():
    """On its shortest axis c, tipped 0.02 rad about its longest a: it rolls to and fro on
    the ellipse of b and c, whose radius of curvature at the bottom is b^2 / c, so its centre
    rises by (b^2 / c - c) theta^2 / 2 and it turns about the contact point, c below the
    centre: omega^2 = g (b^2 / c - c) / (I_a / m + c^2), I_a = m (b^2 + c^2) / 5 (small
    swings; the swing's own correction is of order theta^2, 4e-4). Its period over five
    swings within 1%, and its energy (kinetic and potential) never above the start's."""
    a, b, c = RADII
    tilt = 0.02
    omega = math.sqrt(9.81 * (b * b / c - c) / ((b * b + c * c) / 5 + c * c))
    turn = so3.exp(np.array([tilt, 0.0, 0.0]))
    rest = math.sqrt((b * math.sin(tilt)) ** 2 + (c * math.cos(tilt)) ** 2)  # centre height
    world = collision_world([_body('egg', RADII, (0.0, 0.0, rest - 1e-4), turn)], 5e-4, G,
                            planes=GROUND, contact=ContactSettings(friction=1.0,
                                                                   sleep_time=0.0))
    inertia = np.diag(_inertia(RADII))

    def energy():
        s = world.state('egg')
        w = np.asarray(s.rotation).T @ np.asarray(s.angular_velocity)
        return (0.5 * MASS * float(np.dot(s.linear_velocity, s.linear_velocity))
                + 0.5 * float(w @ inertia @ w) + MASS * 9.81 * float(s.position[2]))

    start = energy()
    crossings, previous, t = [], tilt, 0.0
    while len(crossings) < 11 and t < 6.0:
        world.step(1)
        t += 5e-4
        side = float(np.asarray(world.state('egg').rotation)[2, 1])  # sin of the tilt about x
        if side * previous < 0.0:
            crossings.append(t - 5e-4 * side / (side - previous))
        previous = side
        assert energy() <= start + 1e-9
    assert len(crossings) == 11
    period = (crossings[-1] - crossings[0]) / 5
    assert period == pytest.approx(2 * math.pi / omega, rel=0.01)


def _normal_at(shape, pose, point):
    """The outward unit normal of ``shape`` (an ellipsoid) at ``point`` (world), and how far
    the point is off its surface ((x/a)^2 + (y/b)^2 + (z/c)^2 - 1 in its axes)."""
    centre, rotation = pose
    local = rotation.T @ (np.asarray(point) - centre)
    inverse = 1.0 / np.array(shape.radii) ** 2
    normal = rotation @ (local * inverse)
    return normal / np.linalg.norm(normal), float(local @ (local * inverse)) - 1.0


def _least_reach(a, pose_a, b, pose_b, start):
    """The least reach of A - B along a unit n, A's support along n plus B's along -n less
    the centres' distance along n (BFGS on the sphere from several starts): the depth of the
    overlap, or minus the gap."""
    def reach(x):
        n = x / np.linalg.norm(x)
        total = float((pose_a[0] - pose_b[0]) @ n)
        for shape, (centre, rotation), m in ((a, pose_a, n), (b, pose_b, -n)):
            total += float(np.linalg.norm(np.array(shape.radii) * (rotation.T @ m)))
        return total
    rng = np.random.default_rng(0)
    starts = [start] + [rng.normal(size=3) for _ in range(6)]
    return min(minimize(reach, x0, method='BFGS', options={'gtol': 1e-12}).fun for x0 in starts)


def test_two_ellipsoids_touch_where_their_normals_are_opposite():
    """Random pairs overlapping by up to 2 cm along a direction u or apart by up
    to 2 mm (margin 1 cm; those apart by more along another way have none): one
    contact, its points a = p + depth n / 2 and b = p - depth n / 2 on the surfaces, A's
    outward normal at a is n and B's at b is -n (so a - b is along n: the shortest way out),
    and the depth is the least reach of A - B (an independent minimisation). (GJK's and EPA's
    polytopes alone left the normal 2-3 degrees off at a 1 cm overlap.)"""
    rng = np.random.default_rng(3)
    rows = nk.MAX_CONTACTS_PER_PAIR
    tested = 0
    for _ in range(80):
        a = Ellipsoid(tuple(rng.uniform(0.05, 0.3, 3)))
        b = Ellipsoid(tuple(rng.uniform(0.05, 0.3, 3)))
        pose_a = (rng.normal(size=3) * 0.1, so3.exp(rng.normal(size=3)))
        rotation = so3.exp(rng.normal(size=3))
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        span = sum(float(np.linalg.norm(np.array(s.radii) * (r.T @ m)))
                   for s, r, m in ((a, pose_a[1], u), (b, rotation, -u)))
        pose_b = (pose_a[0] + u * (span - rng.uniform(-2e-3, 2e-2)), rotation)
        out = (np.zeros((rows, 3)), np.zeros((rows, 3)), np.zeros(rows), np.zeros(rows, np.int64))
        pool = shapes.Pool()
        arrays = nph.shape_arrays(a, *pose_a, pool) + nph.shape_arrays(b, *pose_b, pool)
        least = _least_reach(a, pose_a, b, pose_b, u)
        count = ck.convex_pair(*arrays, pool.array(), 0.01, *out, 0)
        if least < -0.01 - 1e-9:  # (apart by more along another way than along u)
            assert count == 0
            continue
        assert count == 1
        point, n, depth = out[0][0], out[1][0], float(out[2][0])
        normal_a, off_a = _normal_at(a, pose_a, point + 0.5 * depth * n)
        normal_b, off_b = _normal_at(b, pose_b, point - 0.5 * depth * n)
        assert abs(off_a) < 1e-12 and abs(off_b) < 1e-12
        np.testing.assert_allclose(normal_a, n, rtol=0, atol=1e-9)
        np.testing.assert_allclose(normal_b, -n, rtol=0, atol=1e-9)
        assert depth == pytest.approx(least, abs=1e-12)
        tested += 1
    assert tested > 40


def test_scene_colliders_read_an_ellipsoid_and_refuse_bad_radii():
    egg = shapes.shape_from_dict({'type': 'ellipsoid', 'radii': [0.3, 0.2, 0.1],
                                  'position': [0.0, 0.1, 0.0]})
    assert egg == Ellipsoid((0.3, 0.2, 0.1), position=(0.0, 0.1, 0.0))
    assert shapes.shape_from_dict(shapes.shape_to_dict(egg)) == egg
    assert egg.bounding_radius == 0.3
    for radii, what in (([0.3, 0.2], 'radii'), ([0.3, -0.2, 0.1], 'radii[1]'),
                        ([0.3, float('nan'), 0.1], 'radii'), ('big', 'radii')):
        with pytest.raises(ValueError, match=r'radii'):
            shapes.shape_from_dict({'type': 'ellipsoid', 'radii': radii})
    with pytest.raises(ValueError, match='radii missing'):
        shapes.shape_from_dict({'type': 'ellipsoid'})


def test_a_run_with_ellipsoids_replays_bit_for_bit(tmp_path):
    bodies = (_body('egg', RADII, (0.0, 0.02, 0.6), so3.exp(np.array([0.3, 0.2, 0.1])),
                    initial_angular_velocity=(1.0, -2.0, 0.5)),
              BodySpec('rock', static=True, initial_position=(0.0, 0.0, 0.1),
                       colliders=(Ellipsoid((0.4, 0.3, 0.1)),)),
              BodySpec('ground', static=True, colliders=(Plane(),)))
    config = Config(dt=1e-3, steps_per_publish=10, gravity=(0.0, 0.0, -9.81), bodies=bodies)
    path = tmp_path / 'eggs.mcap'
    record_offline(path, config, 60)
    result = replay.verify(str(path))
    assert result.outputs > 0 and result.outputs == result.recorded
    assert result.mismatched_messages == 0 and not result.integration_error
    rec = replay.load(str(path))
    (egg,) = next(b for b in rec.config.bodies if b.name == 'egg').colliders
    assert egg == Ellipsoid(RADII)
