# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
# built-msgs: tf2_msgs
"""What a ROS user expects of a simulated body, over DDS: /tf and /tf_static as tf2 has them,
frame_prefix, <body>/imu and <body>/accel against Newton, and refusals of bad noise."""

import struct
import subprocess

from geometry_msgs.msg import AccelStamped, PoseStamped, Wrench, WrenchStamped
from nav_msgs.msg import Odometry
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu
from tf2_msgs.msg import TFMessage

from rb_sim_ros.offline import replay
from rb_sim_ros.ros.simulator_node import APPLIED_QOS
from support.ros_harness import stamp_ns

STATIC = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _bits(*values) -> bytes:
    return struct.pack(f'<{len(values)}d', *values)


def _xyz(v):
    return (v.x, v.y, v.z)


def test_tf_has_jazzys_type_hash_and_the_published_poses_bit_for_bit(start_sim, probe):
    sim = start_sim('-p', 'initial_angular_velocity:=[0.3, -0.2, 1.0]',
                    '-p', 'initial_linear_velocity:=[0.5, 0.0, 0.1]')
    tfs = probe.collect(TFMessage, '/tf', QoSProfile(depth=100))
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: len(tfs) > 10 and len(poses) > 10, what='/tf and poses')
    infos = probe.node.get_publishers_info_by_topic('/tf')
    assert len(infos) == 1 and infos[0].topic_type == 'tf2_msgs/msg/TFMessage'
    # The hash rosbags computes from Jazzy's own definition: real tf2 listeners match it.
    jazzy = get_typestore(Stores.ROS2_JAZZY).hash_rihs01('tf2_msgs/msg/TFMessage')
    assert str(infos[0].topic_type_hash) == jazzy
    by_stamp = {stamp_ns(p.header.stamp): p for p in poses}
    matched = 0
    for msg in tfs:
        assert len(msg.transforms) == 1
        t = msg.transforms[0]
        assert (t.header.frame_id, t.child_frame_id) == ('world', 'base_link')
        pose = by_stamp.get(stamp_ns(t.header.stamp))
        if pose is None:
            continue
        matched += 1
        r, o = t.transform.rotation, pose.pose.orientation
        assert _bits(*_xyz(t.transform.translation)) == _bits(*_xyz(pose.pose.position))
        assert _bits(r.x, r.y, r.z, r.w) == _bits(o.x, o.y, o.z, o.w)
    assert matched > 5
    stamps = [stamp_ns(m.transforms[0].header.stamp) for m in tfs]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)  # sim time, each once
    sim.stop()


def test_static_bodies_once_on_tf_static_and_frame_prefix_everywhere(
        start_sim, probe, tmp_path):
    scene = tmp_path / 'scene.yaml'
    scene.write_text('bodies:\n  - {name: a, mass: 1.0, inertia: [0.1, 0.2, 0.3], '
                     'angular_velocity: [0, 0, 1]}\n'
                     '  - {name: wall, static: true, position: [2.0, -1.0, 0.5], '
                     'orientation: [0, 0, 0.6, 0.8]}\n')
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'frame_prefix:=sim1/')
    odom = probe.collect(Odometry, 'a/odom')
    imu = probe.collect(Imu, 'a/imu')
    tfs = probe.collect(TFMessage, '/tf', QoSProfile(depth=100))
    probe.wait_for(lambda: odom and imu and tfs, what='odom, imu and /tf of a')
    # A late subscriber still gets the static transforms (transient local), exactly once.
    static = probe.collect(TFMessage, '/tf_static', STATIC)
    probe.wait_for(lambda: static, what='/tf_static')
    n = len(odom)
    probe.wait_for(lambda: len(odom) > n + 20, what='more odom')
    assert len(static) == 1 and len(static[0].transforms) == 1
    t = static[0].transforms[0]
    assert (t.header.frame_id, t.child_frame_id) == ('world', 'sim1/wall')
    assert _xyz(t.transform.translation) == (2.0, -1.0, 0.5)
    assert pytest.approx(_xyz(t.transform.rotation) + (t.transform.rotation.w,)) == \
        (0, 0, 0.6, 0.8)
    assert stamp_ns(t.header.stamp) == 0
    assert all([x.child_frame_id for x in m.transforms] == ['sim1/a'] for m in tfs)
    assert odom[-1].child_frame_id == 'sim1/a' and imu[-1].header.frame_id == 'sim1/a'
    assert odom[-1].header.frame_id == 'world'
    # A static body has no imu or accel: it never moves.
    assert probe.node.get_publishers_info_by_topic('/wall/imu') == []
    # The prefixed body frame is the body's frame for a wrench too.
    applied = probe.collect(WrenchStamped, 'a/applied_wrench', APPLIED_QOS)
    pub = probe.publisher(WrenchStamped, 'a/wrench_stamped')
    msg = WrenchStamped()
    msg.header.frame_id = 'sim1/a'
    msg.wrench.force.x = 1.0
    pub.publish(msg)
    probe.wait_for(lambda: any(w.wrench.force.x == 1.0 for w in applied), what='the wrench')
    assert [w.header.frame_id for w in applied if w.wrench.force.x == 1.0] == ['sim1/a']
    sim.stop()


