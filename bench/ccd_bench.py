# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Continuous collision: tunnelling caught, ghost stops removed, and what the swept test costs.

    python -m bench.ccd_bench [--quick] [--json out.json]

1. Tunnelling: a plate 20 x 20 x 1 cm at 100 m/s (10 cm a step at dt = 1 ms) at a static wall
   1 cm thick, in 1000 orientations drawn uniformly (seed 0), e = 0.5, mu = 0.5, flow4 (edge
   impacts leave it turning at ~1000 rad/s): how many runs end with the plate's centre past
   the wall's far face, with the default settings and with the plain discrete method
   (``speculative: false``).
2. Ghost stops: a ball (r = 5 cm) at 100 m/s skimming a box's edge and face 1 mm or 1 cm
   clear, at 10 phases of the step: how many runs end with another velocity than 100 m/s
   along x (it touches nothing), with the swept test and without it (``continuous_speed:
   inf``, what the simulator did before).
3. Cost: the 1000-sphere heap of bench/collision_bench.py (dropped, its first 1000 steps,
   while the spheres fall and land at up to ~2 m/s) and the collision demo (scenes/
   collisions.yaml through ``Simulation`` as the node steps it, its first 1000 steps),
   each timed with and without the swept test in the same run, alternately, best of 3; the
   pairs swept and contacts missed over the run are counted in a run of their own.

Writes docs/bench/ccd_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
import math
from pathlib import Path
import sys
import time

import numpy as np
from tqdm import tqdm

from bench import collision_bench as cb, figures
from rb_sim_ros.contact.collision_shapes import Box, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, Simulation

DT = 1e-3
OFF = math.inf   # continuous_speed that sweeps no body


def plate_run(q, speculative: bool = True) -> float:
    """The plate's largest x over 12 steps (the wall spans x in [-5, 5] mm)."""
    wall = BodySpec('wall', static=True, colliders=(Box((0.01, 1.0, 1.0)),))
    plate = BodySpec('plate', 1.0, (0.2 ** 2 / 12 + 0.01 ** 2 / 12,) * 2 + (0.08 / 12,),
                     initial_position=(-0.4, 0.0, 0.0), initial_orientation_xyzw=tuple(q),
                     initial_linear_velocity=(100.0, 0.0, 0.0),
                     colliders=(Box((0.2, 0.2, 0.01)),))
    world = collision_world([plate, wall], DT, integrator='flow4', contact=ContactSettings(
        restitution=0.5, friction=0.5, sleep_time=0.0, speculative=speculative))
    most = -math.inf
    for _ in range(12):
        world.step(1)
        most = max(most, float(world.state('plate').position[0]))
    return most


