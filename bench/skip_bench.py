# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What each skip saves: the specialised step against the general path, on scenes that need less.

    python bench/skip_bench.py [--steps 100000] [--repeats 5]

For each scene, first checks that the specialised and the general path agree (bit for bit
where the maths is the same, else to 1e-12), then times both (minimum of --repeats runs of
--steps steps) and prints us per step and the speed-up.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from rb_sim_ros import RigidBody, so3, State, Stepper, Wrench

ASYMMETRIC = RigidBody(2.0, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.4]])
SPHERE = RigidBody(1.0, [0.4, 0.4, 0.4])
G = (0.0, 0.0, -9.81)

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
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--steps', type=int, default=100_000)
    parser.add_argument('--repeats', type=int, default=5)
    opts = parser.parse_args()
    print(f'{"scene":<54} {"general":>9} {"specialised":>12} {"speed-up":>9}  skipped')
    for name, (skipped, body, state, wrench, env) in SCENES.items():
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
        t_gen, t_spec = _time(gen, opts.steps, opts.repeats), _time(spec, opts.steps,
                                                                    opts.repeats)
        print(f'{name:<54} {t_gen:>6.2f} us {t_spec:>9.2f} us {t_gen / t_spec:>8.1f}x  '
              f'{skipped}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
