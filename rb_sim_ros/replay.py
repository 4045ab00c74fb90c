# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""replay: verify, recover or republish a recording of the simulator.

    replay --verify run.mcap          re-simulate offline, compare, exit 1 on any difference
    replay --recover run.mcap out.mcap  finalise a killed recording (rosbags/ros2 bag open it)
    replay run.mcap [--rate 2]        republish pose/twist/odom with /clock, in sim-time order

--verify needs no ROS graph: it rebuilds the run from the recording's metadata (body, dt,
integrator, initial state) and its inputs at the steps they took effect, fills the output
messages as the node does, and compares them with the recorded ones, field by field and bit
by bit. Expected: identical.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
import json
import math
import struct
import sys
import time

from rb_sim_ros import node_recorder, ros_arguments
from rb_sim_ros.recording import ReaderError, RecordingReader, recover, WriterError
from rb_sim_ros.ros_messages import OutputMessages, time_msg
from rb_sim_ros.simulation import Config, Simulation
from rb_sim_ros.stepper import IntegrationError

QUANTITIES = ('position', 'orientation', 'linear_velocity', 'angular_velocity')


@dataclass
class Verification:
    """Largest difference per quantity over all recorded outputs, and what was compared."""

    outputs: int = 0
    inputs: int = 0
    mismatched_messages: int = 0
    max_difference: dict = field(default_factory=lambda: dict.fromkeys(QUANTITIES, 0.0))
    first_mismatch: str = ''
    truncated: bool = False
    last_time_ns: int = 0

    @property
    def identical(self) -> bool:
        return self.outputs > 0 and self.mismatched_messages == 0


@dataclass
class Recording:
    """A recording read back: what re-simulates it and what it recorded."""

    config: Config
    parameters: dict
    inputs: list  # (step, event)
    outputs: list  # (step, body, kind, topic, msg, log_time_ns)
    truncated: bool

    def frames(self, body: str) -> tuple[str, str]:
        """(world frame, body frame) the node stamped ``body``'s outputs with."""
        p = self.parameters
        single = not p.get('scene_file')
        return (p.get('world_frame', 'odom'),
                p.get('body_frame', 'base_link') if single else body)


def load(path: str) -> Recording:
    """Read a recording of the simulator; ReaderError if it is not one."""
    reader = RecordingReader(path)
    meta = reader.metadata.get(node_recorder.METADATA)
    if meta is None:
        raise ReaderError(f'{path}: no {node_recorder.METADATA!r} metadata: not a recording of '
                          'the rb_sim_ros simulator')
    try:
        config = Config.from_dict(json.loads(meta['config']))
        parameters = json.loads(meta['parameters'])
        output_topics = json.loads(meta['output_topics'])
    except (KeyError, ValueError, TypeError) as e:
        raise ReaderError(f'{path}: unreadable {node_recorder.METADATA!r} metadata: {e}') from e
    by_topic = {topic: (body, kind) for body, topics in output_topics.items()
                for kind, topic in topics.items()}
    inputs, outputs = [], []
    dt_ns = config.dt * 1e9
    for topic, msg, log_time, _publish_time, sequence in reader.messages():
        step = round(log_time / dt_ns)  # log time is step * dt; sequence holds step mod 2^32
        if step % 2 ** 32 != sequence:
            raise ReaderError(f'{path}: {topic} at {log_time} ns has sequence {sequence}, '
                              f'not its step {step}')
        parsed = node_recorder.parse_input_topic(topic)
        if parsed is not None:
            inputs.append((step, node_recorder.event_from_message(*parsed, msg)))
        elif topic in by_topic:
            outputs.append((step, *by_topic[topic], topic, msg, log_time))
    return Recording(config, parameters, inputs, outputs, reader.truncated)


def _vectors(kind: str, msg):
    """The quantities an output message (pose, twist or odom) carries, as tuples."""
    if kind == 'pose':
        p, o = msg.pose.position, msg.pose.orientation
        return {'position': (p.x, p.y, p.z), 'orientation': (o.x, o.y, o.z, o.w)}
    if kind == 'odom':
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        return {'position': (p.x, p.y, p.z), 'orientation': (o.x, o.y, o.z, o.w),
                'linear_velocity': (lin.x, lin.y, lin.z),
                'angular_velocity': (ang.x, ang.y, ang.z)}
    lin, ang = msg.linear, msg.angular
    return {'linear_velocity': (lin.x, lin.y, lin.z), 'angular_velocity': (ang.x, ang.y, ang.z)}


def identical(kind: str, a, b) -> bool:
    """Every field equal, and every float the same bits (so 0.0 and -0.0 differ).

    Not the serialised bytes: rclpy's CDR leaves alignment padding uninitialised, so two
    serialisations of one message can differ there (seen here)."""
    if a != b:
        return False
    va, vb = _vectors(kind, a), _vectors(kind, b)
    return all(struct.pack(f'<{len(va[q])}d', *va[q]) == struct.pack(f'<{len(vb[q])}d', *vb[q])
               for q in va)


