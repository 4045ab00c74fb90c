# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Spheres settled in a box: rb_sim_ros's CollisionWorld next to MuJoCo, same scene, one run.

    python -m bench.collision_bench [--quick] [--spheres 1000] [--json out.json]

The scene: N spheres (radius 5 cm, 0.5 kg) on a cubic lattice with 1 cm gaps, the lowest
layer 5 mm above the floor, small random velocities (seeded), inside a box of five planes
(floor and four walls) a little wider than the lattice; gravity 9.81 m/s^2, dt = 1 ms,
friction 0.5. They fall onto each other and the lattice collapses into a heap (RMS speed of
the spheres about 1 m/s). Each engine steps until its heap is settled: the RMS speed below
2 cm/s at five checks in a row, 100 steps apart (at most ``--max-settle`` steps; MuJoCo's soft
contacts keep its heap jittering at 0.5-1.5 cm/s). The ``--steps`` after that are timed one by
one (median), and the RMS speed must still be below 2 cm/s after them.

Like for like: neither engine sleeps; rb_sim_ros runs projected Gauss-Seidel, 10 velocity
iterations at most (and 4 position iterations); MuJoCo settles, and is timed, with its PGS
solver at the same budget of 10 iterations. From copies of MuJoCo's settled state its other
solvers are timed too: CG at 10 iterations, and its defaults (Newton, at most 100 iterations,
tolerance 1e-8; it takes about a second a step on the 1000-sphere heap, so fewer steps) and CG
at its default 100. MuJoCo has soft contacts, pyramidal friction cones and no restitution
coefficient (ours is 0.2). Contacts are counted the same way on both sides: those that carried
a force in the step (rb_sim_ros: normal impulse > 0; MuJoCo: efc_force > 0 on one of the
contact's rows); rb_sim_ros's count of all its contacts, speculative ones included, is given
beside it.

First the checks, which stop the run (exit 1) if they fail: both engines keep every sphere
inside the box and above the floor, the heaps agree (mean height of the centres within a
radius of each other), and (but with --quick) both heaps settled. Then the table and the
sanity checks of its figures (finite, positive, within orders of magnitude: ratios within
1e-4..1000, MuJoCo's Newton solver being some 400 times slower than the rest here; contact
counts within 5x of each other). Also the time of rb_sim_ros's step (one compiled call:
integrate, broad, narrow, solve, write), and the same N spheres without colliders: what a
run that has no collision world (``Simulation``) costs next to the bare Steppers.
Writes docs/bench/collision_bench.json (or ``--json``; --quick: none unless asked).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import mujoco
import numpy as np

from bench import figures
from rb_sim_ros.contact.collision_shapes import Plane, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core.stepper import Stepper
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec, Config, Simulation

DT = 1e-3
RADIUS = 0.05
MASS = 0.5
GAP = 0.01
FRICTION = 0.5
RESTITUTION = 0.2
GRAVITY = (0.0, 0.0, -9.81)
SETTLED_RMS = 0.02      # m/s: a heap is settled when the RMS speed of its spheres stays below
SETTLED_CHECKS = 5      # ... at this many checks in a row, 100 steps apart
ITERATIONS = 10         # velocity iterations (ours: the default) and MuJoCo PGS's budget


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


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(v * v, axis=1))))


