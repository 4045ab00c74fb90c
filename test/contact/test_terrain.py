# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The terrain collider (contact/shapes/terrain.py, contact/terrain_kernels.py): a triangle
mesh on a static body, its triangles found through a bounding-volume hierarchy. Oracles: a
flat tiled floor is the plane (every moving kind rests and slides on it as on the plane, a
ball rolls across its edges without a bump), the deepest contact of a ball near a bumpy
terrain is its radius less its distance to the nearest triangle (computed here triangle by
triangle), a hull dropped on bumps comes to rest above them, a ball thrown in a bin stays in
it, and compiled and interpreted contacts are the same bits. (Its protocol, support, drawing
and pair rows in both orders: test_shape_table, with every kind.)"""

import json
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from rb_sim_ros.contact import narrow_phase as nph, shapes
from rb_sim_ros.contact.collision_shapes import Box, Hull, Plane, Sphere, Terrain
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.contact.shapes import terrain
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import scene_from_data, SceneError
from rb_sim_ros.sim.simulation import BodySpec
from support import narrow_fingerprint

G = (0.0, 0.0, -9.81)
I3 = np.eye(3)


def grid(n, size, height=lambda x, y: 0.0, flip=False):
    """A heightfield of n x n cells of ``size`` (m) centred on the origin, its diagonals
    alternating (a tiled floor when flat): (vertices, triangles), counter-clockwise from
    above (clockwise with ``flip``)."""
    xs = (np.arange(n + 1) - n / 2) * size
    vertices = [(float(x), float(y), float(height(x, y))) for y in xs for x in xs]
    triangles = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 1, a + n + 2
            pair = [(a, b, d), (a, d, c)] if (i + j) % 2 else [(a, b, c), (b, d, c)]
            triangles += [(t[0], t[2], t[1]) if flip else t for t in pair]
    return vertices, triangles


def bumps(x, y):
    return 0.04 * math.sin(3.1 * x + 0.4) * math.cos(2.3 * y) + 0.02 * math.sin(7.0 * x * y)


def bin_surface(half, height):
    """An open box (floor and four walls) of inner half width ``half``, its triangles facing
    in."""
    h, z = half, height
    v = [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0),
         (-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)]
    t = [(0, 1, 2), (0, 2, 3),              # floor, up
         (0, 4, 5), (0, 5, 1),              # y = -h, facing +y
         (1, 5, 6), (1, 6, 2),              # x = +h, facing -x
         (2, 6, 7), (2, 7, 3),              # y = +h, facing -y
         (3, 7, 4), (3, 4, 0)]              # x = -h, facing +x
    return [tuple(float(c) for c in p) for p in v], t


def _ground(surface, **kwargs):
    return BodySpec('ground', static=True, colliders=(surface,), **kwargs)


# -- the value -----------------------------------------------------------------------------------

def test_a_terrain_keeps_its_triangles_and_refuses_bad_meshes_naming_why():
    vertices, triangles = grid(2, 1.0)
    t = Terrain(vertices, triangles)
    assert len(t.triangles) == 8 and t.dropped == 0
    np.testing.assert_allclose(t.normals, [[0.0, 0.0, 1.0]] * 8)
    assert shapes.shape_from_dict(shapes.shape_to_dict(t)) == t
    sliver = Terrain(vertices + [(3.0, 0.0, 0.0)], triangles + [(3, 4, 9)])  # in a line
    assert sliver.triangles == t.triangles and sliver.dropped == 1
    nan = [list(p) for p in vertices]
    nan[4][2] = math.nan
    for bad, match in [((nan, triangles), r'vertices\[4\] is not finite'),
                       ((vertices, [(0, 1, 99)]), r'triangles\[0\] = \[0, 1, 99\] names a vertex'),
                       ((vertices, [(0, 1, 1)]), 'repeats a vertex'),
                       ((vertices, [(0.0, 1.0, 2.0)]), 'integer vertex indices'),
                       ((vertices, []), 'non-empty list'),
                       ((vertices[:2], [(0, 1, 0)]), 'at least 3'),
                       (([(0, 0, 0), (1, 0, 0), (2, 0, 0)], [(0, 1, 2)]), 'no area'),
                       (([(0, 0, 1e10), (1, 0, 0), (2, 0, 0)], [(0, 1, 2)]), 'MAX_LENGTH'),
                       (([('0', '0', '0')] * 3, [(0, 1, 2)]), 'numbers'),
                       (([(0, 0, True), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)]), 'numbers'),
                       ((vertices, [(True, False, 2)]), 'integer vertex indices'),
                       ((vertices, [(0, 1, 3), (0, 3, 1)]), r'lie on each other facing away'),
                       ((vertices, [(0, 1, 3), (1, 3, 4)]), r'run the edge \[1, 3\] the same'),
                       (('flat', triangles), 'list of')]:
        with pytest.raises(ValueError, match=match):
            Terrain(*bad)


def test_too_many_triangles_are_refused_before_any_work(monkeypatch):
    monkeypatch.setattr(terrain, 'MAX_TRIANGLES', 7)
    vertices, triangles = grid(2, 1.0)
    with pytest.raises(ValueError, match='at most MAX_TRIANGLES = 7, got 8'):
        Terrain(vertices, triangles)


def test_edges_are_active_on_the_border_and_at_convex_folds_only():
    flat = Terrain(*grid(3, 1.0))
    border = 0
    for t, tri in enumerate(flat.triangles):
        for k in range(3):
            a, b = np.array(flat.vertices[tri[k]]), np.array(flat.vertices[tri[(k + 1) % 3]])
            on_border = any(abs(a[i]) == abs(b[i]) == 1.5 and a[i] == b[i] for i in (0, 1))
            assert flat.active[t, k] == on_border
            border += on_border
    assert border == 12
    # a ridge (convex fold) and a valley (concave fold) along y = 0, and one that folds by
    # less than FLAT_ANGLE
    for rise, active in ((0.3, True), (-0.3, False), (0.2 * terrain.FLAT_ANGLE, False)):
        v = [(-1, -1, 0), (-1, 1, 0), (0, -1, rise), (0, 1, rise), (1, -1, 0), (1, 1, 0)]
        fold = Terrain(v, [(0, 2, 3), (0, 3, 1), (2, 4, 5), (2, 5, 3)])
        on_fold = [fold.active[t, k] for t, tri in enumerate(fold.triangles) for k in range(3)
                   if {tri[k], tri[(k + 1) % 3]} == {2, 3}]
        assert on_fold == [active, active], rise


def test_the_hierarchy_holds_each_triangle_once_in_boxes_that_hold_it():
    vertices, triangles = grid(17, 0.3, bumps)
    v, t = np.array(vertices), np.array(triangles)
    nodes, order = terrain.hierarchy(v, t)
    assert sorted(order.tolist()) == list(range(len(t)))
    corners = v[t]

    def walk(k, depth):
        low, high, first, count = nodes[k, :3], nodes[k, 3:6], int(nodes[k, 6]), int(nodes[k, 7])
        if count:
            assert count <= terrain.LEAF_SIZE
            held = corners[order[first:first + count]].reshape(-1, 3)
            assert np.all(held >= low) and np.all(held <= high)
            return count, depth
        got = [walk(c, depth + 1) for c in (first, first + 1)]
        for c in (first, first + 1):
            assert np.all(nodes[c, :3] >= low) and np.all(nodes[c, 3:6] <= high)
        return got[0][0] + got[1][0], max(got[0][1], got[1][1])
    total, depth = walk(0, 0)
    assert total == len(t) and depth <= math.ceil(math.log2(len(t) / terrain.LEAF_SIZE)) + 1


# -- contacts ------------------------------------------------------------------------------------

def _point_triangle(p, a, b, c):
    """The distance from p to the triangle abc, by projecting p onto its plane or, outside it,
    onto each edge segment."""
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    foot = p - (p - a) @ n * n
    inside = all(np.cross(q - o, foot - o) @ n >= 0.0 for o, q in ((a, b), (b, c), (c, a)))
    if inside:
        return abs((p - a) @ n)
    best = math.inf
    for o, q in ((a, b), (b, c), (c, a)):
        s = min(max((p - o) @ (q - o) / ((q - o) @ (q - o)), 0.0), 1.0)
        best = min(best, float(np.linalg.norm(p - (o + s * (q - o)))))
    return best


def test_a_balls_deepest_contact_is_its_radius_less_its_distance_to_the_nearest_triangle():
    """Over a bumpy terrain, turned and moved, balls just above it: the deepest contact the
    hierarchy's walk gives is r - d, d the least distance to any of the 1,152 triangles; and a
    ball beyond the margin of every triangle has none."""
    rng = np.random.default_rng(5)
    vertices, triangles = grid(24, 0.1, bumps)
    ground = Terrain(vertices, triangles, position=(0.3, -0.2, 0.1),
                     orientation_xyzw=(0.0, 0.0, math.sin(0.35), math.cos(0.35)))
    rotation = ground.rotation
    world_v = np.array(vertices) @ rotation.T + np.array(ground.position)
    tri = np.array(ground.triangles)
    met = 0
    for _ in range(60):
        x, y = rng.uniform(-1.0, 1.0, 2)
        r = float(rng.uniform(0.03, 0.15))
        local = np.array([x, y, bumps(x, y) + r + float(rng.uniform(-0.02, 0.03))])
        centre = rotation @ local + np.array(ground.position)
        d = min(_point_triangle(centre, *world_v[k]) for k in tri)
        found = nph.collide(Sphere(r), (centre, I3), ground,
                            shapes.world_pose(ground, np.zeros(3), I3), 0.05)
        if r - d < -0.05:
            assert found == []
            continue
        met += 1
        assert found, (x, y, r, d)
        assert max(c.depth for c in found) == pytest.approx(r - d, abs=1e-9)
    assert met > 40


def test_compiled_and_interpreted_terrain_contacts_are_the_same_bits(tmp_path):
    """Each moving kind at random poses near a bumpy terrain (both orders of the pair):
    the contacts written compiled and interpreted hash the same."""
    rng = np.random.default_rng(11)
    vertices, triangles = grid(12, 0.15, bumps)
    ground = Terrain(vertices, triangles)
    solids = [shapes.shape_from_dict(d) for d in (
        {'type': 'sphere', 'radius': 0.1}, {'type': 'capsule', 'radius': 0.05, 'length': 0.3},
        {'type': 'box', 'size': [0.3, 0.2, 0.1]},
        {'type': 'cylinder', 'radius': 0.1, 'length': 0.2},
        {'type': 'hull', 'points': rng.normal(size=(12, 3)).tolist()},
        {'type': 'ellipsoid', 'radii': [0.15, 0.1, 0.05]})]
    pool = shapes.Pool()
    packed, pairs = [nph.shape_arrays(ground, np.zeros(3), I3, pool)], []
    for k in range(120):
        shape = solids[k % len(solids)]
        x, y = rng.uniform(-0.8, 0.8, 2)
        centre = np.array([x, y, bumps(x, y) + float(rng.uniform(0.0, 0.2))])
        packed.append(nph.shape_arrays(shape, centre, so3.exp(rng.normal(size=3)), pool))
        pairs.append((len(packed) - 1, 0) if k % 2 else (0, len(packed) - 1))
    path = tmp_path / 'pairs.npz'
    pair_a, pair_b = (np.array(c, dtype=np.int64) for c in zip(*pairs))
    np.savez(path, pair_a=pair_a, pair_b=pair_b,
             kinds=np.array([p[0] for p in packed], dtype=np.int64),
             geoms=np.array([p[1] for p in packed]), pool=pool.array(),
             centres=np.array([p[2] for p in packed]),
             rotations=np.array([p[3] for p in packed]), margins=np.full(len(pairs), 0.02))
    prints = []
    for disable in ('0', '1'):
        env = dict(os.environ, NUMBA_DISABLE_JIT=disable)
        out = subprocess.run([sys.executable, narrow_fingerprint.__file__, str(path)],
                             env=env, capture_output=True, text=True, timeout=900)
        assert out.returncode == 0, out.stderr[-3000:]
        prints.append(json.loads(out.stdout.strip().splitlines()[-1]))
    compiled, interpreted = prints
    assert compiled.pop('compiled') is True and interpreted.pop('compiled') is False
    assert compiled == interpreted and compiled['count'] > 150


# -- worlds --------------------------------------------------------------------------------------

def _rolling_ball(surface, steps=2000):
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(-3.2, -0.3, 0.1),
                    initial_linear_velocity=(2.0, 0.7, 0.0), colliders=(Sphere(0.1),))
    world = collision_world([_ground(surface), ball], 1e-3, G,
                            contact=ContactSettings(friction=0.5))
    heights, rises = [], []
    for _ in range(steps):
        world.step(1)
        state = world.state('ball')
        heights.append(float(state.position[2]))
        rises.append(float(state.linear_velocity[2]))
    return world.state('ball'), np.array(heights), np.array(rises)


def test_a_ball_rolls_across_a_tiled_floor_without_a_bump():
    """A ball thrown sliding across 40 tiles of a flat floor of 200 triangles, crossing their
    edges and corners at a slant: it rolls as on the plane (5/7 of its speed once the slip
    ends), never rising (|v_z| < 1e-9) nor turning about the vertical."""
    state, heights, rises = _rolling_ball(Terrain(*grid(10, 1.0)))
    plane, plane_heights, _ = _rolling_ball(Plane())
    assert np.abs(rises).max() < 1e-9
    np.testing.assert_allclose(heights, plane_heights, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state.position, plane.position, atol=1e-9)
    np.testing.assert_allclose(state.linear_velocity, np.array([2.0, 0.7, 0.0]) * 5 / 7,
                               atol=1e-9)
    assert abs(state.angular_velocity[2]) < 1e-9


def strip(count=40, width=0.25):
    """A floor one tile wide: every triangle has an edge on its border (active), so each goes
    through the convex phase and its inner edges through the turn (or the drop)."""
    vertices, triangles = [], []
    for i in range(count + 1):
        vertices += [(-5.0 + i * width, -width / 2, 0.0), (-5.0 + i * width, width / 2, 0.0)]
    for i in range(count):
        a, b, c, d = 2 * i, 2 * i + 2, 2 * i + 1, 2 * i + 3
        triangles += [(a, b, d), (a, d, c)] if i % 2 else [(a, b, c), (b, d, c)]
    return Terrain(vertices, triangles)


def test_a_ball_rolls_along_a_strip_of_border_triangles_without_a_bump():
    """Along a strip one tile wide (every triangle has a border edge: the convex phase meets
    it, and the contacts at its inner edges are turned to the floor's normal or dropped) a
    ball rolls exactly as on the plane. Keeping the tilted contacts at inner edges lifted it
    by 0.057 m/s."""
    ground = strip()
    assert ground.active.any(axis=1).all()

    def roll(surface):
        ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(-4.5, 0.01, 0.1),
                        initial_linear_velocity=(2.0, 0.0, 0.0), colliders=(Sphere(0.1),))
        world = collision_world([_ground(surface), ball], 1e-3, G,
                                contact=ContactSettings(friction=0.5))
        heights, rises = [], []
        for _ in range(2000):
            world.step(1)
            state = world.state('ball')
            heights.append(float(state.position[2]))
            rises.append(float(state.linear_velocity[2]))
        return world.state('ball'), np.array(heights), np.array(rises)
    on_strip, heights, rises = roll(ground)
    on_plane, plane_heights, _ = roll(Plane())
    assert np.abs(rises).max() < 1e-9
    np.testing.assert_allclose(heights, plane_heights, rtol=0, atol=1e-12)
    np.testing.assert_allclose(on_strip.position, on_plane.position, atol=1e-9)
    assert on_strip.position[0] > -2.5  # it crossed some 11 tiles


def test_a_wide_box_rests_level_on_fine_tiles_its_contacts_spread_over_its_face():
    """A 0.6 m box on 5 cm tiles meets hundreds of contacts (past what a pair gathers: they
    are thinned, spread over them): it rests level at the plane's height, its 9 contacts
    spanning its face."""
    corners = [(x, y, z) for x in (-0.3, 0.3) for y in (-0.3, 0.3) for z in (-0.1, 0.1)]

    def rest(surface):  # (the box's hull: a world the hull test compiled already)
        box = BodySpec('box', 10.0, (0.6,) * 3, initial_position=(0.013, -0.021, 0.1),
                       colliders=(Hull(corners),))
        world = collision_world([_ground(surface), box], 1e-3, G,
                                contact=ContactSettings(friction=0.5, sleep_time=0.0))
        world.step(1000)
        return world.state('box'), world.last_contacts()
    state, contacts = rest(Terrain(*grid(30, 0.05)))
    plane, _ = rest(Plane())
    assert np.abs(state.rotation - I3).max() < 1e-6
    assert state.position[2] == pytest.approx(plane.position[2], abs=1e-6)
    points = np.array([c.point for c in contacts])
    assert len(contacts) == 9 and np.ptp(points[:, 0]) > 0.5 and np.ptp(points[:, 1]) > 0.5


def test_deep_overlaps_push_out_along_the_normal_and_a_body_behind_is_left_alone():
    """One triangle (every edge a border): a ball or a box sunk to or past its plane is
    pushed out along its normal by its depth below the plane, as a plane would; a ball wholly
    behind it (one-sided) meets nothing."""
    one = Terrain([(-1, -1, 0), (1, -1, 0), (0, 1.5, 0)], [(0, 1, 2)])
    pose = shapes.world_pose(one, np.zeros(3), I3)
    for shape, z, depth in ((Sphere(0.1), 0.001, 0.099), (Sphere(0.1), 0.0, 0.1),
                            (Sphere(0.1), -0.05, 0.15), (Box((0.2, 0.2, 0.2)), -0.05, 0.15)):
        found = nph.collide(shape, (np.array([0.0, 0.0, z]), I3), one, pose, 0.01)
        assert found, (shape, z)
        for c in found:
            assert c.depth == pytest.approx(depth, abs=1e-12), (shape, z)
            np.testing.assert_allclose(c.normal, [0.0, 0.0, -1.0], atol=1e-12)
    assert nph.collide(Sphere(0.1), (np.array([0.0, 0.0, -0.2]), I3), one, pose, 0.01) == []


def test_every_moving_kind_rests_and_slides_on_a_tiled_floor_as_on_the_plane():
    """Interpreted (one subprocess, NUMBA_DISABLE_JIT=1: six kinds on a terrain would compile a
    world of every pair of them): each kind dropped turned and sliding on a tiled floor ends
    where it ends on the plane, within 10 um (its contacts lie on tile edges and corners: a
    capsule lying across a diagonal has two more, which share its weight)."""
    code = textwrap.dedent("""
        import json, math
        import numpy as np
        from rb_sim_ros.contact import shapes
        from rb_sim_ros.contact.collision_shapes import Plane, Terrain
        from rb_sim_ros.contact.settings import ContactSettings
        from rb_sim_ros.sim.bodies import collision_world
        from rb_sim_ros.sim.simulation import BodySpec
        from test_terrain import grid
        cube = [[x, y, z] for x in (-.1, .1) for y in (-.1, .1) for z in (-.1, .1)]
        kinds = [{'type': 'sphere', 'radius': 0.1}, {'type': 'box', 'size': [0.2, 0.2, 0.2]},
                 {'type': 'capsule', 'radius': 0.05, 'length': 0.2},
                 {'type': 'cylinder', 'radius': 0.1, 'length': 0.2},
                 {'type': 'hull', 'points': cube},
                 {'type': 'ellipsoid', 'radii': [0.1, 0.15, 0.08]}]
        out = {}
        for data in kinds:
            ends = []
            for ground in (Terrain(*grid(10, 1.0)), Plane()):
                body = BodySpec('b', 1.0, (0.01,) * 3, initial_position=(0.37, 0.21, 0.3),
                                initial_orientation_xyzw=(0, 0, math.sin(0.15), math.cos(0.15)),
                                initial_linear_velocity=(0.3, 0.1, 0.0),
                                colliders=(shapes.shape_from_dict(data),))
                world = collision_world(
                    [BodySpec('ground', static=True, colliders=(ground,)), body], 1e-3,
                    (0, 0, -9.81), contact=ContactSettings(friction=0.5))
                world.step(800)
                s = world.state('b')
                ends.append([*s.position.tolist(), *s.linear_velocity.tolist()])
            out[data['type']] = ends
        print(json.dumps(out))
        """)
    here = os.path.dirname(os.path.abspath(__file__))
    env = dict(os.environ, NUMBA_DISABLE_JIT='1',
               PYTHONPATH=os.pathsep.join([here, os.path.dirname(here),
                                           os.environ.get('PYTHONPATH', '')]))
    run = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                         text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    ends = json.loads(run.stdout.strip().splitlines()[-1])
    assert sorted(ends) == sorted(n for n in shapes.NAMES if not shapes.BY_NAME[n].STATIC_ONLY)
    for kind, (on_terrain, on_plane) in ends.items():
        np.testing.assert_allclose(on_terrain[:3], on_plane[:3], atol=1e-5, err_msg=kind)
        np.testing.assert_allclose(on_terrain[3:], on_plane[3:], atol=1e-4, err_msg=kind)
        assert on_plane[2] < 0.11  # at rest, down


def test_a_hull_dropped_on_bumps_comes_to_rest_above_them():
    """A hull of 20 points dropped turned on a bumpy terrain: it comes to rest (speed below
    1 mm/s) with no vertex deeper below the surface than the solver's slop and a hair."""
    rng = np.random.default_rng(3)
    points = rng.normal(size=(20, 3)) * (0.12, 0.09, 0.06)
    rock = Hull(points.tolist())
    mass, centre, inertia = rock.mass_properties(1000.0)
    rock = Hull((np.array(rock.points) - centre).tolist())
    moments = np.linalg.eigvalsh(inertia)
    ground = Terrain(*grid(16, 0.15, bumps))
    body = BodySpec('rock', mass, tuple(float(m) for m in moments),
                    initial_position=(0.1, -0.05, 0.4),
                    initial_orientation_xyzw=(0.3, -0.2, 0.1, 0.93), colliders=(rock,))
    world = collision_world([_ground(ground), body], 1e-3, G,
                            contact=ContactSettings(friction=0.8, sleep_time=0.0))
    world.step(3000)
    state = world.state('rock')
    assert np.linalg.norm(state.linear_velocity) < 1e-3
    # how far each vertex lies below the plane of the triangle under it
    v, t = np.array(ground.vertices), np.array(ground.triangles)
    deepest = -math.inf
    for p in np.array(rock.points) @ state.rotation.T + state.position:
        for k in t:
            a, b, c = v[k]
            n = np.cross(b - a, c - a)
            n /= np.linalg.norm(n)
            foot = p - (p - a) @ n * n
            if all(np.cross(q - o, foot - o) @ n >= 0.0 for o, q in ((a, b), (b, c), (c, a))):
                deepest = max(deepest, float((a - p) @ n))
    assert deepest < 2e-4 and state.position[2] > -0.1


def test_a_ball_thrown_in_a_bin_stays_in_it_and_rests_on_its_floor():
    """A ball thrown at 4 m/s at a wall of a bin (one terrain of ten triangles, facing in):
    it bounces about inside, never past a wall, and ends rolling on the floor, its centre a
    radius up, not bouncing (its corners are concave folds: no snag there either)."""
    v, t = bin_surface(0.5, 0.4)
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 0.25),
                    initial_linear_velocity=(4.0, 2.5, 0.0), colliders=(Sphere(0.1),))
    world = collision_world([_ground(Terrain(v, t)), ball], 1e-3, G,
                            contact=ContactSettings(friction=0.3, restitution=0.5))
    inside = 0.5 - 0.1 + 2e-4
    for _ in range(4000):
        world.step(1)
        p = world.state('ball').position
        assert abs(p[0]) <= inside and abs(p[1]) <= inside and p[2] > 0.1 - 2e-4, p
    state = world.state('ball')
    assert state.position[2] == pytest.approx(0.1, abs=2e-4)
    assert abs(state.linear_velocity[2]) < 1e-6 and world.last_stats.contacts >= 1


