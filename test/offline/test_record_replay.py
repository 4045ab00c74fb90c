# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
# built-msgs: tf2_msgs
"""Recordings of the real node over DDS, read by rosbags and re-simulated bit for bit."""

import copy
import json
import math
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped, Twist, Wrench, WrenchStamped
from mcap.writer import Writer
import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader
from std_srvs.srv import Empty, SetBool, Trigger
from tf2_msgs.msg import TFMessage

from oracles.node_recording import record_offline
from rb_sim_ros.core import multistep
from rb_sim_ros.offline import replay
from rb_sim_ros.recording import offered_qos_profiles, RecordingReader
from rb_sim_ros.ros.node_recorder import RUN_DEFINITION
from rb_sim_ros.ros.simulator_node import APPLIED_QOS
from rb_sim_ros.sim.simulation import BodySpec, Config
from support import ros_harness
from support.recordings import mcap_parts
from support.ros_harness import stamp_ns

FIXTURE = Path(__file__).resolve().parents[1] / 'fixtures' / 'regression.mcap'
FIXTURES = FIXTURE.parent


def _wrench(fx, tz):
    w = Wrench()
    w.force.x, w.torque.z = fx, tz
    return w


def _replay(installed, env, *args, timeout=120):
    return subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), *args], env=env,
                          capture_output=True, text=True, timeout=timeout)


def _rosbags_count(path):
    with AnyReader([Path(path)]) as reader:
        return sum(1 for c, _t, raw in reader.messages() if reader.deserialize(raw, c.msgtype))


def _drive(probe, n_wrenches=4):
    """Publish a changing wrench schedule, a teleport and a reset, waiting for each to apply."""
    poses = probe.collect(PoseStamped, 'pose')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, 'wrench')
    probe.wait_for(lambda: len(poses) > 2, what='poses')
    for i in range(n_wrenches):
        pub.publish(_wrench(0.5 * (i + 1), 0.01 * (-1) ** i))
        probe.wait_for(lambda: len(applied) > i, what=f'wrench {i}')
        n = len(poses)
        probe.wait_for(lambda: len(poses) > n + 3, what='poses after it')
    set_twist = probe.publisher(Twist, 'set_twist')
    t = Twist()
    t.angular.x = 2.0
    set_twist.publish(t)
    probe.call(Empty, 'reset', Empty.Request())
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 5, what='poses after the reset')
    return poses


@pytest.mark.parametrize('integrator', sorted(multistep.METHODS))
def test_a_recorded_run_replays_bit_for_bit(start_sim, probe, installed, ros_env, tmp_path,
                                            integrator):
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'record:={f}', '-p', 'inertia:=[0.2, 0.3, 0.45]',
                    '-p', 'initial_angular_velocity:=[0.3, 1.0, -0.2]',
                    '-p', f'integrator:={integrator}')
    _drive(probe)
    assert sim.stop(signal.SIGINT) == 0
    rec = RecordingReader(str(f))
    assert json.loads(rec.metadata['rb_sim_ros']['config'])['integrator'] == integrator
    assert not rec.truncated
    n = sum(1 for _ in rec.messages())
    assert _rosbags_count(f) == n  # the independent reader decodes every message
    result = _replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical: every output message re-simulated bit for bit' in result.stdout
    kinds = {t.rsplit('/', 1)[-1] for t in rec.channels}
    assert {'wrench', 'set_twist', 'reset', 'pose', 'twist', 'odom'} <= kinds


def test_resimulation_is_deterministic(start_sim, probe, tmp_path):
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'record:={f}')
    _drive(probe, n_wrenches=3)
    sim.stop()
    # The node says that it records, and where the file is once it is finished.
    out = sim.output()
    assert f"recording to '{f}'" in out and f"recording finished: '{f}'" in out, out
    assert 'body (1 kg)' in out, out
    # resimulate() refills one message per kind: keep copies.
    runs = [[(*r[:4], copy.deepcopy(r[4])) for r in replay.resimulate(replay.load(str(f)))]
            for _ in range(3)]
    assert len(runs[0]) > 30
    for a, b, c in zip(*runs):
        kind, recorded = a[1], a[3]
        assert replay.identical(kind, a[4], b[4]) and replay.identical(kind, b[4], c[4])
        assert replay.identical(kind, a[4], recorded)


