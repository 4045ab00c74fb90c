# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""100 convex hulls (20 to 60 vertices each) poured into a bin, per step: rb_sim_ros next to
MuJoCo (the same vertices as mesh geoms, which it collides as their hulls), same scene, one
run.

    python -m bench.hull_pile_bench [--quick] [--json out.json]

The hulls: random points on ellipsoids of semi-axes 4 to 8 cm (seeded), 1000 kg/m^3, each
body's mass and inertia its hull's (given to MuJoCo by ``<inertial>``), dropped turned from a
5 x 5 x 4 grid into a 1 m square bin of four static box walls on the ground; 2 s at dt = 1 ms,
neither engine sleeping, mu = 0.5. The bin is box walls: a bin of triangle mesh (the
issue's figure) waits for the terrain kind.

Checks first (exit 1 if one fails), for both engines: every hull inside the bin and above
the ground at the end, none thrown (its fastest hull below 0.5 m/s; a rounded pebble may
still roll on the floor, more so without MuJoCo's rolling friction). Then the time per
step, ms, the whole run in one call (``step(2000)``, ``mj_step(m, d, 2000)``), best of the
repeats; the ratio ours / MuJoCo.

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
from rb_sim_ros.contact.collision_shapes import Box, Hull, Plane
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


def ours(bodies, steps: int):
    world = collision_world(bodies, DT, (0.0, 0.0, -G), planes=(Plane(),),
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


def check(world, data, count: int) -> list[str]:
    """Every hull in the bin, above the ground, none thrown, for both engines."""
    ours_x = np.array([world.state(f'h{k}').position for k in range(count)])
    ours_v = np.array([world.state(f'h{k}').linear_velocity for k in range(count)])
    theirs_x = np.array(data.qpos).reshape(count, 7)[:, :3]
    theirs_v = np.array(data.qvel).reshape(count, 6)[:, :3]
    problems = []
    for who, x, v in (('rb_sim_ros', ours_x, ours_v), ('MuJoCo', theirs_x, theirs_v)):
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
    best = {'rb_sim_ros': math.inf, 'MuJoCo Newton': math.inf}
    problems: list[str] = []
    for _ in range(repeats):
        world, t_ours = ours(bodies, steps)
        data, t_theirs = theirs(xml, steps)
        problems = check(world, data, count)
        best['rb_sim_ros'] = min(best['rb_sim_ros'], t_ours)
        best['MuJoCo Newton'] = min(best['MuJoCo Newton'], t_theirs)
        if problems:
            break
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print(f'\n{count} hulls poured into a bin, {steps} steps of 1 ms, one call, best of '
          f'{repeats}')
    print('| engine | ms per step |\n| --- | ---: |')
    for who, t in best.items():
        print(f'| {who} | {t * 1e3:.3f} |')
    print(f'ours / MuJoCo: {best["rb_sim_ros"] / best["MuJoCo Newton"]:.2f}x')
    sane = figures.Sanity()
    for who, t in best.items():
        sane.within(who, t, 1e-6, 1.0)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'hull_pile_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'repeats': repeats, 'dt': DT, 'hulls': count,
                             'steps': steps, 'seconds_per_step': best})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
