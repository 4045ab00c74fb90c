# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A convex hull in contact, per step: rb_sim_ros's convex narrow phase next to MuJoCo's (its
mesh geoms, which it collides as their hulls), same scene, one run.

    python -m bench.hull_bench [--quick] [--json out.json]

The scenes, each moving (or pressed, awake) the whole time it is timed:

* ``tipping post``: the hull of a 0.1 x 0.1 x 0.5 m block's corners, leaning 0.3 rad on an
  edge (past its balance at 0.197 rad): it falls onto its side (hull-plane);
* ``pebble on the ground``: the hull of 40 points on an ellipsoid (0.15, 0.1, 0.08 m,
  seeded), dropped 2 cm turned: it settles on a face (hull-plane);
* ``hull on a hull``: a block's hull (0.2 m cube) dropped 1 cm onto a static 1 m cube's hull
  (hull-hull: GJK, EPA and the clipped faces every step);
* ``pebble on terrain``: the pebble dropped so on a flat floor of triangles, 10 x 10 tiles of
  10 cm (hull-terrain: the hierarchy's walk, each triangle near it by the convex phase, the
  inner edges); MuJoCo's the same floor as its terrain, a height field of 11 x 11 samples.

Checks first (exit 1 if one fails), for both engines: the post on its side (its centre at
0.05 m), the pebble's lowest vertex on the ground or the floor (1 mm), the block on the cube
(1 mm). Then the time per step (median over a run's calls, best of the repeats) at one step
a call and ten (``step(10)``, ``mj_step(m, d, 10)``), MuJoCo with its default Newton solver,
dt = 1 ms, no sleeping on either side; ratios ours / MuJoCo. The bodies have the same mass
and inertia on both sides (ours, from the hull, given to MuJoCo's body by ``<inertial>``).

Writes docs/bench/hull_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import sys

import numpy as np

from bench.contact_step_bench import scenes_main
from rb_sim_ros.contact.collision_shapes import Hull, Plane, Terrain
from rb_sim_ros.core import so3
from rb_sim_ros.sim.simulation import BodySpec

DT = 1e-3
G = 9.81
POST = np.array([0.1, 0.1, 0.5])
LEAN = 0.3


def _corners(size) -> np.ndarray:
    return np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)],
                    dtype=float) * np.asarray(size) / 2


def pebble_points() -> np.ndarray:
    """40 points on an ellipsoid, seeded."""
    rng = np.random.default_rng(11)
    u = rng.normal(size=(40, 3))
    return u / np.linalg.norm(u, axis=1)[:, None] * (0.15, 0.1, 0.08)


def _quat(rotation) -> tuple:
    return tuple(float(c) for c in so3.quaternion_xyzw_from_matrix(rotation))


def _mj_quat(q) -> str:
    return f'{q[3]:.17g} {q[0]:.17g} {q[1]:.17g} {q[2]:.17g}'


def _numbers(values) -> str:
    return ' '.join(f'{v:.17g}' for v in np.asarray(values).ravel())


def _solid(name: str, points: np.ndarray, density: float):
    """(hull about its centre of mass, mass, inertia, its MuJoCo mesh asset and body inside)."""
    m, centre, inertia = Hull(points.tolist()).mass_properties(density)
    hull = Hull((points - centre).tolist())
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    asset = f'<mesh name="{name}" vertex="{_numbers(hull.vertices)}"/>'
    inside = (f'<inertial pos="0 0 0" mass="{m:.17g}" diaginertia="{_numbers(moments)}" '
              f'quat="{_mj_quat(so3.quaternion_xyzw_from_matrix(axes))}"/>'
              f'<geom type="mesh" mesh="{name}" friction="0.5 0.005 0.0001"/>')
    return hull, m, inertia, asset, inside


