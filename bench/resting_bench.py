# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What sleeping buys: a floor of boxes at rest, awake and asleep, next to MuJoCo, one run.

    python -m bench.resting_bench [--quick] [--side 10] [--json out.json]

The scene: side x side stacks of two 0.2 m cubes (2 kg each) on the ground, 5 cm apart, at
rest, gravity 9.81 m/s^2, dt = 1 ms, friction 0.5. Each engine settles it for ``--settle``
steps, then ``--steps`` are timed one by one (median). Like for like, twice: solving against
solving, rb_sim_ros with sleeping off (every contact solved every step) against MuJoCo with
sleeping off (its default Newton solver, same boxes as free bodies on a plane); and sleeping
against sleeping, rb_sim_ros with sleeping (default settings: everything asleep after 0.5 s)
against MuJoCo with its sleeping enabled (``mjENBL_SLEEP``, default tolerance). Then a ball is
dropped onto one stack in rb_sim_ros: the steps while it falls and lands wake that stack only,
and their cost is timed too.

Last, the collision demo (scenes/collisions.yaml through ``Simulation``, as the node steps
it): ms per step over its first second, while things fall and bounce, and over the steps
from 4 to 5 s, when it has gone to sleep.

Checks, which stop the run (exit 1) if they fail: in every engine every box stays within
1 mm of where it started (a resting floor must stay put), the sleeping runs are all asleep
before timing (rb_sim_ros; MuJoCo's awake-tree count is reported), and the figures are sane
(finite, positive, within orders of magnitude; no timing budgets). Writes
docs/bench/resting_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import mujoco
import numpy as np

from bench import figures
from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core.rigid_body import State
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, Simulation

DT = 1e-3
SIZE = 0.2
MASS = 2.0
GAP = 0.05
FRICTION = 0.5
GRAVITY = (0.0, 0.0, -9.81)


def positions(side: int) -> np.ndarray:
    pitch = SIZE + GAP
    return np.array([((i - (side - 1) / 2) * pitch, (j - (side - 1) / 2) * pitch,
                      SIZE / 2 + SIZE * k)
                     for i in range(side) for j in range(side) for k in range(2)])


def world(side: int, sleep_time: float) -> CollisionWorld:
    moment = MASS * SIZE * SIZE / 6.0
    bodies = [BodySpec(f'b{n}', MASS, (moment,) * 3, initial_position=tuple(p),
                       colliders=(Box((SIZE,) * 3),)) for n, p in enumerate(positions(side))]
    bodies.append(BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(50.0, 0.0, 0.1),
                           colliders=(Sphere(0.1),)))     # waits on the ground, far away
    return collision_world(bodies, DT, GRAVITY, planes=(Plane(),),
                           contact=ContactSettings(friction=FRICTION, sleep_time=sleep_time))


def timed(step, steps: int) -> float:
    times = []
    for _ in range(steps):
        t = time.perf_counter()
        step()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def run_ours(side: int, sleep_time: float, settle: int, steps: int) -> dict:
    w = world(side, sleep_time)
    w.step(settle)
    asleep = len(w.sleeping)
    rest = timed(lambda: w.step(1), steps)
    contacts = w.last_stats.contacts
    start = positions(side)
    drift = float(np.abs(np.array([w.state(f'b{n}').position for n in range(len(start))])
                         - start).max())
    # Drop the ball on the middle stack from 0.3 m above it; time the fall and landing.
    top = start[:, 2].max() + SIZE / 2
    centre = start[np.argmin(np.abs(start[:, :2]).sum(axis=1)), :2]
    w.set_state('ball', State((centre[0] + 0.03, centre[1], top + 0.4), None,
                              (0.0, 0.0, -1.0)))
    drop = timed(lambda: w.step(1), 400)
    return {'seconds_per_step': rest, 'asleep': asleep, 'drift': drift,
            'drop_seconds_per_step': drop, 'awake_after_drop': len(w.steppers) - len(
                w.sleeping), 'contacts': contacts}


def run_mujoco(side: int, settle: int, steps: int, sleep: bool) -> dict:
    boxes = ''.join(f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}"><freejoint/>'
                    f'<geom type="box" size="{SIZE / 2} {SIZE / 2} {SIZE / 2}" mass="{MASS}" '
                    f'friction="{FRICTION} 0 0"/></body>' for p in positions(side))
    xml = (f'<mujoco><option timestep="{DT}" gravity="{GRAVITY[0]} {GRAVITY[1]} '
           f'{GRAVITY[2]}"/><worldbody><geom type="plane" size="50 50 0.1" '
           f'friction="{FRICTION} 0 0"/>{boxes}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    if sleep:
        model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=settle)
    awake = int(data.ntree_awake)
    rest = timed(lambda: mujoco.mj_step(model, data), steps)
    start = positions(side)
    drift = float(np.abs(data.qpos.reshape(-1, 7)[:, :3] - start).max())
    return {'seconds_per_step': rest, 'drift': drift, 'contacts': int(data.ncon),
            'awake_trees': awake, 'solver': 'Newton'}


