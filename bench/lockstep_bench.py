#!/usr/bin/env python3
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Lockstep round trips a second, what they cost against the open loop, what bounds them, and
whether a closed loop repeats bit for bit under load and at any pace.

    python -m bench.lockstep_bench [--quick] [--seconds 20] [--no-write]

Each case is a fresh simulator process (``python -m rb_sim_ros.ros.simulator_node``) run to
``stop_after`` at real_time_factor 0 (as fast as possible), with ``examples/
attitude_controller.py`` as the controller (a plain rclpy node on ControlLoop), on a ROS domain
of its own; the rates are the node's own count at its exit (from its first step to its last,
start-up not included):

* one body and its controller in lockstep (the round trip: state out, answer in, one period);
  the controller's ControlLoop in its own thread (the default), and through the node's
  executor (``control_thread:=false``);
* two bodies, each with its own controller process (``lockstep_inputs:=[a, b]``);
* the same body open loop (no lockstep, no controller): the cost of lockstep is the ratio;
* a bare rclpy ping-pong between two processes (an Odometry out, a WrenchStamped back), in
  the same run: each side spun by rclpy's SingleThreadedExecutor, and each side a wait set
  on its one subscription (no executor: the leanest loop rclpy has). The second is the floor
  of any round trip between two rclpy nodes on this machine, whatever they do;
* the node's own work a period (stepping, filling and publishing; from its exit line): the rest
  of a round trip is the controller and DDS;
* four recordings of the same closed loop (idle and with both cores kept busy by two CPU-bound
  processes, at real_time_factor 0 and 1): compared field by field (``same_run``).

Writes docs/bench/lockstep_bench.json (unless --no-write; --quick, 1 s runs, writes none).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import random
import re
import subprocess
import sys
import tempfile
import time

from bench import figures

ROOT = Path(__file__).resolve().parents[1]

CONTROLLER = ROOT / 'examples' / 'attitude_controller.py'
INERTIA = '[0.1, 0.2, 0.3]'
_SUMMARY = re.compile(r'(\d+) periods in ([\d.]+) s \((\d+) periods/s\); the node\'s own work '
                      r'(\d+) us a period(?:; lockstep: (\d+)% of the time waiting)?')

PING = """
import sys, time, rclpy
from rclpy.node import Node
from rclpy.executors import SingleThreadedExecutor
from nav_msgs.msg import Odometry
from geometry_msgs.msg import WrenchStamped
rclpy.init()
n = Node('ping')
pub = n.create_publisher(Odometry, 'odom', 10)
got = [0]
n.create_subscription(WrenchStamped, 'wrench_stamped', lambda m: got.__setitem__(0, got[0] + 1),
                      10)
ex = SingleThreadedExecutor()
ex.add_node(n)
while pub.get_subscription_count() < 1:
    ex.spin_once(timeout_sec=0.1)
time.sleep(1.0)
N = int(sys.argv[1])
t = time.perf_counter()
for k in range(N):
    o = Odometry()
    o.header.stamp.nanosec = k
    pub.publish(o)
    while got[0] < k + 1:
        ex.spin_once(timeout_sec=5.0)
print(N / (time.perf_counter() - t))
"""
PONG = """
import rclpy
from rclpy.node import Node
from nav_msgs.msg import Odometry
from geometry_msgs.msg import WrenchStamped
rclpy.init()
n = Node('pong')
pub = n.create_publisher(WrenchStamped, 'wrench_stamped', 10)
def answer(m):
    w = WrenchStamped()
    w.header.stamp = m.header.stamp
    pub.publish(w)
n.create_subscription(Odometry, 'odom', answer, 10)
rclpy.spin(n)
"""


