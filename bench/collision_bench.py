# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Spheres settling in a box: rb_sim_ros's CollisionWorld next to MuJoCo, same scene, one run.

    python bench/collision_bench.py [--quick] [--spheres 1000] [--json out.json]

The scene: N spheres (radius 5 cm, 0.5 kg) on a cubic lattice with 1 cm gaps, the lowest
layer 5 mm above the floor, small random velocities (seeded), inside a box of five planes
(floor and four walls) a little wider than the lattice; gravity 9.81 m/s^2, dt = 1 ms,
friction 0.5. They fall onto each other and the lattice collapses into a heap. Both engines
take the same ``--settle`` steps, then the same ``--steps`` are timed one by one.
MuJoCo gets spheres with free joints and plane geoms (its defaults otherwise: soft contacts,
pyramidal friction cones; it has no restitution coefficient, ours is 0.2). Its default Newton
solver takes about a second a step on the 1000-sphere heap here, so MuJoCo settles with its CG
solver and both solvers are timed from that settled state (Newton on fewer steps).

First the checks, which stop the run (exit 1) if they fail: after the run both engines keep
every sphere inside the box and above the floor, and the heaps agree (mean height of the
centres within a radius of each other). Then the table: cost of a step, contacts per step and
contacts per second (contacts found per wall second of stepping), pairs tested by the narrow
phase, and where rb_sim_ros spends a step (integrate: the Steppers; broad: read the poses,
AABBs, sweep and prune; narrow; solve: impulses and position correction; write: apply_contact of
every touched body). Last, the same N spheres without colliders: what a world that skips the
collision pass costs next to the bare Steppers.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import platform
import sys
import time

import mujoco
import numpy as np

from rb_sim_ros.collision_shapes import Plane, Sphere
from rb_sim_ros.collision_world import CollisionWorld
from rb_sim_ros.simulation import BodySpec
from rb_sim_ros.stepper import Stepper

DT = 1e-3
RADIUS = 0.05
MASS = 0.5
GAP = 0.01
FRICTION = 0.5
RESTITUTION = 0.2
GRAVITY = (0.0, 0.0, -9.81)


def scene(count: int, seed: int = 0) -> dict:
    """Positions (m), velocities (m/s) of ``count`` spheres on a lattice, and the half width
    (m) of the box (the walls stand at +-half)."""
    side = max(1, round(count ** (1.0 / 3.0)))
    layers = -(-count // (side * side))
    pitch = 2 * RADIUS + GAP
    rng = np.random.default_rng(seed)
    cells = [(i, j, k) for k in range(layers) for i in range(side) for j in range(side)]
    cells = np.array(cells[:count], dtype=float)
    positions = np.stack([(cells[:, 0] - (side - 1) / 2) * pitch,
                          (cells[:, 1] - (side - 1) / 2) * pitch,
                          RADIUS + 0.005 + cells[:, 2] * pitch], axis=1)
    return {'positions': positions, 'velocities': rng.normal(size=(count, 3)) * 0.1,
            'half': side * pitch / 2 + 2 * RADIUS}


def walls(half: float) -> tuple[Plane, ...]:
    return (Plane((0.0, 0.0, 1.0), 0.0), Plane((1.0, 0.0, 0.0), -half),
            Plane((-1.0, 0.0, 0.0), -half), Plane((0.0, 1.0, 0.0), -half),
            Plane((0.0, -1.0, 0.0), -half))


def bodies(s: dict, colliders: bool = True) -> list[BodySpec]:
    inertia = (0.4 * MASS * RADIUS * RADIUS,) * 3
    return [BodySpec(f's{i}', MASS, inertia, initial_position=tuple(p),
                     initial_linear_velocity=tuple(v),
                     colliders=(Sphere(RADIUS),) if colliders else ())
            for i, (p, v) in enumerate(zip(s['positions'], s['velocities']))]


# -- rb_sim_ros --------------------------------------------------------------------------------
def run_ours(s: dict, settle: int, steps: int) -> dict:
    world = CollisionWorld(bodies(s), DT, GRAVITY, restitution=RESTITUTION, friction=FRICTION,
                           planes=walls(s['half']))
    world.step(settle)
    world.totals.seconds.clear()
    totals = world.totals
    names = ('contacts', 'active', 'candidate_pairs', 'plane_pairs', 'velocity_iterations',
             'position_iterations', 'touched')
    base = {k: getattr(totals, k) for k in names}
    times, colours = [], []
    for _ in range(steps):
        t = time.perf_counter()
        world.step(1)
        times.append(time.perf_counter() - t)
        colours.append(world.last_stats.colours)
    per = {k: (getattr(totals, k) - v) / steps for k, v in base.items()}
    positions = np.array([world.state(b.name).position for b in world.bodies])
    return {'seconds_per_step': float(np.median(times)), 'contacts': per['contacts'],
            'active_contacts': per['active'],
            'pairs_tested': per['candidate_pairs'] + per['plane_pairs'],
            'touched': per['touched'], 'colours': float(np.mean(colours)),
            'velocity_iterations': per['velocity_iterations'],
            'position_iterations': per['position_iterations'],
            'phases': {k: v / steps for k, v in totals.seconds.items()},
            'positions': positions}


# -- MuJoCo ------------------------------------------------------------------------------------
def mujoco_model(s: dict) -> mujoco.MjModel:
    half = s['half']
    plane = f'type="plane" size="{half} {half} 0.1" friction="{FRICTION} 0 0"'
    geoms = [f'<geom {plane} pos="0 0 0"/>',
             f'<geom {plane} pos="{half} 0 0" zaxis="-1 0 0"/>',
             f'<geom {plane} pos="{-half} 0 0" zaxis="1 0 0"/>',
             f'<geom {plane} pos="0 {half} 0" zaxis="0 -1 0"/>',
             f'<geom {plane} pos="0 {-half} 0" zaxis="0 1 0"/>']
    spheres = [f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}"><freejoint/>'
               f'<geom type="sphere" size="{RADIUS}" mass="{MASS}" friction="{FRICTION} 0 0"/>'
               '</body>' for p in s['positions']]
    xml = (f'<mujoco><option timestep="{DT}" gravity="{GRAVITY[0]} {GRAVITY[1]} {GRAVITY[2]}"/>'
           f'<size memory="{64 + len(spheres) // 4}M"/>'
           f'<worldbody>{"".join(geoms)}{"".join(spheres)}</worldbody></mujoco>')
    return mujoco.MjModel.from_xml_string(xml)


