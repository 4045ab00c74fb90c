# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""What a hostile or careless user sends never kills, hangs or poisons the node (issue 11)."""

import math
import random
import signal
import subprocess
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, Twist, Wrench, WrenchStamped
from nav_msgs.msg import Odometry
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import Imu
from std_srvs.srv import Empty, SetBool, Trigger

from rb_sim_ros.ros.simulator_node import APPLIED_QOS
from support.ros_harness import stamp_ns


def _value(v) -> ParameterValue:
    if isinstance(v, bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=v)
    if isinstance(v, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=v)
    if isinstance(v, float):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v)
    if isinstance(v, str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=v)
    return ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY,
                          double_array_value=[float(c) for c in v])


def _set(probe, **values):
    req = SetParameters.Request()
    req.parameters = [Parameter(name=k, value=_value(v)) for k, v in values.items()]
    return probe.call(SetParameters, 'rb_sim/set_parameters', req).results


def _wrench(f, t=(0.0, 0.0, 0.0)):
    m = Wrench()
    m.force.x, m.force.y, m.force.z = f
    m.torque.x, m.torque.y, m.torque.z = t
    return m


def _finite(msg) -> bool:
    if isinstance(msg, PoseStamped):
        p, o = msg.pose.position, msg.pose.orientation
        vals = (p.x, p.y, p.z, o.x, o.y, o.z, o.w)
    elif isinstance(msg, Odometry):
        p, o, t = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist
        vals = (p.x, p.y, p.z, o.x, o.y, o.z, o.w, t.linear.x, t.linear.y, t.linear.z,
                t.angular.x, t.angular.y, t.angular.z)
    else:
        vals = (msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y,
                msg.angular.z)
    return all(math.isfinite(v) for v in vals)


@pytest.mark.parametrize('args, name', [
    (('-p', 'inertia:=5'), 'inertia'),
    (('-p', 'initial_position:=5'), 'initial_position'),
    (('-p', 'record:=5'), 'record'),
    (('-p', 'scene_file:=5'), 'scene_file'),
    (('-p', 'dt:=1e-300'), 'dt'),
    (('-p', 'mass:=true'), 'mass'),
    (('-p', 'max_catchup:=0.5'), 'max_catchup'),
    (('-p', 'real_time_factor:=1e-300'), 'real_time_factor'),
    (('-p', 'start_paused:=1'), 'start_paused'),
    (('-p', 'dt:=1e-9', '-p', 'publish_rate:=0.001'), 'steps a period'),
    (('-p', 'record:=/nonexistent-dir/run.mcap'), 'nonexistent-dir'),
])
def test_bad_startup_values_are_one_line_and_exit_2(start_sim, args, name):
    sim = start_sim(*args)
    assert sim.proc.wait(60) == 2
    out = sim.output()
    assert name in out and 'Traceback' not in out, out
    assert len(out.strip().splitlines()) == 1, out


def test_bad_runtime_values_are_refused_and_the_node_keeps_stepping(start_sim, probe):
    start_sim()
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: poses, what='a pose')
    for name, value in (('initial_position', 5), ('max_catchup', 0.5),
                        ('real_time_factor', 1e-300), ('command_timeout', True),
                        ('max_wrench', 'big'), ('initial_orientation', [0.0, 0.0, 0.0, 0.0]),
                        ('wrench_frame', 3)):
        (result,) = _set(probe, **{name: value})
        assert not result.successful and name in result.reason, (name, result.reason)
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 5, what='poses after the refusals')


def test_a_huge_finite_wrench_is_rejected_not_fatal(start_sim, probe):
    sim = start_sim('-p', 'command_timeout:=0.0')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    poses = probe.collect(PoseStamped, 'pose')
    pub = probe.publisher(Wrench, 'wrench')
    pub.publish(_wrench((1.4e154, 0.0, 0.0)))
    pub.publish(_wrench((0.0, 0.0, 0.0), (1e300, 1e300, 0.0)))
    pub.publish(_wrench((0.0, 2.0, 0.0)))
    probe.wait_for(lambda: applied, what='the good wrench')
    assert applied[0].wrench.force.y == 2.0 and len(applied) == 1
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 3, what='poses after the huge wrenches')
    assert sim.proc.poll() is None
    assert 'exceeds max_wrench' in sim.output()


