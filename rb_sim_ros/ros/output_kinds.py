# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The outputs the node publishes for each body and records, one row each: what the node's
ports (``body_ports``), the recorder (``node_recorder``), replay's comparison and ``sweep`` read,
so that a new output kind is a row here (and its filling in ``ros_messages.OutputMessages``).

Each kind: its ``name`` (the topic under the body's prefix, the key in a recording's
``output_topics``), its message type, what it carries (``simulator --help``), whether it
needs the body's accelerations (``motion``: moving bodies only, filled by ``fill_motion``),
whether every recording has it (``required``: the first kinds; the others came later), and
``quantities(msg)``, the floats of a message that replay compares, by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from geometry_msgs.msg import AccelStamped, PoseStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu


def xyz(v) -> tuple:
    """A vector message's (x, y, z)."""
    return (v.x, v.y, v.z)


def xyzw(q) -> tuple:
    """A quaternion message's (x, y, z, w)."""
    return (q.x, q.y, q.z, q.w)


@dataclass(frozen=True)
class OutputKind:
    name: str
    msg_type: type
    what: str
    motion: bool
    required: bool
    quantities: Callable[[object], dict]


KINDS = (
    OutputKind('pose', PoseStamped, 'pose in world_frame', False, True,
               lambda m: {'position': xyz(m.pose.position),
                          'orientation': xyzw(m.pose.orientation)}),
    OutputKind('twist', Twist, 'velocities in twist_frame', False, True,
               lambda m: {'linear_velocity': xyz(m.linear),
                          'angular_velocity': xyz(m.angular)}),
    OutputKind('odom', Odometry, 'pose in world_frame, twist in the body frame', False, True,
               lambda m: {'position': xyz(m.pose.pose.position),
                          'orientation': xyzw(m.pose.pose.orientation),
                          'linear_velocity': xyz(m.twist.twist.linear),
                          'angular_velocity': xyz(m.twist.twist.angular)}),
    OutputKind('imu', Imu, 'orientation, angular velocity, specific force', True, False,
               lambda m: {'orientation': xyzw(m.orientation),
                          'angular_velocity': xyz(m.angular_velocity),
                          'linear_acceleration': xyz(m.linear_acceleration)}),
    OutputKind('accel', AccelStamped, 'acceleration of the centre of mass', True, False,
               lambda m: {'linear_acceleration': xyz(m.accel.linear),
                          'angular_acceleration': xyz(m.accel.angular)}),
)
BY_NAME = {k.name: k for k in KINDS}
NAMES = tuple(k.name for k in KINDS)
MOTION = tuple(k.name for k in KINDS if k.motion)
REQUIRED = tuple(k.name for k in KINDS if k.required)


def needs_motion(name: str) -> bool:
    """Whether output ``name`` carries the body's accelerations (False for any other topic)."""
    kind = BY_NAME.get(name)
    return kind is not None and kind.motion
