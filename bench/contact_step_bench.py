# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""One body in contact, per step: rb_sim_ros's CollisionWorld next to MuJoCo, same scene, one run.

    python -m bench.contact_step_bench [--quick] [--json out.json]

The scenes a controller test meets, each moving the whole time it is timed (no sleeping):

* ``sliding box``: a 1 m cube (1 kg) sliding at 2 m/s on the ground, mu = 0.4: it stops
  after v0^2 / (2 mu g) = 0.51 m;
* ``bouncing ball``: a ball (r = 0.1 m) dropped from 1 m, e = 0.5 (MuJoCo: its default soft
  contact, which does not bounce the same: the check is only that it lands);
* ``rolling ball``: a ball rolling down a 20 degree incline from rest, mu = 0.5: it rolls
  without slipping, a = 5/7 g sin(20 deg);
* ``tipping cube``: a cube balanced on an edge, tipped by 0.1 rad: it falls flat.

Checks first (exit 1 if one fails): each engine's run against the closed form or the outcome
above (stopping distance within 2%, landed, rolling acceleration within 2%, lying on a face).
Then the time per step of each engine, the median over the calls of a run from the same start
(and, one step a call, their mean: the slow calls a real-time loop meets), with the same call
pattern on both sides: one step a call (a controller stepping the world),
ten steps a call (a node's publish period: ``step(10)`` and ``mj_step(m, d, 10)``, whose loop is
in C as ours is), and the whole run in one call. MuJoCo runs its default solver (Newton) and
PGS, both with their default iteration caps; dt = 1 ms for both; neither sleeps (ours:
``sleep_time=0``; MuJoCo's sleeping is off by default). Ratios ours / MuJoCo are printed.

Writes docs/bench/contact_step_bench.json (or ``--json``; ``--quick`` writes none unless
asked). Sanity (plausibility, exit 1): every time finite and between 0.1 us and 100 ms a step.
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
from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

DT = 1e-3
G = 9.81
SLOPE = math.radians(20.0)


def _incline_normal() -> tuple[float, float, float]:
    return (-math.sin(SLOPE), 0.0, math.cos(SLOPE))


def scenes() -> dict:
    """name -> (rb_sim_ros bodies, planes, restitution, friction, MuJoCo XML, steps to run)."""
    cube_i = (1.0 / 6.0,) * 3
    ball_i = (0.4 * 1.0 * 0.01,) * 3
    # A cube on an edge, turned by 45 degrees plus a tip of 0.1 rad about y: its lowest edge
    # touches the ground when the centre is at 0.5 (cos + sin) of the angle.
    angle = math.pi / 4 + 0.1
    edge_rot = so3.exp([0.0, angle, 0.0])
    edge_pos = np.array([0.0, 0.0, 0.5 * (math.cos(angle) + math.sin(angle))])
    n = _incline_normal()
    ball_start = tuple(0.1 * np.array(n))
    quat = so3.quaternion_xyzw_from_matrix(edge_rot)
    ground = '<geom type="plane" size="50 50 0.1" friction="{mu} 0.005 0.0001"/>'
    incline = ('<geom type="plane" size="50 50 0.1" friction="{mu} 0.005 0.0001" '
               f'zaxis="{n[0]:.17g} {n[1]:.17g} {n[2]:.17g}"/>')

    def xml(world, body):
        return (f'<mujoco><option timestep="{DT}" gravity="0 0 {-G}"/>'
                f'<worldbody>{world}{body}</worldbody></mujoco>')

    return {
        'sliding box': (
            [BodySpec('b', 1.0, cube_i, initial_position=(0.0, 0.0, 0.5),
                      initial_linear_velocity=(2.0, 0.0, 0.0), colliders=(Box((1, 1, 1)),))],
            (Plane((0, 0, 1), 0.0),), 0.0, 0.4,
            xml(ground.format(mu=0.4), '<body pos="0 0 0.5"><freejoint/><geom type="box" '
                'size="0.5 0.5 0.5" mass="1" friction="0.4 0.005 0.0001"/></body>'),
            700, {'qvel': (2.0, 0, 0, 0, 0, 0)}),
        'bouncing ball': (
            [BodySpec('b', 1.0, ball_i, initial_position=(0.0, 0.0, 1.0),
                      colliders=(Sphere(0.1),))],
            (Plane((0, 0, 1), 0.0),), 0.5, 0.5,
            xml(ground.format(mu=0.5), '<body pos="0 0 1"><freejoint/><geom type="sphere" '
                'size="0.1" mass="1"/></body>'),
            600, {}),
        'rolling ball': (
            [BodySpec('b', 1.0, ball_i, initial_position=ball_start, colliders=(Sphere(0.1),))],
            (Plane(n, 0.0),), 0.0, 0.5,
            xml(incline.format(mu=0.5), f'<body pos="{ball_start[0]:.17g} 0 '
                f'{ball_start[2]:.17g}"><freejoint/><geom type="sphere" size="0.1" '
                'mass="1" friction="0.5 0.005 0.0001"/></body>'),
            500, {}),
        'tipping cube': (
            [BodySpec('b', 1.0, cube_i, initial_position=tuple(edge_pos),
                      initial_orientation_xyzw=tuple(quat), colliders=(Box((1, 1, 1)),))],
            (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(ground.format(mu=0.5), f'<body pos="{edge_pos[0]:.17g} 0 {edge_pos[2]:.17g}" '
                f'quat="{quat[3]:.17g} {quat[0]:.17g} {quat[1]:.17g} {quat[2]:.17g}">'
                '<freejoint/><geom type="box" size="0.5 0.5 0.5" mass="1"/></body>'),
            1500, {}),
    }


def ours(scene, steps: int, per_call: int = 1) -> tuple[CollisionWorld, list[float]]:
    bodies, planes, e, mu = scene[:4]
    world = collision_world(bodies, DT, (0.0, 0.0, -G), planes=planes,
                            contact=ContactSettings(restitution=e, friction=mu, sleep_time=0.0))
    times = []
    for _ in range(steps // per_call):
        t = time.perf_counter()
        world.step(per_call)
        times.append((time.perf_counter() - t) / per_call)
    return world, times


def theirs(scene, steps: int, solver, per_call: int = 1) -> tuple[mujoco.MjData, list[float]]:
    """MuJoCo on the same scene, ``per_call`` steps in each ``mj_step`` call (its ``nstep``: the
    loop over steps in C, as ours is for ``step(n)``)."""
    model = mujoco.MjModel.from_xml_string(scene[4])
    model.opt.solver = solver
    data = mujoco.MjData(model)
    for key, value in scene[6].items():
        getattr(data, key)[:] = value
    mujoco.mj_forward(model, data)
    times = []
    for _ in range(steps // per_call):
        t = time.perf_counter()
        mujoco.mj_step(model, data, per_call)
        times.append((time.perf_counter() - t) / per_call)
    return data, times


def scenes_main(module: str, doc: str, scenes: dict, check, json_name: str) -> int:
    """The run of a benchmark of one-body contact scenes beside MuJoCo (``cylinder_bench``,
    ``hull_bench``): ``scenes`` name -> the form ``ours`` and ``theirs`` take; ``check(name,
    world, data, scene)`` the problems of each engine's outcome (exit 1 if any, before
    anything is timed). Then the time per step (median over a run's calls, best of the
    repeats) at one step a call and ten, MuJoCo with its default Newton solver; ratios ours /
    MuJoCo; the figures written to docs/bench/``json_name`` (or ``--json``)."""
    parser = argparse.ArgumentParser(
        prog=f'python -m bench.{module}', description=doc,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='the checks, and 1 repeat')
    parser.add_argument('--repeats', type=int, help='timed runs of each scene (default 5)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        f'docs/bench/{json_name}; --quick: none)')
    opts = parser.parse_args()
    repeats = opts.repeats or (1 if opts.quick else 5)
    newton = mujoco.mjtSolver.mjSOL_NEWTON
    problems, rows = [], {}
    for name, scene in scenes.items():
        steps = scene[5]
        world, _ = ours(scene, steps)
        data, _ = theirs(scene, steps, newton)
        problems += check(name, world, data, scene)
        best: dict = {}
        for _ in range(repeats):
            for calls, n in (('1', 1), ('10', 10)):
                for who, t in ((f'rb_sim_ros, {calls}', ours(scene, steps, n)[1]),
                               (f'MuJoCo Newton, {calls}', theirs(scene, steps, newton, n)[1])):
                    best[who] = min(best.get(who, math.inf), float(np.median(t)))
        rows[name] = best
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print('\nus per step, dt = 1 ms, median of a run, best of the repeats; one step a call and'
          '\nten (step(10), mj_step(m, d, 10))')
    print('| scene | steps a call | rb_sim_ros | MuJoCo Newton | ours / MuJoCo |')
    print('| --- | --- | ---: | ---: | ---: |')
    for name, r in rows.items():
        for calls in ('1', '10'):
            o, t = r[f'rb_sim_ros, {calls}'], r[f'MuJoCo Newton, {calls}']
            print(f'| {name} | {calls} | {o * 1e6:.2f} | {t * 1e6:.2f} | {o / t:.2f}x |')
    sane = figures.Sanity()
    for name, r in rows.items():
        for c, value in r.items():
            sane.within(f'{name}, {c}', value, 1e-7, 0.1)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / json_name)
    if path:
        figures.write(path, {'quick': opts.quick, 'repeats': repeats, 'dt': DT,
                             'seconds_per_step': rows})
    return sane.report()


def check(name: str, world: CollisionWorld, data: mujoco.MjData) -> list[str]:
    """The closed form or outcome of each scene (module doc), for both engines."""
    st = world.state('b')
    x, v = st.position, st.linear_velocity
    qx, qv = data.qpos[:3], data.qvel[:3]
    problems = []
    if name == 'sliding box':
        expect = 2.0 ** 2 / (2 * 0.4 * G)
        for who, xx, vv in (('rb_sim_ros', x, v), ('MuJoCo', qx, qv)):
            if abs(xx[0] - expect) > 0.02 * expect or abs(vv[0]) > 1e-3:
                problems.append(f'{who}: box stopped at {xx[0]:.4f} m, expected {expect:.4f}')
    elif name == 'bouncing ball':
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            if not 0.05 < xx[2] < 1.0:
                problems.append(f'{who}: ball at height {xx[2]:.4f} m, not landed')
    elif name == 'rolling ball':
        t = world.time
        expect = 0.5 * 5.0 / 7.0 * G * math.sin(SLOPE) * t * t
        along = np.array([math.cos(SLOPE), 0.0, math.sin(SLOPE)])
        start = 0.1 * np.array(_incline_normal())
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            moved = -float((xx - start) @ along)
            if abs(moved - expect) > 0.02 * expect:
                problems.append(f'{who}: rolled {moved:.4f} m, expected {expect:.4f}')
    else:
        for who, xx, r in (('rb_sim_ros', x, st.rotation),
                           ('MuJoCo', qx, so3.matrix_from_quaternion_xyzw(
                               (*data.qpos[4:7], data.qpos[3])))):
            if abs(xx[2] - 0.5) > 0.01 or np.max(np.abs(r[2])) < 0.999:  # a face axis vertical
                problems.append(f'{who}: cube at height {xx[2]:.4f} m, not lying on a face')
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.contact_step_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='the checks, and 1 repeat')
    parser.add_argument('--repeats', type=int, help='timed runs of each scene (default 5)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/contact_step_bench.json; --quick: none)')
    opts = parser.parse_args()
    repeats = opts.repeats or (1 if opts.quick else 5)
    problems, rows = [], {}
    for name, scene in scenes().items():
        steps = scene[5]
        world, _ = ours(scene, steps)
        data, _ = theirs(scene, steps, mujoco.mjtSolver.mjSOL_NEWTON)
        problems += check(name, world, data)
        best = {}
        for _ in range(repeats):
            newton, pgs = mujoco.mjtSolver.mjSOL_NEWTON, mujoco.mjtSolver.mjSOL_PGS
            cells = {}
            for calls, n in (('1', 1), ('10', 10), ('run', steps)):
                cells[f'rb_sim_ros, {calls}'] = ours(scene, steps, n)[1]
                cells[f'MuJoCo Newton, {calls}'] = theirs(scene, steps, newton, n)[1]
                cells[f'MuJoCo PGS, {calls}'] = theirs(scene, steps, pgs, n)[1]
            for k, t in cells.items():
                best[k] = min(best.get(k, math.inf), float(np.median(t)))
                if k.endswith(', 1'):  # a controller's call: its slow calls count too
                    best[k + ', mean'] = min(best.get(k + ', mean', math.inf),
                                             float(np.mean(t)))
        rows[name] = best
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print('\nus per step, dt = 1 ms, the body moving throughout; both engines called alike: one'
          '\nstep a call, ten steps a call (step(10), mj_step(m, d, 10)), the whole run'
          ' in one call')
    print('| scene | steps a call | rb_sim_ros | MuJoCo Newton | MuJoCo PGS | ours / Newton |'
          ' ours / PGS |')
    print('| --- | --- | ---: | ---: | ---: | ---: | ---: |')
    for name, r in rows.items():
        for calls in ('1', '10', 'run'):
            ours_t, newton_t, pgs_t = (r[f'{who}, {calls}'] for who in
                                       ('rb_sim_ros', 'MuJoCo Newton', 'MuJoCo PGS'))
            print(f'| {name} | {calls} | {ours_t * 1e6:.2f} | {newton_t * 1e6:.2f} | '
                  f'{pgs_t * 1e6:.2f} | {ours_t / newton_t:.2f}x | {ours_t / pgs_t:.2f}x |')
    print('\none step a call, the mean over the run beside the median (us; a real-time loop'
          '\nlives on its slow calls)')
    print('| scene | rb_sim_ros median | mean | MuJoCo Newton median | mean | ours / Newton, '
          'mean |')
    print('| --- | ---: | ---: | ---: | ---: | ---: |')
    for name, r in rows.items():
        o, om = r['rb_sim_ros, 1'], r['rb_sim_ros, 1, mean']
        m, mm = r['MuJoCo Newton, 1'], r['MuJoCo Newton, 1, mean']
        print(f'| {name} | {o * 1e6:.2f} | {om * 1e6:.2f} | {m * 1e6:.2f} | {mm * 1e6:.2f} | '
              f'{om / mm:.2f}x |')
    sane = figures.Sanity()
    for name, r in rows.items():
        for c, value in r.items():
            sane.within(f'{name}, {c}', value, 1e-7, 0.1)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'contact_step_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'repeats': repeats, 'dt': DT,
                             'seconds_per_step': rows})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