def _scripted_run(start_sim, probe, path):
    """Inputs while paused take effect at once: the same script gives the same steps."""
    sim = start_sim('-p', f'record:={path}', '-p', 'start_paused:=true')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, 'wrench')
    for i in range(3):
        pub.publish(_wrench(1.0 + i, -0.02 * i))
        probe.wait_for(lambda: len(applied) > i, what=f'wrench {i}')
        for _ in range(4):
            assert probe.call(Trigger, 'step', Trigger.Request()).success
    sim.stop()
    return [(t.rsplit('/', 1)[-1], m) for t, m, *_ in RecordingReader(str(path)).messages()
            if not t.startswith('/rb_sim/input/') and t != RUN_DEFINITION]


def test_two_runs_with_inputs_at_the_same_steps_record_identical_outputs(start_sim, probe,
                                                                         tmp_path):
    first = _scripted_run(start_sim, probe, tmp_path / 'run0.mcap')
    second = _scripted_run(start_sim, probe, tmp_path / 'run1.mcap')
    # pose, twist, odom, imu, accel and /tf at step 0 and after each of 12 steps
    assert len(first) == len(second) == 6 * (1 + 12)
    assert {k for k, _ in first} == {'pose', 'twist', 'odom', 'imu', 'accel', 'tf'}
    assert all(replay.identical(k, a, b) for (k, a), (_, b) in zip(first, second))


def test_sigterm_finalises_the_recording(start_sim, probe, tmp_path):
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'record:={f}')
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: len(poses) > 20, what='poses')
    sim.stop(signal.SIGTERM)
    assert not RecordingReader(str(f)).truncated
    assert _rosbags_count(f) > 60


def test_sigkill_keeps_complete_chunks_that_verify_and_recover(
        start_sim, probe, installed, ros_env, tmp_path):
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'record:={f}', '-p', 'real_time_factor:=5.0')
    _drive(probe, n_wrenches=2)
    # Wait for at least one compressed chunk (64 KiB of messages) on disk.
    probe.wait_for(lambda: os.path.getsize(f) > 8000, what='a chunk on disk', timeout=60)
    sim.stop(signal.SIGKILL)
    result = _replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'truncated recording' in result.stdout and 'identical' in result.stdout
    out = tmp_path / 'recovered.mcap'
    result = _replay(installed, ros_env, '--recover', str(f), str(out))
    assert result.returncode == 0, result.stderr
    assert _rosbags_count(out) == sum(1 for _ in RecordingReader(str(f)).messages()) > 0


def test_the_regression_fixture_still_replays_bit_for_bit(installed, ros_env):
    result = _replay(installed, ros_env, '--verify', str(FIXTURE))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical' in result.stdout


@pytest.mark.parametrize('name', ['collision_demo.mcap', 'resting_stack.mcap'])
def test_the_collision_fixtures_still_replay_bit_for_bit(installed, ros_env, name):
    """The collision demo and a resting stack (test/fixtures/make_collision_fixtures.py) pin
    the contact numerics, on any processor: the step uses no BLAS."""
    result = _replay(installed, ros_env, '--verify', str(FIXTURES / name))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical' in result.stdout


def _positions(path):
    """{body: [(t s, x, y, z, speed m/s)]} from an independent reader (rosbags)."""
    out: dict = {}
    with AnyReader([Path(path)]) as reader:
        for c, _t, raw in reader.messages():
            if c.topic.endswith('/odom'):
                m = reader.deserialize(raw, c.msgtype)
                p, v = m.pose.pose.position, m.twist.twist.linear
                t = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
                out.setdefault(c.topic.split('/')[1], []).append(
                    (t, p.x, p.y, p.z, math.sqrt(v.x * v.x + v.y * v.y + v.z * v.z)))
    return out


