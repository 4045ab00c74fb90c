# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Lockstep: the node steps on only once every controller has answered the state it published,
so a closed-loop run depends on what the controllers answered, never on when.

The protocol. Each publish period the node publishes the state stamped t_k (pose, twist, odom,
imu, accel, /tf, /clock), then waits. A lockstep input is a body's ``wrench_stamped``. It
answers t_k with a WrenchStamped whose ``header.stamp`` is t_k: the wrench to hold from then
on, or ``frame_id: hold`` (``HOLD``) for "no change". A controller only has to copy the stamp
of the state it used. Once every input has answered, the answers take effect together, in the
order of the bodies' names, at the first step after t_k, or ``delay`` periods later (to model a
controller's latency deterministically), and the node steps on. An answer for another stamp is
refused and counted. A repeat of an answer already taken is ignored and counted apart, since
the node re-sends a state to a controller that has not answered yet.

What changes the state between two periods (a reset, set_entity_state, a spawn or delete,
while paused or not) takes effect at its step and is recorded there; the answers already
given to the state published before it stand and take effect as they would have, and the
controllers see the changed state at the next period. Deterministic all the same: the change
and the answers are both inputs at known steps, and replay applies them there.

This module holds the bookkeeping only (no ROS): the node's step loop hands it each answer as
it takes it (taken_inputs), and asks it whether to step on and which answers take effect now.
A wrench answer is whatever event the node made of the message (a SetWrench).
"""

from __future__ import annotations

import collections
import contextlib
from dataclasses import dataclass, field
import threading
import time
from typing import Any

# The frame_id of an answer that changes nothing (the held wrench stays).
HOLD = 'hold'
ON_TIMEOUT = ('error', 'hold')


@dataclass
class Member:
    """One lockstep input: a body's wrench_stamped."""

    body: str
    answered: int | None = None  # the stamp of its last answer taken
    answer: object = None        # that answer: an event, or HOLD
    heard: bool = False          # it answered once at least (a state re-sent until then)


@dataclass
class Counters:
    refused: int = 0      # answers for another stamp, or a second answer for one
    repeated: int = 0     # an answer taken already, received again
    timeouts: int = 0     # periods stepped on without every answer (lockstep_timeout)
    periods: int = 0      # periods whose answers were taken
    waited_ns: int = 0    # wall time spent waiting for answers
    since: float = field(default_factory=time.monotonic)


class _Flag:
    """threading.Event's set, clear and is_set, for one thread."""

    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def clear(self) -> None:
        self._set = False

    def is_set(self) -> bool:
        return self._set


