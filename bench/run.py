# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Regenerate the benchmark report: run time against error, and numerical stress.

    python -m bench.run                          # docs/benchmarks.md and docs/img/*.png
    python -m bench.run --quick --out /tmp/b     # a few seconds' check that nothing rotted

Work-precision: rb_sim_ros's methods, MuJoCo (Euler, implicitfast, RK4; one free body) and
scipy's DOP853 on four scenes with references (elliptic oracle, closed-form top, DOP853 at
1e-13). The references are checked against each other and every fixed-step method must
converge at its order before anything is timed; if one does not, the run stops with exit
status 1 (the summary says which). Stress: Dzhanibekov flip period, extreme inertia (with
mujoco#3553), fast spin, a long run, a blow-up. Also the cost of one step (bench/step_cost.py).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import platform
import sys
import time

import mujoco
import numpy as np
import scipy
from tqdm import tqdm

from bench import figures, peers, report, step_cost, stress, work_precision as wp

HERE = Path(__file__).resolve().parent


def machine() -> dict:
    """CPU model (from /proc/cpuinfo), core count, OS and the versions that matter."""
    cpu = platform.processor() or 'unknown CPU'
    try:
        for line in Path('/proc/cpuinfo').read_text().splitlines():
            if line.startswith('model name'):
                cpu = line.split(':', 1)[1].strip()
                break
    except OSError:
        pass
    return {'cpu': cpu, 'cores': os.cpu_count(), 'os': platform.platform(),
            'python': platform.python_version(), 'numpy': np.__version__,
            'scipy': scipy.__version__, 'mujoco': mujoco.__version__}


def _bar(total: int, desc: str):
    return tqdm(total=total, desc=f'{desc:15s}', file=sys.stderr, leave=True, dynamic_ncols=True)


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.run', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='short scenes, small sweeps, few repeats (a few seconds); the '
                             'orders are still checked')
    parser.add_argument('--out', default=None,
                        help='folder for benchmarks.md and img/*.png (default: docs/)')
    parser.add_argument('--json', default=None,
                        help='where to write the summary (default: docs/bench/run.json, the '
                             'figures docs/benchmarks.md shows, or OUT/summary.json when --out '
                             'is given)')
    opts = parser.parse_args(argv)
    out = HERE.parent / 'docs' if opts.out is None else Path(opts.out)
    json_path = Path(opts.json) if opts.json else (
        HERE.parent / 'docs' / 'bench' / 'run.json' if opts.out is None
        else out / 'summary.json')
    (out / 'img').mkdir(parents=True, exist_ok=True)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    quick = opts.quick
    t0 = time.monotonic()
    summary = {'command': figures.command(), 'date': time.strftime('%Y-%m-%d'),
               'machine': machine(), 'quick': quick,
               'steps_n': list(wp.QUICK_STEPS if quick else wp.FULL_STEPS),
               'rtols': list(wp.rtols(quick)), 'repeats': 2 if quick else 5,
               'orders_checked': False}

    def save():
        summary['seconds'] = time.monotonic() - t0
        json_path.write_text(json.dumps(summary, indent=1, default=_json_default))

    # 1. Correctness first: references, then every method's order. Nothing is timed yet.
    with _bar(wp.count(quick), 'accuracy') as bar:
        try:
            results = wp.accuracy(quick, bar)
        except wp.OrderError as e:
            summary['failures'] = [str(e)]
            save()
            print(f'FAILED: {e}', file=sys.stderr)
            return 1
    failures = wp.check_orders(results)
    summary['work_precision'] = results
    if failures:
        summary['failures'] = failures
        save()
        print('FAILED: not at their order, so nothing was timed:\n  ' + '\n  '.join(failures),
              file=sys.stderr)
        return 1
    summary['orders_checked'] = True
    summary['step_cost_check'] = step_cost.check()

    # 2. Timing.
    summary['step_cost_steps'] = 20_000 if quick else 100_000
    with _bar(step_cost.count(), 'step cost') as bar:
        summary['step_cost'] = step_cost.measure(summary['step_cost_steps'],
                                                 summary['repeats'], bar)
    with _bar(wp.count(quick), 'timing') as bar:
        wp.timing(results, quick, bar)
    for name, scene in results.items():
        wp.plot(name, scene, out / report.image(scene['scene']['key']))

    # 3. Stress.
    st = summary['stress'] = {'blow_up': stress.blow_up()}
    with _bar(len(stress.dzhanibekov_runs(quick)), 'Dzhanibekov') as bar:
        st['dzhanibekov'] = stress.dzhanibekov(quick, bar)
    with _bar(stress.extreme_count(quick), 'extreme inertia') as bar:
        st['extreme_inertia'] = stress.extreme_inertia(quick, bar)
    n_runners = len(peers.steppers())
    spins = stress.QUICK_SPINS if quick else stress.FULL_SPINS
    with _bar(len(spins) * n_runners, 'fast spin') as bar:
        st['fast_spin'] = stress.fast_spin(quick, bar)
    stress.plot_fast_spin(st['fast_spin'], out / 'img' / 'fast_spin.png')
    with _bar(n_runners * stress.long_run_steps(quick), 'long run') as bar:
        st['long_run'] = stress.long_run(quick, bar)
    stress.plot_long_run(st['long_run'], out / 'img' / 'long_run.png')

    save()
    path = report.write(out, summary)
    print(report.console(summary))
    print(f'wrote {path} and {json_path} in {summary["seconds"]:.0f} s', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