# -- scene files ---------------------------------------------------------------------------------

def test_a_scene_reads_a_terrain_inline_or_from_a_mesh_file_and_refuses_it_on_a_moving_body(
        tmp_path):
    trimesh = pytest.importorskip('trimesh')
    vertices, triangles = grid(3, 0.5, bumps)
    trimesh.Trimesh(vertices, triangles, process=False).export(tmp_path / 'site.stl')
    scene = tmp_path / 'scene.yaml'
    scene.write_text('{}')  # (its folder is where its mesh files are read from)

    def body(collider, static=True):
        moving = {} if static else {'mass': 1.0, 'inertia': [1.0, 1.0, 1.0]}
        return {'bodies': [{'name': 'ground', 'static': static, 'colliders': [collider],
                            **moving}]}
    inline = scene_from_data(body({'type': 'terrain', 'vertices': [list(p) for p in vertices],
                                   'triangles': [list(t) for t in triangles]}), str(scene))
    from_file = scene_from_data(body({'type': 'terrain', 'file': 'site.stl', 'scale': 2.0,
                                      'friction': 0.4}), str(scene))
    a = inline.bodies[0].colliders[0]
    b = from_file.bodies[0].colliders[0]
    assert isinstance(a, Terrain) and isinstance(b, Terrain) and b.friction == 0.4
    # an STL keeps float32 corners: the same surface, its shared corners merged
    assert len(b.triangles) == len(a.triangles) and len(b.vertices) == len(a.vertices)
    np.testing.assert_allclose(sorted(map(tuple, np.array(b.vertices) / 2.0)),
                               sorted(a.vertices), atol=1e-6)
    for bad, match in [
            (body({'type': 'terrain', 'vertices': [list(p) for p in vertices],
                   'triangles': [list(t) for t in triangles]}, False),
             'only allowed on a static body'),
            (body({'type': 'terrain', 'file': 'none.stl'}), 'no such file'),
            (body({'type': 'terrain', 'file': '../x.stl'}), 'outside the folders'),
            (body({'type': 'terrain', 'file': 'site.stl', 'colour': 1}), 'unknown keys'),
            (body({'type': 'terrain', 'vertices': [[0, 0, 'x']] * 3, 'triangles': [[0, 1, 2]]}),
             'vertices')]:
        with pytest.raises(SceneError, match=match):
            scene_from_data(bad, str(scene))


