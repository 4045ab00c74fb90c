#!/usr/bin/env python3
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Point a rigid body at a target orientation: a quaternion PD law, closed over ROS topics.

    ./tools/simulate.sh --ros-args -p inertia:=[0.1,0.2,0.3] -p record:=run.mcap &
    python examples/attitude_controller.py --ros-args -p target_rpy:=[0.3,-0.2,1.2]
    python -m rb_sim_ros.offline.replay --plot run.mcap           # what it did

It reads the body's orientation q and body-frame angular velocity w from ``odom`` (or ``imu``:
the noisy sensor, with ``source:=imu``) and sends the body-frame torque

    tau = -K_p sign(e_w) e_v - K_d w,    e = q_target^-1 q  (the error quaternion)

on ``wrench_stamped`` (frame_id: the body's frame, as odom names it), stamped with the stamp of
the state it was computed from: through ``rb_sim_ros.ros.control_loop.ControlLoop``, so that
it is the answer a simulator in lockstep waits for (``-p lockstep:=true``: the run is then
the same bits on any machine and under any load), and an ordinary command without lockstep.
This law is globally
stabilising for a rigid body (Wie, Weiss and Arapostathis 1989). With the gains per axis
K_p = 2 I wn^2 and K_d = 2 zeta wn I, small errors (e_v ~ theta / 2) follow
theta'' + 2 zeta wn theta' + wn^2 theta = 0: settling to 2 % in about 4 / (zeta wn) and
overshoot exp(-pi zeta / sqrt(1 - zeta^2)) (1.5 % at zeta = 0.8). ``inertia`` is the body's
principal moments, as the simulator's parameter (a diagonal tensor).
"""

import math
import random
import sys
import time

from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import Imu

from rb_sim_ros.ros.control_loop import ControlLoop


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple:
    """x, y, z, w of R = Rz(yaw) Ry(pitch) Rx(roll) (REP-103: fixed axes x, y, z)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def error_quaternion(target, q) -> tuple:
    """target^-1 q (x, y, z, w), both unit: the rotation from the target to the body."""
    tx, ty, tz, tw = -target[0], -target[1], -target[2], target[3]
    x, y, z, w = q
    return (tw * x + tx * w + ty * z - tz * y, tw * y - tx * z + ty * w + tz * x,
            tw * z + tx * y - ty * x + tz * w, tw * w - tx * x - ty * y - tz * z)


def pd_torque(target, q, w, kp, kd, max_torque: float) -> tuple:
    """The body-frame torque of the law above, each component clipped to +-max_torque."""
    norm = math.sqrt(sum(c * c for c in q))
    q = tuple(c / norm for c in q)
    e = error_quaternion(target, q)
    s = 1.0 if e[3] >= 0.0 else -1.0  # the shorter way round
    return tuple(max(-max_torque, min(max_torque, -kp[k] * s * e[k] - kd[k] * w[k]))
                 for k in range(3))


# The controller's parameters: (name, default, description). The ROS node declares them; an
# in-process run (rb_sim_ros.offline.closed_loop) hands them to make_law as a dict.
PARAMETERS = (
    ('target_rpy', [0.0, 0.0, math.pi / 2],
     'Target roll, pitch, yaw (rad; REP-103 fixed axes) in the world frame.'),
    ('inertia', [0.1, 0.1, 0.1], "The body's principal moments of inertia (kg m^2), body frame."),
    ('natural_frequency', 2.0, 'Closed-loop natural frequency wn (rad/s).'),
    ('damping_ratio', 0.8, 'Closed-loop damping ratio zeta.'),
    ('max_torque', 10.0, 'Largest torque per axis (N m).'),
    ('source', 'odom', "Read the state from 'odom' (ground truth) or 'imu'."),
)


class AttitudeLaw:
    """The law alone, without ROS: called with each state message (Odometry or Imu), it
    returns ((0, 0, 0), body-frame torque), or None (no change) for a state that is not
    finite. ``state`` names the topic it reads."""

    def __init__(self, parameters: dict) -> None:
        values = {name: default for name, default, _ in PARAMETERS}
        unknown = sorted(set(parameters) - set(values))
        if unknown:
            raise ValueError(f"unknown parameter '{unknown[0]}' (known: "
                             f"{', '.join(values)})")
        values.update(parameters)
        rpy, inertia = list(values['target_rpy']), list(values['inertia'])
        wn, zeta = values['natural_frequency'], values['damping_ratio']
        self.max_torque, self.state = values['max_torque'], values['source']
        numbers = rpy + inertia + [wn, zeta, self.max_torque]
        if len(rpy) != 3 or len(inertia) != 3 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in numbers) or min(inertia) <= 0 or wn <= 0 or zeta <= 0 or \
                self.max_torque <= 0 or self.state not in ('odom', 'imu'):
            raise ValueError('target_rpy needs 3 angles, inertia 3 moments > 0; '
                             'natural_frequency, damping_ratio and max_torque must be > 0, '
                             "source 'odom' or 'imu'")
        self.values = values
        self.target = quaternion_from_rpy(*rpy)
        self.kp = [2.0 * i * wn * wn for i in inertia]
        self.kd = [2.0 * zeta * wn * i for i in inertia]

    def __call__(self, msg):
        if isinstance(msg, Odometry):
            o, w = msg.pose.pose.orientation, msg.twist.twist.angular  # odom's twist: body
        else:
            o, w = msg.orientation, msg.angular_velocity
        q, w = (o.x, o.y, o.z, o.w), (w.x, w.y, w.z)
        if not all(math.isfinite(c) for c in q + w) or not any(q):
            return None
        return (0.0, 0.0, 0.0), pd_torque(self.target, q, w, self.kp, self.kd, self.max_torque)


