# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node's timing: late ticks, tick jitter, CPU, wrench-to-pose latency, fastest RTF.

    python bench/node_timing.py [--seconds 10] [--json out.json]

Starts the simulator as a separate process (as users run it) on a private ROS domain, and a
probe node in this process. For publish rates of 100 Hz and 1 kHz at dt = 1 ms and real time:
late-tick fraction and p50/p99 tick lateness from the node's /diagnostics, the node's CPU per
core from /proc, and the latency from publishing a wrench to receiving the first pose that
includes it (p50/p99). Then the fastest real-time factor (real_time_factor 0) for one body at
dt = 1 ms, and, second by second, for a scene (``--scene``, default the collision demo, whose
bodies settle and sleep). Prints a table; figures are this machine's, measured now.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import random
import signal
import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Wrench, WrenchStamped
import rclpy
from rclpy.executors import SingleThreadedExecutor

from rb_sim_ros.simulator_node import APPLIED_QOS

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
    args = [sys.executable, '-m', 'rb_sim_ros.simulator_node', '--ros-args']
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


def measure_fastest(env, probe: Probe, rate: float, seconds: float, listen: bool) -> dict:
    """Sim seconds per wall second at real_time_factor 0, from the node's /diagnostics; with
    ``listen`` a subscriber also takes every pose (DDS delivery to it then costs the node)."""
    proc = _start(env, 'dt:=0.001', f'publish_rate:={rate}', 'real_time_factor:=0.0')
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
    return {'publish_rate_hz': rate, 'pose_subscriber': listen,
            'real_time_factor': ratios[len(ratios) // 2]}


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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--seconds', type=float, default=10.0, help='per measurement')
    parser.add_argument('--samples', type=int, default=100, help='latency samples per rate')
    parser.add_argument('--json', help='write the figures here too')
    parser.add_argument('--scene', default=str(Path(__file__).resolve().parents[1] / 'scenes'
                                               / 'collisions.yaml'),
                        help='a scene run as fast as possible (default: the collision demo)')
    opts = parser.parse_args()
    domain = random.randint(1, 100)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    env.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    os.environ.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    probe = Probe(domain)
    try:
        rates = [measure_rate(env, probe, r, opts.seconds, opts.samples) for r in (100.0, 1000.0)]
        fastest = [measure_fastest(env, probe, r, opts.seconds, listen)
                   for r in (100.0, 10.0) for listen in (False, True)]
        scene = measure_scene(env, probe, opts.scene, opts.seconds)
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
        print(f'fastest real-time factor, dt = 1 ms, publishing at {f["publish_rate_hz"]:.0f} Hz '
              f'(sim), {who}: {f["real_time_factor"]:.0f}x')
    print(f'{Path(scene["scene"]).name} as fast as possible, sim seconds per wall second, '
          'each wall second: ' + ', '.join(f'{r:.2f}' for r in scene['sim_over_wall'])
          + ' (bodies asleep: ' + ', '.join(str(n) for n in scene['sleeping_bodies']) + ')')
    if opts.json:
        with open(opts.json, 'w') as fh:
            json.dump({'rates': rates, 'fastest': fastest, 'scene': scene}, fh, indent=2)
    return 0


if __name__ == '__main__':
    sys.exit(main())
