# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""send_wrench: drive the simulator without ros2cli.

    send_wrench --force 0 0 1 --torque 0 0 0.1 --duration 2
    send_wrench --frame body --torque 0.05 0 0 --duration 1
    send_wrench --csv profile.csv

A CSV profile has a header and rows ``t,fx,fy,fz,tx,ty,tz`` with an optional ``frame`` column
(world or body): each row's wrench (N, N m) is held from its time t (s, from the start) until the
next row's; the last row is held for --duration more seconds (default 0). The wrench is
republished at --rate Hz so that the simulator's command_timeout does not zero it, and a zero
wrench is sent at the end (or on Ctrl-C) to leave the body unforced.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time

from geometry_msgs.msg import Wrench, WrenchStamped
import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from rb_sim_ros import ros_arguments

FIELDS = ('t', 'fx', 'fy', 'fz', 'tx', 'ty', 'tz')


def load_profile(path: str) -> list[tuple[float, tuple[float, ...], str | None]]:
    """Rows (t, (fx, fy, fz, tx, ty, tz), frame or None) sorted by t; ValueError names the line."""
    rows = []
    with open(path, newline='') as f:
        reader = csv.DictReader(f)
        missing = [c for c in FIELDS if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f'{path}: missing columns {missing} (need {",".join(FIELDS)})')
        for line, row in enumerate(reader, start=2):
            try:
                values = tuple(float(row[c]) for c in FIELDS)
            except (TypeError, ValueError):
                raise ValueError(f'{path}:{line}: not a number in {row}') from None
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f'{path}:{line}: non-finite value in {row}')
            frame = (row.get('frame') or '').strip() or None
            if frame not in (None, 'world', 'body'):
                raise ValueError(f"{path}:{line}: frame must be world or body, got '{frame}'")
            rows.append((values[0], values[1:], frame))
    if not rows:
        raise ValueError(f'{path}: no rows')
    if any(b[0] < a[0] for a, b in zip(rows, rows[1:])):
        raise ValueError(f'{path}: times must not decrease')
    return rows


def _message(values, frame, world_frame, body_frame):
    w = Wrench()
    w.force.x, w.force.y, w.force.z = values[:3]
    w.torque.x, w.torque.y, w.torque.z = values[3:]
    if frame is None:
        return w
    msg = WrenchStamped(wrench=w)
    msg.header.frame_id = world_frame if frame == 'world' else body_frame
    return msg


def main(args=None) -> int:
    argv = sys.argv if args is None else args
    p = argparse.ArgumentParser(prog='send_wrench', description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--force', nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar='N')
    p.add_argument('--torque', nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar='NM')
    p.add_argument('--frame', choices=('world', 'body'),
                   help="send on wrench_stamped in this frame (default: on 'wrench', in the "
                   "simulator's wrench_frame)")
    p.add_argument('--csv', help='a wrench profile (see above) instead of --force/--torque')
    p.add_argument('--duration', type=float, default=None,
                   help='seconds to hold the (last) wrench (default 1 s, or 0 with --csv)')
    p.add_argument('--rate', type=float, default=50.0, help='republish rate (Hz)')
    p.add_argument('--wait', type=float, default=10.0,
                   help='seconds to wait for the simulator to subscribe')
    p.add_argument('--world-frame', default='odom')
    p.add_argument('--body-frame', default='base_link')
    opts = p.parse_args(ros_arguments.non_ros_args(argv, 'send_wrench'))
    try:
        profile = (load_profile(opts.csv) if opts.csv
                   else [(0.0, tuple(opts.force) + tuple(opts.torque), opts.frame)])
    except (OSError, ValueError) as e:
        print(f'send_wrench: {e}', file=sys.stderr)
        return 2
    duration = opts.duration if opts.duration is not None else (0.0 if opts.csv else 1.0)
    if duration < 0 or not opts.rate > 0:
        print('send_wrench: --duration must be >= 0 and --rate > 0', file=sys.stderr)
        return 2
    stamped = any(frame is not None for _, _, frame in profile)
    # No rclpy signal handler: Ctrl-C raises KeyboardInterrupt with the context still up,
    # so the zero wrench below still goes out.
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('send_wrench')
    pub = (node.create_publisher(WrenchStamped, 'wrench_stamped', 10) if stamped
           else node.create_publisher(Wrench, 'wrench', 10))
    zero = (profile[-1][0], (0.0,) * 6, profile[-1][2])
    try:
        end = time.monotonic() + opts.wait
        while pub.get_subscription_count() == 0:
            if time.monotonic() > end:
                print(f'send_wrench: no subscriber on {pub.topic_name} after {opts.wait} s',
                      file=sys.stderr)
                return 1
            rclpy.spin_once(node, timeout_sec=0.05)
        start = time.monotonic()
        stop_at = profile[-1][0] + duration
        i = 0
        while True:
            now = time.monotonic() - start
            if now > stop_at:
                break
            while i + 1 < len(profile) and profile[i + 1][0] <= now:
                i += 1
            t, values, frame = profile[i]
            pub.publish(_message(values, frame, opts.world_frame, opts.body_frame))
            rclpy.spin_once(node, timeout_sec=0.0)
            time.sleep(max(0.0, 1.0 / opts.rate - (time.monotonic() - start - now)))
        print(f'send_wrench: sent {len(profile)} wrench(es) for {stop_at:.3f} s on '
              f'{pub.topic_name}')
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if rclpy.ok():
            pub.publish(_message(zero[1], zero[2], opts.world_frame, opts.body_frame))
            # Destroying the writer at once can drop the zero before the simulator has it,
            # leaving the last wrench held: wait for the (reliable) delivery to be acked.
            try:
                acked = pub.wait_for_all_acked(Duration(seconds=2.0))
            except KeyboardInterrupt:  # a second Ctrl-C: stop waiting, still shut down
                acked = False
            if not acked:
                print('send_wrench: the final zero wrench was not acknowledged',
                      file=sys.stderr)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
