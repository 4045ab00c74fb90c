# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Monte Carlo campaign throughput: closed-loop runs a second in-process with 1 and 2 local
workers (and on a local Ray), over DDS with 2 workers, and a campaign of 10,000 runs.

    python -m bench.campaign_bench [--runs 100] [--dds-runs 10] [--big 10000] [--quick]

Each run is examples/attitude_controller.py in lockstep with one body for 10 s of sim time
(dt 1 ms, a state and an answer every 10 ms: 1,001 periods), recorded as a campaign records
by default (odom every period and each wrench input: record_outputs [odom], publish_tf
false), with its inertia, initial twist and the IMU seed dispersed, and its metrics computed
(offline/campaign). The engines are started and warmed (a first small campaign: workers up,
kernels loaded) before timing; the start is printed beside. The 1- and 2-worker campaigns
run in alternate rounds (``--rounds``, default 3) and the best of each is the figure: this
machine's speed drifts over minutes, and two figures minutes apart would put the drift in
their ratio. In-process, the controller is called through the lockstep helper; over DDS
(``--dds``) every run is two processes, the simulator node and the controller node, as a
user runs them. The rows are the same whatever the engine (checked: every metric of every
run, and the DDS runs' against the in-process ones).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path
import sys
import tempfile
import time

from bench import figures
from rb_sim_ros.offline import campaign, sweep

ROOT = Path(__file__).resolve().parents[1]
CONTROLLER = str(ROOT / 'examples' / 'attitude_controller.py')
METRICS = ('initial_error_rad', 'final_error_rad', 'settling_s', 'overshoot', 'peak_torque',
           'rms_torque')


def spec(runs: int, stop_after: float, dds: bool = False) -> dict:
    return {'controller': CONTROLLER,
            'controller_params': {'target_rpy': [0.3, -0.2, 1.2], 'inertia': [0.2, 0.2, 0.3],
                                  'source': 'imu'},
            'params': {'inertia': [0.2, 0.2, 0.3], 'imu_gyro_noise': 0.001},
            'vary': [['inertia.0', 'uniform(0.18, 0.22)'],
                     ['initial_angular_velocity.2', 'normal(0, 0.1)']],
            'seeds': runs, 'stop_after': stop_after, 'scene': '', 'body': '', 'metrics': [],
            'dds': dds}


def timed(engine, runs: int, stop_after: float, out: str, dds: bool = False):
    """(seconds, the rows' metrics, CPU seconds a run in the workers)."""
    t0 = time.perf_counter()
    rows = campaign.campaign(spec(runs, stop_after, dds), out, engine, progress=False)
    seconds = time.perf_counter() - t0
    bad = [r['error'] for r in rows if r.get('error')]
    assert not bad, bad[:3]
    with open(Path(out) / 'summary.csv') as f:
        read = list(csv.DictReader(f))
    metrics = [tuple(r[m] for m in METRICS) for r in read]
    return seconds, metrics, sum(float(r['cpu_s']) for r in read) / runs


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.campaign_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--runs', type=int, default=100)
    parser.add_argument('--dds-runs', type=int, default=10)
    parser.add_argument('--big', type=int, default=0, metavar='RUNS',
                        help='also a campaign of this many runs on 2 workers (e.g. 10000)')
    parser.add_argument('--stop-after', type=float, default=10.0)
    parser.add_argument('--quick', action='store_true', help='6 runs of 1 s, 2 over DDS')
    parser.add_argument('--no-ray', action='store_true')
    parser.add_argument('--rounds', type=int, default=3,
                        help='rounds of the 1- and 2-worker campaigns, alternated; the best '
                        'of each is the figure (default 3; --quick: 1)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/campaign_bench.json; --quick: none)')
    opts = parser.parse_args()
    runs, dds_runs, stop = (6, 2, 1.0) if opts.quick else \
        (opts.runs, opts.dds_runs, opts.stop_after)
    print(f'campaign of the attitude controller: runs of {stop:g} s (1 ms steps, 100 Hz), '
          'recorded, metrics computed')
    rounds = 1 if opts.quick else max(1, opts.rounds)
    results: dict = {}

    def record(label, n, seconds, metrics, cpu, start, each=None):
        results[label] = {'runs': n, 'seconds': seconds, 'runs_per_s': n / seconds,
                          'cpu_s_per_run': cpu, 'start_s': start, 'metrics': metrics}
        if each:
            results[label]['rounds_runs_per_s'] = each
        used = '' if label.startswith('over DDS') else \
            f'{cpu * 1e3:.0f} ms of CPU a run in the worker; '
        best = f'; best of {len(each)} rounds: {", ".join(f"{r:.2f}" for r in each)}' \
            if each and len(each) > 1 else ''
        print(f'  {label:<32} {n / seconds:7.2f} runs/s  ({seconds / n * 1e3:7.1f} ms a '
              f'run; {used}starting and warming the engine took {start:.1f} s{best})',
              flush=True)

    with tempfile.TemporaryDirectory() as d:
        # 1 and 2 local workers in alternate rounds (this machine's speed drifts over
        # minutes: a ratio of two measurements minutes apart would measure the drift)
        local = {}
        for label, workers in (('in-process, 1 worker', 1), ('in-process, 2 workers', 2)):
            t0 = time.perf_counter()
            engine = sweep.LocalEngine(workers)
            timed(engine, 2 * workers, min(stop, 0.1), f'{d}/warm{workers}')
            local[label] = (engine, time.perf_counter() - t0, [])
        try:
            for k in range(rounds):
                for label, (engine, _, done) in local.items():
                    done.append(timed(engine, runs, stop, f'{d}/round{k}_{engine.workers}'))
        finally:
            for engine, _, _ in local.values():
                engine.close()
        for label, (_, start, done) in local.items():
            seconds, metrics, cpu = min(done, key=lambda r: r[0])
            record(label, runs, seconds, metrics, cpu, start, [runs / r[0] for r in done])
        others = [] if opts.no_ray else [('in-process, Ray (local) 2 CPUs', False, 'local')]
        others.append(('over DDS, 2 workers', True, None))
        for k, (label, dds, ray) in enumerate(others):
            t0 = time.perf_counter()
            engine = sweep.make_engine(ray, 2)
            n = dds_runs if dds else runs
            try:
                timed(engine, 4, min(stop, 0.1), f'{d}/warm_other{k}', dds)
                start = time.perf_counter() - t0
                seconds, metrics, cpu = timed(engine, n, stop, f'{d}/other{k}', dds)
            finally:
                engine.close()
            record(label, n, seconds, metrics, cpu, start)
        first = results['in-process, 1 worker']['metrics']
        for label, r in results.items():
            if r['metrics'] != first[:len(r['metrics'])]:
                print(f'{label} disagrees with in-process, 1 worker on the runs')
                return 1
        print('  every engine gives the same rows (the DDS runs too)')
        big = None
        if opts.big:
            engine = sweep.LocalEngine(2)
            try:
                timed(engine, 4, 0.1, f'{d}/warm_big')
                seconds, _, cpu = timed(engine, opts.big, stop, f'{d}/big')
            finally:
                engine.close()
            big = {'runs': opts.big, 'seconds': seconds, 'cpu_s_per_run': cpu}
            print(f'  {opts.big:,} runs on 2 workers: {seconds / 60:.1f} min '
                  f'({opts.big / seconds:.2f} runs/s)')
    one, two = results['in-process, 1 worker'], results['in-process, 2 workers']
    dds = results['over DDS, 2 workers']
    scaling = two['runs_per_s'] / one['runs_per_s']
    print(f'  2 workers against 1: {scaling:.2f}x (goal >= 1.8x)')
    print(f'  in-process against over DDS (2 workers each): '
          f"{two['runs_per_s'] / dds['runs_per_s']:.0f}x")
    hours = one['cpu_s_per_run'] * 1e6 / 3600
    print(f"  a million runs: {hours:.0f} core-hours in-process (a worker's CPU a run)")
    for r in results.values():
        del r['metrics']
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'campaign_bench.json')
    if path is not None:
        figures.write(path, {'quick': opts.quick, 'stop_after': stop, 'engines': [
            {'engine': label, **r} for label, r in results.items()], 'big': big})
        print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