# The leanest rclpy loop there is: one subscription, a wait set on it alone, no executor.
LEAN = """
import sys, time, rclpy
from rclpy.node import Node
from nav_msgs.msg import Odometry
from geometry_msgs.msg import WrenchStamped
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
rclpy.init()
ping = sys.argv[1] == 'ping'
n = Node(sys.argv[1])
out_type, in_type, out_topic, in_topic = ((Odometry, WrenchStamped, 'odom', 'wrench_stamped')
                                          if ping else
                                          (WrenchStamped, Odometry, 'wrench_stamped', 'odom'))
pub = n.create_publisher(out_type, out_topic, 10)
sub = n.create_subscription(in_type, in_topic, lambda m: None, 10)
out = out_type()
ws = _rclpy.WaitSet(1, 0, 0, 0, 0, 0, n.context.handle)
def take():
    while True:
        with sub.handle:
            ws.clear_entities()
            ws.add_subscription(sub.handle)
            ws.wait(5_000_000_000)
            got = sub.handle.take_message(sub.msg_type, sub.raw)
        if got is not None:
            return got[0]
while pub.get_subscription_count() < 1 or sub.get_publisher_count() < 1:
    time.sleep(0.05)
time.sleep(1.0)
if ping:
    N = int(sys.argv[2])
    t = time.perf_counter()
    for k in range(N):
        out.header.stamp.nanosec = k
        pub.publish(out)
        take()
    print(N / (time.perf_counter() - t))
else:
    while True:
        out.header.stamp = take().header.stamp
        pub.publish(out)
"""


def environment() -> dict:
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = str(random.randrange(150, 230))
    env.setdefault('NUMBA_CACHE_DIR', str(ROOT / '.venv' / 'numba-cache'))
    env.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(ROOT), env.get('PYTHONPATH')]))
    return env


def run(sim_args, controllers, seconds: float, work: Path, name: str,
        load: bool = False, record: bool = True) -> dict:
    """One simulator run to ``seconds`` of sim time with the ``controllers`` (their extra
    arguments each); returns the figures of its exit line and the recording's path."""
    env = environment()
    path = work / f'{name}.mcap'
    burners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
               for _ in range(2 if load else 0)]
    sim = subprocess.Popen(
        [sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args',
         '-p', f'stop_after:={seconds}', '-p', f'inertia:={INERTIA}',
         *(['-p', f'record:={path}', '-p', 'record_overwrite:=true'] if record else []),
         *sim_args],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=work)
    procs = [subprocess.Popen([sys.executable, str(CONTROLLER), '--ros-args',
                               '-p', f'inertia:={INERTIA}',
                               '-p', 'target_rpy:=[0.3, -0.2, 1.2]', *extra],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              cwd=work)
             for extra in controllers]
    try:
        out, _ = sim.communicate(timeout=900)
    finally:
        for p in procs + burners:
            p.kill()
            p.wait()
    match = _SUMMARY.search(out)
    if sim.returncode != 0 or match is None:
        raise SystemExit(f'{name}: the simulator exited {sim.returncode}:\n{out[-3000:]}')
    periods, wall, rate, own, waiting = match.groups()
    return {'periods': int(periods), 'wall_s': float(wall),
            'periods_per_s': int(periods) / float(wall), 'own_work_us': float(own),
            'waiting_fraction': int(waiting) / 100 if waiting else 0.0,
            'recording': str(path)}