def test_the_collision_fixtures_hold_what_they_claim():
    """What the fixtures pin is physics, not noise: nothing sinks into the ground beyond the
    slop; the stack stands on the ground at its heights and is at rest before the push; the
    pushed top box then moves in +x and the others stay (geometric facts of the scene)."""
    demo = _positions(FIXTURES / 'collision_demo.mcap')
    for body, lowest in (('ball', 0.1), ('stack_0', 0.15), ('crate', 0.1)):
        assert min(z for _t, _x, _y, z, _v in demo[body]) > lowest - 1e-3, body
    stack = _positions(FIXTURES / 'resting_stack.mcap')
    tops = {'box_0': 0.1, 'box_1': 0.3, 'box_2': 0.5, 'box_3': 0.7, 'ball': 0.1}
    before = {b: [s for s in samples if 1.5 <= s[0] < 2.0] for b, samples in stack.items()}
    for body, z in tops.items():
        assert before[body], body
        for _t, _x, _y, zb, speed in before[body]:
            assert abs(zb - z) < 1e-3 and speed < 1e-3, (body, zb, speed)
    end = {b: samples[-1] for b, samples in stack.items()}
    assert end['box_3'][1] - before['box_3'][-1][1] > 0.01  # pushed along +x
    for body in ('box_0', 'ball'):
        assert abs(end[body][1] - before[body][-1][1]) < 1e-3, body


def test_replay_refuses_bad_files_clearly(installed, ros_env, tmp_path):
    cases = {'text.mcap': b'not a recording\n', 'empty.mcap': b'',
             'cut.mcap': FIXTURE.read_bytes()[:40]}
    for name, content in cases.items():
        f = tmp_path / name
        f.write_bytes(content)
        result = _replay(installed, ros_env, '--verify', str(f))
        assert result.returncode == 2, name
        assert result.stderr.startswith(f'replay: {f}: ') and 'Traceback' not in result.stderr
    result = _replay(installed, ros_env, '--verify', str(tmp_path / 'missing.mcap'))
    assert result.returncode == 2 and 'Traceback' not in result.stderr


def test_replay_republishes_with_clock(probe, installed, ros_env):
    expected = [m for t, m, *_ in RecordingReader(str(FIXTURE)).messages() if t == '/pose']
    poses = probe.collect(PoseStamped, 'pose', 100)
    proc = subprocess.Popen([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), str(FIXTURE),
                             '--wait', '30', '--rate', '1.0'], env=ros_env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        probe.wait_for(lambda: proc.poll() is not None, timeout=60, what='replay to finish')
        probe.wait_for(lambda: len(poses) >= len(expected), timeout=10, what='all poses')
    finally:
        proc.kill()
    assert poses == expected
    assert '100.0%' in proc.stderr.read()


def test_pause_survives_in_recordings(start_sim, probe, installed, ros_env, tmp_path):
    # Pausing and stepping are not inputs: a run with them still verifies.
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'record:={f}')
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: len(poses) > 3, what='poses')
    assert probe.call(SetBool, 'pause', SetBool.Request(data=True)).success
    pub = probe.publisher(Wrench, 'wrench')
    pub.publish(_wrench(3.0, 0.1))
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    probe.wait_for(lambda: applied, what='the wrench')
    for _ in range(3):
        assert probe.call(Trigger, 'step', Trigger.Request()).success
    assert probe.call(SetBool, 'pause', SetBool.Request(data=False)).success
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 5, what='poses after resuming')
    sim.stop()
    result = _replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_scene_recording_replays_bit_for_bit(start_sim, probe, installed, ros_env,
                                               tmp_path):
    scene = tmp_path / 'scene.yaml'
    scene.write_text('gravity: [0, 0, -9.81]\nintegrator: lie4\nbodies:\n'
                     '  - {name: a, mass: 2.0, inertia: [[0.2, 0.01, 0], [0.01, 0.3, 0], '
                     '[0, 0, 0.4]], angular_velocity: [0.1, 0.2, 0.3], '
                     'points: {nozzle: [0, 0.2, -0.1]}}\n'
                     '  - {name: b, shape: cylinder, radius: 0.1, length: 0.5, density: 800, '
                     'angular_damping: 0.2, angular_velocity: [0, 0, 5]}\n'
                     '  - {name: wall, static: true}\n')
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', f'record:={f}',
                    '-p', 'odom_pose_covariance:=[0.01, 0.01, 0.04, 0.001, 0.001, 0.002]')
    poses = probe.collect(PoseStamped, 'b/pose')
    applied = probe.collect(WrenchStamped, 'a/applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, 'a/wrench')
    at_point = probe.publisher(WrenchStamped, 'a/wrench_stamped')
    probe.wait_for(lambda: len(poses) > 3, what='poses of b')
    pub.publish(_wrench(1.0, 0.05))
    probe.wait_for(lambda: applied, what='the wrench on a')
    nozzle = WrenchStamped(wrench=_wrench(0.5, 0.0))
    nozzle.header.frame_id = 'nozzle'  # the recording carries the point and its wrench
    at_point.publish(nozzle)
    probe.wait_for(lambda: len(applied) > 1, what='the wrench at the nozzle')
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 5, what='more poses')
    sim.stop()
    rec = RecordingReader(str(f))
    # the scene's integrator (the node's parameter left empty)
    assert json.loads(rec.metadata['rb_sim_ros']['config'])['integrator'] == 'lie4'
    # odom carries the covariance set by parameter, read back by the independent reader
    with AnyReader([f]) as reader:
        odom = [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages()
                if c.topic == '/b/odom']
    assert odom and all([o.pose.covariance[7 * k] for k in range(6)]
                        == [0.01, 0.01, 0.04, 0.001, 0.001, 0.002] for o in odom)
    assert all(sum(o.twist.covariance) == 0.0 for o in odom)
    assert {'/a/pose', '/b/odom', '/rb_sim/input/a/wrench'} <= set(rec.channels)
    assert not any(t.startswith('/wall/') for t in rec.channels)  # a static body: nothing
    result = _replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical' in result.stdout