def test_a_timeout_shorter_than_a_step_still_times_out(start_sim, probe):
    start_sim('-p', 'command_timeout:=1e-13')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, 'wrench')
    pub.publish(_wrench((1.0, 0.0, 0.0)))
    probe.wait_for(lambda: len(applied) >= 2, what='the command and its timeout')
    cmd, zero = applied[:2]
    assert cmd.wrench.force.x == 1.0 and zero.wrench == Wrench()
    # Checked at the start of each 10-step period: the next one.
    assert stamp_ns(zero.header.stamp) - stamp_ns(cmd.header.stamp) == 10_000_000


def test_an_integration_error_pauses_with_an_error_and_reset_goes_on(start_sim, probe):
    """A 1e-10 kg body under 1e300 N: the step overflows. Nothing non-finite is published,
    /diagnostics says ERROR, set_twist does not kill the node, reset clears it and runs."""
    sim = start_sim('-p', 'mass:=1e-10', '-p', 'max_wrench:=1e301', '-p',
                    'command_timeout:=0.0')
    poses = probe.collect(PoseStamped, 'pose')
    odoms = probe.collect(Odometry, 'odom')
    # Heard: the publish after the failed step then finds the acceleration not finite too.
    probe.collect(Imu, 'imu')
    diags = probe.collect(DiagnosticArray, '/diagnostics')
    probe.wait_for(lambda: poses, what='a pose')
    probe.publisher(Wrench, 'wrench').publish(_wrench((1e300, 0.0, 0.0)))
    probe.wait_for(lambda: any(d.status[0].level == DiagnosticStatus.ERROR for d in diags),
                   what='an ERROR in /diagnostics')
    # The cause, the integration's error (a step became non-finite, from v and omega), not
    # what followed from it (the publish after it found the acceleration not finite).
    error = next(d.status[0].message for d in diags
                 if d.status[0].level == DiagnosticStatus.ERROR)
    assert 'became non-finite at step' in error and 'from v = ' in error, error
    assert 'has a non-finite state' not in error, error
    probe.publisher(Twist, 'set_twist').publish(Twist())
    time_at_error = stamp_ns(poses[-1].header.stamp)
    probe.call(Empty, 'reset', Empty.Request())
    probe.wait_for(lambda: stamp_ns(poses[-1].header.stamp) > time_at_error + 50_000_000,
                   what='stepping again after reset')
    n = len(diags)
    probe.wait_for(lambda: len(diags) > n and diags[-1].status[0].level == DiagnosticStatus.OK,
                   what='/diagnostics OK again')
    assert all(_finite(m) for m in poses + odoms)
    assert sim.proc.poll() is None
    assert sim.output().count('paused at the last finite state') == 1


@pytest.mark.parametrize('override', [
    'qos_overrides./clock.publisher.reliability:=sometimes',
    'qos_overrides./tf.publisher.depth:=-1',
    'qos_overrides./poses.publisher.durability:=forever',
    'qos_overrides./diagnostics.publisher.depth:=99999999999',
])
def test_a_start_refused_for_its_qos_never_touches_the_recording(start_sim, tmp_path, override):
    """Refused in one line; an existing file is the same bytes after (record_overwrite
    truncated it), and without one no file is left (one of 32 kB blocked the corrected
    command)."""
    kept = tmp_path / 'kept.mcap'
    data = bytes(range(256)) * 64
    kept.write_bytes(data)
    fresh = tmp_path / 'fresh.mcap'
    for f, more in ((kept, ('-p', 'record_overwrite:=true')), (fresh, ())):
        sim = start_sim('-p', f'record:={f}', *more, '-p', override)
        assert sim.proc.wait(60) == 2
        out = sim.output()
        assert len(out.strip().splitlines()) == 1 and 'qos_overrides' in out, out
        assert 'Traceback' not in out, out
    assert kept.read_bytes() == data
    assert not fresh.exists()


