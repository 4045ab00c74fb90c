# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""100 convex hulls (20 to 60 vertices each) poured into a bin, per step: rb_sim_ros next to
MuJoCo (the same vertices as mesh geoms, which it collides as their hulls), same scene, one
run.

    python -m bench.hull_pile_bench [--quick] [--json out.json]

The hulls: random points on ellipsoids of semi-axes 4 to 8 cm (seeded), 1000 kg/m^3, each
body's mass and inertia its hull's (given to MuJoCo by ``<inertial>``), dropped turned from a
5 x 5 x 4 grid into a 1 m square bin on the ground; 2 s at dt = 1 ms, neither engine
sleeping, mu = 0.5. The bin: four static box walls, for both engines; and for ours a second
run with the bin one triangle mesh (a terrain: its floor and walls in 5 cm tiles facing in,
2,720 triangles, on no plane), what a user's bin or landing site is. MuJoCo collides a mesh as
its convex hull, so its bin stays the box walls (a decomposition into boxes, as its users
build one).

Checks first (exit 1 if one fails), for every run: every hull inside the bin and above
the ground at the end, none thrown (its fastest hull below 0.5 m/s; a rounded pebble may
still roll on the floor, more so without MuJoCo's rolling friction). Then the time per
step, ms, the whole run in one call (``step(2000)``, ``mj_step(m, d, 2000)``), best of the
repeats; the ratios ours / MuJoCo; the deepest penetration of the last step (ours: the
deepest contact; MuJoCo: its most negative contact distance) and the hulls' mean speed then
(how far the pile is from rest: its drift).

Writes docs/bench/hull_pile_bench.json (or ``--json``; ``--quick`` writes none unless
asked).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys
import time

import mujoco
import numpy as np

from bench import figures
from rb_sim_ros.contact.collision_shapes import Box, Hull, Plane, Terrain
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

DT = 1e-3
G = 9.81
COUNT = 100
HALF = 0.5       # the bin's inner half width (m)
WALL = 0.05      # its walls' thickness
HEIGHT = 0.6


def _numbers(values) -> str:
    return ' '.join(f'{v:.17g}' for v in np.asarray(values).ravel())


def _mj_quat(q) -> str:
    return f'{q[3]:.17g} {q[0]:.17g} {q[1]:.17g} {q[2]:.17g}'


def scene(count: int = COUNT):
    """(our bodies, MuJoCo's XML): the hulls and the bin (module doc)."""
    rng = np.random.default_rng(0)
    bodies, assets, xml_bodies = [], [], []
    for k in range(count):
        n = int(rng.integers(20, 61))
        points = rng.normal(size=(n, 3))
        points = points / np.linalg.norm(points, axis=1)[:, None] * rng.uniform(0.04, 0.08, 3)
        m, centre, inertia = Hull(points.tolist()).mass_properties(1000.0)
        hull = Hull((points - centre).tolist())
        i, j, layer = k % 5, (k // 5) % 5, k // 25
        at = (-0.3 + 0.15 * i, -0.3 + 0.15 * j, 0.2 + 0.18 * layer)
        q = tuple(float(c) for c in so3.quaternion_xyzw_from_matrix(so3.exp(rng.normal(size=3))))
        bodies.append(BodySpec(f'h{k}', m, tuple(inertia.ravel()), initial_position=at,
                               initial_orientation_xyzw=q, colliders=(hull,)))
        moments, axes = np.linalg.eigh(inertia)
        if np.linalg.det(axes) < 0:
            axes[:, 2] = -axes[:, 2]
        assets.append(f'<mesh name="m{k}" vertex="{_numbers(hull.vertices)}"/>')
        xml_bodies.append(
            f'<body pos="{_numbers(at)}" quat="{_mj_quat(q)}"><freejoint/>'
            f'<inertial pos="0 0 0" mass="{m:.17g}" diaginertia="{_numbers(moments)}" '
            f'quat="{_mj_quat(so3.quaternion_xyzw_from_matrix(axes))}"/>'
            f'<geom type="mesh" mesh="m{k}" friction="0.5 0.005 0.0001"/></body>')
    walls = []
    for axis in (0, 1):
        for sign in (-1.0, 1.0):
            centre = [0.0, 0.0, HEIGHT / 2]
            centre[axis] = sign * (HALF + WALL / 2)
            size = [2 * HALF + 2 * WALL, 2 * HALF + 2 * WALL, HEIGHT]
            size[axis] = WALL
            walls.append((tuple(size), tuple(centre)))
    bodies.append(BodySpec('bin', static=True, colliders=tuple(
        Box(size, position=centre) for size, centre in walls)))
    wall_xml = ''.join(f'<geom type="box" size="{_numbers(np.array(size) / 2)}" '
                       f'pos="{_numbers(centre)}" friction="0.5 0.005 0.0001"/>'
                       for size, centre in walls)
    xml = (f'<mujoco><option timestep="{DT}" gravity="0 0 {-G}"/>'
           f'<size memory="200M"/><asset>{"".join(assets)}</asset><worldbody>'
           '<geom type="plane" size="5 5 0.1" friction="0.5 0.005 0.0001"/>'
           f'{wall_xml}{"".join(xml_bodies)}</worldbody></mujoco>')
    return bodies, xml


TILE = 0.05     # the terrain bin's tiles (m)


def terrain_bin() -> BodySpec:
    """The bin as one terrain: its floor (z = 0) and four walls, each a grid of TILE squares
    split in two triangles (diagonals alternating), facing in, sharing the corners where they
    meet (its inside edges and corners concave folds)."""
    vertices: list = []
    triangles: list = []
    index: dict = {}

    def sheet(origin, u, v, nu, nv):  # a grid of nu x nv tiles from origin along u and v,
        # its triangles counter-clockwise seen along u x v (facing that way)
        def at(i, j):  # a corner's index, shared with the sheets it borders
            key = tuple(round(float(c), 9) for c in
                        np.array(origin) + i * np.array(u) + j * np.array(v))
            if key not in index:
                index[key] = len(vertices)
                vertices.append(key)
            return index[key]
        for j in range(nv):
            for i in range(nu):
                a, b, c, d = at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)
                triangles.extend([(a, b, d), (a, d, c)] if (i + j) % 2 else
                                 [(a, b, c), (b, d, c)])
    n, up = round(2 * HALF / TILE), round(HEIGHT / TILE)
    h = HALF
    sheet((-h, -h, 0.0), (TILE, 0, 0), (0, TILE, 0), n, n)           # the floor, up
    sheet((-h, -h, 0.0), (0, 0, TILE), (TILE, 0, 0), up, n)          # y = -h, facing +y
    sheet((h, -h, 0.0), (0, 0, TILE), (0, TILE, 0), up, n)           # x = +h, facing -x
    sheet((h, h, 0.0), (0, 0, TILE), (-TILE, 0, 0), up, n)           # y = +h, facing -y
    sheet((-h, h, 0.0), (0, 0, TILE), (0, -TILE, 0), up, n)          # x = -h, facing +x
    return BodySpec('bin', static=True, colliders=(Terrain(vertices, triangles),))


def ours(bodies, steps: int, planes=(Plane(),)):
    world = collision_world(bodies, DT, (0.0, 0.0, -G), planes=planes,
                            contact=ContactSettings(friction=0.5, sleep_time=0.0))
    world.step(1)  # (compiled, or loaded from the cache, before the clock starts)
    start = time.perf_counter()
    world.step(steps)
    return world, (time.perf_counter() - start) / steps


def theirs(xml: str, steps: int):
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1)
    start = time.perf_counter()
    mujoco.mj_step(model, data, steps)
    return data, (time.perf_counter() - start) / steps