def test_the_example_scene_rolls_its_ball_to_the_bottom_of_its_bowl():
    """scenes/terrain.yaml, interpreted (a subprocess with NUMBA_DISABLE_JIT=1): its ball rolls
    about the bowl and comes to rest at its lowest corner, the origin (rolling resistance takes
    its energy); its box stays where it stopped on the slope (friction 0.5 holds it there)."""
    code = textwrap.dedent("""
        import json
        from rb_sim_ros.sim.scene import load_scene
        from rb_sim_ros.sim.simulation import Config, Simulation
        scene = load_scene('scenes/terrain.yaml')
        sim = Simulation(Config(bodies=scene.bodies, gravity=scene.gravity,
                                contact=scene.contact))
        sim.run(9000)
        print(json.dumps({n: [list(v) for v in sim.pose_twist(n)] for n in ('ball', 'box')}))
        """)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    run = subprocess.run([sys.executable, '-c', code], env=dict(os.environ, NUMBA_DISABLE_JIT='1'),
                         cwd=root, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    ends = json.loads(run.stdout.strip().splitlines()[-1])
    (x, y, z), _, v, _ = ends['ball']
    assert abs(x) < 2e-3 and abs(y) < 2e-3 and 0.1 <= z < 0.1 + 0.0223
    assert np.linalg.norm(v) < 1e-3 and np.linalg.norm(ends['box'][2]) < 1e-3
    assert ends['box'][0][2] > 0.1  # up the slope, not sunk into the bowl
