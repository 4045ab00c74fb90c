# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""How the node starts and stops: start-up time and memory against scene size, and a loop of
SIGINT/SIGTERM at full speed with recordings that must verify.

    python -m bench.node_lifecycle [--bodies 1000 10000] [--runs 20] [--quick]

Start-up: the simulator as users run it (a separate process, a private ROS domain), on a scene of
N free bodies; the time from starting the process to the first 'poses' message this process
receives, and the node's peak memory (VmHWM). First, the collision demo's start with an empty
compilation cache, twice: with compile_in_background:=false (every kernel compiles before the
first step), and as by default (the node steps in the interpreter while a child process
compiles: the first poses of a step, the time until compiled, the interpreted speed); then with
the cache that wrote (every later start), then the package installed as colcon build installs
it (setup.py install, which compiles the kernels into the installed tree: its time) and starts
from there: each the median of 3, with the time the node's log says it is stepping (what a
subscriber waits beyond that is DDS discovery). Stop: `--runs` times, a node at real_time_factor 0
recording, `send_wrench` run against it, then SIGINT or SIGTERM (alternating); each must exit 0
without a traceback or FATAL, within 2 s of the signal, and its recording must pass `replay
--verify`. Prints the figures and writes them to docs/bench/node_lifecycle.json (a full run);
exit 1 if a stop failed. ``--quick`` (200 bodies, 2 stops, run by the tests) checks the same but
not the 2 s (the suite runs on loaded machines) and not the first start (it compiles for
minutes).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import random
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped

from bench import figures
from bench.node_timing import Probe


ROOT = Path(__file__).resolve().parents[1]
SITE = Path('lib') / f'python{sys.version_info[0]}.{sys.version_info[1]}' / 'site-packages'


def _env(domain: int) -> dict:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               PYTHONUNBUFFERED='1')
    env.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    return env


