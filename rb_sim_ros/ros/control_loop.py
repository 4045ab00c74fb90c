# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The controller's side of lockstep, for controller authors: one state in, one command out,
stamped as the state.

    from rb_sim_ros.ros.control_loop import ControlLoop

    class MyController(Node):
        def __init__(self):
            super().__init__('my_controller')
            self.loop = ControlLoop(self, self.law)          # odom in, wrench_stamped out
                                                              # (last: it starts at once)

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
* a state older than the last one answered is a new run (a simulator started again, its clock
  back at 0: one publisher's states never arrive out of order): the loop forgets the last
  answer, calls ``on_restart()`` if given (a law with memory resets it there) and answers it
  (counted in ``restarts``); with ``restart_after`` > 0, a state older by less than that many
  seconds is ignored instead (counted in ``stale``: for states from several publishers);
* a law that raises is logged and answered with "no change" (HOLD), so that a lockstep run
  goes on, the same way every time;
* ``answered``, ``repeated``, ``stale`` and ``restarts`` count what happened.

The loop has a thread of its own (``thread=True``, the default): it waits on the state
subscription alone, calls the law and publishes the answer, while the node's executor
(``rclpy.spin``) serves the rest (parameters, timers, other topics). Through the executor each
state would cost a rebuild of its wait set over every entity of the node (bench/
lockstep_bench.py measures both ways). The law
then runs in that thread: make the ControlLoop last in the node's ``__init__``, once what the
law reads is set, and ``close()`` it before destroying the node. ``thread=False``: the
executor calls ``on_state``.
"""

from __future__ import annotations

import threading
from typing import Callable

from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry

from rb_sim_ros.ros.lockstep import HOLD
from rb_sim_ros.ros.taken_inputs import TakenInputs

__all__ = ['ControlLoop', 'HOLD', 'command_message', 'command_parts']


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
                 qos=10, restart_after: float = 0.0,
                 on_restart: Callable[[], None] | None = None, thread: bool = True) -> None:
        self.law = law
        self._node = node
        self.frame = frame
        self.on_restart = on_restart
        self._restart_ns = int(restart_after * 1e9)
        self.answered = self.repeated = self.stale = self.restarts = 0
        self._last: tuple[int, WrenchStamped] | None = None
        self.publisher = node.create_publisher(WrenchStamped, command_topic, qos)
        self._taken = TakenInputs(node.context, self._callback_failed) if thread else None
        group = {'callback_group': self._taken.group} if thread else {}
        self.subscription = node.create_subscription(state_type, state_topic, self.on_state,
                                                     qos, **group)
        self._closed = threading.Event()
        self._thread = None
        if thread:
            self._taken.add(self.subscription)
            self._thread = threading.Thread(target=self._run, name='control_loop',
                                            daemon=True)
            self._thread.start()

    def _run(self) -> None:
        context = self._node.context
        while not self._closed.is_set() and context.ok():
            try:
                self._taken.take(0.1)
            except Exception:  # noqa: B902 - the node or its context went away meanwhile
                if self._closed.is_set() or not context.ok():
                    return
                raise

    def _failed(self, error: Exception) -> None:
        self._node.get_logger().error(f'control law failed: {type(error).__name__}: {error}; '
                                      'answered with no change', throttle_duration_sec=1.0)

    def _callback_failed(self, error: Exception) -> None:
        # on_state answers a law's error itself: this is the loop's own (a bad command from
        # the law, a publish on a closed node), and that state may be unanswered
        self._node.get_logger().error(f'control loop failed on a state: '
                                      f'{type(error).__name__}: {error}',
                                      throttle_duration_sec=1.0)

    def close(self) -> None:
        """Stop the loop's thread (before the node is destroyed): it ends after the state it
        is answering, if any."""
        self._closed.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join()

    def on_state(self, msg) -> None:
        stamp = stamp_ns(msg.header.stamp)
        last = self._last
        if last is not None and stamp <= last[0]:
            if stamp == last[0]:  # the same state again: the same answer
                self.repeated += 1
                self.publisher.publish(last[1])
                return
            if last[0] - stamp < self._restart_ns:
                self.stale += 1
                return
            self.restarts += 1  # the clock went back: a new run
            if self.on_restart is not None:
                self.on_restart()
        try:
            out = self.command(msg, self.law(msg))
        except Exception as e:  # noqa: B902 - whatever the law did, the loop must answer
            self._failed(e)
            out = self.command(msg, None)
        self._last = (stamp, out)
        self.answered += 1
        self.publisher.publish(out)

    def command(self, state, wrench) -> WrenchStamped:
        """The WrenchStamped answering ``state`` with ``wrench`` ((force, torque) or None)."""
        return command_message(state, wrench, self.frame)


def command_parts(state, wrench, frame: str = 'body') -> tuple:
    """(frame_id, force, torque) of the answer to the state message ``state`` with ``wrench``
    ((force, torque), or None for HOLD: (HOLD, None, None)), in ``frame`` ('body': the
    state's body frame), each force and torque three floats: what ``command_message`` puts
    in its WrenchStamped, and what offline/closed_loop takes for a controller called
    in-process without making the message, so that both paths give the same bits. Raises
    what float() and unpacking raise for a wrench that is not two triples of numbers."""
    if wrench is None:
        return HOLD, None, None
    fid = body_frame_of(state) if frame == 'body' else frame
    force, torque = wrench
    fx, fy, fz = map(float, force)
    tx, ty, tz = map(float, torque)
    return fid, (fx, fy, fz), (tx, ty, tz)


def command_message(state, wrench, frame: str = 'body',
                    out: WrenchStamped | None = None) -> WrenchStamped:
    """The WrenchStamped answering the state message ``state`` with ``wrench`` ((force,
    torque), or None for HOLD), stamped as the state, in ``frame`` ('body': the state's body
    frame): what a ControlLoop publishes (``command_parts`` in a message). ``out``: a
    message to fill (a HOLD's wrench is then what it held), else a new one."""
    if out is None:
        out = WrenchStamped()
    out.header.stamp = state.header.stamp
    fid, force, torque = command_parts(state, wrench, frame)
    out.header.frame_id = fid
    if force is not None:
        f, t = out.wrench.force, out.wrench.torque
        f.x, f.y, f.z = force
        t.x, t.y, t.z = torque
    return out