def test_imu_and_accel_read_newton_and_euler_and_no_tf_when_asked(start_sim, probe):
    """2 kg, 0.1 kg m^2 about every axis, turned 90 degrees about z; F = (2, 0, 0) N and
    tau = (0, 0, 0.05) N m in the world: a = (1, 0, 0), beta = (0, 0, 0.5) (world), the IMU
    reads R^T a (about (0, -1, 0)) with no gravity, and its gyro the body-frame twist bit for
    bit."""
    sim = start_sim('-p', 'mass:=2.0', '-p', 'initial_orientation:=[0.0, 0.0, 0.7071067811865476, '
                    '0.7071067811865476]', '-p', 'publish_tf:=false', '-p', 'command_timeout:=0.0',
                    '-p', 'imu_gyro_noise:=0.0')
    imu = probe.collect(Imu, 'imu')
    accel = probe.collect(AccelStamped, 'accel')
    odom = probe.collect(Odometry, 'odom')
    probe.wait_for(lambda: imu and accel and odom, what='imu, accel and odom')
    assert accel[-1].accel.linear.x == 0.0 and imu[-1].linear_acceleration.y == 0.0  # at rest
    pub = probe.publisher(Wrench, 'wrench')
    w = Wrench()
    w.force.x, w.torque.z = 2.0, 0.05
    pub.publish(w)
    probe.wait_for(lambda: accel[-1].accel.linear.x > 0, what='the wrench')
    n = len(imu)
    probe.wait_for(lambda: len(imu) > n + 10 and len(odom) > n + 10, what='more samples')
    a = accel[-1]
    assert a.header.frame_id == 'world'
    assert _xyz(a.accel.linear) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)
    assert _xyz(a.accel.angular) == pytest.approx((0.0, 0.0, 0.5), abs=1e-12)
    sample = imu[-1]
    assert sample.header.frame_id == 'base_link'
    q = sample.orientation
    body = Rotation.from_quat([q.x, q.y, q.z, q.w]).inv().apply([1.0, 0.0, 0.0])
    assert _xyz(sample.linear_acceleration) == pytest.approx(tuple(body), abs=1e-12)
    assert body[1] < -0.99  # about (0, -1, 0): it has turned a little since the push
    # odom of the same publish (two topics: it may arrive after the imu sample)
    at = stamp_ns(sample.header.stamp)
    probe.wait_for(lambda: any(stamp_ns(o.header.stamp) == at for o in odom),
                   what='the odom published with the imu sample')
    o = next(o for o in odom if stamp_ns(o.header.stamp) == at)
    assert _bits(*_xyz(sample.angular_velocity)) == _bits(*_xyz(o.twist.twist.angular))
    p = o.pose.pose.orientation
    assert _bits(q.x, q.y, q.z, q.w) == _bits(p.x, p.y, p.z, p.w)
    assert list(sample.angular_velocity_covariance) == [0.0] * 9
    assert probe.node.get_publishers_info_by_topic('/tf') == []  # publish_tf:=false
    sim.stop()