def resimulate(rec: Recording):
    """Re-run a recording: yields (step, kind, topic, recorded message, re-simulated message)
    for every recorded output, in step order. Stops early if the run went non-finite (the node
    paused there and recorded nothing later)."""
    sim = Simulation(rec.config)
    twist_frame = rec.parameters.get('twist_frame', 'body')
    outs = {b.name: OutputMessages(*rec.frames(b.name), twist_frame) for b in rec.config.bodies}
    pending = sorted(rec.inputs, key=lambda e: e[0])
    filled = {}
    for step, body, kind, topic, msg, log_time in sorted(rec.outputs, key=lambda o: o[0]):
        try:
            pending = sim.run_until(step, pending)
        except IntegrationError:
            return
        out = outs[body]
        if filled.get(body) != step:
            out.fill(sim.time_ns, *sim.pose_twist(body))
            filled[body] = step
        yield step, kind, topic, msg, getattr(out, kind), log_time


def verify(path: str) -> Verification:
    """Re-simulate ``path`` offline and compare every recorded output with the re-run."""
    rec = load(path)
    result = Verification(inputs=len(rec.inputs), truncated=rec.truncated)
    for step, kind, topic, msg, mine, log_time in resimulate(rec):
        result.outputs += 1
        result.last_time_ns = log_time
        theirs_v, mine_v = _vectors(kind, msg), _vectors(kind, mine)
        for q, v in theirs_v.items():
            d = max(abs(a - b) for a, b in zip(v, mine_v[q]))
            if not d <= result.max_difference[q]:  # also catches nan
                result.max_difference[q] = d if not math.isnan(d) else math.inf
        if not identical(kind, msg, mine):
            result.mismatched_messages += 1
            if not result.first_mismatch:
                result.first_mismatch = f'{topic} at step {step} (t = {log_time * 1e-9:.9f} s)'
    return result


def play(path: str, rate: float, clock: bool = True, wait: float = 0.0) -> int:
    """Republish the recorded outputs in sim-time order with /clock, ``rate`` x sim time;
    first wait up to ``wait`` seconds for a subscriber on one of them."""
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock

    outputs = [(o[3], o[4], o[5]) for o in load(path).outputs]  # (topic, msg, log time)
    outputs.sort(key=lambda o: o[2])
    rclpy.init()
    node = rclpy.create_node('rb_sim_replay')  # on the ROS graph of the environment
    pubs = {topic: node.create_publisher(type(msg), topic, 10) for topic, msg, _ in outputs}
    clock_pub = node.create_publisher(Clock, '/clock', QoSProfile(
        depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)) if clock else None
    try:
        if not outputs:
            return 0
        end_wait = time.monotonic() + wait
        while time.monotonic() < end_wait and not any(
                p.get_subscription_count() for p in pubs.values()):
            rclpy.spin_once(node, timeout_sec=0.05)
        t0_sim, t0_wall = outputs[0][2], time.monotonic()
        end = outputs[-1][2]
        last_report = 0.0
        for topic, msg, log_time in outputs:
            if rate > 0:
                delay = (log_time - t0_sim) * 1e-9 / rate - (time.monotonic() - t0_wall)
                if delay > 0:
                    time.sleep(delay)
            if clock_pub is not None:
                clock_pub.publish(Clock(clock=time_msg(log_time)))
            pubs[topic].publish(msg)
            if time.monotonic() - last_report > 1.0:
                last_report = time.monotonic()
                done = (log_time - t0_sim) / max(1, end - t0_sim)
                print(f'\rreplay: t = {log_time * 1e-9:10.3f} s  {100 * done:5.1f}%',
                      end='', file=sys.stderr, flush=True)
        print(f'\rreplay: t = {end * 1e-9:10.3f} s  100.0%', file=sys.stderr)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args=None) -> int:
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(prog='replay', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('file', help='a recording (.mcap) made with the record parameter')
    parser.add_argument('out', nargs='?', help='with --recover: the finalised copy to write')
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument('--verify', action='store_true', help='re-simulate and compare')
    mode.add_argument('--recover', action='store_true', help='finalise a killed recording')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='playback speed (sim time per wall time; 0: as fast as possible)')
    parser.add_argument('--no-clock', action='store_true', help='do not publish /clock')
    parser.add_argument('--wait', type=float, default=0.0,
                        help='seconds to wait for a subscriber before playing')
    parser.add_argument('--overwrite', action='store_true', help='with --recover')
    opts = parser.parse_args(ros_arguments.non_ros_args(argv, 'replay'))
    try:
        if opts.verify:
            return _print_verification(opts.file, verify(opts.file))
        if opts.recover:
            if not opts.out:
                parser.error('--recover needs FILE and OUT')
            counts = recover(opts.file, opts.out, overwrite=opts.overwrite)
            print(f'replay: recovered {counts} into {opts.out}')
            return 0
        if opts.out:
            parser.error('OUT is only for --recover')
        return play(opts.file, opts.rate, clock=not opts.no_clock, wait=opts.wait)
    except (ReaderError, WriterError, OSError) as e:
        print(f'replay: {e}', file=sys.stderr)
        return 2


def _print_verification(path: str, r: Verification) -> int:
    note = ' (truncated recording: compared what it holds)' if r.truncated else ''
    print(f'{path}: {r.inputs} inputs, {r.outputs} output messages up to '
          f't = {r.last_time_ns * 1e-9:.6f} s{note}')
    for q in QUANTITIES:
        print(f'  largest difference in {q:<17} {r.max_difference[q]:.3g}')
    if r.identical:
        print('identical: every output message re-simulated bit for bit')
        return 0
    print(f'MISMATCH: {r.mismatched_messages} of {r.outputs} messages differ'
          + (f', first {r.first_mismatch}' if r.first_mismatch else ''))
    return 1


if __name__ == '__main__':
    sys.exit(main())