def test_a_collision_recording_replays_bit_for_bit(start_sim, probe, installed, ros_env,
                                                   tmp_path):
    """A ball bounces on the ground, a pushed crate slides into a wall, a teleported ball
    lands on the crate: the contacts happen in the node, and replay re-simulates them."""
    r = 0.1
    scene = tmp_path / 'scene.yaml'
    scene.write_text('gravity: [0, 0, -9.81]\ncontact: {restitution: 0.5, friction: 0.4}\n'
                     'bodies:\n'
                     f'  - {{name: ball, shape: sphere, radius: {r}, density: 500, '
                     'position: [0, 0, 0.4], colliders: shape}\n'
                     '  - {name: crate, shape: box, size: [0.3, 0.3, 0.2], density: 300, '
                     'position: [1, 0, 0.1], colliders: shape}\n'
                     '  - {name: ground, static: true, colliders: [{type: plane}]}\n'
                     '  - {name: wall, static: true, position: [1.6, 0, 0.5], '
                     'colliders: [{type: box, size: [0.1, 2, 1]}]}\n')
    f = tmp_path / 'run.mcap'
    # Paused until the probe is on the graph: the bounces are over in about a second, which
    # DDS discovery between two new processes can take.
    sim = start_sim('-p', f'scene_file:={scene}', '-p', f'record:={f}',
                    '-p', 'start_paused:=true')
    ball = probe.collect(PoseStamped, 'ball/pose')
    crate = probe.collect(PoseStamped, 'crate/pose')
    applied = probe.collect(WrenchStamped, 'crate/applied_wrench', APPLIED_QOS)
    probe.wait_for(lambda: probe.node.count_publishers('/ball/pose') >= 1
                   and probe.node.count_publishers('/crate/pose') >= 1, what='the node')
    assert probe.call(SetBool, 'pause', SetBool.Request(data=False)).success

    def bounced():
        z = [p.pose.position.z for p in ball]
        low = min(range(len(z)), key=z.__getitem__) if z else 0
        return z and z[low] < 0.15 and max(z[low:]) > z[low] + 0.02

    probe.wait_for(bounced, what='the ball bouncing')
    push = probe.publisher(Wrench, 'crate/wrench')
    push.publish(_wrench(60.0, 0.0))  # friction holds it up to 0.4 m g = 21 N
    probe.wait_for(lambda: applied, what='the push on the crate')
    probe.wait_for(lambda: crate[-1].pose.position.x > 1.3, what='the crate at the wall')
    teleport = probe.publisher(PoseStamped, 'ball/set_pose')
    above = PoseStamped()
    above.header.frame_id = 'world'
    above.pose.position.x, above.pose.position.y, above.pose.position.z = 1.4, 0.0, 0.6
    above.pose.orientation.w = 1.0
    teleport.publish(above)
    probe.wait_for(lambda: ball[-1].pose.position.x > 1.0, what='the teleport')
    n = len(ball)
    # Bounces of e = 0.5 from 0.3 m die out in about 1.2 s.
    probe.wait_for(lambda: len(ball) > n + 200, what='the ball landing on the crate')
    sim.stop()

    # What the node did, read back by the independent reader.
    z, crate_x = {}, []
    with AnyReader([f]) as reader:
        for c, t, raw in reader.messages():
            msg = reader.deserialize(raw, c.msgtype)
            if c.topic == '/ball/pose':
                z[t] = (msg.pose.position.x, msg.pose.position.z)
            elif c.topic == '/crate/pose':
                crate_x.append(msg.pose.position.x)
    assert min(p[1] for p in z.values()) > r - 1e-3            # never through the ground
    assert max(crate_x) < 1.55 - 0.15 + 1e-3                  # stopped by the wall
    on_crate = [p[1] for p in z.values() if p[0] > 1.0][-20:]
    assert all(abs(h - (0.2 + r)) < 2e-3 for h in on_crate), on_crate  # resting on the crate
    result = _replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical: every output message re-simulated bit for bit' in result.stdout