def test_sigint_at_full_speed_exits_0_and_the_recording_verifies(start_sim, probe,
                                                                 installed, ros_env, tmp_path):
    out = tmp_path / 'run.mcap'
    sim = start_sim('-p', 'real_time_factor:=0.0', '-p', f'record:={out}')
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: len(poses) > 50, what='poses')
    pub = probe.publisher(Wrench, 'wrench')
    for k in range(20):
        pub.publish(_wrench((0.1 * k, 0.0, 0.0), (0.0, 0.0, 0.01)))
    probe.wait_for(lambda: len(poses) > 200, what='more poses')
    assert sim.stop(signal.SIGINT, timeout=60) == 0
    log = sim.output()
    assert 'Traceback' not in log and 'FATAL' not in log and 'RCLError' not in log, log
    result = subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), '--verify',
                             str(out)], env=ros_env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_sigterm_while_a_large_scene_starts_exits_cleanly(start_sim, tmp_path):
    scene = tmp_path / 'many.yaml'
    scene.write_text('bodies:\n' + ''.join(
        f'  - {{name: b{i}, mass: 1.0, inertia: [0.1, 0.1, 0.1], position: [{i}, 0, 0]}}\n'
        for i in range(3000)))
    sim = start_sim('-p', f'scene_file:={scene}')
    # Signalled once it is reading the scene: a signal during Python's imports, before the node
    # runs at all, ends the process as the default action does (a loaded CI machine took
    # longer than the fixed 1.5 s this waited).
    end = time.monotonic() + 300.0
    while 'reading the scene' not in sim.output():
        assert sim.proc.poll() is None and time.monotonic() < end, sim.output()
        time.sleep(0.05)
    assert sim.stop(signal.SIGTERM, timeout=60) == 0
    assert 'Traceback' not in sim.output()


