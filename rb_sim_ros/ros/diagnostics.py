# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node's /diagnostics: step cost, late ticks, tick jitter, sim/wall ratio, rejections,
and the contacts of the last step when bodies collide."""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from rb_sim_ros.core import jit
from rb_sim_ros.ros.body_ports import OVERRIDABLE


class Diagnostics:
    """Counters kept by the node; published about once a wall second."""

    PERIOD_NS = 1_000_000_000

    def __init__(self) -> None:
        self.rejected = 0
        self.dropped_periods = 0
        self.error = ''            # why the physics stopped; reset or unpause clear it
        self.recording_error = ''  # why the recording stopped; stays
        self.contacts = None  # collision_world.StepStats of the last step, when bodies collide
        self.compiling = ''  # which process compiles the kernels while they run interpreted
        self.lockstep = None  # the node's lockstep.Lockstep, in lockstep
        self._dropped_interpreted = 0  # periods dropped until then (expected: not a warning)
        self.ticks = 0
        self.late_ticks = 0
        self._lateness_ns: list[float] = []
        self._steps = 0
        self._step_ns = 0
        self._last_wall = time.monotonic_ns()
        self._last_sim_ns = 0
        self._sim_ns = 0
        self._pub = None

    def create_publisher(self, node) -> None:
        """/diagnostics, whose QoS takes overrides as every topic of the node does."""
        self._pub = node.create_publisher(DiagnosticArray, '/diagnostics', 10,
                                          qos_overriding_options=OVERRIDABLE)

    def tick(self, lateness_ns: float, late: bool) -> None:
        """A timer tick that was due ``lateness_ns`` ago; ``late`` if it had to catch up."""
        self.ticks += 1
        self.late_ticks += late
        if len(self._lateness_ns) < 100_000:
            self._lateness_ns.append(lateness_ns)

    def stepped(self, steps: int, cost_ns: int, sim_ns: int) -> None:
        self._steps += steps
        self._step_ns += cost_ns
        self._sim_ns = sim_ns

    def compiled(self) -> None:
        """The kernels run compiled from now on (they ran interpreted while compiling)."""
        self.compiling = ''
        self._dropped_interpreted = self.dropped_periods

    def maybe_publish(self, node, real_time_factor: float) -> None:
        now = time.monotonic_ns()
        if now - self._last_wall < self.PERIOD_NS or self._pub is None:
            return
        wall = now - self._last_wall
        lateness = sorted(self._lateness_ns)

        def pct(q):
            return lateness[min(len(lateness) - 1, int(q * len(lateness)))] * 1e-6 \
                if lateness else 0.0

        values = {
            'step_cost_us': self._step_ns / self._steps * 1e-3 if self._steps else 0.0,
            'steps': self._steps,
            'sim_over_wall': (self._sim_ns - self._last_sim_ns) / wall,
            'real_time_factor_requested': real_time_factor,
            'ticks': self.ticks,
            'late_ticks_total': self.late_ticks,
            'tick_lateness_p50_ms': pct(0.5),
            'tick_lateness_p99_ms': pct(0.99),
            'dropped_periods_total': self.dropped_periods,
            'rejected_inputs_total': self.rejected,
            'kernels': (f'interpreted: {self.compiling or "NUMBA_DISABLE_JIT=1"}'
                        if jit.interpreted() else 'compiled'),
        }
        if self.contacts is not None:
            values['contacts'] = self.contacts.contacts
            values['active_contacts'] = self.contacts.active
            values['sleeping_bodies'] = self.contacts.sleeping
        waiting = ''
        if self.lockstep is not None:
            ls = self.lockstep
            waiting = ls.describe()
            values['lockstep_inputs'] = ', '.join(ls.inputs()) or 'none yet'
            values['lockstep_waiting_for'] = ', '.join(ls.missing()) or 'nothing'
            values['lockstep_waited_s'] = ls.waited() if waiting else 0.0
            values['lockstep_refused_total'] = ls.counters.refused
            values['lockstep_repeated_total'] = ls.counters.repeated
            values['lockstep_timeouts_total'] = ls.counters.timeouts
        status = DiagnosticStatus(name='rb_sim: simulator', hardware_id='rb_sim_ros')
        error = '; '.join(e for e in (self.error, self.recording_error) if e)
        if error:
            status.level, status.message = DiagnosticStatus.ERROR, error
        elif waiting and self.lockstep.waited() >= 1.0:  # a stalled controller: said
            status.level, status.message = DiagnosticStatus.WARN, f'lockstep: {waiting}'
        elif self.compiling:
            status.level = DiagnosticStatus.OK
            status.message = 'running in the interpreter while the kernels compile'
        elif self.dropped_periods > self._dropped_interpreted:
            status.level, status.message = DiagnosticStatus.WARN, 'falling behind real time'
        else:
            status.level, status.message = DiagnosticStatus.OK, 'running'
        status.values = [KeyValue(key=k, value=f'{v:.6g}' if isinstance(v, float) else str(v))
                         for k, v in values.items()]
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = node.get_clock().now().to_msg()
        self._pub.publish(msg)
        self._last_wall, self._last_sim_ns = now, self._sim_ns
        self._steps = self._step_ns = 0
        self._lateness_ns.clear()
