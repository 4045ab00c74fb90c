# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ROS inputs and outputs of one simulated body, for the simulator node.

Topics are relative to ``prefix``: '' for the built-in single body (``wrench``, ``pose``, ...),
'<name>/' for each body of a scene (``<name>/wrench``, ``<name>/pose``, ...). Callbacks only
validate and turn messages into simulation events for the node's queue; they never step.
"""

from __future__ import annotations

import math
import warnings

from geometry_msgs.msg import PoseStamped, Twist, Wrench as WrenchMsg, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile
from rclpy.qos_overriding_options import QoSOverridingOptions

from rb_sim_ros.core.rigid_body import Frame, Wrench
from rb_sim_ros.ros import node_params, output_kinds, ros_messages
from rb_sim_ros.ros.lockstep import HOLD
from rb_sim_ros.sim.imu import ImuSensor
from rb_sim_ros.sim.simulation import SetPose, SetWrench

# Latched (transient local) like a state: a late subscriber still gets the recent ones.
APPLIED_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
# The deepest history DDS takes (its depth is a 32-bit int; rclpy's profile raises a
# TypeError of pybind11's for a deeper one, rcl an error for a negative one).
MAX_DEPTH = 2 ** 31 - 1


def _valid_overrides(qos: QoSProfile) -> SetParametersResult:
    """The profile of a topic after its overrides, checked before rclpy hands it to rcl: a
    keep_last history needs a depth of 1 or more (keep_all ignores it, 0 as rosbag2 writes)."""
    low = 0 if qos.history == HistoryPolicy.KEEP_ALL else 1
    if not low <= qos.depth <= MAX_DEPTH:
        return SetParametersResult(successful=False, reason=(
            f'depth must be from {low} to {MAX_DEPTH}, got {qos.depth}'))
    return SetParametersResult(successful=True)


# (rclpy warns of a zero depth as the override sets it, in three lines, before the check
# above refuses it in one.)
warnings.filterwarnings('ignore', message='A zero depth with KEEP_LAST', category=UserWarning)
# Every topic's history, depth, reliability and durability can be set by parameter, as for
# rclcpp nodes: qos_overrides./<topic>.publisher.depth:=1 (or .subscription.reliability ...).
OVERRIDABLE = QoSOverridingOptions([QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH,
                                    QoSPolicyKind.RELIABILITY, QoSPolicyKind.DURABILITY],
                                   callback=_valid_overrides)


# A body's topics, relative to its prefix: (topic, message type, what it carries). The node
# creates them from these tables, and ``simulator --help`` lists them from the same.
PUBLISHED = tuple((k.name, k.msg_type, k.what) for k in output_kinds.KINDS) + (
    ('applied_wrench', WrenchStamped, 'the wrench held, at each change (transient local)'),
)
MOVING_ONLY = output_kinds.MOTION
RECORDED = output_kinds.NAMES  # the outputs a recording holds
SUBSCRIBED = (
    ('wrench', WrenchMsg, 'wrench (N, N m) in wrench_frame, held until the next'),
    ('wrench_stamped', WrenchStamped, 'the same in its frame_id: world, the body or a point'),
    ('set_pose', PoseStamped, 'teleport to a pose in world_frame'),
    ('set_twist', Twist, 'set the velocities (twist_frame)'),
)


def stamped_wrench(wrench_msg: WrenchMsg, fid: str, world_frame: str, body_frame: str,
                   points: dict, wrench_frame: str, max_wrench: float):
    """The core Wrench of a wrench_stamped's wrench in frame ``fid`` (leading '/' stripped):
    '' is ``wrench_frame``'s, the world or the body by their frame ids (or 'world', 'body'),
    or an application point of ``points`` (force there, axes the body's). ValueError naming
    what is wrong. The node's answer to a wrench_stamped, and an in-process controller's
    (offline/closed_loop, with the message's numbers: ``wrench_in``), are made here alike."""
    f, t = wrench_msg.force, wrench_msg.torque
    return wrench_in((f.x, f.y, f.z), (t.x, t.y, t.z), fid, world_frame, body_frame, points,
                     wrench_frame, max_wrench)


def wrench_in(force: tuple, torque: tuple, fid: str, world_frame: str, body_frame: str,
              points: dict, wrench_frame: str, max_wrench: float):
    """``stamped_wrench`` of a message whose force and torque are these 3-tuples."""
    if fid == '':
        frame = Frame.parse(wrench_frame)
    elif fid in (world_frame, 'world'):
        frame = Frame.WORLD
    elif fid in (body_frame, 'body'):
        frame = Frame.BODY
    elif fid in points:
        return ros_messages.wrench_at(force, torque, points[fid], max_wrench)
    else:
        named = f", nor a point ({', '.join(sorted(points))})" if points else ''
        raise ValueError(f"frame_id '{fid}' is neither '{world_frame}' nor '{body_frame}'"
                         f'{named} (no tf lookup here)')
    ros_messages.check_wrench(force, torque, max_wrench)
    return Wrench(force, torque, frame)


class TwistInput:
    """A set_twist not yet turned into the world frame (that needs R at the step it applies)."""

    def __init__(self, body: str, in_body: bool, linear, angular) -> None:
        self.body, self.in_body, self.linear, self.angular = body, in_body, linear, angular


class BodyPorts:
    """Subscriptions and publishers of one body; ``queue(event)`` and ``reject(what, error)``
    are the node's."""

    def __init__(self, node, name: str, prefix: str, world_frame: str, body_frame: str,
                 twist_frame: str, settings, queue, reject, points=(), moving: bool = True,
                 imu_noise=None, index: int = 0, answer=None, answers_group=None) -> None:
        """``moving``: the body can move (a static one gets no imu or accel); ``imu_noise``:
        a sim.imu.ImuNoise; ``index``: the body's index in the scene (its noise stream);
        ``answer(body, stamp_ns, event or HOLD)``: in lockstep, the node's, handed every
        wrench_stamped first (True: it was a lockstep answer, taken or refused), whose
        subscription is then made in ``answers_group`` (taken_inputs: the step loop takes its
        messages)."""
        self._answer, self._answers_group = answer, answers_group
        self.name = name
        self.points = dict(points)  # name -> (x, y, z) m, body frame
        self.world_frame, self.body_frame = world_frame, body_frame
        self.settings = settings  # a dict-like view of the node's parameters, read on use
        self._queue, self._reject = queue, reject
        self.out = ros_messages.OutputMessages(
            world_frame, body_frame, twist_frame,
            node_params.covariance36(settings['odom_pose_covariance']),
            node_params.covariance36(settings['odom_twist_covariance']), imu_noise)
        self.sensor = ImuSensor(imu_noise, index) if moving and imu_noise is not None else None
        self.last_command_step = 0
        # A profile each: rclpy writes the overrides into the profile it is given.

        def qos():
            return QoSProfile(depth=10)
        self._pubs: dict = {}  # topic (relative) -> publisher
        self.motion_pubs = self.state_pubs = ()
        self._subs: list = []
        self.answers = None
        self.filled = False  # the last publish filled every message (republish may send it)
        try:
            self._create(node, prefix, qos, moving)
        except BaseException:  # a bad QoS override of one topic: none of them stays
            self.destroy(node)
            raise

    def _create(self, node, prefix: str, qos, moving: bool) -> None:
        over = {'qos_overriding_options': OVERRIDABLE}
        for topic, msg_type, _ in PUBLISHED:
            if topic in MOVING_ONLY and not moving:
                continue
            profile = QoSProfile(depth=APPLIED_QOS.depth, durability=APPLIED_QOS.durability) \
                if topic == 'applied_wrench' else qos()
            self._pubs[topic] = node.create_publisher(msg_type, prefix + topic, profile,
                                                      **over)
        self.pub_applied = self._pubs['applied_wrench']
        self.state_pubs = tuple((self._pubs[kind], getattr(self.out, kind))
                                for kind in RECORDED if kind not in MOVING_ONLY)
        self.motion_pubs = tuple((self._pubs[kind], getattr(self.out, kind))
                                 for kind in MOVING_ONLY if kind in self._pubs)
        callbacks = {'wrench': self._on_wrench, 'wrench_stamped': self._on_wrench_stamped,
                     'set_pose': self._on_set_pose, 'set_twist': self._on_set_twist}
        for topic, msg_type, _ in SUBSCRIBED:
            group = self._answers_group if topic == 'wrench_stamped' else None
            self._subs.append(node.create_subscription(msg_type, prefix + topic,
                                                       callbacks[topic], qos(),
                                                       callback_group=group, **over))
            if topic == 'wrench_stamped':
                self.answers = self._subs[-1]  # where lockstep answers come

    def destroy(self, node) -> None:
        """Take the body's topics off ``node`` (a deleted body's)."""
        for sub in self._subs:
            node.destroy_subscription(sub)
        for pub in self._pubs.values():
            node.destroy_publisher(pub)
        self._subs, self._pubs = [], {}
        self.motion_pubs = self.state_pubs = ()
        self.answers = None
        self.pub_applied = None

    def topics(self) -> dict[str, str]:
        """kind -> the topic it is published on (what a recording names)."""
        return {kind: pub.topic_name for kind, pub in self._pubs.items()
                if kind in RECORDED}

    def answering(self) -> int:
        """Publishers matched on the body's wrench_stamped (its lockstep input)."""
        return self.answers.get_publisher_count() if self.answers is not None else 0

    def republish(self) -> None:
        """The messages of the last publish again, to whoever listens now (lockstep: to a
        controller whose subscription matched after it); nothing drawn, nothing recorded.
        Only if the last publish filled them all: a state that was not finite, or not filled
        (nobody listened, nothing recorded, not in lockstep), is never sent."""
        if not self.filled:
            return
        for pub, msg in self.state_pubs + self.motion_pubs:
            if pub.get_subscription_count():
                pub.publish(msg)

    def publish(self, sim, recorder=None, fill: bool = False) -> bool:
        """Publish the body's state, and for a moving body its imu and accel, to whoever
        listens: a topic with no subscriber (and no recording) costs neither a fill nor a
        serialisation. The IMU's noise is drawn at every publish that goes out, listened to or
        not, so that it depends only on the steps of the publishes (replay draws at the
        recorded ones). A non-finite state, or one whose body-frame twist or acceleration
        overflows, is never published: False then, and no noise drawn."""
        time_ns = sim.time_ns
        self.filled = False  # (until this publish has filled every message)
        pose_twist = sim.pose_twist(self.name)
        if not all(math.isfinite(c) for vec in pose_twist for c in vec):
            return False
        pubs = [p for p in self.state_pubs if p[0].get_subscription_count()]
        motion = [p for p in self.motion_pubs if p[0].get_subscription_count()]
        sensor = self.sensor
        if not (pubs or motion or recorder is not None or fill):
            if sensor is not None:  # unheard, but drawn: the noise follows publishes only
                sensor.sample(time_ns)
            return True
        r = ros_messages.rotation_from_quaternion(pose_twist[1])
        if not self.out.fill(time_ns, *pose_twist, rotation=r):
            return False
        if motion or ((recorder is not None or fill) and self.motion_pubs):
            a, b = sim.accelerations(self.name)
            # The noise is drawn only for a publish that goes out (and so is recorded, as
            # replay draws it): taken back if the values are not finite.
            offsets = sensor.sample(time_ns) if sensor is not None else None
            if not self.out.fill_motion(time_ns, pose_twist[1], pose_twist[3], a, b,
                                        sim.config.gravity, offsets, rotation=r):
                if sensor is not None:
                    sensor.undo()
                return False
        elif sensor is not None:
            sensor.sample(time_ns)
        # (the motion messages too, unless nobody listened to them and nothing asked)
        self.filled = not self.motion_pubs or bool(motion) or recorder is not None or fill
        for pub, msg in pubs + motion:
            pub.publish(msg)
        if recorder is not None:
            recorder.output(self.name, sim.step_count, time_ns, self.out)
        return True

    def applied(self, wrench, time_ns: int) -> None:
        msg = WrenchStamped()
        msg.header.stamp = ros_messages.time_msg(time_ns)
        msg.header.frame_id = self.body_frame if wrench.frame is Frame.BODY else self.world_frame
        f, t = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z = (float(c) for c in wrench.force)
        t.x, t.y, t.z = (float(c) for c in wrench.torque)
        self.pub_applied.publish(msg)

    # -- callbacks -------------------------------------------------------------------------
    def _on_wrench(self, msg: WrenchMsg) -> None:
        event = self._wrench_event(msg, Frame.parse(self.settings['wrench_frame']), 'wrench')
        if event is not None:
            self._queue(event)

    def _on_wrench_stamped(self, msg: WrenchStamped) -> None:
        if self._answer is not None and self.answers is None:
            return  # a deleted body's, taken as it went: nothing to answer
        fid = msg.header.frame_id.lstrip('/')
        event = HOLD if fid == HOLD else self._stamped_event(msg.wrench, fid)
        # In lockstep an answer, refused or not, is the node's: a bad wrench answers with
        # no change (the refusal said), so that the loop goes on as it would every time.
        if self._answer is not None and self._answer(
                self.name, msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
                HOLD if event is None else event):
            return
        if event is HOLD:
            self._reject('wrench_stamped', ValueError(
                f"frame_id '{HOLD}' answers a state in lockstep, and this is not a lockstep "
                'input'))
        elif event is not None:
            self._queue(event)

    def _stamped_event(self, wrench_msg: WrenchMsg, fid: str):
        """The SetWrench of a wrench_stamped in frame ``fid``, or None (refused and said)."""
        try:
            return SetWrench(stamped_wrench(wrench_msg, fid, self.world_frame, self.body_frame,
                                            self.points, self.settings['wrench_frame'],
                                            self.settings['max_wrench']), self.name)
        except ValueError as e:
            self._reject('wrench_stamped', e)
            return None

    def _wrench_event(self, wrench_msg: WrenchMsg, frame: Frame, what: str):
        try:
            wrench = ros_messages.wrench_from_msg(wrench_msg, frame, self.settings['max_wrench'])
        except ValueError as e:
            self._reject(what, e)
            return None
        return SetWrench(wrench, self.name)

    def _on_set_pose(self, msg: PoseStamped) -> None:
        fid = msg.header.frame_id.lstrip('/')
        p, o = msg.pose.position, msg.pose.orientation
        q = (o.x, o.y, o.z, o.w)
        position = (p.x, p.y, p.z)
        if fid not in ('', self.world_frame):
            error = f"frame_id must be '{self.world_frame}', got '{fid}'"
        elif not all(math.isfinite(c) for c in q + position) or not any(q):
            error = f'pose must be finite with a non-zero quaternion, got {position}, {q}'
        else:
            self._queue(SetPose(position, q, self.name))
            return
        self._reject('set_pose', ValueError(error))

    def _on_set_twist(self, msg: Twist) -> None:
        lin = (msg.linear.x, msg.linear.y, msg.linear.z)
        ang = (msg.angular.x, msg.angular.y, msg.angular.z)
        if not all(math.isfinite(c) for c in lin + ang):
            self._reject('set_twist', ValueError(f'twist must be finite, got {lin}, {ang}'))
            return
        self._queue(TwistInput(self.name, self.out.twist_in_body, lin, ang))
