# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Subscriptions that no executor serves: the thread that waits on them takes their messages.
(The node's step loop takes the lockstep answers so; a ControlLoop's thread takes its states.)

In lockstep the node's step loop waits for the controllers' answers itself, on a wait set of
the answer subscriptions alone, and steps the next period as soon as the last one is taken.
Through the executor, each answer would cost a rebuild of the executor's wait set over every
entity of the node (services, parameter services, QoS event handlers: some hundred
microseconds in rclpy) and a switch between threads; a round trip with a controller is about
twice that.

The subscriptions belong to the node as any other (names, remapping, QoS overrides, graph),
but in a callback group that the executor never finds ready (``NotExecuted``), so it never
waits on them.
"""

from __future__ import annotations

import contextlib
import threading
import time

from rclpy.callback_groups import CallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy


class NotExecuted(CallbackGroup):
    """A callback group whose entities an executor never waits on nor runs."""

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


class TakenInputs:
    """The subscriptions of ``group`` (made with ``callback_group=group``), waited on and
    taken by ``take`` in the calling thread. ``on_error(exception)``: a callback that raised
    (the others are still served; without it, the exception goes up)."""

    def __init__(self, context, on_error=None) -> None:
        self.group = NotExecuted()
        self._context = context
        self._on_error = on_error
        self._subs: list = []
        self._lock = threading.Lock()
        self._wait_set = None  # for the subscriptions of _made
        self._made: tuple = ()

    def add(self, sub) -> None:
        with self._lock:
            self._subs.append(sub)

    def remove(self, sub) -> None:
        with self._lock:
            if sub in self._subs:
                self._subs.remove(sub)

    def take(self, timeout_s: float) -> int:
        """Wait up to ``timeout_s`` for messages on the subscriptions, and hand each message
        taken to its subscription's callback, in this thread; returns how many."""
        with self._lock:
            subs = tuple(self._subs)
        if not subs:
            time.sleep(timeout_s)
            return 0
        taken = 0
        with contextlib.ExitStack() as held:  # none destroyed while waited on
            live = []
            for sub in subs:
                try:
                    held.enter_context(sub.handle)
                    live.append(sub)
                except Exception:  # noqa: B902 - destroyed meanwhile (a deleted body's)
                    continue
            if not live:  # all destroyed (the node going away): nothing to wait on
                time.sleep(timeout_s)
                return 0
            if tuple(live) != self._made:
                self._wait_set = _rclpy.WaitSet(len(live), 0, 0, 0, 0, 0,
                                                self._context.handle)
                self._made = tuple(live)
            ws = self._wait_set
            ws.clear_entities()
            for sub in live:
                ws.add_subscription(sub.handle)
            ws.wait(max(0, int(timeout_s * 1e9)))
            ready = ws.get_ready_entities('subscription')
            for sub in live:
                if sub.handle.pointer not in ready:
                    continue
                while True:
                    got = sub.handle.take_message(sub.msg_type, sub.raw)
                    if got is None:
                        break
                    taken += 1
                    try:
                        sub.callback(got[0])
                    except Exception as e:  # noqa: B902 - one bad callback stops no other
                        if self._on_error is None:
                            raise
                        self._on_error(e)
        return taken
