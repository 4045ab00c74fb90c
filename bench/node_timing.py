# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node's timing: late ticks, tick jitter, CPU, wrench-to-pose latency, fastest RTF.

    python -m bench.node_timing [--quick] [--seconds 10] [--json out.json]

Starts the simulator as a separate process (as users run it) on a private ROS domain, and a
probe node in this process. For publish rates of 100 Hz and 1 kHz at dt = 1 ms and real time:
late-tick fraction and p50/p99 tick lateness from the node's /diagnostics, the node's CPU per
core from /proc, and the latency from publishing a wrench to receiving the first pose that
includes it (p50/p99). Then the fastest real-time factor (real_time_factor 0, median of the
node's per-second sim/wall ratios) at dt = 1 ms and 100 Hz output, for a moving body (a full,
non-diagonal inertia tensor, spinning at (1, 2, 3) rad/s and moving at 1 m/s: the whole step
runs), with no subscriber and with one that takes every pose, and for the default body at
rest (which the stepper does not integrate at all: for scale only). Last, second by second,
a scene (``--scene``, default the collision demo, whose bodies settle and sleep), and the same
scene with sleeping off (every body integrated and every contact solved at every step: the
cost while things move).

Checks: the last pose the subscriber received of the moving body agrees (1e-9) with a
``Stepper`` stepped offline to its stamp; every figure is finite and plausible (fractions in
[0, 1], latencies 0.01 ms to 1 s, CPU up to 2 cores, real-time factors 1x to 1e5x). Exit 1 if
one fails. ``--quick`` (about 15 s): 2 s per measurement, 1 kHz only, 10 latency samples, the
moving body with a subscriber only, no scene. Writes docs/bench/node_timing.json (or
``--json``; --quick: none unless asked). Figures are this machine's, measured now.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import random
import signal
import subprocess
import sys
import tempfile
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Wrench, WrenchStamped
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
import yaml

from bench import figures
from rb_sim_ros import RigidBody, State, Stepper
from rb_sim_ros.ros.body_ports import APPLIED_QOS

CLK_TCK = os.sysconf('SC_CLK_TCK')


def _cpu_seconds(pid: int) -> float:
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class Probe:
    def __init__(self, domain: int) -> None:
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node('bench_probe', context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)

    def spin_until(self, predicate, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > end:
                return False
            self.ex.spin_once(timeout_sec=0.001)
        return True

    def close(self) -> None:
        self.ex.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def _start(env, *params):
    args = [sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _stop(proc) -> None:
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()


def measure_rate(env, probe: Probe, rate: float, seconds: float, samples: int) -> dict:
    proc = _start(env, 'dt:=0.001', f'publish_rate:={rate}', 'command_timeout:=0.0')
    try:
        diags, poses, applied, arrivals = [], [], [], []
        node = probe.node
        subs = [node.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 10),
                node.create_subscription(
                    PoseStamped, 'pose',
                    lambda m: (poses.append(_stamp_ns(m.header.stamp)),
                               arrivals.append(time.perf_counter_ns())), 100),
                node.create_subscription(WrenchStamped, 'applied_wrench', applied.append,
                                         APPLIED_QOS)]
        pub = node.create_publisher(Wrench, 'wrench', 10)
        if not probe.spin_until(lambda: poses and pub.get_subscription_count(), 30):
            raise RuntimeError('simulator did not come up')
        cpu0, wall0 = _cpu_seconds(proc.pid), time.monotonic()
        latencies = []
        diags.clear()
        for k in range(samples):
            w = Wrench()
            w.torque.z = 0.001 * (k + 1)
            n_applied = len(applied)
            sent = time.perf_counter_ns()
            pub.publish(w)
            probe.spin_until(lambda: len(applied) > n_applied, 5)
            effect = _stamp_ns(applied[-1].header.stamp)
            # the first pose stamped after the period the wrench took effect in
            probe.spin_until(lambda: poses and poses[-1] > effect, 5)
            i = next(i for i, t in enumerate(poses) if t > effect)
            latencies.append((arrivals[i] - sent) * 1e-6)
            probe.spin_until(lambda: False, random.uniform(0.5, 1.5) * seconds / samples)
        cpu = (_cpu_seconds(proc.pid) - cpu0) / (time.monotonic() - wall0)
        probe.spin_until(lambda: len(diags) >= 1, 3)
        for s in subs:
            node.destroy_subscription(s)
        node.destroy_publisher(pub)
    finally:
        _stop(proc)
    ticks = late = 0
    p50 = p99 = []
    p50, p99 = [], []
    for d in diags:
        kv = {v.key: v.value for v in d.status[0].values}
        p50.append(float(kv['tick_lateness_p50_ms']))
        p99.append(float(kv['tick_lateness_p99_ms']))
        ticks, late = int(kv['ticks']), int(kv['late_ticks_total'])
    latencies.sort()
    return {'publish_rate_hz': rate, 'late_tick_fraction': late / ticks if ticks else None,
            'ticks': ticks, 'tick_lateness_p50_ms': max(p50) if p50 else None,
            'tick_lateness_p99_ms': max(p99) if p99 else None, 'cpu_per_core': cpu,
            'latency_p50_ms': latencies[len(latencies) // 2],
            'latency_p99_ms': latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))]}