def check(worlds: dict, data, count: int) -> list[str]:
    """Every hull in the bin, above the ground, none thrown, for every run."""
    runs = [(who, np.array([w.state(f'h{k}').position for k in range(count)]),
             np.array([w.state(f'h{k}').linear_velocity for k in range(count)]))
            for who, w in worlds.items()]
    runs.append(('MuJoCo', np.array(data.qpos).reshape(count, 7)[:, :3],
                 np.array(data.qvel).reshape(count, 6)[:, :3]))
    problems = []
    for who, x, v in runs:
        if np.abs(x[:, :2]).max() > HALF or x[:, 2].min() < 0.0:
            problems.append(f'{who}: a hull left the bin (|x|, |y| up to '
                            f'{np.abs(x[:, :2]).max():.3f} m, z down to {x[:, 2].min():.3f})')
        speed = float(np.linalg.norm(v, axis=1).max())
        if speed > 0.5:
            problems.append(f'{who}: a hull is thrown ({speed:.3f} m/s)')
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.hull_pile_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='16 hulls for 1 s, the checks, 1 repeat')
    parser.add_argument('--repeats', type=int, help='timed runs (default 3)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/hull_pile_bench.json; --quick: none)')
    opts = parser.parse_args()
    repeats = opts.repeats or (1 if opts.quick else 3)
    count, steps = (16, 1000) if opts.quick else (COUNT, 2000)
    bodies, xml = scene(count)
    hulls = [b for b in bodies if b.name != 'bin']
    meshed = hulls + [terrain_bin()]
    runs = {'rb_sim_ros': (bodies, (Plane(),)), 'rb_sim_ros, terrain bin': (meshed, ())}
    best = {**{who: math.inf for who in runs}, 'MuJoCo Newton': math.inf}
    deepest: dict = {}
    drift: dict = {}
    problems: list[str] = []
    for _ in range(repeats):
        worlds = {}
        for who, (specs, planes) in runs.items():
            worlds[who], t_ours = ours(specs, steps, planes)
            best[who] = min(best[who], t_ours)
            deepest[who] = max([0.0] + [c.depth for c in worlds[who].last_contacts()])
            drift[who] = float(np.mean([np.linalg.norm(worlds[who].state(b.name).linear_velocity)
                                        for b in hulls]))
        data, t_theirs = theirs(xml, steps)
        deepest['MuJoCo Newton'] = max([0.0] + [-float(d) for d in data.contact.dist[:data.ncon]])
        drift['MuJoCo Newton'] = float(np.linalg.norm(
            np.array(data.qvel).reshape(count, 6)[:, :3], axis=1).mean())
        problems = check(worlds, data, count)
        best['MuJoCo Newton'] = min(best['MuJoCo Newton'], t_theirs)
        if problems:
            break
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print(f'\n{count} hulls poured into a bin, {steps} steps of 1 ms, one call, best of '
          f'{repeats}')
    print('| engine | ms per step | x MuJoCo | deepest penetration, last step (mm) | mean '
          'speed of the hulls, last step (mm/s) |\n| --- | ---: | ---: | ---: | ---: |')
    for who, t in best.items():
        print(f'| {who} | {t * 1e3:.3f} | {t / best["MuJoCo Newton"]:.2f} | '
              f'{deepest[who] * 1e3:.3f} | {drift[who] * 1e3:.2f} |')
    sane = figures.Sanity()
    for who, t in best.items():
        sane.within(who, t, 1e-6, 1.0)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'hull_pile_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'repeats': repeats, 'dt': DT, 'hulls': count,
                             'steps': steps, 'seconds_per_step': best,
                             'deepest_penetration': deepest, 'mean_speed': drift})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
