# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""send_wrench: drive the simulator without ros2cli.

    send_wrench --force 0 0 1 --torque 0 0 0.1 --duration 2
    send_wrench --frame body --torque 0.05 0 0 --duration 1
    send_wrench --csv profile.csv

A CSV profile has a header and rows ``t,fx,fy,fz,tx,ty,tz`` with an optional ``frame`` column
(world or body): each row's wrench (N, N m) is held from its time t (s, from the start) until the
next row's; the last row is held for --duration more seconds (default 0). A row with a frame goes
on wrench_stamped, one without on wrench (in the simulator's wrench_frame). The wrench is
republished at --rate Hz so that the simulator's command_timeout does not zero it, and a zero
wrench is sent on every way out (the end, an error, Ctrl-C, SIGTERM or SIGHUP) on each topic used,
to leave the body unforced; it counts as arrived when
the simulator reports it on applied_wrench (beside the wrench topic) or DDS acknowledges it.
Every force and torque must be finite with a norm of at most --max-wrench (the simulator's
max_wrench parameter, default 1e6): a bad argument or row is one line on stderr, exit status 2.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time

from geometry_msgs.msg import Wrench, WrenchStamped
import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions

from rb_sim_ros.ros import ros_arguments
# (load_profile and FIELDS: for those that took them from here)
from rb_sim_ros.ros.wrench_profile import (  # noqa: F401
    check_wrench, FIELDS, load_profile, MAX_SECONDS, MAX_WRENCH)

MIN_RATE, MAX_RATE = 0.1, 10_000.0  # Hz
ZERO_TIMEOUT_S = 10.0  # for the final zero to be reported or acknowledged


_Parser = ros_arguments.OneLineParser


def _check_options(opts) -> str:
    """What is wrong with the options, or ''."""
    if not 0 < opts.max_wrench <= 1e300:
        return f'--max-wrench must be a finite number > 0, got {opts.max_wrench!r}'
    if not MIN_RATE <= opts.rate <= MAX_RATE:
        return f'--rate must be from {MIN_RATE:g} to {MAX_RATE:g} Hz, got {opts.rate!r}'
    for name in ('duration', 'wait'):
        value = getattr(opts, name)
        if value is not None and not 0 <= value <= MAX_SECONDS:
            return f'--{name} must be from 0 to {MAX_SECONDS:g} s, got {value!r}'
    if not opts.csv:
        try:
            check_wrench(tuple(opts.force) + tuple(opts.torque), opts.max_wrench,
                         '--force/--torque')
        except ValueError as e:
            return str(e)
    return ''


def _applied_topic(wrench_topic: str) -> str:
    """The simulator's applied_wrench beside its wrench (or wrench_stamped) topic."""
    return wrench_topic.rpartition('/')[0] + '/applied_wrench'


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
    p = _Parser(prog='send_wrench', description=__doc__,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--force', nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar='N')
    p.add_argument('--torque', nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar='NM')
    p.add_argument('--frame', choices=('world', 'body'),
                   help="send on wrench_stamped in this frame (default: on 'wrench', in the "
                   "simulator's wrench_frame)")
    p.add_argument('--csv', help='a wrench profile (see above) instead of --force/--torque')
    p.add_argument('--duration', type=float, default=None,
                   help='seconds to hold the (last) wrench (default 1 s, or 0 with --csv)')
    p.add_argument('--rate', type=float, default=50.0,
                   help=f'republish rate (Hz, {MIN_RATE:g} to {MAX_RATE:g})')
    p.add_argument('--wait', type=float, default=10.0,
                   help='seconds to wait for the simulator to subscribe')
    p.add_argument('--max-wrench', type=float, default=MAX_WRENCH,
                   help='largest force norm (N) and torque norm (N m) to send (default: the '
                   "simulator's max_wrench default, 1e6)")
    p.add_argument('--world-frame', default='world',
                   help="frame_id of a world-frame wrench: the simulator's world_frame "
                   "(default 'world', which it always accepts)")
    p.add_argument('--body-frame', default='base_link',
                   help="frame_id of a body-frame wrench: the simulator's body_frame")
    opts = p.parse_args(ros_arguments.non_ros_args(argv, 'send_wrench'))
    problem = _check_options(opts)
    if problem:
        p.error(problem)
    try:
        profile = (load_profile(opts.csv, opts.max_wrench) if opts.csv
                   else [(0.0, tuple(opts.force) + tuple(opts.torque), opts.frame)])
    except OSError as e:
        print(f'send_wrench: {opts.csv}: cannot read: {e.strerror}', file=sys.stderr)
        return 2
    except ValueError as e:
        print(f'send_wrench: {e}', file=sys.stderr)
        return 2
    duration = opts.duration if opts.duration is not None else (0.0 if opts.csv else 1.0)
    # No rclpy signal handler: Ctrl-C raises KeyboardInterrupt with the context still up,
    # so the zero wrench below still goes out; SIGTERM and SIGHUP do the same.
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('send_wrench')
    # A row with a frame goes on wrench_stamped, one without on wrench: one publisher for each
    # kind the profile uses (a profile may mix them).
    pubs = {}
    for stamped in sorted({frame is not None for _, _, frame in profile}):
        pubs[stamped] = (node.create_publisher(WrenchStamped, 'wrench_stamped', 10) if stamped
                         else node.create_publisher(Wrench, 'wrench', 10))
    zero_reported = []  # set when the simulator reports a zero wrench after ours was sent
    # wrench and wrench_stamped are siblings: one applied_wrench beside both.
    node.create_subscription(WrenchStamped, _applied_topic(next(iter(pubs.values())).topic_name),
                             lambda m: _on_applied(m, zero_reported), QoSProfile(depth=10))
    last_frame = {True: next((f for _, _, f in reversed(profile) if f is not None), None),
                  False: None}
    topics = ' and '.join(p.topic_name for p in pubs.values())
    status = 0
    previous = {}
    try:
        for s in (signal.SIGTERM, signal.SIGHUP):
            previous[s] = signal.signal(s, _interrupt)
        end = time.monotonic() + opts.wait
        while any(p.get_subscription_count() == 0 for p in pubs.values()):
            if time.monotonic() > end:
                print(f'send_wrench: no subscriber on {topics} after {opts.wait} s',
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
            pubs[frame is not None].publish(
                _message(values, frame, opts.world_frame, opts.body_frame))
            rclpy.spin_once(node, timeout_sec=0.0)
            time.sleep(max(0.0, 1.0 / opts.rate - (time.monotonic() - start - now)))
        print(f'send_wrench: sent {len(profile)} wrench(es) for {stop_at:.3f} s on {topics}')
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as e:  # noqa: B902 - one line, and the zero below still goes out
        print(f'send_wrench: stopped by {type(e).__name__}: {e}', file=sys.stderr)
        status = 1
    finally:
        try:  # a second signal here stops the wait (the zero is out), still shuts down
            if rclpy.ok():
                zero_reported.clear()
                zero_reported.append(False)  # only reports from now on count
                for stamped, pub in pubs.items():
                    pub.publish(_message((0.0,) * 6, last_frame[stamped], opts.world_frame,
                                         opts.body_frame))
                # Destroying the writer at once can drop the zero before the simulator has
                # it, leaving the last wrench held: wait until the simulator reports the zero
                # on applied_wrench (at once) or DDS acknowledges it (Fast DDS acknowledges at
                # its next heartbeat, up to 3 s later: needed when the wrench held was
                # already zero).
                arrived = _wait_for_zero(node, list(pubs.values()), zero_reported)
                if not arrived:
                    print(f'send_wrench: the final zero wrench was not acknowledged within '
                          f'{ZERO_TIMEOUT_S:g} s', file=sys.stderr)
        except KeyboardInterrupt:
            print('send_wrench: interrupted again while sending the final zero wrench',
                  file=sys.stderr)
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
            node.destroy_node()
            rclpy.try_shutdown()
    return status


def _interrupt(signum, frame):
    """SIGTERM and SIGHUP stop send_wrench as Ctrl-C does: the final zero still goes out."""
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _on_applied(msg: WrenchStamped, zero_reported: list) -> None:
    f, t = msg.wrench.force, msg.wrench.torque
    if zero_reported and (f.x, f.y, f.z, t.x, t.y, t.z) == (0.0,) * 6:
        zero_reported[0] = True


def _wait_for_zero(node, pubs: list, zero_reported: list) -> bool:
    """True once the simulator reported a zero, or DDS acknowledged every zero sent."""
    def arrived() -> bool:
        return zero_reported[0] or all(p.wait_for_all_acked(Duration(seconds=0)) for p in pubs)
    end = time.monotonic() + ZERO_TIMEOUT_S
    while time.monotonic() < end:
        if arrived():
            return True
        rclpy.spin_once(node, timeout_sec=0.02)
    return arrived()


if __name__ == '__main__':
    sys.exit(main())