def test_imu_noise_fills_the_covariances_and_moves_the_readings(start_sim, probe):
    sim = start_sim('-p', 'imu_gyro_noise:=0.01', '-p', 'imu_accel_noise:=0.2',
                    '-p', 'imu_seed:=5')
    imu = probe.collect(Imu, 'imu')
    probe.wait_for(lambda: len(imu) > 50, what='imu samples')
    sample = imu[-1]
    assert list(sample.angular_velocity_covariance) == pytest.approx(
        [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4])
    assert list(sample.linear_acceleration_covariance) == pytest.approx(
        [0.04, 0, 0, 0, 0.04, 0, 0, 0, 0.04])
    # At rest: the readings are the noise alone, around 0 with the asked spread.
    accel_z = [m.linear_acceleration.z for m in imu]
    mean = sum(accel_z) / len(accel_z)
    spread = (sum((a - mean) ** 2 for a in accel_z) / (len(accel_z) - 1)) ** 0.5
    assert 0.1 < spread < 0.3 and abs(mean) < 0.15
    sim.stop()


@pytest.mark.parametrize('param, value', [
    ('imu_gyro_noise', '.nan'), ('imu_accel_bias_walk', '-1.0'), ('imu_seed', '-3'),
    ('frame_prefix', "'/abs'"), ('publish_tf', "'yes'")])
def test_bad_sensor_parameters_exit_with_one_line(start_sim, param, value):
    sim = start_sim('-p', f'{param}:={value}')
    assert sim.proc.wait(120) == 2
    out = sim.output()
    assert param in out and 'Traceback' not in out


def test_a_recording_with_imu_noise_tf_and_contacts_replays_bit_for_bit(
        start_sim, probe, installed, ros_env, tmp_path):
    """A ball bounces with a noisy IMU; /tf, /tf_static, imu and accel are recorded, read back
    by an independent reader (rosbags) and re-simulated bit for bit; with another seed the
    IMU no longer matches (verify does look at it)."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text('gravity: [0, 0, -9.81]\ncontact: {restitution: 0.5}\nbodies:\n'
                     '  - {name: ball, shape: sphere, radius: 0.1, density: 500, '
                     'position: [0, 0, 0.4], colliders: shape}\n'
                     '  - {name: ground, static: true, colliders: [{type: plane}]}\n')
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', f'record:={f}', '-p',
                    'frame_prefix:=r/', '-p', 'imu_gyro_noise:=0.01', '-p',
                    'imu_accel_noise:=0.1', '-p', 'imu_accel_bias_walk:=0.05', '-p',
                    'imu_seed:=11')
    imu = probe.collect(Imu, 'ball/imu')
    # 2.5 s: it bounces (e = 0.5) to rest in about 1.1 s
    probe.wait_for(lambda: len(imu) > 250, what='the ball bouncing to rest')
    sim.stop()
    z, force, tf_z, static = {}, {}, {}, []
    with AnyReader([f]) as reader:
        for c, t, raw in reader.messages():
            msg = reader.deserialize(raw, c.msgtype)
            if c.topic == '/ball/pose':
                z[t] = msg.pose.position.z
            elif c.topic == '/ball/imu':
                force[t] = msg.linear_acceleration.z
            elif c.topic == '/tf':
                assert [x.child_frame_id for x in msg.transforms] == ['r/ball']
                tf_z[t] = msg.transforms[0].transform.translation.z
            elif c.topic == '/tf_static':
                static.append(msg)
    assert tf_z == z  # /tf is the published pose
    assert len(static) == 1 and static[0].transforms[0].child_frame_id == 'r/ground'
    # In free fall the accelerometer reads noise around 0; at rest on the ground, +g.
    falling = [a for t, a in force.items() if t < 150_000_000]  # it lands at 0.24 s
    resting = [a for t, a in sorted(force.items())[-20:]]
    assert all(abs(a) < 0.6 for a in falling)
    assert sum(resting) / len(resting) == pytest.approx(9.81, abs=0.3)
    result = ros_harness_replay(installed, ros_env, '--verify', str(f))
    assert result.returncode == 0, result.stdout + result.stderr
    assert '/tf ' in result.stdout and '/ball/imu' in result.stdout
    rec = replay.load(str(f))
    rec.parameters['imu_seed'] = 12
    differ = {kind for _s, kind, _t, msg, mine, _l in replay.resimulate(rec)
              if not replay.identical(kind, msg, mine)}
    assert differ == {'imu'}


def ros_harness_replay(installed, env, *args):
    return subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), *args], env=env,
                          capture_output=True, text=True, timeout=600)