class Lockstep:
    """The answers awaited for the last published state, and those due to take effect.

    ``declared``: the bodies whose wrench_stamped are inputs; None for every body whose
    wrench_stamped has a publisher when the run starts (``start``)."""

    def __init__(self, declared: list[str] | None, delay: int = 0,
                 threaded: bool = True) -> None:
        """``threaded`` False: one thread only calls it (offline/closed_loop), so no lock and
        a plain flag for ``ready`` (the same bookkeeping, without their cost)."""
        self.declared = None if declared is None else list(declared)
        self.delay = int(delay)
        self.members: dict[str, Member] = {}
        self.awaited: int | None = None  # the stamp answers must carry (ns)
        self.started = False  # step 0 is behind: the set of inputs is fixed but for leaving
        # The inputs there are were looked for (join): until then step 0 waits, even if
        # some controller answered already (another may have a publisher too).
        self.gathered = False
        self.ready_ns = 0  # when ready was last set (monotonic ns)
        # every member answered the awaited stamp
        self.ready = threading.Event() if threaded else _Flag()
        self.counters = Counters()
        self._pipeline: collections.deque = collections.deque()
        self._lock: Any = threading.Lock() if threaded else contextlib.nullcontext()
        self._waiting_since: float | None = None
        self._timed_out: set[str] = set()
        self._taken: int | None = None  # the stamp whose answers take() queued last
        self.notes: list[str] = []  # what happened to the inputs (joined, left, timed out)

    # -- membership ------------------------------------------------------------------------
    def join(self, bodies) -> list[str]:
        """Make the ``bodies`` (those with a publisher now, or those declared) inputs, before
        step 0; returns those that are new. Step 0 waits for a first join."""
        new = []
        with self._lock:
            for body in bodies:
                if body not in self.members:
                    self.members[body] = Member(body)
                    new.append(body)
            self.gathered = True
            self._update()
        return new

    def leave(self, body: str, deleted: bool = False) -> bool:
        """Body ``body``'s input is gone (no publisher, or the body deleted); True if it was
        one. The others are not waited for it any more. A deleted body's answers still in
        the delay pipeline are dropped too (there is nothing to apply them to)."""
        with self._lock:
            gone = self.members.pop(body, None) is not None
            self._timed_out.discard(body)
            if deleted:
                if self.declared is not None and body in self.declared:
                    self.declared.remove(body)  # (before step 0 it would join again)
                for batch in self._pipeline:
                    batch[:] = [(b, a) for b, a in batch if b != body]
            self._update()
        return gone

    # -- answers (the step loop's thread) ---------------------------------------------------
    def offer(self, body: str, stamp_ns: int, answer) -> str | None:
        """An answer from ``body``'s wrench_stamped: None if taken (or a repeat of one taken),
        else why it was refused. Not an input: 'open' (the node queues it as any input).

        Refused: an answer to another stamp; a second answer to one stamp that differs from
        the first (two controllers on one input, or one that changed its mind: the first
        stands, whichever came first would be a race); an answer from an input timed out on
        the awaited stamp (the run stepped on without it: taking it would be a race too)."""
        with self._lock:
            member = self.members.get(body)
            if member is None:
                if self.declared is None and stamp_ns == self.awaited is not None:
                    # In from the state it answered: before step 0 (it answered before the
                    # node looked for publishers), or a controller that joins late.
                    member = self.members[body] = Member(body)
                    if self.started:
                        self.notes.append(f"'{body}' joined at t = {stamp_ns * 1e-9:.9f} s")
                elif self.declared is not None and body not in self.declared:
                    return 'open'
                elif self.declared is not None:  # declared, left, and back: in again
                    if stamp_ns != self.awaited:
                        return self._refuse(stamp_ns)
                    member = self.members[body] = Member(body)
                    self.notes.append(f"'{body}' is back at t = {stamp_ns * 1e-9:.9f} s")
                else:
                    return self._refuse(stamp_ns)
            if stamp_ns == member.answered:
                if answer != member.answer:
                    self.counters.refused += 1
                    return (f'a second answer to t = {stamp_ns * 1e-9:.9f} s, not the same '
                            'as the first (which stands): is more than one controller '
                            'publishing on it?')
                self.counters.repeated += 1
                return None
            if stamp_ns != self.awaited:
                return self._refuse(stamp_ns)
            if body in self._timed_out:
                self.counters.refused += 1
                return (f'the answer to t = {stamp_ns * 1e-9:.9f} s came after '
                        'lockstep_timeout: the run stepped on without it')
            member.answered, member.answer, member.heard = stamp_ns, answer, True
            self._update()
        return None

    def _refuse(self, stamp_ns: int) -> str:
        self.counters.refused += 1
        awaited = 'no state yet' if self.awaited is None else \
            f'the state of t = {self.awaited * 1e-9:.9f} s'
        return (f'stamp {stamp_ns * 1e-9:.9f} s does not answer the state awaited ({awaited}): '
                'copy the stamp of the state the command was computed from')

    # -- the step loop ---------------------------------------------------------------------
    def expect(self, stamp_ns: int) -> None:
        """A state stamped ``stamp_ns`` is about to be published: answers must carry it."""
        with self._lock:
            self.awaited = stamp_ns
            self._timed_out = set()
            self._waiting_since = time.monotonic()
            self._update()

    def sent(self) -> None:
        """The awaited state is out: the wait for its answers starts now."""
        self._waiting_since = time.monotonic()

    def _update(self) -> None:
        answered = all(m.answered == self.awaited for m in self.members.values()
                       if m.body not in self._timed_out)
        if self.awaited is not None and answered and (self.members or self.started) and \
                (self.started or self.gathered):
            if not self.ready.is_set():
                self.ready_ns = time.monotonic_ns()
            self.ready.set()
        else:
            self.ready.clear()

    def inputs(self) -> list[str]:
        """The inputs waited for (sorted)."""
        with self._lock:
            return sorted(self.members)

    def missing(self) -> list[str]:
        """The inputs that have not answered the awaited state (sorted)."""
        with self._lock:
            return sorted(b for b, m in self.members.items()
                          if m.answered != self.awaited and b not in self._timed_out)

    def unheard(self) -> list[str]:
        """Missing inputs that never answered: they may not have had the state (a state sent
        before their subscription matched is lost), so the node sends it again."""
        with self._lock:
            return sorted(b for b, m in self.members.items()
                          if not m.heard and m.answered != self.awaited)

    def waited(self) -> float:
        """Wall seconds since the awaited state was published."""
        since = self._waiting_since
        return 0.0 if since is None else time.monotonic() - since

    def time_out(self) -> list[str]:
        """Step on without the missing answers (their wrenches held), or before step 0
        without any controller; returns the inputs that did not answer."""
        with self._lock:
            late = sorted(b for b, m in self.members.items()
                          if m.answered != self.awaited and b not in self._timed_out)
            self._timed_out.update(late)
            self.counters.timeouts += 1
            self.started = True  # (no input at all: the run goes on open loop)
            self._update()
        return late

    def rearm(self) -> None:
        """Wait afresh (lockstep_timeout counts from now): after a pause."""
        with self._lock:
            if self._waiting_since is not None:
                self._waiting_since = time.monotonic()

    def take(self) -> list[tuple[str, object]]:
        """The answers of the awaited state (body, event or HOLD), queued; returns those due
        now: the answers of ``delay`` periods ago (none in the first ``delay`` periods). Once
        a stamp: a second call before the next ``expect`` returns nothing and queues nothing
        (a period cut short, then stepped again, does not take its answers twice)."""
        with self._lock:
            if self.awaited is None or self.awaited == self._taken:
                return []
            self._taken = self.awaited
            batch = [(b, self.members[b].answer) for b in sorted(self.members)
                     if self.members[b].answered == self.awaited]
            if not self.started:  # the run's clock: from step 0
                self.counters.since = time.monotonic()
            elif self._waiting_since is not None:
                self.counters.waited_ns += int((time.monotonic() - self._waiting_since) * 1e9)
                self._waiting_since = None
            self.started = True
            self.counters.periods += 1
            self._pipeline.append(batch)
            due = self._pipeline.popleft() if len(self._pipeline) > self.delay else []
        return due

    def describe(self) -> str:
        """What it waits for, one line: for logs and /diagnostics."""
        missing = self.missing()
        if not missing:
            return ''
        return (f"waiting {self.waited():.1f} s for {', '.join(missing)} to answer "
                f't = {(self.awaited or 0) * 1e-9:.9f} s')