def _vm_hwm_mb(pid: int) -> float:
    with open(f'/proc/{pid}/status') as f:
        for line in f:
            if line.startswith('VmHWM:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


def install(prefix: Path) -> float:
    """Install the package into ``prefix`` as colcon build does (setup.py install, which
    compiles the kernels into the installed tree's cache): the seconds it took."""
    build = prefix.parent / 'build'
    build.mkdir(parents=True, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    t0 = time.monotonic()
    subprocess.run([sys.executable, 'setup.py', '-q', 'egg_info', '--egg-base', str(build),
                    'build', '--build-base', str(build), 'install', '--prefix', str(prefix),
                    '--record', str(build / 'install.log'),
                    '--single-version-externally-managed'],
                   cwd=ROOT, env=env, check=True, capture_output=True)
    return time.monotonic() - t0


# The node's log line at the end of its start (ROS's default console format: wall time).
READY = re.compile(r'\[INFO\] \[(\d+\.\d+)\] \[rb_sim\]: simulating')


def startup(n: int, tmp: Path, scene: Path | None = None, cache: Path | None = None,
            installed: Path | None = None) -> tuple[float, float, float]:
    """Seconds to the first poses at a subscriber, peak memory (MB), and seconds to the end of
    the node's start (its log says so; it steps from there, and a subscriber's wait beyond it
    is DDS discovery) of a node on ``n`` free bodies, or on
    ``scene`` (n: its body count); ``cache``: the kernels' compilation cache to use, or
    ``installed``: the prefix of an install (``install``) to run the node from, with its own
    cache; with either, the poses waited for are the first of a step taken (sim time > 0: the
    node publishes the starting poses before its first step, which compiles what it needs)."""
    if scene is None:
        scene = tmp / f'bodies_{n}.yaml'
        scene.write_text('bodies:\n' + ''.join(
            f'  - {{name: b{i}, mass: 1.0, inertia: [0.1, 0.1, 0.1], position: [{i}, 0, 0], '
            f'linear_velocity: [0, 0, 1]}}\n' for i in range(n)))
    domain = random.randint(1, 100)
    probe = Probe(domain)
    got: list = []
    probe.node.create_subscription(PoseArray, 'poses', got.append, 10)
    t0, wall0 = time.monotonic(), time.time()
    env = _env(domain)
    if cache:
        env['NUMBA_CACHE_DIR'] = str(cache)
    if installed:
        env.pop('NUMBA_CACHE_DIR', None)
        env['PYTHONPATH'] = os.pathsep.join(
            [str(installed / SITE)] + [p for p in [env.get('PYTHONPATH')] if p])
    proc = subprocess.Popen([sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args',
                             '-p', f'scene_file:={scene}'], env=env, cwd=tmp,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    log: list = []
    reader = threading.Thread(target=lambda: log.extend(proc.stderr), daemon=True)
    reader.start()

    def ready():
        return next((m for m in map(READY.search, list(log)) if m), None)
    try:
        def stepped(m):
            return (cache is None and installed is None) or m.header.stamp.sec > 0 \
                or m.header.stamp.nanosec > 0
        if not probe.spin_until(lambda: any(stepped(m) for m in got) or proc.poll() is not None,
                                600.0) or not got:
            raise RuntimeError(f'{n} bodies: no poses ({proc.poll()})')
        seconds = time.monotonic() - t0
        memory = _vm_hwm_mb(proc.pid)
        assert len(got[0].poses) == n
        # (its log line may come after the first poses: the step loop starts just before it)
        probe.spin_until(lambda: ready() or proc.poll() is not None, 60.0)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
        reader.join(10)
        probe.close()
    line = ready()
    if line is None:
        raise RuntimeError(f'{n} bodies: the node never said it was simulating')
    return seconds, memory, float(line.group(1)) - wall0


def _median_of_3(*args, **kwargs) -> dict:
    """``startup`` three times: the medians and every run."""
    runs = [startup(*args, **kwargs) for _ in range(3)]
    poses, ready = sorted(r[0] for r in runs), sorted(r[2] for r in runs)
    return {'first_poses_s': poses[1], 'ready_s': ready[1], 'runs': runs}


EARLY_S = 5.0


def first_start(tmp: Path, scene: Path, cache: Path, background: bool) -> dict:
    """A first start of the node on ``scene`` with an empty compilation cache ``cache``.
    ``background`` (compile_in_background): the seconds to the first poses of a step taken
    (sim time > 0), stepped in the interpreter, and to the kernels compiled (its /diagnostics
    says so), and the sim time over wall time in between (and in the first EARLY_S s of
    it); without, the seconds to the first poses of a step (compiled before it)."""
    domain = random.randint(1, 100)
    probe = Probe(domain)
    arrivals: list = []
    probe.node.create_subscription(PoseArray, 'poses', lambda m: arrivals.append(
        ('pose', time.monotonic(), m.header.stamp.sec + m.header.stamp.nanosec * 1e-9)), 10)
    probe.node.create_subscription(DiagnosticArray, '/diagnostics', lambda m: arrivals.append(
        ('kernels', time.monotonic(),
         {v.key: v.value for s in m.status for v in s.values}.get('kernels'))), 10)
    env = dict(_env(domain), NUMBA_CACHE_DIR=str(cache))
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args',
                             '-p', f'scene_file:={scene}',
                             '-p', f'compile_in_background:={str(background).lower()}'],
                            env=env, cwd=tmp, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)

    def moving():
        return [a for a in arrivals if a[0] == 'pose' and a[2] > 0]

    def compiled():
        return [a for a in arrivals if a[0] == 'kernels' and a[2] == 'compiled']
    try:
        if not probe.spin_until(lambda: (moving() and (compiled() or not background))
                                or proc.poll() is not None, 900.0):
            raise RuntimeError(f'first start: no poses or no compiled kernels ({proc.poll()})')
        first = moving()[0]
        out = {'first_poses_s': first[1] - t0}
        if background:
            done = compiled()[0]
            out['compiled_s'] = done[1] - t0
            # Poses before the switch (/diagnostics says it within a second of it): while
            # the demo's bodies fall and hit (the first EARLY_S s), and over the whole
            # compilation (they settle, and sleeping bodies cost little).
            interpreted = [a for a in moving() if a[1] < done[1] - 1.0]
            if not interpreted or interpreted[-1][1] < first[1] + EARLY_S:
                raise RuntimeError('first start: compiled before the interpreted speed could '
                                   'be measured')
            early = [a for a in interpreted if a[1] <= first[1] + EARLY_S][-1]
            out['interpreted_early_sim_over_wall'] = (early[2] - first[2]) / (early[1] - first[1])
            last = interpreted[-1]
            out['interpreted_sim_over_wall'] = (last[2] - first[2]) / (last[1] - first[1])
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
        probe.close()
    return out


def stop_loop(runs: int, tmp: Path, timed: bool = True) -> tuple[list[str], list[float]]:
    failures = []
    exit_times = []
    for k in range(runs):
        domain = random.randint(1, 100)
        out = tmp / f'run{k}.mcap'
        probe = Probe(domain)
        poses: list = []
        probe.node.create_subscription(PoseStamped, 'pose', poses.append, 10)
        proc = subprocess.Popen([sys.executable, '-m', 'rb_sim_ros.ros.simulator_node',
                                 '--ros-args', '-p', 'real_time_factor:=0.0',
                                 '-p', f'record:={out}'], env=_env(domain),
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        probe.spin_until(lambda: len(poses) > 20, 120.0)
        subprocess.run([sys.executable, '-m', 'rb_sim_ros.ros.send_wrench', '--force', '1', '0',
                        '0', '--torque', '0', '0', '0.1', '--duration', '0.3'],
                       env=_env(domain), capture_output=True, timeout=120)
        probe.close()
        sig = signal.SIGINT if k % 2 == 0 else signal.SIGTERM
        t0 = time.monotonic()
        proc.send_signal(sig)
        try:
            code = proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = 'hung'
        seconds = time.monotonic() - t0
        exit_times.append(seconds)
        log = proc.stdout.read()
        verify = subprocess.run([sys.executable, '-m', 'rb_sim_ros.offline.replay', '--verify',
                                 str(out)], env=_env(domain), capture_output=True, text=True)
        bad = [what for what, ok in (('exit code', code == 0),
                                     ('time', seconds <= 2.0 or not timed),
                                     ('traceback', 'Traceback' not in log),
                                     ('FATAL', 'FATAL' not in log),
                                     ('verify', verify.returncode == 0)) if not ok]
        print(f'  run {k + 1:2d} {sig.name}: exit {code} after {seconds:.2f} s, '
              f'verify {verify.returncode}{"  FAILED: " + ", ".join(bad) if bad else ""}',
              flush=True)
        if bad:
            failures.append(f'run {k + 1}: {", ".join(bad)}')
    exit_times.sort()
    print(f'stop: {runs - len(failures)} of {runs} clean; exit after the signal: median '
          f'{exit_times[len(exit_times) // 2]:.2f} s, worst {exit_times[-1]:.2f} s')
    return failures, exit_times


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.node_lifecycle', description=__doc__.split('\n\n')[0])
    parser.add_argument('--bodies', type=int, nargs='*', default=[1000, 10000])
    parser.add_argument('--runs', type=int, default=20)
    parser.add_argument('--quick', action='store_true',
                        help='200 bodies and 2 stops, no time limit, nothing written')
    args = parser.parse_args()
    if args.quick:
        args.bodies, args.runs = [200], 2
    starts, compiling = [], {}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        # A clean install: the collision demo (every kernel of a collision world) with an
        # empty compilation cache, then again with the cache that start wrote.
        demo = ROOT / 'scenes' / 'collisions.yaml'
        if not args.quick:
            # Compiled before the first step (compile_in_background:=false), then stepped in
            # the interpreter while a child compiles (the default), each on an empty cache.
            compiling['cold'] = first_start(tmp, demo, tmp / 'cache-0', False)['first_poses_s']
            print(f'start-up, collision demo, empty cache, compile_in_background:=false: first '
                  f'poses of a step after {compiling["cold"]:.1f} s', flush=True)
            tiers = first_start(tmp, demo, tmp / 'numba-cache', True)
            compiling['cold_background'] = tiers
            print(f'start-up, collision demo, empty cache (default): first poses of a step after '
                  f'{tiers["first_poses_s"]:.1f} s, stepped in the interpreter at '
                  f'{tiers["interpreted_early_sim_over_wall"]:.2f}x real time in its first '
                  f'{EARLY_S:.0f} s ({tiers["interpreted_sim_over_wall"]:.2f}x until compiled); '
                  f'compiled after {tiers["compiled_s"]:.1f} s', flush=True)
            warm = _median_of_3(8, tmp, demo, tmp / 'numba-cache')
            compiling['warm'], compiling['warm_runs'] = warm['first_poses_s'], warm
            print(f'start-up, collision demo, the cache that start wrote (median of 3): first '
                  f'poses of a step at a subscriber after {warm["first_poses_s"]:.1f} s; the node '
                  f'stepping after {warm["ready_s"]:.1f} s', flush=True)
        # A colcon-style install compiles the kernels into its tree: the install's time, and
        # the first start of the node from it.
        if not args.quick:
            install_s = install(tmp / 'install')
            print(f'install as colcon build does (kernels compiled): {install_s:.1f} s',
                  flush=True)
            after = _median_of_3(8, tmp, demo, installed=tmp / 'install')
            compiling['installed'], compiling['installed_runs'] = after['first_poses_s'], after
            compiling['install_s'] = install_s
            print(f'start-up, collision demo, starts after that install (median of 3): first '
                  f'poses of a step at a subscriber after {after["first_poses_s"]:.1f} s; the '
                  f'node stepping after {after["ready_s"]:.1f} s', flush=True)
        # The cache the other starts and the stops use (the source tree's): compiled now
        # (what a first start from it does in the background), so that they load it.
        subprocess.run([sys.executable, '-m', 'rb_sim_ros.sim.precompile'], check=True,
                       stdout=subprocess.DEVNULL)
        for n in args.bodies:
            seconds, memory, _ = startup(n, tmp)
            starts.append({'bodies': n, 'first_poses_s': seconds, 'peak_memory_mb': memory})
            print(f'start-up, {n} bodies: first poses after {seconds:.2f} s, peak memory '
                  f'{memory:.0f} MB', flush=True)
        failures, exits = stop_loop(args.runs, tmp, timed=not args.quick) if args.runs \
            else ([], [])
    if not args.quick and not failures and args.runs:
        figures.write(figures.DOCS_BENCH / 'node_lifecycle.json', {
            'quick': False, 'startup': starts, 'first_start_s': compiling,
            'stop_runs': args.runs,
            'stop_clean': args.runs - len(failures), 'stop_exit_s': exits})
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