def test_a_bad_record_path_is_one_line_and_exit_2(start_sim, tmp_path):
    existing = tmp_path / 'existing.mcap'
    existing.write_bytes(b'precious')
    cases = {tmp_path / 'missing' / 'run.mcap': 'No such file or directory',
             existing: 'set record_overwrite:=true to replace it',
             existing / 'run.mcap': 'Not a directory'}
    for path, why in cases.items():
        sim = start_sim('-p', f'record:={path}')
        assert sim.proc.wait(60) == 2, sim.output()
        lines = [line for line in sim.output().splitlines() if line.strip()]
        assert lines == [line for line in lines if line.startswith('simulator: ')], lines
        assert len(lines) == 1 and str(path) in lines[0] and why in lines[0], lines
    assert existing.read_bytes() == b'precious'


def test_replay_refuses_malformed_metadata_in_one_line(installed, ros_env, tmp_path):
    from mcap.reader import make_reader
    from mcap.writer import Writer
    with open(FIXTURE, 'rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [m for _s, _c, m in reader.iter_messages()]
        meta = next(dict(m.metadata) for m in reader.iter_metadata() if m.name == 'rb_sim_ros')
    for name, change in {'deep': {'config': '[' * 200_000 + ']' * 200_000},
                         'format': {'format': '2'},
                         'tiny dt': {'config': meta['config'].replace(
                             '"dt": 0.001', f'"dt": {0.001 / (2 ** 32 + 1)!r}')}}.items():
        bad = tmp_path / f'{name}.mcap'
        with open(bad, 'wb') as f:
            w = Writer(f)
            w.start(profile='ros2', library='test')
            sids = {i: w.register_schema(s.name, s.encoding, s.data)
                    for i, s in summary.schemas.items()}
            cids = {i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                          dict(c.metadata)) for i, c in summary.channels.items()}
            for m in messages:
                w.add_message(cids[m.channel_id], m.log_time, m.data, m.publish_time,
                              m.sequence)
            w.add_metadata('rb_sim_ros', {**meta, **change})
            w.finish()
        result = _replay(installed, ros_env, '--verify', str(bad))
        assert result.returncode == 2, (name, result.stdout, result.stderr)
        assert result.stderr.startswith(f'replay: {bad}: ') and result.stderr.count('\n') == 1
        assert result.stdout == ''