def test_soak_a_fuzzing_publisher(start_sim, probe, installed, ros_env, tmp_path):
    """About 15 s of random finite, infinite, NaN and huge inputs, teleports, parameter sets
    and service calls: the node stays up, publishes only finite numbers, exits 0 on SIGINT,
    and its recording verifies."""
    out = tmp_path / 'soak.mcap'
    sim = start_sim('-p', 'real_time_factor:=5.0', '-p', f'record:={out}',
                    '-p', 'max_wrench:=1e6')
    poses = probe.collect(PoseStamped, 'pose')
    odoms = probe.collect(Odometry, 'odom')
    twists = probe.collect(Twist, 'twist')
    wrench = probe.publisher(Wrench, 'wrench')
    stamped = probe.publisher(WrenchStamped, 'wrench_stamped')
    set_pose = probe.publisher(PoseStamped, 'set_pose')
    set_twist = probe.publisher(Twist, 'set_twist')
    rng = random.Random(11)
    specials = [0.0, -0.0, 1.0, -3.5, 1e6, 1e154, 1.5e154, 1e300, -1e308, math.inf, -math.inf,
                math.nan, 5e-324, 1e-300]

    def num():
        return rng.choice(specials) if rng.random() < 0.4 else rng.uniform(-20.0, 20.0)

    end = time.monotonic() + 15.0
    sent = 0
    while time.monotonic() < end:
        kind = rng.randrange(8)
        if kind == 0:
            wrench.publish(_wrench((num(), num(), num()), (num(), num(), num())))
        elif kind == 1:
            m = WrenchStamped()
            m.header.frame_id = rng.choice(['', 'world', 'body', 'base_link', 'odom', 'x', '/'])
            m.wrench = _wrench((num(), num(), num()), (num(), num(), num()))
            stamped.publish(m)
        elif kind == 2:
            m = PoseStamped()
            m.header.frame_id = rng.choice(['', 'odom', 'map'])
            p, o = m.pose.position, m.pose.orientation
            p.x, p.y, p.z = num(), num(), num()
            o.x, o.y, o.z, o.w = num(), num(), num(), num()
            set_pose.publish(m)
        elif kind == 3:
            m = Twist()
            m.linear.x, m.linear.y, m.linear.z = num(), num(), num()
            m.angular.x, m.angular.y, m.angular.z = num(), num(), num()
            set_twist.publish(m)
        elif kind == 4:
            name = rng.choice(['command_timeout', 'max_wrench', 'real_time_factor',
                               'max_catchup', 'wrench_frame', 'initial_position', 'dt'])
            value = rng.choice([num(), rng.randrange(-3, 30), True, 'body', 'world',
                                [num(), num(), num()]])
            if name == 'real_time_factor' and isinstance(value, float) and value == 0.0:
                value = 1.0  # keep the run bounded in size
            _set(probe, **{name: value})
        elif kind == 5:
            probe.call(SetBool, 'pause', SetBool.Request(data=rng.random() < 0.5))
        elif kind == 6:
            probe.call(Trigger, 'step', Trigger.Request())
        else:
            probe.call(Empty, 'reset', Empty.Request())
        sent += 1
        probe.executor.spin_once(timeout_sec=0.0)
    # The fuzz may have left the body in a state whose next step fails again (omega 1e308:
    # unpausing alone retries it) and a valid but slow real_time_factor (1e-4: 100 s a
    # period): back to the initial state and the start's rate, then the node must step on.
    (result,) = _set(probe, real_time_factor=5.0)
    assert result.successful, result.reason
    probe.call(Empty, 'reset', Empty.Request())
    probe.call(SetBool, 'pause', SetBool.Request(data=False))
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 3, what='poses after the soak')
    assert sim.proc.poll() is None
    assert sent > 100 and poses and odoms and twists
    assert all(_finite(m) for m in poses + odoms + twists)
    assert sim.stop(signal.SIGINT, timeout=60) == 0
    assert 'Traceback' not in sim.output()
    result = subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), '--verify',
                             str(out)], env=ros_env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_large_scene_gives_topics_to_the_first_bodies_and_poses_to_all(
        start_sim, probe, installed, ros_env, tmp_path):
    """Each topic is a DDS endpoint whose creation costs time against all the others: past
    max_body_topics bodies get no topics of their own, but all are on 'poses' (PoseArray)
    and the recording of the run verifies."""
    from geometry_msgs.msg import PoseArray
    scene = tmp_path / 'five.yaml'
    scene.write_text('bodies:\n' + ''.join(
        f'  - {{name: b{i}, mass: 1.0, inertia: [0.1, 0.1, 0.1], position: [{i}, 0, 0], '
        f'linear_velocity: [0, 0, {i}]}}\n' for i in range(5)))
    out = tmp_path / 'five.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'max_body_topics:=2',
                    '-p', f'record:={out}')
    arrays = probe.collect(PoseArray, 'poses')
    probe.wait_for(lambda: arrays and arrays[-1].header.stamp.sec >= 1, what='1 s of poses')
    msg = arrays[-1]
    t = stamp_ns(msg.header.stamp) * 1e-9
    assert len(msg.poses) == 5 and msg.header.frame_id == 'world'
    for i, pose in enumerate(msg.poses):  # x = i, z = i t (no gravity): exact to rounding
        assert pose.position.x == i and abs(pose.position.z - i * t) < 1e-9 * (1 + i * t)

    def topics():
        return {name for name, _types in probe.node.get_topic_names_and_types()}
    probe.wait_for(lambda: {'/b0/pose', '/b1/wrench'} <= topics(),  # discovery: one by one
                   what="the first two bodies' topics")
    topics = topics()
    assert not any(name.startswith(('/b2/', '/b3/', '/b4/')) for name in topics)
    assert sim.stop(signal.SIGINT, timeout=60) == 0
    result = subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), '--verify',
                             str(out)], env=ros_env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_full_disk_stops_the_recording_not_the_simulation(installed, ros_env, probe,
                                                            tmp_path):
    """The node's files may grow to 300 kB (RLIMIT_FSIZE, SIGXFSZ ignored: writes fail with
    EFBIG as on a full disk). The node says so once, in the log and /diagnostics, steps on,
    exits 0 on SIGINT, and `replay --recover` repairs what was written into a file that
    verifies."""
    import resource
    from diagnostic_msgs.msg import DiagnosticArray

    def limit_files():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, 300_000))

    out = tmp_path / 'full.mcap'
    env = dict(ros_env, ROS_LOG_DIR=str(tmp_path / 'log'))
    proc = subprocess.Popen([str(installed / 'lib' / 'rb_sim_ros' / 'simulator'), '--ros-args',
                             '-p', 'real_time_factor:=0.0', '-p', f'record:={out}',
                             '-p', 'initial_angular_velocity:=[0.1, 0.2, 3.0]'],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, preexec_fn=limit_files)
    try:
        poses = probe.collect(PoseStamped, 'pose')
        diags = probe.collect(DiagnosticArray, '/diagnostics')
        probe.wait_for(lambda: any('recording stopped' in d.status[0].message for d in diags),
                       what='the recording error in /diagnostics')
        assert diags[-1].status[0].level == DiagnosticStatus.ERROR
        t = stamp_ns(poses[-1].header.stamp)
        probe.wait_for(lambda: stamp_ns(poses[-1].header.stamp) > t + 1_000_000_000,
                       what='stepping on without the recording')
        proc.send_signal(signal.SIGINT)
        assert proc.wait(60) == 0
        log = proc.stdout.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert 'Traceback' not in log and log.count('recording stopped') == 1, log
    assert out.stat().st_size <= 300_000
    replay = str(installed / 'lib' / 'rb_sim_ros' / 'replay')
    fixed = tmp_path / 'fixed.mcap'
    result = subprocess.run([replay, '--recover', str(out), str(fixed)], env=ros_env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    result = subprocess.run([replay, '--verify', str(fixed)], env=ros_env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_users_pause_survives_reset_and_a_failed_step_says_so(start_sim, probe):
    """After an overflow the node is paused by the error; once the user pauses it, reset must
    not run it on, and a step that fails answers success false with the reason."""
    start_sim('-p', 'mass:=1e-10', '-p', 'max_wrench:=1e301', '-p', 'command_timeout:=0.0',
              '-p', 'start_paused:=true')
    probe.publisher(Wrench, 'wrench').publish(_wrench((1e300, 0.0, 0.0)))
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    probe.wait_for(lambda: applied, what='the huge wrench applied')
    answer = probe.call(Trigger, 'step', Trigger.Request())
    assert not answer.success and 'non-finite' in answer.message, answer.message
    assert probe.call(SetBool, 'pause', SetBool.Request(data=True)).success
    probe.call(Empty, 'reset', Empty.Request())
    answer = probe.call(Trigger, 'step', Trigger.Request())
    assert answer.success, answer.message  # still paused (else: 'not paused'), and it steps


def test_a_re_sent_identical_wrench_is_not_a_change(start_sim, probe, tmp_path):
    """A controller re-sending the wrench it holds changes nothing: neither a new
    applied_wrench nor an input of the recording (read with mcap's own reader), where each
    once counted as a change (verify's '171 inputs', the plot's '171 changes')."""
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message
    f = tmp_path / 'same.mcap'
    sim = start_sim('-p', f'record:={f}', '-p', 'command_timeout:=0.0',
                    '-p', 'start_paused:=true')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, 'wrench')
    for _ in range(12):
        pub.publish(_wrench((1.0, 0.0, 0.0)))
    pub.publish(_wrench((2.0, 0.0, 0.0)))
    probe.wait_for(lambda: any(m.wrench.force.x == 2.0 for m in applied), what='the change')
    assert sim.stop() == 0
    assert [m.wrench.force.x for m in applied] == [1.0, 2.0]
    with open(f, 'rb') as stream:
        recorded = [deserialize_message(m.data, WrenchStamped).wrench.force.x
                    for _, c, m in make_reader(stream).iter_messages()
                    if c.topic == '/rb_sim/input/body/wrench']
    assert recorded == [1.0, 2.0]
