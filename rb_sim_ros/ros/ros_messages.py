# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Conversions between ROS messages and the core's values, shared by the node and replay.

Output messages are filled in place (``OutputMessages.fill``) so that the node allocates nothing
per publish, and so that replay rebuilds exactly the bytes the node published from the same
state. Conventions (REP-103, REP-105): pose in ``world_frame`` (default ``odom``); twist in
the body frame ``body_frame`` (default ``base_link``) as nav_msgs/Odometry requires for its
twist, or in the world frame if ``twist_frame`` is 'world'.
"""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import AccelStamped, PoseStamped, TransformStamped, Twist, \
    Wrench as WrenchMsg
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import Imu

from rb_sim_ros.core import so3
from rb_sim_ros.core.rigid_body import Frame, Wrench
from rb_sim_ros.ros import output_kinds
from rb_sim_ros.sim.imu import specific_force

# tf2's topics (absolute: tf2_ros listens there whatever the node's namespace).
TF, TF_STATIC = '/tf', '/tf_static'


def time_msg(time_ns: int) -> Time:
    return Time(sec=time_ns // 1_000_000_000, nanosec=time_ns % 1_000_000_000)


def set_stamp(stamp: Time, time_ns: int) -> None:
    """Set ``stamp`` (a builtin_interfaces/Time) to ``time_ns`` in place (a new Time costs
    more than the message it stamps)."""
    stamp.sec, stamp.nanosec = divmod(time_ns, 1_000_000_000)


def wrench_from_msg(msg: WrenchMsg, frame: Frame, max_wrench: float) -> Wrench:
    """A core Wrench from a geometry_msgs/Wrench (N, N m) in ``frame``.

    Raises ValueError naming what is wrong: a non-finite component, or a force or torque whose
    norm exceeds ``max_wrench``.
    """
    f = (msg.force.x, msg.force.y, msg.force.z)
    t = (msg.torque.x, msg.torque.y, msg.torque.z)
    check_wrench(f, t, max_wrench)
    return Wrench(f, t, frame)


def wrench_at_point(msg: WrenchMsg, point, max_wrench: float) -> Wrench:
    """The body-frame wrench at the centre of mass of a geometry_msgs/Wrench given in the
    frame of an application point at ``point`` (m, body frame; axes those of the body)."""
    return wrench_at((msg.force.x, msg.force.y, msg.force.z),
                     (msg.torque.x, msg.torque.y, msg.torque.z), point, max_wrench)


def wrench_at(f: tuple, t: tuple, point, max_wrench: float) -> Wrench:
    """``wrench_at_point`` of force ``f`` and torque ``t`` (3-tuples): the force, and the
    torque plus point x force. Both what is given and the result are checked as
    ``check_wrench``."""
    check_wrench(f, t, max_wrench)
    rx, ry, rz = point
    moment = (t[0] + ry * f[2] - rz * f[1], t[1] + rz * f[0] - rx * f[2],
              t[2] + rx * f[1] - ry * f[0])
    check_wrench(f, moment, max_wrench)
    return Wrench(f, moment, Frame.BODY)


def check_wrench(force, torque, max_wrench: float) -> None:
    """ValueError naming what is wrong unless force (N) and torque (N m) are finite with norms
    <= ``max_wrench``. The norm is math.hypot's, which does not overflow: a finite component
    of 1e200 is over the limit, not an OverflowError."""
    f, t = tuple(force), tuple(torque)
    for c in f + t:
        if not isinstance(c, float) or not math.isfinite(c):
            raise ValueError(f'non-finite wrench: force {f}, torque {t}')
    norm = math.hypot(*f)
    if not norm <= max_wrench:
        raise ValueError(f'force norm {norm:.6g} exceeds max_wrench {max_wrench:.6g}')
    norm = math.hypot(*t)
    if not norm <= max_wrench:
        raise ValueError(f'torque norm {norm:.6g} exceeds max_wrench {max_wrench:.6g}')


# R v (or R^T v) for R given as 9 row-major floats.
rotate = so3.mul9_vec


# 9 row-major floats of the rotation of a unit quaternion (x, y, z, w).
rotation_from_quaternion = so3.rotation9_from_unit_quaternion


class OutputMessages:
    """The published PoseStamped, Twist and Odometry (``fill``), Imu and AccelStamped
    (``fill_motion``), filled in place from a state."""

    def __init__(self, world_frame: str = 'world', body_frame: str = 'base_link',
                 twist_frame: str = 'body', pose_covariance=None,
                 twist_covariance=None, imu_noise=None, kinds=None) -> None:
        """``kinds``: the messages read after a fill (None: all five, as the node publishes
        them); the others are left as they are (offline/closed_loop: what it records and
        its laws read). odom's pose is the PoseStamped's: both are filled if either is.
        ``last``: the numbers of the last ``fill`` (time ns, position, quaternion x-y-z-w,
        body-frame linear and angular velocity: odom's), filled or not."""
        self.kinds = frozenset(output_kinds.NAMES if kinds is None else kinds)
        self.last: tuple = (0, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3)
        self.pose = PoseStamped()
        self.twist = Twist()
        self.odom = Odometry()
        self.imu = Imu()
        self.accel = AccelStamped()
        self.configure(world_frame, body_frame, twist_frame, pose_covariance,
                       twist_covariance, imu_noise)

    def configure(self, world_frame: str, body_frame: str, twist_frame: str,
                  pose_covariance=None, twist_covariance=None, imu_noise=None) -> None:
        """Frames, odom's covariances (36 row-major floats each; None: zeros) and the IMU's
        (from ``imu_noise``, a sim.imu.ImuNoise: the white noise's variances on the
        diagonal; None: zeros)."""
        self.pose.header.frame_id = world_frame
        self.odom.header.frame_id = world_frame
        self.odom.child_frame_id = body_frame
        self.imu.header.frame_id = body_frame
        self.accel.header.frame_id = world_frame
        gyro = imu_noise.gyro_noise ** 2 if imu_noise is not None else 0.0
        acc = imu_noise.accel_noise ** 2 if imu_noise is not None else 0.0
        self.imu.angular_velocity_covariance = [gyro, 0.0, 0.0, 0.0, gyro, 0.0, 0.0, 0.0, gyro]
        self.imu.linear_acceleration_covariance = [acc, 0.0, 0.0, 0.0, acc, 0.0, 0.0, 0.0, acc]
        self.twist_in_body = Frame.parse(twist_frame) is Frame.BODY
        zeros = (0.0,) * 36
        self.odom.pose.covariance = list(pose_covariance or zeros)
        self.odom.twist.covariance = list(twist_covariance or zeros)

    def fill(self, time_ns: int, position, quaternion_xyzw, linear_velocity,
             angular_velocity, rotation=None) -> bool:
        """Fill all three from a world-frame state at ``time_ns`` (sim time, ns). False if a
        body-frame velocity overflowed (|v| near 1e308): then nothing must be sent.
        ``rotation``: ``rotation_from_quaternion(quaternion_xyzw)`` if the caller has it."""
        r = rotation or rotation_from_quaternion(quaternion_xyzw)
        lin_b = rotate(r, linear_velocity, transpose=True)
        ang_b = rotate(r, angular_velocity, transpose=True)
        self.last = (time_ns, position, quaternion_xyzw, lin_b, ang_b)
        kinds = self.kinds
        if 'twist' in kinds:
            lin, ang = (lin_b, ang_b) if self.twist_in_body else \
                (linear_velocity, angular_velocity)
            t = self.twist
            t.linear.x, t.linear.y, t.linear.z = lin
            t.angular.x, t.angular.y, t.angular.z = ang
        if 'pose' in kinds or 'odom' in kinds:
            pose = self.pose.pose
            pose.position.x, pose.position.y, pose.position.z = position
            o = pose.orientation
            o.x, o.y, o.z, o.w = quaternion_xyzw
            stamp = time_msg(time_ns)  # (new each time: a law in-process may keep the old one)
            self.pose.header.stamp = stamp
            self.odom.header.stamp = stamp
            self.odom.pose.pose = pose
            ot = self.odom.twist.twist
            ot.linear.x, ot.linear.y, ot.linear.z = lin_b
            ot.angular.x, ot.angular.y, ot.angular.z = ang_b
        return all(map(math.isfinite, lin_b + ang_b))

    def fill_motion(self, time_ns: int, quaternion_xyzw, angular_velocity, linear_acceleration,
                    angular_acceleration, gravity, imu_offsets=None, rotation=None) -> bool:
        """Fill the Imu (body frame: orientation, angular velocity and specific force a - g,
        plus ``imu_offsets`` = (gyro, accel) noise, body frame) and the AccelStamped (world
        frame) from a world-frame state and its accelerations at ``time_ns``. False if a value
        is not finite: then nothing must be sent. ``rotation``: as ``fill``'s."""
        r = rotation or rotation_from_quaternion(quaternion_xyzw)
        gyro = rotate(r, angular_velocity, transpose=True)
        force = rotate(r, specific_force(linear_acceleration, gravity), transpose=True)
        if imu_offsets is not None:
            (g0, g1, g2), (f0, f1, f2) = imu_offsets
            gyro = (gyro[0] + g0, gyro[1] + g1, gyro[2] + g2)
            force = (force[0] + f0, force[1] + f1, force[2] + f2)
        stamp = time_msg(time_ns)
        if 'imu' in self.kinds:
            imu = self.imu
            imu.header.stamp = stamp
            o = imu.orientation
            o.x, o.y, o.z, o.w = quaternion_xyzw
            w, a = imu.angular_velocity, imu.linear_acceleration
            w.x, w.y, w.z = gyro
            a.x, a.y, a.z = force
        if 'accel' in self.kinds:
            acc = self.accel
            acc.header.stamp = stamp
            lin, ang = acc.accel.linear, acc.accel.angular
            lin.x, lin.y, lin.z = linear_acceleration
            ang.x, ang.y, ang.z = angular_acceleration
        return all(map(math.isfinite, gyro + force + tuple(linear_acceleration)
                       + tuple(angular_acceleration)))


def tf_qos(topic: str) -> QoSProfile:
    """A new profile for ``topic`` as tf2_ros's broadcasters offer it: /tf_static transient
    local, depth 1 (a late listener gets it); /tf depth 100. New each time: rclpy writes QoS
    overrides into the profile it is given."""
    if topic == TF_STATIC:
        return QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    return QoSProfile(depth=100)


def tf_message(msg_type, parent: str, children) -> object:
    """A tf2_msgs/TFMessage (``msg_type``: that class) with a transform parent -> child for
    each child frame, in order; ``fill_tf`` fills their stamps and poses."""
    msg = msg_type()
    for child in children:
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = parent, child
        msg.transforms.append(t)
    return msg


def fill_tf(msg, time_ns: int, poses) -> None:
    """Stamp every transform of ``msg`` with ``time_ns`` and set it from ``poses``, one
    (position, quaternion x-y-z-w) each in order: the published PoseStamped's values, bit for
    bit."""
    stamp = time_msg(time_ns)
    for t, (position, quaternion_xyzw) in zip(msg.transforms, poses):
        t.header.stamp = stamp
        tr, q = t.transform.translation, t.transform.rotation
        tr.x, tr.y, tr.z = position
        q.x, q.y, q.z, q.w = quaternion_xyzw