def make_law(parameters: dict) -> AttitudeLaw:
    """The controller in-process (rb_sim_ros.offline.closed_loop): its law from the same
    parameters the node takes. ValueError naming a bad one."""
    return AttitudeLaw(parameters)


class AttitudeController(Node):
    def __init__(self) -> None:
        super().__init__('attitude_controller')

        def param(name, default, text):
            return self.declare_parameter(name, default,
                                          ParameterDescriptor(description=text)).value
        values = {name: param(name, default, text) for name, default, text in PARAMETERS}
        self.jitter = param('answer_delay_max', 0.0, 'Wait a random wall time up to this (s) '
                            'before each answer: in lockstep the run stays the same bits.')
        thread = param('control_thread', True, 'Answer each state from a thread of its own, '
                       "waiting on the state alone; false: through the node's executor.")
        if not isinstance(self.jitter, (int, float)) or not 0 <= self.jitter <= 10 or \
                not isinstance(thread, bool):
            raise ValueError('answer_delay_max from 0 to 10 s, control_thread true or false')
        self.attitude = make_law({k: list(v) if k in ('target_rpy', 'inertia') else v
                                  for k, v in values.items()})
        self._random = random.Random()  # unseeded: the delays differ from run to run
        self.loop = ControlLoop(self, self.law, *(
            (Odometry, 'odom') if self.attitude.state == 'odom' else (Imu, 'imu')),
            thread=thread)
        self.get_logger().info(f"pointing at rpy {list(values['target_rpy'])} with wn "
                               f"{values['natural_frequency']} rad/s, zeta "
                               f"{values['damping_ratio']}, from {self.attitude.state}")

    def law(self, msg):
        """The body-frame torque for a state (Odometry or Imu); None (no change) for a state
        that is not finite."""
        if self.jitter:
            time.sleep(self._random.uniform(0.0, self.jitter))
        return self.attitude(msg)


def main(args=None) -> int:
    rclpy.init(args=args)
    try:
        node = AttitudeController()
    except ValueError as e:
        print(f'attitude_controller: {e}', file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.loop.close()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