def demo_scene(quick: bool) -> dict:
    """ms per step of scenes/collisions.yaml, as the node steps it (a Simulation, 10 steps a
    call): over the first second and, once asleep, over 4 to 5 s (quick: the first 0.2 s and
    2.0-2.1 s, when it may not all sleep yet)."""
    scene = load_scene(str(figures.ROOT / 'scenes' / 'collisions.yaml'))
    sim = Simulation(Config(gravity=scene.gravity, bodies=scene.bodies, contact=scene.contact))
    sim.warm_up()  # as the node does before its clock starts: no kernel loaded while timed
    first, late, end = (200, 2000, 2100) if quick else (1000, 4000, 5000)

    def run(steps):
        for _ in range(steps // 10):
            sim.run(10)

    t = time.perf_counter()
    run(first)
    moving = (time.perf_counter() - t) / first
    run(late - first)
    asleep = len(sim.world.sleeping)
    t = time.perf_counter()
    run(end - late)
    return {'moving_seconds_per_step': moving, 'moving_steps': first,
            'asleep_seconds_per_step': (time.perf_counter() - t) / (end - late),
            'asleep_steps': [late, end], 'bodies': len(sim.world.steppers),
            'asleep_bodies': asleep}


def sanity(rows: dict, demo: dict) -> figures.Sanity:
    s = figures.Sanity()
    for name, r in rows.items():
        s.within(f'{name}: s per step at rest', r['seconds_per_step'], 1e-7, 10.0)
    for a, b in (('awake', 'mujoco'), ('asleep', 'mujoco_sleeping'), ('awake', 'asleep')):
        s.within(f'{a} / {b}', rows[a]['seconds_per_step'] / rows[b]['seconds_per_step'],
                 0.01, 1e4)
    s.within('demo scene, s per step moving', demo['moving_seconds_per_step'], 1e-6, 1.0)
    s.within('demo scene, s per step asleep', demo['asleep_seconds_per_step'], 1e-7, 1.0)
    s.true('the drop wakes something', rows['asleep']['awake_after_drop'] > 1)
    return s


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.resting_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='3 x 3 stacks, fewer steps')
    parser.add_argument('--side', type=int, help='stacks per side (default 10: 200 boxes)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/resting_bench.json; --quick: none)')
    opts = parser.parse_args()
    side = opts.side or (3 if opts.quick else 10)
    settle, steps = (700, 50) if opts.quick else (1000, 200)
    print(f'{2 * side * side} boxes of {SIZE} m in {side} x {side} stacks of two, dt = {DT} s: '
          f'{settle} steps to settle, then {steps} timed')
    awake = run_ours(side, 0.0, settle, steps)
    asleep = run_ours(side, 0.5, settle, steps)
    theirs = run_mujoco(side, settle, steps, sleep=False)
    theirs_asleep = run_mujoco(side, settle, steps, sleep=True)
    rows = {'awake': awake, 'asleep': asleep, 'mujoco': theirs, 'mujoco_sleeping': theirs_asleep}
    problems = [f'{name}: a box moved {r["drift"] * 1e3:.2f} mm' for name, r in rows.items()
                if r['drift'] > 1e-3]
    if asleep['asleep'] != 2 * side * side + 1:
        problems.append(f'only {asleep["asleep"]} bodies asleep before timing')
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print('\n| engine | ms per step at rest | contacts | largest drift (mm) | ms per step, '
          'a ball dropped on one stack |\n| --- | ---: | ---: | ---: | ---: |')
    for name, r in (('rb_sim_ros, sleeping off', awake), ('rb_sim_ros, sleeping', asleep),
                    ('MuJoCo mj_step (Newton, sleeping off)', theirs),
                    ('MuJoCo mj_step (Newton, sleeping)', theirs_asleep)):
        drop = f'{r["drop_seconds_per_step"] * 1e3:.3f}' if 'drop_seconds_per_step' in r \
            else '-'
        print(f'| {name} | {r["seconds_per_step"] * 1e3:.3f} | {r["contacts"]} | '
              f'{r["drift"] * 1e3:.4f} | {drop} |')
    print(f'\nsleeping: {awake["seconds_per_step"] / asleep["seconds_per_step"]:.0f}x less per '
          f'step at rest. Like for like, rb_sim_ros / MuJoCo: solving every contact '
          f'{awake["seconds_per_step"] / theirs["seconds_per_step"]:.1f}x, both sleeping '
          f'{asleep["seconds_per_step"] / theirs_asleep["seconds_per_step"]:.2f}x (MuJoCo '
          f'trees awake before timing: {theirs_asleep["awake_trees"]} of {2 * side * side}). '
          f'After the drop {asleep["awake_after_drop"]} of {2 * side * side + 1} bodies awake.')
    demo = demo_scene(opts.quick)
    print(f'scenes/collisions.yaml: {demo["moving_seconds_per_step"] * 1e3:.2f} ms per step '
          f'over the first {demo["moving_steps"]} steps, '
          f'{demo["asleep_seconds_per_step"] * 1e3:.3f} ms over steps {demo["asleep_steps"]} '
          f'({demo["asleep_bodies"]} of {demo["bodies"]} moving bodies asleep)')
    sane = sanity(rows, demo)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'resting_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'side': side, 'settle': settle,
                             'steps': steps, **rows, 'demo_scene': demo})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