def run_mujoco(s: dict, settle: int, steps: int, newton_steps: int) -> dict:
    """Settle with the CG solver (the fastest here), then time CG and, from a copy of the same
    settled state, MuJoCo's default Newton solver (much slower on a heap: fewer steps)."""
    model = mujoco_model(s)
    model.opt.solver = mujoco.mjtSolver.mjSOL_CG
    data = mujoco.MjData(model)
    count = len(s['positions'])
    data.qvel.reshape(count, 6)[:, :3] = s['velocities']
    mujoco.mj_forward(model, data)
    mujoco.mj_step(model, data, nstep=settle)
    newton = mujoco.MjData(model)
    mujoco.mj_copyData(newton, model, data)
    out = {}
    for name, solver, d, n in (('CG', mujoco.mjtSolver.mjSOL_CG, data, steps),
                               ('Newton', mujoco.mjtSolver.mjSOL_NEWTON, newton, newton_steps)):
        model.opt.solver = solver
        times, contacts, iterations = [], [], []
        for _ in range(n):
            t = time.perf_counter()
            mujoco.mj_step(model, d)
            times.append(time.perf_counter() - t)
            contacts.append(d.ncon)
            iterations.append(int(d.solver_niter[0]))
        out[name] = {'seconds_per_step': float(np.median(times)),
                     'contacts': float(np.mean(contacts)), 'steps': n,
                     'iterations': float(np.mean(iterations))}
    out['positions'] = data.qpos.reshape(count, 7)[:, :3].copy()
    return out


def no_collider_costs(s: dict, steps: int) -> dict:
    """Seconds per step of N colliderless bodies: a CollisionWorld against bare Steppers."""
    specs = bodies(s, colliders=False)
    world = CollisionWorld(specs, DT, GRAVITY, planes=walls(s['half']))
    steppers = [Stepper(b.body(), DT, b.initial_state(), gravity=GRAVITY) for b in specs]
    best = {'world': np.inf, 'steppers': np.inf}
    for _ in range(3):
        t = time.perf_counter()
        world.step(steps)
        best['world'] = min(best['world'], (time.perf_counter() - t) / steps)
        t = time.perf_counter()
        for st in steppers:
            st.step(steps)
        best['steppers'] = min(best['steppers'], (time.perf_counter() - t) / steps)
    return {**best, 'enabled': world.enabled}


