# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The controller's helper (ros/control_loop.py) without DDS: a node that hands over its
publisher and subscription. Each state gets one answer with its own stamp; the law sees each
state once; a state sent again gets the same answer; an old one is ignored, and a clock gone
far back is a new run."""

import threading

from nav_msgs.msg import Odometry
import rclpy

from rb_sim_ros.ros.control_loop import ControlLoop, HOLD
from support.ros_harness import reserve_domain_id

MS = 1_000_000


class _Publisher:
    def __init__(self) -> None:
        self.sent = []

    def publish(self, msg) -> None:
        self.sent.append(msg)


class _Node:
    def create_publisher(self, msg_type, topic, qos):
        self.pub = _Publisher()
        return self.pub

    def create_subscription(self, msg_type, topic, callback, qos):
        return callback


def _state(t_ns: int, wz: float = 0.0) -> Odometry:
    msg = Odometry()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 1_000_000_000)
    msg.header.frame_id, msg.child_frame_id = 'world', 'sat'
    msg.twist.twist.angular.z = wz
    return msg


def test_each_state_is_answered_once_with_its_stamp_and_the_law_sees_it_once():
    node, seen = _Node(), []

    def law(msg):
        seen.append(msg.header.stamp.nanosec)
        return (0.0, 0.0, 0.0), (0.0, 0.0, -2.0 * msg.twist.twist.angular.z)
    loop = ControlLoop(node, law, thread=False)
    loop.on_state(_state(10 * MS, wz=0.5))
    loop.on_state(_state(10 * MS, wz=0.5))  # sent again by the simulator
    loop.on_state(_state(20 * MS, wz=0.25))
    assert seen == [10 * MS, 20 * MS]
    sent = node.pub.sent
    assert [m.header.stamp.nanosec for m in sent] == [10 * MS, 10 * MS, 20 * MS]
    assert sent[0] is sent[1] and sent[0].header.frame_id == 'sat'
    assert [m.wrench.torque.z for m in sent] == [-1.0, -1.0, -0.5]
    assert (loop.answered, loop.repeated) == (2, 1)


def test_no_change_is_hold_and_a_world_frame_is_named():
    node = _Node()
    loop = ControlLoop(node, lambda msg: None, thread=False)
    loop.on_state(_state(0))
    assert node.pub.sent[-1].header.frame_id == HOLD
    node = _Node()
    loop = ControlLoop(node, lambda msg: ((1.0, 2, 3), (0, 0, 0)), frame='world',
                       thread=False)
    loop.on_state(_state(0))
    out = node.pub.sent[-1]
    assert out.header.frame_id == 'world' and (out.wrench.force.x, out.wrench.force.z) == \
        (1.0, 3.0)


def test_an_old_state_is_ignored_and_a_clock_gone_far_back_is_a_new_run():
    node, seen, restarts = _Node(), [], []
    loop = ControlLoop(node, lambda msg: seen.append(msg.header.stamp) or None,
                       on_restart=lambda: restarts.append(len(seen)), thread=False,
                       restart_after=1.0)
    loop.on_state(_state(5_000 * MS))
    loop.on_state(_state(4_990 * MS))  # out of order, a period old: ignored
    assert (loop.stale, len(seen), len(node.pub.sent)) == (1, 1, 1)
    loop.on_state(_state(0))  # the simulator started again
    assert loop.restarts == 1 and restarts == [1] and len(seen) == 2
    assert node.pub.sent[-1].header.stamp.sec == 0
    loop.on_state(_state(10 * MS))  # and goes on from there
    assert len(seen) == 3 and loop.stale == 1


def test_by_default_any_older_state_is_a_new_run_and_a_law_that_raises_holds():
    node, restarts = _Node(), []
    failing = [False]

    def law(msg):
        if failing[0]:
            raise ZeroDivisionError('a bug')
        return (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    loop = ControlLoop(node, law, on_restart=lambda: restarts.append(1), thread=False)
    node.get_logger = lambda: type('L', (), {'error': lambda *a, **k: None})()
    loop.on_state(_state(500 * MS))
    loop.on_state(_state(490 * MS))  # a run started again, 10 ms ago in the last one's time
    assert restarts == [1] and loop.stale == 0 and loop.answered == 2
    failing[0] = True
    loop.on_state(_state(500 * MS))
    out = node.pub.sent[-1]
    assert out.header.frame_id == HOLD and out.header.stamp.nanosec == 500 * MS


def test_a_law_returning_no_wrench_shape_holds_and_says_so():
    """A wrench the message cannot take (not two triples, not numbers) is the law's error:
    the state is still answered, with no change, and the log names it."""
    for bad in ((1.0, 2.0), ((0, 0), (0, 0, 0)), (('x', 0, 0), (0, 0, 0)), 5):
        node, said = _Node(), []
        node.get_logger = lambda: type('L', (), {'error': lambda s, m, **k: said.append(m)})()
        loop = ControlLoop(node, lambda msg: bad, thread=False)
        loop.on_state(_state(30 * MS))
        out = node.pub.sent[-1]
        assert (out.header.frame_id, out.header.stamp.nanosec) == (HOLD, 30 * MS), bad
        assert len(node.pub.sent) == 1 and loop.answered == 1
        assert len(said) == 1 and 'control law failed' in said[0]


def test_its_thread_ends_with_close_and_with_the_context(monkeypatch):
    """The loop's own thread (the default): close() ends it; a node destroyed without close()
    leaves it waiting quietly (no exception in it), and the context's shutdown ends it."""
    raised = []
    monkeypatch.setattr(threading, 'excepthook', raised.append)
    for closed in (True, False):
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=reserve_domain_id())
        node = rclpy.create_node('controller', context=context)
        loop = ControlLoop(node, lambda msg: None)
        assert loop._thread.is_alive()
        if closed:
            loop.close()
            assert not loop._thread.is_alive()
        node.destroy_node()
        if not closed:
            loop._thread.join(0.5)  # (it would have died in this time, not by a deadline)
            assert loop._thread.is_alive() and raised == []
        rclpy.try_shutdown(context=context)
        loop._thread.join()
        assert raised == []