def tunnelling(count: int) -> dict:
    q = np.random.default_rng(0).normal(size=(count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    passed = {'default': 0, 'discrete': 0}
    for row in tqdm(q, desc='plates', leave=False, disable=None):
        passed['default'] += plate_run(row) > 0.005
        passed['discrete'] += plate_run(row, False) > 0.005
    return {'cases': count, 'passed': passed}


def skim_run(clearance: float, phase: float, continuous_speed: float) -> bool:
    """Whether the skimming ball was stopped or turned (a ghost stop: it touches nothing)."""
    box = BodySpec('box', static=True, initial_position=(0.0, -0.55 - clearance, 0.0),
                   colliders=(Box((1.0, 1.0, 1.0)),))
    ball = BodySpec('ball', 1.0, (0.001,) * 3, initial_position=(-1.0 - phase * 0.1, 0.0, 0.0),
                    initial_linear_velocity=(100.0, 0.0, 0.0), colliders=(Sphere(0.05),))
    world = collision_world([ball, box], DT, contact=ContactSettings(
        restitution=0.5, friction=0.5, sleep_time=0.0, continuous_speed=continuous_speed))
    world.step(30)
    s = world.state('ball')
    return not (np.array_equal(s.linear_velocity, [100.0, 0.0, 0.0])
                and not np.any(s.angular_velocity))


def ghosts() -> dict:
    cases = [(c, p) for c in (1e-3, 1e-2) for p in np.linspace(0.0, 1.0, 10, endpoint=False)]
    on = sum(skim_run(c, p, ContactSettings().continuous_speed) for c, p in cases)
    off = sum(skim_run(c, p, OFF) for c, p in cases)
    return {'cases': len(cases), 'stopped_with_sweep': on, 'stopped_without': off}


def heap_world(continuous_speed: float):
    s = cb.scene(1000)
    return collision_world(cb.bodies(s), DT, cb.GRAVITY, planes=cb.walls(s['half']),
                           contact=ContactSettings(restitution=cb.RESTITUTION,
                                                   friction=cb.FRICTION, sleep_time=0.0,
                                                   continuous_speed=continuous_speed))


def demo_sim(continuous_speed: float) -> Simulation:
    scene = load_scene(str(figures.ROOT / 'scenes' / 'collisions.yaml'))
    sim = Simulation(Config(gravity=scene.gravity, bodies=scene.bodies, contact=replace(
        scene.contact, continuous_speed=continuous_speed)))
    sim.warm_up()
    return sim


def cost(steps: int, repeats: int) -> dict:
    """Seconds per step of each scene with the swept test (default) and without, best of
    ``repeats`` alternate runs, and what the test did over a run."""
    out = {}
    default = ContactSettings().continuous_speed
    for name, make, run in (
            ('heap', heap_world, lambda w, n: w.step(n)),
            ('demo', demo_sim, lambda s, n: [s.run(10) for _ in range(n // 10)])):
        run(make(default), 20)  # (compiled before anything is timed: its own contact tests)
        best = {'with': math.inf, 'without': math.inf}
        for _ in range(repeats):
            for key, speed in (('with', default), ('without', OFF)):
                thing = make(speed)
                t = time.perf_counter()
                run(thing, steps)
                best[key] = min(best[key], (time.perf_counter() - t) / steps)
        counted = make(default)
        world = counted if name == 'heap' else None
        swept = missed = 0
        for _ in range(steps):
            if world is None:
                counted.run(1)
                stats = counted.world.last_stats
            else:
                world.step(1)
                stats = world.last_stats
            swept += stats.swept
            missed += stats.missed
        out[name] = {'seconds_per_step_with': best['with'],
                     'seconds_per_step_without': best['without'],
                     'ratio': best['with'] / best['without'], 'pairs_swept': swept,
                     'contacts_missed': missed, 'steps': steps}
    return out


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.ccd_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='100 plates, 200 steps of each scene, best of 1')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/ccd_bench.json; --quick: none)')
    opts = parser.parse_args()
    plate_run((0.0, 0.0, 0.0, 1.0))  # (compiled before anything is timed)
    tun = tunnelling(100 if opts.quick else 1000)
    print(f"tunnelling: {tun['cases']} plates at 100 m/s: passed the wall: "
          f"{tun['passed']['default']} (default), {tun['passed']['discrete']} (discrete); "
          f"caught {tun['cases'] - tun['passed']['default']}/{tun['cases']}")
    gh = ghosts()
    print(f"ghost stops: {gh['cases']} skimming runs stopped or turned: "
          f"{gh['stopped_with_sweep']} with the swept test, {gh['stopped_without']} without")
    costs = cost(200 if opts.quick else 1000, 1 if opts.quick else 3)
    for name, c in costs.items():
        print(f"{name}: {c['seconds_per_step_with'] * 1e3:.3f} ms per step with the swept test, "
              f"{c['seconds_per_step_without'] * 1e3:.3f} without: x{c['ratio']:.3f} "
              f"({c['pairs_swept']} pairs swept, {c['contacts_missed']} contacts missed in "
              f"{c['steps']} steps)")
    s = figures.Sanity()
    s.true('every plate caught', tun['passed']['default'] == 0)
    s.true('the discrete method lets some through', tun['passed']['discrete'] > 0)
    s.true('no ghost stop with the swept test', gh['stopped_with_sweep'] == 0)
    s.true('ghost stops without it', gh['stopped_without'] > 0)
    for name, c in costs.items():
        s.within(f'{name}: ratio with / without', c['ratio'], 0.3, 3.0)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'ccd_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'dt': DT, 'tunnelling': tun, 'ghosts': gh,
                             'cost': costs})
    return s.report()


if __name__ == '__main__':
    sys.exit(main())