def check(s: dict, name: str, positions: np.ndarray) -> list[str]:
    half = s['half']
    problems = []
    if not np.all(np.isfinite(positions)):
        problems.append(f'{name}: non-finite positions')
    if np.any(np.abs(positions[:, :2]) > half) or np.any(positions[:, 2] < 0.0):
        problems.append(f'{name}: a sphere left the box')
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='125 spheres, 100 settling steps, 30 timed (a few seconds)')
    parser.add_argument('--spheres', type=int, help='number of spheres (default 1000)')
    parser.add_argument('--settle', type=int, help='steps before timing (default 300)')
    parser.add_argument('--steps', type=int, help='steps timed one by one (default 100)')
    parser.add_argument('--newton-steps', type=int,
                        help="steps timed with MuJoCo's Newton solver (default 5, quick 10)")
    parser.add_argument('--json', type=Path, help='write the figures here too')
    opts = parser.parse_args()
    count = opts.spheres or (125 if opts.quick else 1000)
    settle = opts.settle if opts.settle is not None else (100 if opts.quick else 300)
    steps = opts.steps or (30 if opts.quick else 100)
    s = scene(count)
    print(f'{count} spheres r = {RADIUS} m in a box of half width {s["half"]:.3f} m, '
          f'dt = {DT} s: {settle} steps to settle, then {steps} timed')

    t = time.perf_counter()
    ours = run_ours(s, settle, steps)
    ours_wall = time.perf_counter() - t
    theirs = run_mujoco(s, settle, steps, opts.newton_steps or (10 if opts.quick else 5))
    problems = (check(s, 'rb_sim_ros', ours['positions'])
                + check(s, 'MuJoCo', theirs['positions']))
    mean_ours = float(ours['positions'][:, 2].mean())
    mean_theirs = float(theirs['positions'][:, 2].mean())
    print(f'mean height of the centres: rb_sim_ros {mean_ours:.4f} m, MuJoCo '
          f'{mean_theirs:.4f} m (must agree within a radius, {RADIUS} m)')
    if abs(mean_ours - mean_theirs) > RADIUS:
        problems.append('the heaps disagree')
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1

    free = no_collider_costs(s, 200 if opts.quick else 500)
    print('\n| engine | ms per step | contacts per step | contacts per s | pairs tested '
          'per step |\n| --- | ---: | ---: | ---: | ---: |')
    rows = (('rb_sim_ros CollisionWorld', ours, f'{ours["pairs_tested"]:.0f}'),
            (f'MuJoCo mj_step, CG ({theirs["CG"]["iterations"]:.0f} iterations)',
             theirs['CG'], '-'),
            (f'MuJoCo mj_step, Newton (default; {theirs["Newton"]["steps"]} steps timed)',
             theirs['Newton'], '-'))
    for name, r, pairs in rows:
        ms = r['seconds_per_step'] * 1e3
        print(f'| {name} | {ms:.3f} | {r["contacts"]:.0f} | '
              f'{r["contacts"] / r["seconds_per_step"]:,.0f} | {pairs} |')
    ratio = ours['seconds_per_step'] / theirs['CG']['seconds_per_step']
    print(f'\nrb_sim_ros / MuJoCo CG: {ratio:.1f}x the time per step. rb_sim_ros per step: '
          f'{ours["active_contacts"]:.0f} contacts with an impulse, {ours["touched"]:.0f} '
          f'bodies touched (apply_contact), {ours["colours"]:.1f} colours, '
          f'{ours["velocity_iterations"]:.1f} velocity and {ours["position_iterations"]:.1f} '
          'position iterations.')
    print('\n| rb_sim_ros phase | ms per step | share |\n| --- | ---: | ---: |')
    total = sum(ours['phases'].values())
    for phase, sec in ours['phases'].items():
        print(f'| {phase} | {sec * 1e3:.3f} | {sec / total:.0%} |')
    print(f'\n{count} bodies without colliders (collision pass skipped: '
          f'{not free["enabled"]}): CollisionWorld {free["world"] * 1e3:.3f} ms per step, '
          f'bare Steppers {free["steppers"] * 1e3:.3f} ms per step')
    print(f'(rb_sim_ros run: {ours_wall:.1f} s wall)')
    if opts.json:
        out = {'machine': {'python': platform.python_version(), 'numpy': np.__version__,
                           'mujoco': mujoco.__version__,
                           'cpu': platform.processor() or platform.machine()},
               'spheres': count, 'settle': settle, 'steps': steps,
               'rb_sim_ros': {k: v for k, v in ours.items() if k != 'positions'},
               'mujoco': {k: v for k, v in theirs.items() if k != 'positions'},
               'mean_height': {'rb_sim_ros': mean_ours, 'mujoco': mean_theirs},
               'no_colliders': free}
        opts.json.write_text(json.dumps(out, indent=2) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
