# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The cost of one Stepper step (issue 2: goal <= 3 us on the reference machine).

    python bench/step_cost.py [--steps 100000] [--repeats 5]

For each of rb_sim_ros's methods and two bodies (diagonal inertia, torque-free; a full,
non-diagonal inertia under a body-frame force and torque), first checks that one simulated
second at dt = 1 ms agrees with DOP853 (rtol 1e-12) to within the method's expected error, then
times ``stepper.step(steps)``, the minimum of ``repeats`` runs, and prints us per step. MuJoCo's
mj_step on one free body (same inertia; a world-frame torque, which is what xfrc_applied takes)
is printed beside it for scale.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys
import time

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import peers  # noqa: E402
from rb_sim_ros import METHODS, RigidBody, so3, State, Stepper, Wrench  # noqa: E402
import references  # noqa: E402, I100, I201
import scenes as sc  # noqa: E402, I201

GOAL_US = 3.0
DT = 1e-3
FULL_INERTIA = ((0.2, 0.01, 0.0), (0.01, 0.3, 0.02), (0.0, 0.02, 0.4))
START = State(rotation=so3.exp((0.3, -0.5, 0.8)), angular_velocity=(1.0, 2.0, 3.0))
# (label, mass (kg), inertia (kg m^2, body), force (N), torque (N m), frame of the wrench)
CASES = (
    ('diagonal inertia, torque-free', 1.0, sc.diagonal(1.0, 2.0, 3.0), (0.0, 0.0, 0.0),
     (0.0, 0.0, 0.0), 'world'),
    ('full inertia, body-frame wrench', 2.0, FULL_INERTIA, (1.0, 0.0, 0.0), (0.01, 0.0, 0.0),
     'body'),
)
# One simulated second at dt = 1 ms must be this close (rad) to DOP853.
TOLERANCE = {1: 1e-2, 2: 1e-4}


def _reference_rotation(mass, inertia, torque, frame) -> np.ndarray:
    """R after 1 s by DOP853 on quaternions, torque held in ``frame``."""
    y0 = np.concatenate([references.quaternion_wxyz(START.rotation),
                         START.rotation.T @ START.angular_velocity])
    sol = solve_ivp(references.rhs_body_quaternion(np.array(inertia), torque, frame), (0.0, 1.0),
                    y0, method='DOP853', rtol=1e-12, atol=1e-14)
    return references.matrix_from_wxyz(sol.y[:4, -1])


def check() -> list[dict]:
    """Every (method, body) against DOP853 after 1 s; raises AssertionError if one is off."""
    rows = []
    for label, mass, inertia, force, torque, frame in CASES:
        ref = _reference_rotation(mass, inertia, torque, frame)
        for method in METHODS:
            s = Stepper(RigidBody(mass, inertia), DT, START, Wrench(force, torque, frame),
                        method=method)
            s.step(round(1.0 / DT))
            error = so3.angle_between(s.state.rotation, ref)
            limit = TOLERANCE[METHODS[method].order]
            rows.append({'method': method, 'body': label, 'angle_error_1s': error})
            if not error < limit:
                raise AssertionError(f'{method} on {label}: {error:.2e} rad after 1 s, '
                                     f'expected < {limit:g}')
    return rows


def measure(steps: int = 100_000, repeats: int = 5, progress=None) -> list[dict]:
    """[{'method', 'body', 'us_per_step'}]: min over ``repeats`` of stepper.step(steps)."""
    rows = []
    for method in METHODS:
        for label, mass, inertia, force, torque, frame in CASES:
            s = Stepper(RigidBody(mass, inertia), DT, START, Wrench(force, torque, frame),
                        method=method)
            best = math.inf
            for _ in range(repeats):
                t = time.perf_counter()
                s.step(steps)
                best = min(best, time.perf_counter() - t)
            rows.append({'method': f'rb_sim_ros {method}', 'body': label,
                         'us_per_step': best / steps * 1e6})
            if progress:
                progress.update()
    for integrator in ('Euler', 'implicitfast', 'RK4'):
        for label, mass, inertia, force, torque, frame in CASES:
            scene = sc.Scene(label, inertia, tuple(START.rotation.T @ START.angular_velocity),
                             steps * DT, mass=mass)
            m, d = peers.MuJoCo(integrator).model(scene, DT)
            d.xfrc_applied[1] = (*force, *torque)
            best = math.inf
            for _ in range(repeats):
                t = time.perf_counter()
                mujoco.mj_step(m, d, nstep=steps)
                best = min(best, time.perf_counter() - t)
            body = label.replace('body-frame', 'world-frame')
            rows.append({'method': f'MuJoCo {integrator}', 'body': body + ' (mj_step, nstep)',
                         'us_per_step': best / steps * 1e6})
            if progress:
                progress.update()
    return rows


def count() -> int:
    return (len(METHODS) + 3) * len(CASES)


def table(rows: list[dict]) -> str:
    lines = ['| method | body | us per step |', '| --- | --- | ---: |']
    for r in rows:
        lines.append(f'| {r["method"]} | {r["body"]} | {r["us_per_step"]:.2f} |')
    return '\n'.join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--steps', type=int, default=100_000, help='steps per timed run')
    parser.add_argument('--repeats', type=int, default=5, help='timed runs (the minimum counts)')
    opts = parser.parse_args()
    for row in check():
        print(f'agrees: {row["method"]:14s} {row["body"]:32s} '
              f'{row["angle_error_1s"]:.1e} rad after 1 s')
    rows = measure(opts.steps, opts.repeats)
    print(table(rows))
    ours = [r['us_per_step'] for r in rows if r['method'].startswith('rb_sim_ros')]
    print(f'rb_sim_ros: {min(ours):.2f}-{max(ours):.2f} us per step '
          f'(goal <= {GOAL_US:g} us: {"met" if max(ours) <= GOAL_US else "NOT met"})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
