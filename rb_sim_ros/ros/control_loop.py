# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The controller's side of lockstep, for controller authors: one state in, one command out,
stamped as the state.

    from rb_sim_ros.ros.control_loop import ControlLoop

    class MyController(Node):
        def __init__(self):
            super().__init__('my_controller')
            self.loop = ControlLoop(self, self.law)          # odom in, wrench_stamped out

        def law(self, msg):                                   # an Odometry
            return (0.0, 0.0, 0.0), (0.0, 0.0, -0.5 * msg.twist.twist.angular.z)

``law(state)`` returns ``(force, torque)`` (N, N m; in the body's frame by default) or None
for "no change" (the held wrench stays). Its command goes out on ``wrench_stamped`` with the
state's own ``header.stamp``: the answer the simulator waits for in lockstep, and an ordinary
command without lockstep (the same controller runs either way). The bookkeeping:

* a state received again (the simulator sends a state again to a controller it has not heard
  from yet: its first one may have gone out before the subscription matched) gets the answer
  already sent, and the law is not called twice for one state (a law with memory, such as an
  integrator, sees each state once);
* a state older than the last one answered is ignored (counted in ``stale``);
* ``answered``, ``repeated`` and ``stale`` count what happened.
"""

from __future__ import annotations

from typing import Callable

from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry

from rb_sim_ros.ros.lockstep import HOLD

__all__ = ['ControlLoop', 'HOLD']


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def body_frame_of(msg) -> str:
    """The frame of the body a state message is about: odom's child frame, else its header's
    frame (an Imu's)."""
    child = getattr(msg, 'child_frame_id', '')
    return child or msg.header.frame_id


class ControlLoop:
    """Calls ``law`` on each state message of ``node``'s ``state_topic`` and answers it on
    ``command_topic``.

    ``frame``: the frame of the law's wrench: 'body' (the state's body frame, as odom names
    it), 'world', or any frame id the simulator takes (a point of the body).
    """

    def __init__(self, node, law: Callable, state_type=Odometry, state_topic: str = 'odom',
                 command_topic: str = 'wrench_stamped', frame: str = 'body',
                 qos=10) -> None:
        self.law = law
        self.frame = frame
        self.answered = self.repeated = self.stale = 0
        self._last: tuple[int, WrenchStamped] | None = None
        self.publisher = node.create_publisher(WrenchStamped, command_topic, qos)
        self.subscription = node.create_subscription(state_type, state_topic, self.on_state,
                                                     qos)

    def on_state(self, msg) -> None:
        stamp = stamp_ns(msg.header.stamp)
        last = self._last
        if last is not None and stamp <= last[0]:
            if stamp == last[0]:  # the same state again: the same answer
                self.repeated += 1
                self.publisher.publish(last[1])
            else:
                self.stale += 1
            return
        out = self.command(msg, self.law(msg))
        self._last = (stamp, out)
        self.answered += 1
        self.publisher.publish(out)

    def command(self, state, wrench) -> WrenchStamped:
        """The WrenchStamped answering ``state`` with ``wrench`` ((force, torque) or None)."""
        out = WrenchStamped()
        out.header.stamp = state.header.stamp
        if wrench is None:
            out.header.frame_id = HOLD
            return out
        out.header.frame_id = body_frame_of(state) if self.frame == 'body' else self.frame
        force, torque = wrench
        f, t = out.wrench.force, out.wrench.torque
        f.x, f.y, f.z = (float(c) for c in force)
        t.x, t.y, t.z = (float(c) for c in torque)
        return out
