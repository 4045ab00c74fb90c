# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The cost of one Stepper step (issue 2: goal <= 3 us on the reference machine).

    python -m bench.step_cost [--quick] [--steps 100000] [--repeats 5] [--json out.json]

For each of rb_sim_ros's methods and two bodies (diagonal inertia, torque-free; a full,
non-diagonal inertia under a body-frame force and torque), first checks that one simulated
second at dt = 1 ms agrees with DOP853 (rtol 1e-12) to within the method's expected error, then
times ``steps`` steps taken three ways, the minimum of ``repeats`` runs, and prints us per step:
``step(1)`` called ``steps`` times (how the node steps at 1 kHz with a 1 kHz publish rate, and
what a loop that reads every step pays), ``step(10)`` (the node at 1 kHz physics and 100 Hz
output), and one ``step(steps)`` (amortised: the per-call cost spread over all the steps).
MuJoCo's mj_step on one free body (same inertia; a world-frame torque, which is what
xfrc_applied takes) is printed beside it for scale, one step per call and ``nstep``.
Writes docs/bench/step_cost.json (or ``--json``); exit 1 if a check or a sanity check fails.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys
import time

import mujoco
import numpy as np
from scipy.integrate import solve_ivp

from bench import figures, peers, references, scenes as sc
from rb_sim_ros import METHODS, RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

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
TOLERANCE = {1: 1e-2, 2: 1e-4, 3: 1e-6, 4: 1e-8}


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


def ours_and_flows(rows) -> tuple[list[float], list[float]]:
    """us per step of rb_sim_ros's multistep methods (what the goal is about) and of its
    flows (an exact free flow each, flow2, or three, flow4), from rows of one kind of call."""
    ours = [r for r in rows if r['method'].startswith('rb_sim_ros ')]
    flow = [r['method'].startswith('rb_sim_ros flow') for r in ours]
    return ([r['us_per_step'] for r, f in zip(ours, flow) if not f],
            [r['us_per_step'] for r, f in zip(ours, flow) if f])


CALLS = {'step(1)': 1, 'step(10)': 10, 'amortised': None}


def _stepped(step, steps: int, per_call: int | None, repeats: int) -> float:
    """us per step: the minimum over ``repeats`` of ``steps`` steps, ``per_call`` a call
    (None: all in one call)."""
    best = math.inf
    calls = 1 if per_call is None else steps // per_call
    n = steps if per_call is None else per_call
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(calls):
            step(n)
        best = min(best, time.perf_counter() - t)
    return best / (calls * n) * 1e6


def measure(steps: int = 100_000, repeats: int = 5, progress=None,
            calls=('amortised',)) -> list[dict]:
    """[{'method', 'body', 'call', 'us_per_step'}]: min over ``repeats`` of ``steps`` steps,
    for each way of calling of ``calls`` (keys of CALLS)."""
    rows = []
    for method in METHODS:
        for label, mass, inertia, force, torque, frame in CASES:
            s = Stepper(RigidBody(mass, inertia), DT, START, Wrench(force, torque, frame),
                        method=method)
            for call in calls:
                rows.append({'method': f'rb_sim_ros {method}', 'body': label, 'call': call,
                             'us_per_step': _stepped(s.step, steps, CALLS[call], repeats)})
            if progress:
                progress.update()
    for integrator in ('Euler', 'implicitfast', 'RK4'):
        for label, mass, inertia, force, torque, frame in CASES:
            scene = sc.Scene(label, inertia, tuple(START.rotation.T @ START.angular_velocity),
                             steps * DT, mass=mass)
            m, d = peers.MuJoCo(integrator).model(scene, DT)
            d.xfrc_applied[1] = (*force, *torque)
            body = label.replace('body-frame', 'world-frame')
            for call in calls:
                rows.append({'method': f'MuJoCo {integrator}', 'call': call,
                             'body': body + (' (mj_step, nstep)' if call == 'amortised'
                                             else ' (mj_step)'),
                             'us_per_step': _stepped(
                                 lambda n: mujoco.mj_step(m, d, nstep=n), steps, CALLS[call],
                                 repeats)})
            if progress:
                progress.update()
    return rows


def count() -> int:
    return (len(METHODS) + 3) * len(CASES)


def table(rows: list[dict]) -> str:
    calls = list(dict.fromkeys(r.get('call', 'amortised') for r in rows))
    cells: dict = {}
    for r in rows:
        cells.setdefault((r['method'], r['body'].replace(' (mj_step, nstep)', '')
                          .replace(' (mj_step)', '')), {})[r.get('call', 'amortised')] = \
            r['us_per_step']
    lines = ['| method | body | ' + ' | '.join(f'us per step, {c}' for c in calls) + ' |',
             '| --- | --- | ' + ' | '.join('---:' for _ in calls) + ' |']
    for (method, body), v in cells.items():
        lines.append(f'| {method} | {body} | ' + ' | '.join(f'{v[c]:.2f}' for c in calls)
                     + ' |')
    return '\n'.join(lines)


def sanity(rows: list[dict]) -> figures.Sanity:
    """Every figure finite, between 0.01 and 1000 us (a compiled step of one body is some 200
    floating-point operations and a sine and cosine: tens of ns; a call from Python about a
    microsecond; a step in the interpreter tens of us). No comparison between figures: the
    machine is noisy."""
    s = figures.Sanity()
    for r in rows:
        s.within(f'{r["method"]}, {r["body"]}, {r["call"]}', r['us_per_step'], 0.01, 1000.0)
    return s


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.step_cost', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='2,000 steps, 2 repeats')
    parser.add_argument('--steps', type=int, help='steps per timed run (default 100,000)')
    parser.add_argument('--repeats', type=int, help='timed runs (the minimum counts; default 5)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/step_cost.json; --quick: none)')
    opts = parser.parse_args()
    steps = opts.steps or (2000 if opts.quick else 100_000)
    repeats = opts.repeats or (2 if opts.quick else 5)
    checked = check()
    for row in checked:
        print(f'agrees: {row["method"]:14s} {row["body"]:32s} '
              f'{row["angle_error_1s"]:.1e} rad after 1 s')
    rows = measure(steps, repeats, calls=tuple(CALLS))
    print(table(rows))
    ours, flows = ours_and_flows([r for r in rows if r['call'] == 'amortised'])
    print(f'rb_sim_ros amortised, multistep methods: {min(ours):.2f}-{max(ours):.2f} us per '
          f'step (goal <= {GOAL_US:g} us: {"met" if max(ours) <= GOAL_US else "NOT met"}); '
          f'the flows: {min(flows):.2f}-{max(flows):.2f} us')
    out = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'step_cost.json')
    if out:
        figures.write(out, {'quick': opts.quick, 'steps': steps, 'repeats': repeats,
                            'check': checked, 'rows': rows})
    return sanity(rows).report()


if __name__ == '__main__':
    sys.exit(main())