FULL_TENSOR = (0.2, 0.01, 0.0, 0.01, 0.3, 0.02, 0.0, 0.02, 0.4)
SPIN = (1.0, 2.0, 3.0)
VELOCITY = (1.0, 0.0, 0.0)
# name: node parameters
BODIES = {'at rest': (),
          'spinning, full tensor': (f'inertia:={list(FULL_TENSOR)}',
                                    f'initial_angular_velocity:={list(SPIN)}',
                                    f'initial_linear_velocity:={list(VELOCITY)}')}


def pose_error(body: str, pose: PoseStamped) -> float:
    """Largest difference of ``pose`` (position, quaternion up to sign) from a Stepper of the
    same body stepped offline to its stamp."""
    if body == 'at rest':
        s = Stepper(RigidBody(1.0, [0.1, 0.1, 0.1]), 1e-3, State())
    else:
        s = Stepper(RigidBody(1.0, np.array(FULL_TENSOR).reshape(3, 3)), 1e-3,
                    State(linear_velocity=VELOCITY, angular_velocity=SPIN))
    s.step(round(_stamp_ns(pose.header.stamp) / 1e6))
    p, q = pose.pose.position, pose.pose.orientation
    ref = s.state
    got_q = np.array([q.x, q.y, q.z, q.w])
    want_q = np.array(ref.quaternion_xyzw)
    return float(max(np.max(np.abs(np.array([p.x, p.y, p.z]) - ref.position)),
                     min(np.max(np.abs(got_q - want_q)), np.max(np.abs(got_q + want_q)))))


def measure_fastest(env, probe: Probe, rate: float, seconds: float, listen: bool,
                    body: str = 'at rest') -> dict:
    """Sim seconds per wall second at real_time_factor 0, from the node's /diagnostics; with
    ``listen`` a subscriber also takes every pose (DDS delivery to it then costs the node),
    and the last one is checked against an offline Stepper."""
    proc = _start(env, 'dt:=0.001', f'publish_rate:={rate}', 'real_time_factor:=0.0',
                  *BODIES[body])
    try:
        diags, poses = [], []
        subs = [probe.node.create_subscription(DiagnosticArray, '/diagnostics', diags.append,
                                               10)]
        if listen:
            subs.append(probe.node.create_subscription(PoseStamped, 'pose', poses.append, 10))
        if not probe.spin_until(lambda: len(diags) >= 2 + seconds, 30 + seconds):
            raise RuntimeError('simulator did not report')
        for s in subs:
            probe.node.destroy_subscription(s)
    finally:
        _stop(proc)
    ratios = sorted(float({v.key: v.value for v in d.status[0].values}['sim_over_wall'])
                    for d in diags[1:])
    return {'publish_rate_hz': rate, 'pose_subscriber': listen, 'body': body,
            'real_time_factor': ratios[len(ratios) // 2], 'ratios': ratios,
            'poses_received': len(poses),
            'pose_error': pose_error(body, poses[-1]) if poses else None}


def measure_scene(env, probe: Probe, scene: str, seconds: float) -> dict:
    """Sim seconds per wall second, each wall second, of a scene at real_time_factor 0: for
    the collision scene it rises as its bodies come to rest and sleep."""
    proc = _start(env, f'scene_file:={scene}', 'real_time_factor:=0.0')
    try:
        diags = []
        sub = probe.node.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 10)
        if not probe.spin_until(lambda: len(diags) >= 1 + seconds, 30 + seconds):
            raise RuntimeError('simulator did not report')
        probe.node.destroy_subscription(sub)
    finally:
        _stop(proc)
    values = [{v.key: v.value for v in d.status[0].values} for d in diags[1:]]
    return {'scene': scene, 'sim_over_wall': [float(v['sim_over_wall']) for v in values],
            'sleeping_bodies': [int(v.get('sleeping_bodies', 0)) for v in values]}