def test_replay_stops_on_sigint_without_a_traceback(probe, installed, ros_env, tmp_path):
    err = tmp_path / 'stderr.txt'
    with open(err, 'w') as err_file:
        # SIGINT at its default, as a terminal gives it (under a shell's background job it is
        # inherited ignored, and Python then leaves it ignored): set by a small launcher that
        # execs the replay, not by preexec_fn, which is unsafe once rclpy's threads run.
        launcher = ('import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); '
                    'os.execv(sys.argv[1], sys.argv[1:])')
        proc = subprocess.Popen([sys.executable, '-c', launcher,
                                 str(installed / 'lib' / 'rb_sim_ros' / 'replay'), str(FIXTURE),
                                 '--rate', '0.001'], env=ros_env, stdout=subprocess.PIPE,
                                stderr=err_file, text=True)
        try:
            probe.wait_for(lambda: 'replay: publishing' in err.read_text(), timeout=60,
                           what='playback to start')
            proc.send_signal(signal.SIGINT)
            probe.wait_for(lambda: proc.poll() is not None, timeout=60, what='replay to stop')
        finally:
            proc.kill()
            proc.wait()
    text = err.read_text()
    assert proc.returncode == 130, text
    assert 'Traceback' not in text and text.rstrip().endswith('replay: interrupted'), text


