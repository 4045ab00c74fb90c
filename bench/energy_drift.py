# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Kinetic-energy drift of a torque-free body, method by method, against the turn per step.

    python -m bench.energy_drift [--steps 2000] [--bodies 24] [--seed 1] [--turns 0.01,0.1]

For every method and every turn per step |omega| dt on the grid, ``bodies`` random asymmetric
bodies (principal moments obeying the triangle inequality, plates I1 + I2 = I3 among them),
each spinning about a random axis with |omega| = 1 rad/s and dt = the turn, are stepped
torque-free ``steps`` steps one at a time; the cell is the worst over the bodies of
max over the steps of |E_n / E_0 - 1|, E = omega . I_world omega / 2 (an exact invariant of the
motion). ``div`` = the stepper raised IntegrationError (beyond ``Stepper.MAX_TURN`` or
non-finite). Then, per method, the largest turn on the grid at which the drift stays within
each tolerance, and the drift at each method's energy bound (``stepper.TURN_BOUNDS``, the
figures docs/integrators.md quotes: within ENERGY_TOLERANCE over ENERGY_STEPS steps); exit 1 if
one is not within it.
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from rb_sim_ros import METHODS, RigidBody, State, Stepper
from rb_sim_ros.core import so3
from rb_sim_ros.core.stepper import (ENERGY_STEPS, ENERGY_TOLERANCE, IntegrationError,
                                     TURN_BOUNDS, TurnWarning)

TURNS = (0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8,
         0.9)
TOLERANCES = (1e-6, 1e-3, 1e-2)


def bodies(count: int, seed: int) -> list[tuple[tuple[float, float, float], np.ndarray]]:
    """``count`` (principal moments, unit spin axis in the world frame) pairs: moments a <= b
    <= c <= a + b, every fourth body a plate (c = a + b), every fourth a near-prolate rod."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        a, b = np.sort(rng.uniform(0.2, 1.0, 2))
        if k % 4 == 0:
            c = a + b
        elif k % 4 == 1:
            a, c = 0.05 * b, b * (1.0 + 0.05 * rng.uniform())
        else:
            c = rng.uniform(b, a + b)
        axis = rng.normal(size=3)
        out.append(((float(a), float(b), float(c)), axis / np.linalg.norm(axis)))
    return out


def energy(moments, r9, w) -> float:
    """omega . R I R^T omega / 2 from R (row-major) and omega (world)."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r9
    wx, wy, wz = w
    bx = r00 * wx + r10 * wy + r20 * wz
    by = r01 * wx + r11 * wy + r21 * wz
    bz = r02 * wx + r12 * wy + r22 * wz
    ix, iy, iz = moments
    return 0.5 * (ix * bx * bx + iy * by * by + iz * bz * bz)


def drift(method: str, moments, axis, turn: float, steps: int) -> float:
    """max over the steps of |E_n / E_0 - 1|, or inf if the stepper refused a step."""
    stepper = Stepper(RigidBody(1.0, moments), dt=turn, method=method,
                      state=State(rotation=so3.exp((0.3, -0.2, 0.5)),
                                  angular_velocity=tuple(axis)))
    _, r, _, w = stepper.components()
    e0 = energy(moments, r, w)
    worst = 0.0
    for _ in range(steps):
        try:
            stepper.step(1)
        except IntegrationError:
            return float('inf')
        _, r, _, w = stepper.components()
        worst = max(worst, abs(energy(moments, r, w) / e0 - 1.0))
    return worst


def table(methods, turns, steps: int, count: int, seed: int) -> dict[str, list[float]]:
    cases = bodies(count, seed)
    return {m: [max(drift(m, mo, ax, t, steps) for mo, ax in cases) for t in turns]
            for m in methods}


def largest_within(row, turns, tolerance: float) -> float:
    """The largest turn of the grid up to which (every smaller turn included) the drift
    stays within ``tolerance``; 0 if none."""
    best = 0.0
    for t, d in zip(turns, row):
        if not d <= tolerance:
            break
        best = t
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.energy_drift', description=__doc__.split('\n\n')[0])
    parser.add_argument('--steps', type=int, default=2000)
    parser.add_argument('--bodies', type=int, default=24)
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--turns', default=','.join(str(t) for t in TURNS),
                        help='turns per step |omega| dt (rad), comma-separated')
    parser.add_argument('--methods', default=','.join(METHODS))
    args = parser.parse_args(argv)
    warnings.simplefilter('ignore', TurnWarning)  # the runs above the bounds are the point
    turns = [float(t) for t in args.turns.split(',')]
    methods = args.methods.split(',')
    result = table(methods, turns, args.steps, args.bodies, args.seed)
    print(f'Worst relative kinetic-energy drift over {args.steps} torque-free steps, '
          f'{args.bodies} random bodies (seed {args.seed}); div = IntegrationError')
    print('| |omega| dt (rad) | ' + ' | '.join(methods) + ' |')
    print('| ---: |' + ' ---: |' * len(methods))
    for j, t in enumerate(turns):
        cells = ['div' if result[m][j] == float('inf') else f'{result[m][j]:.1e}'
                 for m in methods]
        print(f'| {t:g} | ' + ' | '.join(cells) + ' |')
    print()
    print('Largest turn per step (rad) with the drift within the tolerance at it and below:')
    print('| method | ' + ' | '.join(f'{tol:g}' for tol in TOLERANCES) + ' |')
    print('| --- |' + ' ---: |' * len(TOLERANCES))
    for m in methods:
        print(f'| {m} | ' + ' | '.join(f'{largest_within(result[m], turns, tol):g}'
                                       for tol in TOLERANCES) + ' |')
    print()
    print(f'Energy bounds (rb_sim_ros.core.stepper.TURN_BOUNDS): worst drift at the bound over '
          f'{args.steps} steps, tolerance {ENERGY_TOLERANCE:g} over {ENERGY_STEPS} steps')
    print('| method | bound (rad a step) | drift at it | within |')
    print('| --- | ---: | ---: | --- |')
    cases = bodies(args.bodies, args.seed)
    ok = True
    for m in methods:
        bound = TURN_BOUNDS.get(m)
        if bound is None:
            print(f'| {m} | none (exact torque-free) | | |')
            continue
        at = (result[m][turns.index(bound)] if bound in turns
              else max(drift(m, mo, ax, bound, args.steps) for mo, ax in cases))
        within = at <= ENERGY_TOLERANCE * args.steps / ENERGY_STEPS
        ok = ok and within
        print(f'| {m} | {bound:g} | {at:.1e} | {"yes" if within else "NO"} |')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