def ping_pong(n: int, lean: bool = False) -> float:
    env = environment()
    pong = subprocess.Popen([sys.executable, '-c', *((LEAN, 'pong') if lean else (PONG,))],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        out = subprocess.run([sys.executable, '-c', *((LEAN, 'ping') if lean else (PING,)),
                              str(n)], env=env, check=True,
                             capture_output=True, text=True, timeout=600).stdout
    finally:
        pong.kill()
        pong.wait()
    return float(out.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.lockstep_bench', description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=20.0,
                        help='sim seconds of each rate run (100 periods a second)')
    parser.add_argument('--quick', action='store_true', help='1 s runs; writes nothing')
    parser.add_argument('--no-write', action='store_true')
    opts = parser.parse_args()
    if opts.quick:
        opts.seconds, opts.no_write = 1.0, True
    from rb_sim_ros.ros.node_recorder import same_run
    work = Path(tempfile.mkdtemp(prefix='lockstep_bench_'))
    fast = ['-p', 'real_time_factor:=0.0']
    lock = ['-p', 'lockstep:=true']
    t0 = time.time()
    print("lockstep round trips (periods/s at real_time_factor 0, the node's own count):")
    one = run(fast + lock, [[]], opts.seconds, work, 'one', record=False)
    print(f"  one body + its controller: {one['periods_per_s']:.0f} periods/s "
          f"({1e6 / one['periods_per_s']:.0f} us a round trip; the node's own work "
          f"{one['own_work_us']:.0f} us a period, waiting {one['waiting_fraction']:.0%})")
    executed = run(fast + lock, [['-p', 'control_thread:=false']], opts.seconds, work,
                   'one-executed', record=False)
    print(f"  the same, the controller's ControlLoop through its executor: "
          f"{executed['periods_per_s']:.0f} periods/s (its own thread: "
          f"{one['periods_per_s'] / executed['periods_per_s']:.2f}x)")
    one_rec = run(fast + lock, [[]], opts.seconds, work, 'one-recorded')
    print(f"  the same, recorded: {one_rec['periods_per_s']:.0f} periods/s (the node's own "
          f"work {one_rec['own_work_us']:.0f} us a period)")
    scene = work / 'two.yaml'
    scene.write_text('bodies:\n  - {name: a, mass: 1.0, inertia: ' + INERTIA + '}\n'
                     '  - {name: b, mass: 1.0, inertia: ' + INERTIA + '}\n')
    two = run(fast + lock + ['-p', f'scene_file:={scene}', '-p', 'lockstep_inputs:=[a, b]'],
              [['-r', '__ns:=/a'], ['-r', '__ns:=/b']], opts.seconds, work, 'two',
              record=False)
    print(f"  two bodies + two controllers: {two['periods_per_s']:.0f} periods/s")
    open_loop = run(fast, [], opts.seconds * 10, work, 'open', record=False)
    print(f"  the same body open loop (no controller): {open_loop['periods_per_s']:.0f} "
          f"periods/s: lockstep costs {open_loop['periods_per_s'] / one['periods_per_s']:.0f}x")
    spun = ping_pong(int(max(1000, opts.seconds * 100)))
    floor = ping_pong(int(max(1000, opts.seconds * 200)), lean=True)
    print(f'  a bare rclpy ping-pong between two processes: {spun:.0f} round trips/s '
          f'({1e6 / spun:.0f} us) spun by executors; {floor:.0f} round trips/s '
          f'({1e6 / floor:.0f} us) on a wait set each: the floor of any rclpy round trip '
          'here')
    print('one closed loop four ways (idle / both cores busy, real_time_factor 0 / 1):')
    runs = {}
    for load in (False, True):
        for rtf in (0.0, 1.0):
            name = f"{'loaded' if load else 'idle'}-rtf{rtf:g}"
            runs[name] = run(lock + ['-p', f'real_time_factor:={rtf}',
                                     '-p', 'imu_gyro_noise:=0.01'],
                             [['-p', 'source:=imu', '-p', 'answer_delay_max:=0.002']],
                             1.0 if opts.quick else 3.0, work, name,
                             load=load)['recording']
    first = next(iter(runs))
    same = {name: same_run(runs[first], path) for name, path in runs.items()}
    for name, diff in same.items():
        print(f'  {name}: ' + ('identical to ' + first if not diff else f'DIFFERS: {diff}'))
    print(f'({time.time() - t0:.0f} s)')
    if not opts.no_write:
        for row in (one, executed, one_rec, two, open_loop):
            row.pop('recording')  # (a temporary file)
        path = figures.write(figures.DOCS_BENCH / 'lockstep_bench.json', {
            'quick': False, 'seconds': opts.seconds, 'one_controller': one,
            'one_controller_executed': executed, 'one_recorded': one_rec,
            'two_controllers': two,
            'open_loop': open_loop, 'rclpy_ping_pong_executors_per_s': spun,
            'rclpy_ping_pong_per_s': floor,
            'identical': {name: not diff for name, diff in same.items()}})
        print(f'wrote {path}')
    return 0 if not any(same.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
