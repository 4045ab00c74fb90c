# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Regenerate the benchmark report: run time against error, and numerical stress.

    python bench/run.py            # the full report into docs/ (under 10 minutes)
    python bench/run.py --quick --out /tmp/b   # a few seconds' check that nothing rotted

Work-precision: rb_sim_ros's methods, MuJoCo (Euler, implicitfast, RK4; one free joint) and
scipy DOP853 on four scenes with references (elliptic oracle, closed-form top, DOP853 at 1e-13).
Each stepping method must first converge at its order, else nothing is timed (exit 1).
Stress: Dzhanibekov flip period, extreme inertia (incl. mujoco#3553), fast spin, a long run,
a blow-up. Writes benchmarks.md, img/*.png and summary.json into --out.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import platform
import sys
import time

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from rb_sim_ros import RigidBody, State, Stepper, Wrench  # noqa: E402
import scenes as sc  # noqa: E402
import stress  # noqa: E402
import work_precision as wp  # noqa: E402


def machine() -> str:
    cpu = platform.processor() or 'unknown CPU'
    try:
        for line in Path('/proc/cpuinfo').read_text().splitlines():
            if line.startswith('model name'):
                cpu = line.split(':', 1)[1].strip()
                break
    except OSError:
        pass
    return (f'{cpu}, {os.cpu_count()} cores; Python {platform.python_version()}, numpy '
            f'{np.__version__}, MuJoCo {mujoco.__version__}; {platform.platform()}')


def step_cost(quick: bool) -> list[dict]:
    """us per step of one body: rb_sim_ros's methods (diagonal torque-free; full inertia with
    a body-frame wrench) next to MuJoCo's mj_step on one free body."""
    steps = 20_000 if quick else 200_000
    full = RigidBody(2.0, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.4]])
    rows = []
    for method in ('eq27', 'taylor1'):
        for label, body, wrench in (('diagonal, torque-free', RigidBody(1.0, [1, 2, 3]),
                                     Wrench()),
                                    ('full inertia, body wrench', full,
                                     Wrench([1, 0, 0], [0.01, 0, 0], 'body'))):
            s = Stepper(body, 1e-3, State(angular_velocity=[1, 2, 3]), wrench, method=method)
            best = float('inf')
            for _ in range(3 if quick else 5):
                t = time.perf_counter()
                s.step(steps)
                best = min(best, time.perf_counter() - t)
            rows.append({'method': f'rb_sim_ros {method}', 'body': label,
                         'us_per_step': best / steps * 1e6})
    for integrator in ('Euler', 'RK4'):
        runner = sc_peer(integrator)
        scene = sc.Scene('cost', (1.0, 2.0, 3.0), (1.0, 2.0, 3.0), steps * 1e-3)
        secs = runner.seconds_per_sim_second(scene, 1e-3, 3 if quick else 5) * scene.t_end
        rows.append({'method': runner.name, 'body': 'diagonal, torque-free (mj_step, nstep)',
                     'us_per_step': secs / steps * 1e6})
    return rows


def sc_peer(integrator):
    import peers
    return peers.MuJoCo(integrator)


def report(out: Path, summary: dict, quick: bool) -> str:
    lines = ['# Benchmarks: run time against error, and numerical stress', '',
             f'Measured {summary["date"]} on {summary["machine"]}.',
             f'Regenerate: `./tools/bench.sh` (this run took {summary["seconds"]:.0f} s) or, '
             "for a few seconds' check, `./tools/bench.sh --quick --out DIR`."
             + (' **Quick mode: small sweeps.**' if quick else ''),
             '', '## Cost of one step', '', '| method | body | us per step |',
             '| --- | --- | ---: |']
    for r in summary['step_cost']:
        lines.append(f'| {r["method"]} | {r["body"]} | {r["us_per_step"]:.2f} |')
    lines += ['', 'rb_sim_ros is pure Python (about 270 float operations a step); MuJoCo is C.',
              '', '## Work-precision', '',
              'Error: orientation angle (rad) of R at the final time against the reference. '
              'Time: wall seconds per simulated second (minimum of several runs). Every method '
              'was first checked to converge at its order (fitted slope below).', '']
    for name, result in summary['work_precision'].items():
        img = f'img/work_precision_{name.replace(" ", "_").replace(".", "")}.png'
        lines += [f'### {name}', '', f'![{name}]({img})', '',
                  '| method | order (fitted) | finest dt or rtol | error (rad) | '
                  'max error over run | s per sim s |',
                  '| --- | ---: | ---: | ---: | ---: | ---: |']
        for method, data in result.items():
            p = data['points'][-1]
            step = p.get('dt', p.get('rtol'))
            order = f'{data["order"]:.2f}' if data['order'] is not None else '-'
            lines.append(f'| {method} | {order} | {step:.3g} | {p["angle_final"]:.2e} | '
                         f'{p["angle_max"]:.2e} | {p["seconds_per_sim_second"]:.2e} |')
        cheap = wp.cheapest_at(result, 1e-6)
        best = sorted((v, k) for k, v in cheap.items() if v < float('inf'))
        if best:
            lines += ['', 'Cheapest to reach 1e-6 rad: ' + ', '.join(
                f'{k} {v:.2e} s' for v, k in best[:4]) + '.']
        lines.append('')
    s = summary['stress']
    d = s['dzhanibekov']
    lines += ['## Stress', '', '### Dzhanibekov flip (dt = 1 ms)', '',
              f'Period of the body-frame motion: measured {d["measured_period_s"]:.6f} s, '
              f'elliptic oracle 4K(k)/rate {d["expected_period_s"]:.6f} s, relative error '
              f'{d["relative_error"]:.1e}.', '', '### Extreme inertia (dt = 1 ms, torque-free)',
              '', '| case | method | energy drift | momentum drift | finite |',
              '| --- | --- | ---: | ---: | --- |']
    for row in s['extreme_inertia']:
        for method, v in row.items():
            if isinstance(v, dict):
                lines.append(f'| {row["case"]} | {method} | {v["energy_drift"]:.2e} | '
                             f'{v["momentum_drift"]:.2e} | {v["finite"]} |')
    lines += ['', '### Fast spin: worst orientation error over 100 steps against omega*dt', '']
    methods = [k for k in s['fast_spin'][0] if k != 'omega_dt']
    lines += ['| omega dt | ' + ' | '.join(methods) + ' |',
              '| ---: |' + ' ---: |' * len(methods)]
    for row in s['fast_spin']:
        lines.append(f'| {row["omega_dt"]} | ' + ' | '.join(f'{row[m]:.1e}' for m in methods)
                     + ' |')
    lines.append('')
    for m in methods:
        ok = [row['omega_dt'] for row in s['fast_spin'] if row[m] < 1e-2]
        lines.append(f'- {m}: stays within 1e-2 rad up to omega*dt = {max(ok) if ok else "-"}')
    lines += ['', 'Past that the orientation is lost (errors of order pi) but the state stays '
              'finite: none of these methods blows up on a torque-free spin. MuJoCo warns that '
              'the simulation is unstable at the largest steps of the stress cases and resets.']
    lr = s['long_run']
    lines += ['', f'### Long run: {lr["steps"]:.0e} steps torque-free (eq27, dt = 1 ms)', '',
              '![long run](img/long_run.png)', '',
              f'Final relative energy drift {lr["energy_drift"][-1]:.2e}, angular momentum drift '
              f'{lr["momentum_drift"][-1]:.2e}; worst orthonormality error of R '
              f'{lr["max_orthonormality_error"]:.1e}.', '']
    b = s['blow_up']
    lines += ['### Blow-up', '', f'A state that overflows raises `IntegrationError` at step '
              f'{b.get("step")} and leaves the last finite state (finite: '
              f'{b.get("state_finite")}): "{b.get("message", "")[:100]}..."', '']
    text = '\n'.join(lines)
    (out / 'benchmarks.md').write_text(text)
    return text


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='a few seconds, small sweeps')
    parser.add_argument('--out', default=str(HERE.parent / 'docs'), help='report folder')
    opts = parser.parse_args()
    out = Path(opts.out)
    (out / 'img').mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    summary = {'date': time.strftime('%Y-%m-%d'), 'machine': machine(), 'quick': opts.quick}
    summary['step_cost'] = step_cost(opts.quick)
    results = {}
    with tqdm(total=wp.count(opts.quick), desc='work-precision', file=sys.stderr) as bar:
        for scene in sc.scenes(opts.quick):
            try:
                results[scene.name] = wp.sweep(scene, opts.quick, bar)
            except wp.OrderError as e:
                print(f'order check failed: {e}', file=sys.stderr)
                return 1
            wp.plot(scene.name, results[scene.name], out / 'img' / (
                'work_precision_' + scene.name.replace(' ', '_').replace('.', '') + '.png'))
    summary['work_precision'] = results
    with tqdm(total=200, desc='long run', file=sys.stderr) as bar:
        long_run = stress.long_run(opts.quick, bar)
    stress.plot_long_run(long_run, out / 'img' / 'long_run.png')
    summary['stress'] = {'dzhanibekov': stress.dzhanibekov(opts.quick),
                         'extreme_inertia': stress.extreme_inertia(opts.quick),
                         'fast_spin': stress.fast_spin(opts.quick), 'long_run': long_run,
                         'blow_up': stress.blow_up()}
    summary['seconds'] = time.monotonic() - t0
    summary['orders_checked'] = True
    (out / 'summary.json').write_text(json.dumps(summary, indent=1, default=float))
    report(out, summary, opts.quick)
    print(f'wrote {out / "benchmarks.md"} in {summary["seconds"]:.0f} s', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
