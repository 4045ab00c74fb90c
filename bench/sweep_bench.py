# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Sweep throughput: runs per second with 1 and 2 local workers and on a local Ray, one run.

    python -m bench.sweep_bench [--runs 24] [--steps 1000] [--quick]

Each run is the collision demo (scenes/collisions.yaml, 8 bodies, gravity, contacts) for
``--steps`` steps of 1 ms with the ball's height varied, recorded as the node records it. The
engines are started and warmed (a first small sweep: worker start, imports, loading the
compiled kernels) before timing, so the figure is the sweep's own throughput; the start cost
is printed beside it. The runs are the same for every engine (checked: every row's final ball
height equal). Prints runs/s, the 2-worker scaling and the per-run cost it implies for a
million runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import tempfile
import time


from bench import figures
from rb_sim_ros.offline import sweep

ROOT = Path(__file__).resolve().parents[1]
SCENE = str(ROOT / 'scenes' / 'collisions.yaml')


def timed(engine, runs: int, steps: int, out: str):
    varies = [('bodies.ball.position.2', ('values', [1.0 + 0.05 * k for k in range(runs)]))]
    t0, c0 = time.perf_counter(), time.process_time()
    rows = sweep.sweep(SCENE, varies, 1, steps, out, engine=engine, progress=False)
    seconds = time.perf_counter() - t0
    timed.driver_cpu = time.process_time() - c0
    assert not any(r.get('error') for r in rows), [r['error'] for r in rows if r.get('error')]
    timed.cpu = sum(float(r['cpu_s']) for r in rows)
    timed.wall = sum(float(r['wall_s']) for r in rows)
    return seconds, [r['ball.z'] for r in rows]


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.sweep_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--runs', type=int, default=24)
    parser.add_argument('--steps', type=int, default=1000)
    parser.add_argument('--quick', action='store_true', help='8 runs of 200 steps')
    parser.add_argument('--no-ray', action='store_true')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/sweep_bench.json; --quick: none)')
    opts = parser.parse_args()
    runs, steps = (8, 200) if opts.quick else (opts.runs, opts.steps)
    print(f'sweep of the collision demo: {runs} runs of {steps} steps (dt 1 ms), recorded')
    results = {}
    engines = [('local, 1 worker', lambda: sweep.LocalEngine(1)),
               ('local, 2 workers', lambda: sweep.LocalEngine(2))]
    if not opts.no_ray:
        engines.append(('ray (local), 2 CPUs', lambda: sweep.RayEngine('local', 2)))
    with tempfile.TemporaryDirectory() as d:
        for label, make in engines:
            t0 = time.perf_counter()
            engine = make()
            try:
                timed(engine, 2, 10, f'{d}/warm')  # workers up, kernels loaded
                start = time.perf_counter() - t0
                seconds, heights = timed(engine, runs, steps, f'{d}/{label[:5]}{len(results)}')
            finally:
                engine.close()
            results[label] = (seconds, heights, timed.cpu / runs, start)
            print(f'  {label:<22} {runs / seconds:7.2f} runs/s  ({seconds / runs * 1e3:7.1f} ms '
                  f'a run; starting and warming the engine took {start:.1f} s; the driver '
                  f'used {timed.driver_cpu / seconds:.0%} of a core; a run used '
                  f'{timed.cpu / timed.wall:.2f} cores while it ran)')
    heights = [r[1] for r in results.values()]
    if any(h != heights[0] for h in heights):
        print('the engines disagree on the runs')
        return 1
    one, two = results['local, 1 worker'][0], results['local, 2 workers'][0]
    print(f'  scaling from 1 to 2 local workers: {one / two:.2f}x (goal >= 1.8x)')
    per_run = two / runs * 2  # CPU-seconds a run
    print(f'  a million such runs: {per_run * 1e6 / 3600:.0f} CPU-hours '
          f'({per_run * 1e6 / 3600 / 100:.1f} h on 100 cores as fast as these)')
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'sweep_bench.json')
    if path is not None:
        figures.write(path, {'quick': opts.quick, 'runs': runs, 'steps': steps, 'engines': [
            {'engine': label, 'seconds': r[0], 'runs_per_s': runs / r[0],
             'cpu_s_per_run': r[2], 'start_s': r[3]} for label, r in results.items()]})
        print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