def scenes() -> dict:
    """name -> (bodies, planes, restitution, friction, MuJoCo XML, steps, {}): the form
    ``contact_step_bench.ours`` and ``theirs`` take."""
    ground = '<geom type="plane" size="50 50 0.1" friction="0.5 0.005 0.0001"/>'

    def xml(assets, world, *bodies):
        body = ''.join(f'<body pos="{_numbers(p)}" quat="{_mj_quat(q)}"><freejoint/>'
                       f'{inside}</body>' for p, q, inside in bodies)
        return (f'<mujoco><option timestep="{DT}" gravity="0 0 {-G}"/><asset>{assets}'
                f'</asset><worldbody>{world}{body}</worldbody></mujoco>')

    def body(name, solid, position, rotation):
        hull, m, inertia = solid[:3]
        return BodySpec(name, m, tuple(inertia.ravel()), initial_position=tuple(position),
                        initial_orientation_xyzw=_quat(rotation), colliders=(hull,))

    post = _solid('post', _corners(POST), 800.0)
    lean = so3.exp((0.0, LEAN, 0.0))
    low = -(lean @ post[0].vertices.T)[2].min()
    at_post = (0.0, 0.0, low)
    pebble = _solid('pebble', pebble_points(), 2500.0)
    turn = so3.exp((0.4, -0.3, 0.2))
    at_pebble = (0.0, 0.0, -(turn @ pebble[0].vertices.T)[2].min() + 0.02)
    block = _solid('block', _corners((0.2, 0.2, 0.2)), 500.0)
    cube = Hull(_corners((1.0, 1.0, 1.0)).tolist())
    table = BodySpec('cube', 1.0, (1.0, 1.0, 1.0), static=True, initial_position=(0.0, 0.0, 0.5),
                     colliders=(cube,))
    at_block = (0.05, -0.03, 1.0 + 0.1 + 0.01)
    cube_xml = ('<geom type="mesh" mesh="cube" pos="0 0 0.5" '
                'friction="0.5 0.005 0.0001"/>')
    cube_asset = f'<mesh name="cube" vertex="{_numbers(cube.vertices)}"/>'
    q0 = _quat(np.eye(3))
    tiles, tile = 10, 0.1
    xs = (np.arange(tiles + 1) - tiles / 2) * tile
    corners = [(float(x), float(y), 0.0) for y in xs for x in xs]
    cells = []
    for j in range(tiles):
        for i in range(tiles):
            a = j * (tiles + 1) + i
            b, c, d = a + 1, a + tiles + 1, a + tiles + 2
            cells += [(a, b, d), (a, d, c)] if (i + j) % 2 else [(a, b, c), (b, d, c)]
    floor = BodySpec('floor', static=True, colliders=(Terrain(corners, cells),))
    field = (f'<hfield name="floor" nrow="{tiles + 1}" ncol="{tiles + 1}" '
             f'size="{tiles * tile / 2} {tiles * tile / 2} 0.1 0.05"/>')
    field_xml = '<geom type="hfield" hfield="floor" friction="0.5 0.005 0.0001"/>'
    return {
        'tipping post': (
            [body('b', post, at_post, lean)], (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(post[3], ground, (at_post, _quat(lean), post[4])), 1500, {}),
        'pebble on the ground': (
            [body('b', pebble, at_pebble, turn)], (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(pebble[3], ground, (at_pebble, _quat(turn), pebble[4])), 1000, {}),
        'hull on a hull': (
            [table, body('b', block, at_block, np.eye(3))], (Plane((0, 0, 1), 0.0),), 0.0,
            0.5, xml(block[3] + cube_asset, ground + cube_xml, (at_block, q0, block[4])),
            1000, {}),
        'pebble on terrain': (
            [floor, body('b', pebble, at_pebble, turn)], (), 0.0, 0.5,
            xml(pebble[3] + field, field_xml, (at_pebble, _quat(turn), pebble[4])), 1000, {}),
    }


def check(name: str, world, data, scene) -> list[str]:
    """Each scene's outcome (module doc), for both engines (MuJoCo's body 'b' is its last)."""
    st = world.state('b')
    x = np.array(st.position)
    qx = np.array(data.qpos[-7:-4])
    qr = so3.matrix_from_quaternion_xyzw((*data.qpos[-3:], data.qpos[-4]))
    problems = []
    if name == 'tipping post':
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            if abs(xx[2] - POST[0] / 2) > 1e-3:
                problems.append(f'{who}: post at {xx[2]:.4f} m, not on its side')
    elif name in ('pebble on the ground', 'pebble on terrain'):
        hull = next(b for b in scene[0] if b.name == 'b').colliders[0]
        for who, xx, r in (('rb_sim_ros', x, st.rotation), ('MuJoCo', qx, qr)):
            lowest = float((xx + hull.vertices @ np.asarray(r).T)[:, 2].min())
            if abs(lowest) > 1e-3:
                problems.append(f'{who}: lowest vertex at {lowest:.4f} m, not on the ground')
    else:
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            if abs(xx[2] - 1.1) > 1e-3:
                problems.append(f'{who}: block at {xx[2]:.4f} m, expected 1.1')
    return problems


def main() -> int:
    return scenes_main('hull_bench', __doc__, scenes(), check, 'hull_bench.json')


if __name__ == '__main__':
    sys.exit(main())
