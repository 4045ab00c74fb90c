# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Republishing a recording (``replay FILE``): start-up time and peak memory.

    python -m bench.replay_bench [--keep DIR]

Records, as the node records them (oracles/node_recording.py: pose, twist and odom of every
moving body), the collision fixture's scene (scenes/collisions.yaml, 3 s at 50 Hz output, as
test/fixtures/make_collision_fixtures.py runs it) and a 60 s run of one spinning body at the
node's default 100 Hz; and takes the collision fixture itself (recorded by the node: imu,
accel, /tf and /tf_static too). Each file is then republished by ``replay FILE --rate 0
--no-clock`` in a child process on a real rclpy node, on a private ROS domain with localhost
discovery: start-up is from just before the child is started until its first message is
published (interpreter, imports, ``load`` checking the whole file, one publisher per topic);
peak memory is the child's ru_maxrss (os.wait4), over the whole playback. One line per file.
Figures are this machine's, measured now (both cores may be busy: they are upper bounds).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import random
import subprocess
import sys
import tempfile
import time

ROOT = Path(__file__).resolve().parents[1]


def _child(path: str) -> int:
    """Republish ``path`` as fast as possible; print the monotonic time of the first publish
    and of the end of ``load``."""
    from rb_sim_ros.offline import replay

    send, load = replay._Sender.__call__, replay.load
    marks = {}

    def timed_send(self, pub, topic, msg):
        send(self, pub, topic, msg)
        if 'first' not in marks:
            marks['first'] = time.monotonic()
            print(f'first {marks["first"]!r}', flush=True)

    def timed_load(p):
        rec = load(p)
        print(f'loaded {time.monotonic()!r}', flush=True)
        return rec

    replay._Sender.__call__, replay.load = timed_send, timed_load
    return replay.main(['replay', path, '--rate', '0', '--no-clock'])


def _record(out: Path) -> list[tuple[str, Path]]:
    from oracles.node_recording import record_offline
    from rb_sim_ros.sim.scene import load_scene
    from rb_sim_ros.sim.simulation import BodySpec, Config

    scene = load_scene(str(ROOT / 'scenes' / 'collisions.yaml'))
    collisions = out / 'collisions_3s.mcap'
    record_offline(collisions, Config(dt=1e-3, steps_per_publish=20, gravity=scene.gravity,
                                      bodies=scene.bodies, contact=scene.contact), 150)
    one = out / 'one_body_60s.mcap'
    body = BodySpec('body', 1.0, (0.2, 0.3, 0.45), initial_angular_velocity=(0.3, 1.0, -0.2))
    record_offline(one, Config(dt=1e-3, steps_per_publish=10, bodies=(body,)), 6000)
    return [('collision scene, 3 s at 50 Hz (offline)', collisions),
            ('one body, 60 s at 100 Hz (offline)', one),
            ("collision fixture (the node's, all outputs)",
             ROOT / 'test' / 'fixtures' / 'collision_demo.mcap')]


def _measure(path: Path, env: dict) -> tuple[float, float, float]:
    """(start-up s, of which until loaded s, peak RSS MiB) of republishing ``path``."""
    start = time.monotonic()
    # this module again, as python -m bench.replay_bench: env's PYTHONPATH has the root
    proc = subprocess.Popen([sys.executable, '-m', 'bench.replay_bench', '--child', str(path)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    out = proc.stdout.read()
    _pid, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f'replay {path} failed (exit {proc.returncode})')
    marks = dict(line.split() for line in out.splitlines() if line.split()[0] in
                 ('first', 'loaded'))
    return (float(marks['first']) - start, float(marks['loaded']) - start,
            usage.ru_maxrss / 1024)


def main(args=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.replay_bench', description=__doc__.split('\n')[0])
    parser.add_argument('--child', help=argparse.SUPPRESS)
    parser.add_argument('--keep', metavar='DIR', help='record into DIR and keep the files')
    opts = parser.parse_args(args)
    if opts.child:
        return _child(opts.child)
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.randrange(100, 200)),
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(ROOT), env.get('PYTHONPATH')]))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(opts.keep or tmp)
        out.mkdir(parents=True, exist_ok=True)
        from rb_sim_ros.recording import RecordingReader
        for what, path in _record(out):
            reader = RecordingReader(str(path))
            seconds = (reader.end_time_ns - reader.start_time_ns) * 1e-9
            startup, loaded, rss = _measure(path, env)
            print(f'{what}: {path.stat().st_size / 1e6:.2f} MB, {reader.message_count} '
                  f'messages, {seconds:.1f} s: start-up {startup:.2f} s to the first message '
                  f'(load done at {loaded:.2f} s), peak RSS {rss:.0f} MiB  '
                  f'[replay {path.name} --rate 0 --no-clock]', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