def test_a_first_start_steps_while_compiling_and_records_the_compiled_bits(
        probe, installed, ros_env, tmp_path):
    """No compiled kernels in the cache (a first start from a source checkout): two balls
    bouncing on the ground move before their kernels are compiled, stepped in the interpreter
    while a child process compiles them; then the node goes on compiled, and the recording of
    both tiers replays bit for bit (replay steps compiled only). (Two contact tests, whose
    part compiles in a minute; the scene's eight took 15 minutes of a loaded CI.)"""
    env = dict(ros_env, NUMBA_CACHE_DIR=str(tmp_path / 'cache'))  # empty: nothing compiled
    env.pop('RB_SIM_ROS_CONTACT_TESTS', None)  # as a user's: the scene's own tests (conftest)
    f = tmp_path / 'run.mcap'
    scene = tmp_path / 'balls.yaml'
    scene.write_text(
        'gravity: [0.0, 0.0, -9.81]\n'
        'contact: {restitution: 0.9, friction: 0.5}\n'
        'bodies:\n'
        '  - {name: a, shape: sphere, radius: 0.1, density: 500.0, position: [0.0, 0.0, 1.0],\n'
        '     linear_velocity: [0.5, 0.0, 0.0], colliders: shape}\n'
        '  - {name: b, shape: sphere, radius: 0.1, density: 500.0, position: [0.6, 0.0, 1.5],\n'
        '     colliders: shape}\n'
        '  - name: ground\n'
        '    static: true\n'
        '    colliders: [{type: plane, normal: [0.0, 0.0, 1.0], offset: 0.0}]\n')
    arrivals = []  # (kind, value) in the order received: one callback thread
    probe.node.create_subscription(
        PoseArray, 'poses', lambda m: arrivals.append(('pose', stamp_ns(m.header.stamp))), 10)
    probe.node.create_subscription(DiagnosticArray, '/diagnostics', lambda m: arrivals.append(
        ('kernels', {v.key: v.value for s in m.status for v in s.values}.get('kernels'))), 10)
    sim = ros_harness.SimProcess(installed, env, ['--ros-args', '-p', f'scene_file:={scene}',
                                                  '-p', f'record:={f}'], tmp_path)

    def kernels():
        return [v for k, v in arrivals if k == 'kernels']

    probe.wait_for(lambda: 'compiled' in kernels(), timeout=900, what='compiled kernels')
    first_compiled = arrivals.index(('kernels', 'compiled'))
    before = arrivals[:first_compiled]
    assert [v for k, v in before if k == 'kernels' and not v.startswith('interpreted')] == []
    moving = [t for k, t in before if k == 'pose' and t > 0]
    assert len(moving) > 5, before  # it stepped and published while compiling
    n = len(arrivals)
    probe.wait_for(lambda: len(arrivals) > n + 100, what='poses stepped compiled')
    assert sim.stop() == 0
    log = sim.output()
    assert 'stepping in the interpreter' in log and 'stepping compiled from step' in log, log
    assert 'compiling in this process instead' not in log, log  # the child compiled them
    # The recording is as long as the compilation took (minutes of sim time, hundreds of
    # thousands of messages on a loaded machine): its check gets the compilation's bound.
    result = _replay(installed, env, '--verify', str(f), timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'identical: every output message re-simulated bit for bit' in result.stdout


def _replay_proc(installed, env, err_path, *args):
    err = open(err_path, 'w')
    proc = subprocess.Popen([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=err, text=True)
    err.close()
    return proc


def test_a_subscriber_joining_during_playback_gets_what_follows_and_the_latched_tf_static(
        probe, installed, ros_env, tmp_path):
    """As from ``ros2 bag play``: a subscriber that joins after the first messages went out
    receives the messages from then on and /tf_static (transient local, sent once at step 0).
    The run definition is not republished: the node never publishes it (it is the file's)."""
    demo = FIXTURES / 'collision_demo.mcap'
    recorded = RecordingReader(str(demo))
    poses = [m for t, m, *_ in recorded.messages('/ball/pose')]
    (static,) = [m for t, m, *_ in recorded.messages('/tf_static')]
    err = tmp_path / 'stderr.txt'
    proc = _replay_proc(installed, ros_env, err, str(demo), '--rate', '0.05', '--no-clock')
    try:
        # Joined late: after playback has started (its first line follows the first publish).
        probe.wait_for(lambda: 'replay: publishing' in err.read_text() or proc.poll() is not None,
                       timeout=120, what='playback to start')
        assert proc.poll() is None, err.read_text()
        got = probe.collect(PoseStamped, '/ball/pose')
        latched = probe.collect(TFMessage, '/tf_static', QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        probe.wait_for(lambda: len(got) >= 5 and latched, timeout=120,
                       what='poses and /tf_static after joining')
        assert probe.node.count_publishers(RUN_DEFINITION) == 0
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert latched == [static] and len(static.transforms) > 0
    first = poses.index(got[0])
    assert first > 0 and got == poses[first:first + len(got)]  # from joining on, in order


def test_replay_as_fast_as_possible_waits_for_a_keep_all_subscriber_and_drops_nothing(
        probe, installed, ros_env, tmp_path):
    """A topic recorded keep_all is republished keep_all: at --rate 0 the subscribers fall
    behind and DDS has no room (publish failed with an RCLError); replay waits for them."""
    n = 20_000  # more than DDS keeps for a subscriber that takes nothing (10,000 here)
    config = Config(dt=1e-3, steps_per_publish=1, bodies=(BodySpec('b', 1.0, (0.1, 0.2, 0.3)),))
    src = tmp_path / 'run.mcap'
    record_offline(src, config, n)
    header, schemas, channels, messages, metadata = mcap_parts(src)
    f = tmp_path / 'keep_all.mcap'
    with open(f, 'wb') as out:
        w = Writer(out)
        w.start(profile=header.profile, library=header.library)
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id], {
            **c.metadata, 'offered_qos_profiles': offered_qos_profiles(
                {'history': 'keep_all', 'depth': 0})} if c.topic == '/b/pose'
            else dict(c.metadata)) for i, c in channels.items()}
        for m in messages:
            w.add_message(cids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)
        for name, record in metadata.items():
            w.add_metadata(name, record)
        w.finish()
    assert replay.load(str(f)).qos['/b/pose']['history'] == 'keep_all'
    got = probe.collect(PoseStamped, '/b/pose', QoSProfile(
        history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE))
    err = tmp_path / 'stderr.txt'
    proc = _replay_proc(installed, ros_env, err, str(f), '--rate', '0', '--wait', '120',
                        '--no-clock')
    try:
        # The probe takes nothing (it does not spin) until the replay has had to wait.
        end = time.monotonic() + 300
        while proc.poll() is None and 'subscribers are behind' not in err.read_text():
            assert time.monotonic() < end, err.read_text()
            time.sleep(0.05)
        assert 'subscribers are behind' in err.read_text(), err.read_text()  # it had to wait
        probe.wait_for(lambda: proc.poll() is not None, timeout=300, what='replay to finish')
        probe.wait_for(lambda: len(got) >= n + 1, timeout=120, what='every pose')
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 0, err.read_text()
    assert 'Traceback' not in err.read_text()
    assert [stamp_ns(m.header.stamp) for m in got] == [k * 1_000_000 for k in range(n + 1)]
