# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What each skip saves: the specialised step against the general path, on scenes that need less.

    python -m bench.skip_bench [--quick] [--steps 100000] [--repeats 5] [--json out.json]

For each scene, first checks that the specialised and the general path agree (bit for bit
where the maths is the same, else to 1e-12), then times both (minimum of --repeats runs of
one ``step(steps)``: amortised, the per-call cost spread over the steps) and prints us per
step and the speed-up. Writes docs/bench/skip_bench.json (or ``--json``; ``--quick``: 5,000
steps, 2 repeats, no file unless asked). Exit 1 if the paths disagree or a figure is not
plausible (finite, 0.01 to 100 us a step, speed-ups 0.2x to 100x; the parked body costs
nothing: under 0.2 us).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import numpy as np

from bench import figures
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

ASYMMETRIC = RigidBody(2.0, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.4]])
SPHERE = RigidBody(1.0, [0.4, 0.4, 0.4])
G = (0.0, 0.0, -9.81)

KEYS = ('general', 'projectile', 'sphere', 'attitude', 'parked')
SCENES = {
    # name: (what is skipped, body, state, wrench, environment)
    'general (nothing to skip)': ('-', ASYMMETRIC, State(angular_velocity=[1, 2, 3]),
                                  Wrench([1, 0, 0], [0.01, 0, 0], 'body'), {}),
    'projectile: gravity, force, no torque, not spinning': (
        'rotation update, angular accelerations', ASYMMETRIC,
        State(linear_velocity=[3, 0, 5]), Wrench(force=[0.5, 0, 0]), {'gravity': G}),
    'spinning sphere under a world torque': (
        'gyroscopic term, frame changes', SPHERE, State(angular_velocity=[1, 2, 3]),
        Wrench(torque=[0.01, 0, 0.02]), {}),
    'attitude only: body torque, no force': (
        'nothing (translation is 3% of a step)', ASYMMETRIC, State(angular_velocity=[1, 2, 3]),
        Wrench(torque=[0.01, 0, 0], frame='body'), {}),
    'at rest, no wrench (a parked body)': ('everything', ASYMMETRIC, State(), Wrench(), {}),
}


def _time(stepper: Stepper, steps: int, repeats: int) -> float:
    best = float('inf')
    for _ in range(repeats):
        t0 = time.perf_counter()
        stepper.step(steps)
        best = min(best, time.perf_counter() - t0)
    return best / steps * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.skip_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='5,000 steps, 2 repeats')
    parser.add_argument('--steps', type=int, help='steps per timed run (default 100,000)')
    parser.add_argument('--repeats', type=int, help='timed runs (default 5)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/skip_bench.json; --quick: none)')
    opts = parser.parse_args()
    steps = opts.steps or (5000 if opts.quick else 100_000)
    repeats = opts.repeats or (2 if opts.quick else 5)
    rows, sane = [], figures.Sanity()
    print(f'{"scene":<54} {"general":>9} {"specialised":>12} {"speed-up":>9}  skipped')
    for key, (name, (skipped, body, state, wrench, env)) in zip(KEYS, SCENES.items()):
        spec = Stepper(body, 1e-3, state, wrench, specialize=True, **env)
        gen = Stepper(body, 1e-3, state, wrench, specialize=False, **env)
        for s in (spec, gen):
            s.step(2000)
        a, b = spec.state, gen.state
        agree = max(np.max(np.abs(a.position - b.position)),
                    np.max(np.abs(a.linear_velocity - b.linear_velocity)),
                    np.max(np.abs(a.angular_velocity - b.angular_velocity)),
                    so3.angle_between(a.rotation, b.rotation))
        if agree > 1e-12:
            print(f'{name}: specialised and general paths differ by {agree:.3g}',
                  file=sys.stderr)
            return 1
        t_gen, t_spec = _time(gen, steps, repeats), _time(spec, steps, repeats)
        print(f'{name:<54} {t_gen:>6.2f} us {t_spec:>9.2f} us {t_gen / t_spec:>8.1f}x  '
              f'{skipped}')
        rows.append({'key': key, 'scene': name, 'skipped': skipped, 'agreement': agree,
                     'general_us': t_gen, 'specialised_us': t_spec})
        sane.within(f'{key}: general us per step', t_gen, 0.01, 100.0)
        if key == 'parked':
            sane.within(f'{key}: specialised us per step', t_spec, 0.0, 0.2)
        else:
            sane.within(f'{key}: specialised us per step', t_spec, 0.01, 100.0)
            sane.within(f'{key}: speed-up', t_gen / t_spec, 0.2, 100.0)
    out = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'skip_bench.json')
    if out:
        figures.write(out, {'quick': opts.quick, 'steps': steps, 'repeats': repeats,
                            'rows': rows})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