def sanity(rates, fastest, scene) -> figures.Sanity:
    s = figures.Sanity()
    for r in rates:
        hz = r['publish_rate_hz']
        s.within(f'{hz} Hz: late-tick fraction', r['late_tick_fraction'], 0.0, 1.0)
        s.within(f'{hz} Hz: ticks', r['ticks'], 1, 1e9)
        for key in ('tick_lateness_p50_ms', 'tick_lateness_p99_ms'):
            s.within(f'{hz} Hz: {key}', r[key], 0.0, 1000.0)
        s.within(f'{hz} Hz: CPU per core', r['cpu_per_core'], 1e-4, 2.0)
        for key in ('latency_p50_ms', 'latency_p99_ms'):
            s.within(f'{hz} Hz: {key}', r[key], 0.01, 1000.0)
    for f in fastest:
        who = f'fastest, {f["body"]}, subscriber {f["pose_subscriber"]}'
        s.within(f'{who}: real-time factor', f['real_time_factor'], 1.0, 1e5)
        if f['pose_subscriber']:
            s.within(f'{who}: poses received', f['poses_received'], 1, 1e9)
            s.within(f'{who}: last pose against an offline Stepper', f['pose_error'], 0.0, 1e-9)
    if scene:
        for r in scene['sim_over_wall']:
            s.within('scene: sim seconds per wall second', r, 0.01, 1e5)
    return s


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.node_timing', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='a short sanity run (~15 s)')
    parser.add_argument('--seconds', type=float, help='per measurement (default 10)')
    parser.add_argument('--samples', type=int, help='latency samples per rate (default 100)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/node_timing.json; --quick: none)')
    parser.add_argument('--scene', default=str(Path(__file__).resolve().parents[1] / 'scenes'
                                               / 'collisions.yaml'),
                        help='a scene run as fast as possible (default: the collision demo)')
    opts = parser.parse_args()
    seconds = opts.seconds or (2.0 if opts.quick else 10.0)
    samples = opts.samples or (10 if opts.quick else 100)
    domain = random.randint(1, 100)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    env.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    os.environ.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    moving = 'spinning, full tensor'
    cases = ([(moving, True)] if opts.quick else
             [(moving, False), (moving, True), ('at rest', False)])
    probe = Probe(domain)
    try:
        rates = [measure_rate(env, probe, r, seconds, samples)
                 for r in ((1000.0,) if opts.quick else (100.0, 1000.0))]
        fastest = [measure_fastest(env, probe, 100.0, seconds, listen, body)
                   for body, listen in cases]
        scene = awake = None
        if not opts.quick:
            scene = measure_scene(env, probe, opts.scene, seconds)
            # The same scene with sleeping off: every body integrated and every contact solved
            # at every step, the cost while things move.
            with tempfile.TemporaryDirectory() as d:
                text = Path(opts.scene).read_text()
                data = yaml.safe_load(text)
                data.setdefault('contact', {})['sleep_time'] = 0.0
                no_sleep = Path(d) / Path(opts.scene).name
                no_sleep.write_text(yaml.safe_dump(data))
                awake = measure_scene(env, probe, str(no_sleep), seconds)
                awake['scene'] = scene['scene'] + ' (contact: sleep_time 0)'
    finally:
        probe.close()
    print(f'{"publish":>8} {"late ticks":>11} {"lateness p50":>13} {"p99":>8} {"CPU/core":>9} '
          f'{"latency p50":>12} {"p99":>8}')
    for r in rates:
        late = r['late_tick_fraction']
        print(f'{r["publish_rate_hz"]:>6.0f}Hz {100 * late:>10.2f}% '
              f'{r["tick_lateness_p50_ms"]:>10.3f} ms {r["tick_lateness_p99_ms"]:>5.3f} ms '
              f'{100 * r["cpu_per_core"]:>8.1f}% {r["latency_p50_ms"]:>9.2f} ms '
              f'{r["latency_p99_ms"]:>5.2f} ms')
    for f in fastest:
        who = 'a pose subscriber' if f['pose_subscriber'] else 'no subscriber'
        check = (f', last pose {f["pose_error"]:.1e} from an offline Stepper'
                 if f['pose_error'] is not None else '')
        print(f'fastest real-time factor, {f["body"]}, dt = 1 ms, publishing at '
              f'{f["publish_rate_hz"]:.0f} Hz (sim), {who}: {f["real_time_factor"]:.0f}x{check}')
    if scene:
        print(f'{Path(scene["scene"]).name} as fast as possible, sim seconds per wall second, '
              'each wall second: ' + ', '.join(f'{r:.2f}' for r in scene['sim_over_wall'])
              + ' (bodies asleep: ' + ', '.join(str(n) for n in scene['sleeping_bodies'])
              + ')')
        print('the same, sleeping off: ' + ', '.join(f'{r:.2f}' for r in awake['sim_over_wall']))
        scene['scene'] = str(Path(scene['scene']).resolve().relative_to(figures.ROOT)) \
            if Path(scene['scene']).resolve().is_relative_to(figures.ROOT) else scene['scene']
        awake['scene'] = scene['scene'] + ' (contact: sleep_time 0)'
    sane = sanity(rates, fastest, scene)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'node_timing.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'seconds': seconds, 'samples': samples,
                             'rates': rates, 'fastest': fastest, 'scene': scene,
                             'scene_sleeping_off': awake})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
