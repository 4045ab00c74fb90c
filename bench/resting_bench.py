# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What sleeping buys: a floor of boxes at rest, awake and asleep, next to MuJoCo, one run.

    python bench/resting_bench.py [--quick] [--side 10] [--json out.json]

The scene: side x side stacks of two 0.2 m cubes (2 kg each) on the ground, 5 cm apart, at
rest, gravity 9.81 m/s^2, dt = 1 ms, friction 0.5. Each engine settles it for ``--settle``
steps, then ``--steps`` are timed one by one (median): rb_sim_ros with sleeping off (every
contact solved every step, as an engine without sleeping must), rb_sim_ros with sleeping
(default settings: everything asleep after 0.5 s), and MuJoCo (its default Newton solver, same
boxes as free bodies on a plane). Then a ball is dropped onto one stack: the steps while it
falls and lands wake that stack only, and their cost is timed too.

Checks, which stop the run (exit 1) if they fail: in every engine every box stays within
1 mm of where it started (a resting floor must stay put), and the sleeping run is all asleep
before timing.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import time

import mujoco
import numpy as np

from rb_sim_ros.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.collision_world import CollisionWorld
from rb_sim_ros.rigid_body import State
from rb_sim_ros.simulation import BodySpec

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
    return CollisionWorld(bodies, DT, GRAVITY, friction=FRICTION, planes=(Plane(),),
                          sleep_time=sleep_time)


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
            'drop_seconds_per_step': drop, 'awake_after_drop': len(w.bodies) - len(
                w.sleeping), 'contacts': contacts}


def run_mujoco(side: int, settle: int, steps: int) -> dict:
    boxes = ''.join(f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}"><freejoint/>'
                    f'<geom type="box" size="{SIZE / 2} {SIZE / 2} {SIZE / 2}" mass="{MASS}" '
                    f'friction="{FRICTION} 0 0"/></body>' for p in positions(side))
    xml = (f'<mujoco><option timestep="{DT}" gravity="{GRAVITY[0]} {GRAVITY[1]} '
           f'{GRAVITY[2]}"/><worldbody><geom type="plane" size="50 50 0.1" '
           f'friction="{FRICTION} 0 0"/>{boxes}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=settle)
    rest = timed(lambda: mujoco.mj_step(model, data), steps)
    start = positions(side)
    drift = float(np.abs(data.qpos.reshape(-1, 7)[:, :3] - start).max())
    return {'seconds_per_step': rest, 'drift': drift, 'contacts': int(data.ncon)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='3 x 3 stacks, fewer steps')
    parser.add_argument('--side', type=int, help='stacks per side (default 10: 200 boxes)')
    parser.add_argument('--json', type=Path, help='write the figures here too')
    opts = parser.parse_args()
    side = opts.side or (3 if opts.quick else 10)
    settle, steps = (700, 50) if opts.quick else (1000, 200)
    print(f'{2 * side * side} boxes of {SIZE} m in {side} x {side} stacks of two, dt = {DT} s: '
          f'{settle} steps to settle, then {steps} timed')
    awake = run_ours(side, 0.0, settle, steps)
    asleep = run_ours(side, 0.5, settle, steps)
    theirs = run_mujoco(side, settle, steps)
    problems = [f'{name}: a box moved {r["drift"] * 1e3:.2f} mm' for name, r in
                (('rb_sim_ros awake', awake), ('rb_sim_ros asleep', asleep), ('MuJoCo', theirs))
                if r['drift'] > 1e-3]
    if asleep['asleep'] != 2 * side * side + 1:
        problems.append(f'only {asleep["asleep"]} bodies asleep before timing')
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1
    print('\n| engine | ms per step at rest | contacts | largest drift (mm) | ms per step, '
          'a ball dropped on one stack |\n| --- | ---: | ---: | ---: | ---: |')
    for name, r in (('rb_sim_ros, sleeping off', awake), ('rb_sim_ros, sleeping', asleep),
                    ('MuJoCo mj_step (Newton)', theirs)):
        drop = f'{r["drop_seconds_per_step"] * 1e3:.3f}' if 'drop_seconds_per_step' in r \
            else '-'
        print(f'| {name} | {r["seconds_per_step"] * 1e3:.3f} | {r["contacts"]} | '
              f'{r["drift"] * 1e3:.4f} | {drop} |')
    print(f'\nsleeping: {awake["seconds_per_step"] / asleep["seconds_per_step"]:.0f}x less per '
          f'step at rest; rb_sim_ros asleep / MuJoCo: '
          f'{asleep["seconds_per_step"] / theirs["seconds_per_step"]:.2f}x. After the drop '
          f'{asleep["awake_after_drop"]} of {2 * side * side + 1} bodies awake.')
    if opts.json:
        opts.json.write_text(json.dumps({'side': side, 'awake': awake, 'asleep': asleep,
                                         'mujoco': theirs}, indent=2) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