# -- rb_sim_ros --------------------------------------------------------------------------------
def run_ours(s: dict, max_settle: int, steps: int) -> dict:
    # No sleeping (MuJoCo's is off by default too): a settled heap whose bodies slept would be
    # timed doing nothing.
    specs = bodies(s)
    world = collision_world(specs, DT, GRAVITY, planes=walls(s['half']),
                            contact=ContactSettings(restitution=RESTITUTION, friction=FRICTION,
                                                    sleep_time=0.0))
    assert world.settings.velocity_iterations == ITERATIONS

    def rms():
        return _rms(np.array([world.state(b.name).linear_velocity for b in specs]))

    settle = calm = 0
    while settle < max_settle and calm < SETTLED_CHECKS:
        world.step(100)
        settle += 100
        calm = calm + 1 if rms() < SETTLED_RMS else 0
    rms_before = rms()
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
    totals = world.totals  # read again: the sums are brought up to date when read
    per = {k: (getattr(totals, k) - v) / steps for k, v in base.items()}
    positions = np.array([world.state(b.name).position for b in specs])
    return {'seconds_per_step': float(np.median(times)), 'settle_steps': settle,
            'rms_speed_before': rms_before, 'rms_speed_after': rms(),
            'contacts': per['contacts'], 'forced_contacts': per['active'],
            'pairs_tested': per['candidate_pairs'] + per['plane_pairs'],
            'touched': per['touched'], 'colours': float(np.mean(colours)),
            'iterations': per['velocity_iterations'],
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


def _forced(model, data) -> int:
    """Contacts with a force on one of their rows (pyramidal cones: 2 (dim - 1) rows)."""
    n = 0
    for c in data.contact[:data.ncon]:
        if c.efc_address < 0:
            continue
        rows = 1 if c.dim == 1 else 2 * (c.dim - 1)
        if np.any(data.efc_force[c.efc_address:c.efc_address + rows] > 0.0):
            n += 1
    return n


# (label, solver, iterations or None for MuJoCo's default, steps timed: None = --steps)
SOLVERS = (('PGS, 10 iterations', mujoco.mjtSolver.mjSOL_PGS, ITERATIONS, None),
           ('CG, 10 iterations', mujoco.mjtSolver.mjSOL_CG, ITERATIONS, None),
           ('CG, 100 iterations (default cap)', mujoco.mjtSolver.mjSOL_CG, None, None),
           ('Newton (default)', mujoco.mjtSolver.mjSOL_NEWTON, None, 'newton'))


def run_mujoco(s: dict, max_settle: int, steps: int, newton_steps: int) -> dict:
    """Settle with PGS at 10 iterations (our budget), then time each of SOLVERS from a copy
    of that settled state."""
    model = mujoco_model(s)
    default_iterations = model.opt.iterations
    model.opt.solver, model.opt.iterations = mujoco.mjtSolver.mjSOL_PGS, ITERATIONS
    data = mujoco.MjData(model)
    count = len(s['positions'])
    data.qvel.reshape(count, 6)[:, :3] = s['velocities']
    mujoco.mj_forward(model, data)

    def rms(d):
        return _rms(d.qvel.reshape(count, 6)[:, :3])

    settle = calm = 0
    while settle < max_settle and calm < SETTLED_CHECKS:
        mujoco.mj_step(model, data, nstep=100)
        settle += 100
        calm = calm + 1 if rms(data) < SETTLED_RMS else 0
    out = {}
    for name, solver, iterations, n in SOLVERS:
        d = mujoco.MjData(model)
        mujoco.mj_copyData(d, model, data)
        model.opt.solver = solver
        model.opt.iterations = iterations or default_iterations
        n = newton_steps if n == 'newton' else steps
        times, contacts, forced, iters = [], [], [], []
        rms_before = rms(d)
        for _ in range(n):
            t = time.perf_counter()
            mujoco.mj_step(model, d)
            times.append(time.perf_counter() - t)
            contacts.append(d.ncon)
            forced.append(_forced(model, d))
            iters.append(int(d.solver_niter[0]))
        out[name] = {'seconds_per_step': float(np.median(times)), 'steps': n,
                     'max_iterations': model.opt.iterations,
                     'contacts': float(np.mean(contacts)),
                     'forced_contacts': float(np.mean(forced)),
                     'iterations': float(np.mean(iters)), 'rms_speed_before': rms_before,
                     'rms_speed_after': rms(d)}
        if name.startswith('PGS'):
            out['positions'] = d.qpos.reshape(count, 7)[:, :3].copy()
    out['settle_steps'] = settle
    return out


def no_collider_costs(s: dict, steps: int) -> dict:
    """Seconds per step of N colliderless bodies: a Simulation of them (which has no collision
    world: the one switch) against bare Steppers."""
    specs = bodies(s, colliders=False)
    world = Simulation(Config(dt=DT, gravity=GRAVITY, bodies=tuple(specs)))
    steppers = [Stepper(b.body(), DT, b.initial_state(), gravity=GRAVITY) for b in specs]
    best = {'world': np.inf, 'steppers': np.inf}
    for _ in range(3):
        t = time.perf_counter()
        world.run(steps)
        best['world'] = min(best['world'], (time.perf_counter() - t) / steps)
        t = time.perf_counter()
        for st in steppers:
            st.step(steps)
        best['steppers'] = min(best['steppers'], (time.perf_counter() - t) / steps)
    return {**best, 'enabled': world.world is not None}


def check(s: dict, name: str, positions: np.ndarray) -> list[str]:
    half = s['half']
    problems = []
    if not np.all(np.isfinite(positions)):
        problems.append(f'{name}: non-finite positions')
    if np.any(np.abs(positions[:, :2]) > half) or np.any(positions[:, 2] < 0.0):
        problems.append(f'{name}: a sphere left the box')
    return problems


def sanity(ours: dict, theirs: dict) -> figures.Sanity:
    s = figures.Sanity()
    s.within('rb_sim_ros s per step', ours['seconds_per_step'], 1e-6, 10.0)
    s.within('rb_sim_ros contacts with a force per step', ours['forced_contacts'], 1.0, 1e5)
    for name, r in theirs.items():
        s.within(f'MuJoCo {name}: s per step', r['seconds_per_step'], 1e-6, 10.0)
        s.within(f'rb_sim_ros / MuJoCo {name}',
                 ours['seconds_per_step'] / r['seconds_per_step'], 1e-4, 1000.0)
        s.within(f'contacts with a force, rb_sim_ros / MuJoCo {name}',
                 ours['forced_contacts'] / max(r['forced_contacts'], 1e-9), 0.2, 5.0)
    s.true(f'rb_sim_ros ran at most {ITERATIONS} velocity iterations',
           ours['iterations'] <= ITERATIONS)
    s.true(f'MuJoCo PGS ran at most {ITERATIONS} iterations',
           theirs['PGS, 10 iterations']['iterations'] <= ITERATIONS)
    return s


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.collision_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='125 spheres, at most 300 settling steps (not required to '
                             'settle), 20 timed (a few seconds)')
    parser.add_argument('--spheres', type=int, help='number of spheres (default 1000)')
    parser.add_argument('--max-settle', type=int,
                        help='most steps to settle before timing (default 6000)')
    parser.add_argument('--steps', type=int, help='steps timed one by one (default 100)')
    parser.add_argument('--newton-steps', type=int,
                        help="steps timed with MuJoCo's Newton solver (default 5, quick 3)")
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/collision_bench.json; --quick: none)')
    opts = parser.parse_args()
    count = opts.spheres or (125 if opts.quick else 1000)
    max_settle = opts.max_settle or (300 if opts.quick else 6000)
    steps = opts.steps or (20 if opts.quick else 100)
    s = scene(count)
    print(f'{count} spheres r = {RADIUS} m in a box of half width {s["half"]:.3f} m, '
          f'dt = {DT} s: up to {max_settle} steps to settle (RMS speed < {SETTLED_RMS} m/s '
          f'{SETTLED_CHECKS} times in a row), '
          f'then {steps} timed', flush=True)

    t = time.perf_counter()
    ours = run_ours(s, max_settle, steps)
    ours_wall = time.perf_counter() - t
    print(f'rb_sim_ros: {ours["settle_steps"]} steps to settle, {ours_wall:.0f} s', flush=True)
    theirs = run_mujoco(s, max_settle, steps, opts.newton_steps or (3 if opts.quick else 5))
    settle_theirs = theirs.pop('settle_steps')
    print(f'MuJoCo (PGS): {settle_theirs} steps to settle', flush=True)
    positions = theirs.pop('positions')
    problems = check(s, 'rb_sim_ros', ours['positions']) + check(s, 'MuJoCo', positions)
    mean_ours = float(ours['positions'][:, 2].mean())
    mean_theirs = float(positions[:, 2].mean())
    print(f'mean height of the centres: rb_sim_ros {mean_ours:.4f} m, MuJoCo '
          f'{mean_theirs:.4f} m (must agree within a radius, {RADIUS} m)')
    if abs(mean_ours - mean_theirs) > RADIUS:
        problems.append('the heaps disagree')
    like = theirs['PGS, 10 iterations']
    for name, r in (('rb_sim_ros', ours), ('MuJoCo', like)):
        print(f'{name}: RMS speed {r["rms_speed_before"]:.4f} m/s before timing, '
              f'{r["rms_speed_after"]:.4f} m/s after')
        if not opts.quick and max(r['rms_speed_before'], r['rms_speed_after']) >= SETTLED_RMS:
            problems.append(f'{name} did not settle within {max_settle} steps')
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1

    free = no_collider_costs(s, 200 if opts.quick else 500)
    print(f'\nsteps to settle: rb_sim_ros {ours["settle_steps"]}, MuJoCo (PGS) {settle_theirs}')
    print('\n| engine | ms per step | contacts with a force per step | contacts with a force '
          'per s | iterations per step (cap) |\n| --- | ---: | ---: | ---: | ---: |')
    rows = [(f'rb_sim_ros CollisionWorld (PGS; {ours["contacts"]:.0f} contacts with the '
             'speculative ones)', ours, ITERATIONS)]
    rows += [(f'MuJoCo {name} ({r["steps"]} steps timed)', r, r['max_iterations'])
             for name, r in theirs.items()]
    for name, r, cap in rows:
        ms = r['seconds_per_step'] * 1e3
        print(f'| {name} | {ms:.3f} | {r["forced_contacts"]:.0f} | '
              f'{r["forced_contacts"] / r["seconds_per_step"]:,.0f} | '
              f'{r["iterations"]:.1f} ({cap}) |')
    for name, r in theirs.items():
        print(f'rb_sim_ros / MuJoCo {name}: '
              f'{ours["seconds_per_step"] / r["seconds_per_step"]:.2f}x the time per step')
    print(f'rb_sim_ros per step: {ours["pairs_tested"]:.0f} pairs tested, {ours["touched"]:.0f} '
          f'bodies touched (apply_contact), {ours["colours"]:.1f} colours, '
          f'{ours["position_iterations"]:.1f} position iterations.')
    print('\n| rb_sim_ros phase | ms per step | share |\n| --- | ---: | ---: |')
    total = sum(ours['phases'].values())
    for phase, sec in ours['phases'].items():
        print(f'| {phase} | {sec * 1e3:.3f} | {sec / total:.0%} |')
    print(f'\n{count} bodies without colliders (collision pass skipped: '
          f'{not free["enabled"]}): Simulation.run {free["world"] * 1e3:.3f} ms per step, '
          f'bare Steppers {free["steppers"] * 1e3:.3f} ms per step')
    sane = sanity(ours, theirs)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'collision_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'spheres': count, 'steps': steps,
                             'settled_rms_speed': SETTLED_RMS,
                             'settled_checks': SETTLED_CHECKS,
                             'rb_sim_ros': {k: v for k, v in ours.items() if k != 'positions'},
                             'mujoco': theirs, 'mujoco_settle_steps': settle_theirs,
                             'mean_height': {'rb_sim_ros': mean_ours, 'mujoco': mean_theirs},
                             'no_colliders': free})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
