# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The fixed-step stepper: one body, one held wrench, the multistep method of Proof 3.

    stepper = Stepper(RigidBody(2.0, [0.1, 0.2, 0.3]), dt=1e-3)
    stepper.set_wrench(Wrench(torque=(0, 0, 0.01), frame='body'))
    stepper.step(1000)
    stepper.state.quaternion_xyzw

History. The method needs a_{n-1}, beta_{n-1}. The stepper keeps the previous state, not just
its accelerations, for two reasons:

* start-up: after ``set_state`` there is no previous step. The first step predicts the state at
  t + dt with a one-step Taylor step, takes the accelerations there and extrapolates back,
  a_{-1} = 2 a_0 - a_1*, so the first step is as accurate as the others (local O(dt^3)) and
  the global order stays 2;
* wrench changes: a wrench is held from the step after ``set_wrench``. Extrapolating with
  accelerations of the old wrench puts an O(dt) error into v and omega at each change and the
  method falls to first order (NOTES.md, 2). So on a change a_{n-1}, beta_{n-1} are evaluated
  again at the previous state under the new wrench.

Orthonormality. Each step multiplies R by an exactly-orthonormal-up-to-rounding exp(); rounding
accumulates like a random walk, so every ``ORTHONORMALIZE_EVERY`` steps one Newton step of the
polar decomposition pulls R back to SO(3) (to ~1e-16); the correction is far below the
method's own error and deterministic.
"""

from __future__ import annotations

import math
from typing import Any, Sequence
import warnings

import numpy as np

from rb_sim_ros.core import euler_dynamics, jit, multistep, so3
from rb_sim_ros.core import step_kernel as K
from rb_sim_ros.core.rigid_body import (finite_floats, Frame, rate, RigidBody, State, Wrench,
                                        ZERO_WRENCH)
from rb_sim_ros.core.step_count import check_steps, MAX_STEPS


# The energy bound of each method (docs/integrators.md, "Energy and the turn per step";
# measured by ``python -m bench.energy_drift``): up to TURN_BOUNDS[name] rad a step,
# |omega| dt, a torque-free body with unequal moments keeps its kinetic energy within
# ENERGY_TOLERANCE (relative) over ENERGY_STEPS steps; beyond it the drift grows fast (the
# explicit Adams-Bashforth update of Euler's equations: AB2, eq27's, drifts by the order of
# (omega dt)^4 / 4 a step; AB4, lie4's, has a parasitic root outside the unit circle from
# 0.43 rad a step of the linearised motion, where the energy doubles within about a hundred
# steps). The drift grows about in proportion to the steps. A step that ends beyond the bound
# gives a TurnWarning, once per body. The flows have no bound: they are exact torque-free.
ENERGY_TOLERANCE = 1e-3
ENERGY_STEPS = 2000
TURN_BOUNDS = {'eq27': 0.03, 'eq27-no-cross': 0.03, 'taylor1': 0.02, 'lie3': 0.07, 'lie4': 0.1}


class TurnWarning(RuntimeWarning):
    """A body with unequal moments ended a step turning more than its method's energy bound
    (``TURN_BOUNDS``) rad a step: its energy may drift beyond ENERGY_TOLERANCE."""


def turn_bound(method) -> float | None:
    """The energy bound (rad a step) of ``method`` (a method of ``multistep.METHODS``), None
    for one that has none (the flows, or a table not of ``METHODS``)."""
    if multistep.METHODS.get(method.name) != method:
        return None
    return TURN_BOUNDS.get(method.name)


def turn_warning_sq(method, dt: float, isotropic: bool) -> float:
    """The squared |omega| (rad/s)^2 above which a body's step warns (inf: never)."""
    bound = turn_bound(method)
    return math.inf if isotropic or bound is None else (bound / dt) ** 2


def turn_message(method, dt: float, omega: float, who: str) -> str:
    """The TurnWarning's text for ``who`` (a body, or bodies of a batch) at |omega| rad/s."""
    bound = turn_bound(method)
    assert bound is not None, 'a method without an energy bound never warns'
    return (f'{who} turned {omega * dt:.3g} rad in a step of {method.name} (|omega| = '
            f'{omega:.6g} rad/s, dt = {dt:g} s), above its energy bound of {bound:g} rad a '
            f'step: beyond it a torque-free body may drift by more than {ENERGY_TOLERANCE:g} '
            f'of its kinetic energy in {ENERGY_STEPS} steps (docs/integrators.md, "Energy '
            f'and the turn per step"); take dt <= {bound / omega:.3g} s, or flow2 or flow4 '
            '(exact torque-free). Said once for each body')


class IntegrationError(RuntimeError):
    """The state became non-finite; ``step`` is the step number (from 0) that produced it."""

    def __init__(self, step: int, message: str) -> None:
        super().__init__(message)
        self.step = step


def carry_over(steppers: dict, before: dict, step_count: int) -> None:
    """A run rebuilt around other bodies goes on: each of ``steppers`` (by name) takes over
    the motion of the one of its name in ``before`` (``Stepper.take_over``); a new one rests
    until ``step_count``, so that its clock is the run's."""
    for name, s in steppers.items():
        old = before.get(name)
        if old is not None:
            s.take_over(old)
        else:
            s.rest(step_count)


def step_all(steppers, n: int) -> None:
    """Step every stepper n steps; if one goes non-finite the others still advance, and the
    first IntegrationError (in the order given) is raised after (that stepper stays at its
    last finite state). Steppers that share a ``BodyStore`` take their steps in one call.
    (The loop is ``Stepping.run``'s, written out: a TurnWarning names the caller's line, as
    many frames up from either.)"""
    check_steps(n)
    if n == 0:
        return
    stepping = Stepping(steppers)
    failed: set | None = None
    for store, rows in stepping._groups:
        bad = store.advance(rows, n)
        if bad:
            failed = failed or set()
            failed.update((row, id(store)) for row in bad)
    if failed:
        for s in stepping.steppers:
            if (s._row, id(s._store)) in failed:
                raise s._error()


class Stepping:
    """``step_all`` of a fixed list of steppers, grouped by store once (a run that steps the
    same bodies call after call pays the grouping once, not at each step(1))."""

    def __init__(self, steppers) -> None:
        self.steppers = tuple(steppers)
        stores: dict[int, tuple[BodyStore, list]] = {}
        seen = set()
        for s in self.steppers:
            if id(s) in seen:  # its row twice would make a run of all rows miss one
                raise ValueError('step_all: a stepper is listed twice')
            seen.add(id(s))
            stores.setdefault(id(s._store), (s._store, []))[1].append(s)
        self._groups = tuple((store, np.array([s._row for s in group], dtype=np.int64))
                             for store, group in stores.values())

    def run(self, n: int) -> None:
        """n steps of each (``step_all``)."""
        check_steps(n)
        if n == 0:
            return
        failed: set | None = None
        for store, rows in self._groups:
            bad = store.advance(rows, n)
            if bad:
                failed = failed or set()
                failed.update((row, id(store)) for row in bad)
        if failed:
            for s in self.steppers:
                if (s._row, id(s._store)) in failed:
                    raise s._error()


def check_dt(dt: Any) -> float:
    """dt as a float; ValueError unless it is a finite number of seconds > 0."""
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f'dt must be a number of seconds, got {dt!r}') from None
    if not math.isfinite(dt) or dt <= 0.0:
        raise ValueError(f'dt must be finite and > 0 s, got {dt!r}')
    return dt


class FixedStep:
    """The clock of a fixed-step integrator (Stepper and batch.BatchStepper): its subclasses
    set ``_dt``, ``_method`` and ``_step_count``."""

    _dt: float
    _method: Any  # multistep.Multistep or multistep.Splitting
    _step_count: int

    @property
    def dt(self) -> float:
        """The fixed step (s)."""
        return self._dt

    @property
    def method(self) -> multistep.Multistep | multistep.Splitting:
        return self._method

    @property
    def step_count(self) -> int:
        """Steps taken since construction (``set_state`` does not reset it)."""
        return self._step_count

    @property
    def time(self) -> float:
        """Simulated time (s): step_count * dt."""
        return self.step_count * self._dt


class BodyStore:
    """Rows of the step kernel's arrays (``step_kernel``) for bodies that share dt and the
    method: each ``Stepper`` is a view of one row (``Stepper.store``, ``Stepper.row``); a
    whole store, or any set of its rows, takes n steps in one compiled call (``advance``).

    What a stage that steps rows reads of them (a collision world's): ``state`` (each row's
    x, v, omega and its rotation r = R Q in principal axes, with the history of its method;
    ``step_kernel``'s columns), ``frames`` (Q of each row, 9 floats row-major: the body's
    principal axes in its own frame; ``has_frame`` False where Q is the identity, which is
    then not applied) and ``clock`` (each row's step count: the one clock of a body)."""

    def __init__(self, count: int, dt: float,
                 method: multistep.Multistep | multistep.Splitting) -> None:
        self.dt, self.method = dt, method
        self.coefficients = coefficients(method, dt, Stepper.ORTHONORMALIZE_EVERY)
        self.state, self.params, self.work = K.new_arrays(count, method.steps)
        self.spare = np.zeros_like(self.state)
        self.frames = np.tile(np.eye(3).reshape(9), (count, 1))
        self.has_frame = np.zeros(count, dtype=np.bool_)
        self.status = np.zeros(count, dtype=np.int64)
        self.taken = np.zeros(count, dtype=np.int64)
        self.bad = np.zeros((count, 3))
        self.clock = np.zeros(count, dtype=np.int64)
        # Each row's squared |omega| above which its step warns (TurnWarning); inf once it has
        # (and for rows that never warn: isotropic, a flow).
        self.warn_sq = np.full(count, math.inf)
        self._used = 0
        # How many times a wrench of its rows changed (Stepper.set_wrench): a world that
        # wakes a sleeper on a new wrench looks at its bodies only when this moved.
        self.wrench_changes = 0
        # the name of the kernel of one row's step (step_kernel.STEP_ONE), looked up again
        # after a tier swap (which rebinds it), and (jit.swaps then, its jit.entry_point for
        # the types of these arrays): what ``one`` gives. The arrays above are made here and
        # never rebound to others (``finish`` swaps state and spare, which have one type).
        self._step_one = K.STEP_ONE[K.family(self.coefficients)]
        self._one: tuple = (-1, None)

    def __len__(self) -> int:
        return len(self.clock)

    def warm_up(self, stepping: bool = True) -> None:
        """Compile (or load from the cache) the kernels a step runs, without taking one: the
        first call of a process pays for that, so a node makes it before its clock starts.
        ``stepping=False``: only those that write rows, for a store whose steps another
        kernel takes (an enabled collision world's ``world_steps``)."""
        rows = np.zeros(0, dtype=np.int64)
        if stepping and len(self.clock):  # (n = 0: nothing moves)
            getattr(K, self._step_one)(self.state, self.spare, self.params, self.coefficients,
                                       0, 0, self.status, self.taken, self.bad, self.work,
                                       self.clock, self.warn_sq)
        if stepping:
            out = (self.status, self.taken, self.bad, self.work)
            K.advance(self.state, self.spare, self.params, self.coefficients, rows, 0, False,
                      *out)
            if K.blocked(self.coefficients, len(self.clock), 1, False):  # a step of them all
                K.advance_blocks(self.state, self.spare, self.params, self.coefficients, rows,
                                 1, *out)
        K.copy_rows(self.state, self.spare, rows)
        if len(self.clock):
            K.evaluate_bodies(self.state, self.params, rows)

    def take_row(self) -> int:
        """The next free row (a new Stepper's)."""
        if self._used >= len(self.clock):
            raise ValueError(f'this BodyStore has no free row ({len(self.clock)} rows)')
        self._used += 1
        return self._used - 1

    def advance(self, rows: np.ndarray, n: int) -> list[int]:
        """Take n >= 1 steps of the bodies ``rows`` (int64, ascending, no repeats). A body
        that fails (``Stepper.step``'s errors) stays at its state after the last good step;
        the rows that failed are returned, their reason in ``status``."""
        if len(rows) == 1:  # a Stepper's step: all of it in one compiled call
            code = self.one()[1](self.state, self.spare, self.params, self.coefficients,
                                 int(rows[0]), n, self.status, self.taken, self.bad, self.work,
                                 self.clock, self.warn_sq)
            if code != 1:
                if code == 2:
                    self.check_turns(rows)
                return []
        elif not len(rows):
            return []
        else:
            K.advance(self.state, self.spare, self.params, self.coefficients, rows, n, False,
                      self.status, self.taken, self.bad, self.work)
        return self.finish(rows, n, 5)

    def one(self) -> tuple:
        """(jit.swaps, f): f(state, spare, params, coefficients, row, n, status, taken, bad,
        work, clock, warn_sq) takes n steps of one row (``step_kernel.STEP_ONE``: the step,
        the copy back, the clock and the turn check) and returns 0, 1 if it failed (then
        ``finish``), 2 if it may turn past its bound (then ``check_turns``): the kernel's
        compiled entry for the types of these arrays, which stay those (``jit.entry_point``;
        made again after a tier swap)."""
        one = self._one
        if one[0] != jit.swaps:
            one = self._one = (jit.swaps, jit.entry_point(
                getattr(K, self._step_one), self.state, self.spare, self.params,
                self.coefficients, 0, 1, self.status, self.taken, self.bad, self.work,
                self.clock, self.warn_sq))
        return one

    def finish(self, rows: np.ndarray, n: int, stacklevel: int) -> list[int]:
        """After n steps of ``rows`` by a kernel that checked only their end states: the
        rows that failed taken again, one step at a time, to the state before their bad
        step; the states copied back, the clocks moved on, the turns checked (a TurnWarning
        at ``stacklevel`` from here). The rows that failed, as ``advance`` returns them."""
        failed = rows[self.status[rows] != K.STATUS_OK]
        out = (self.status, self.taken, self.bad, self.work)
        if len(failed):
            # Taken again from the untouched rows, step by step: the state before the bad
            # step lands in ``spare``, and ``taken`` says how many were good.
            K.advance(self.state, self.spare, self.params, self.coefficients, failed, n,
                      True, *out)
        if len(rows) == len(self.clock):
            self.state, self.spare = self.spare, self.state
        else:
            K.copy_rows(self.state, self.spare, rows)
        self.clock[rows] += n
        if len(failed):
            self.clock[failed] -= n - self.taken[failed]
            # (the others raise)
            self.check_turns(rows[self.status[rows] == K.STATUS_OK], stacklevel)
        else:
            self.check_turns(rows, stacklevel)
        return failed.tolist()

    def check_turns(self, rows: np.ndarray, stacklevel: int = 4) -> None:
        """A TurnWarning for each of ``rows`` (int64) whose body now turns faster than its
        method's energy bound, once for each row (after a run of any kernel that steps
        them), at ``stacklevel`` frames up from here (4, from ``advance``: the line that
        called its caller, a Stepper's step)."""
        watched = rows[self.warn_sq[rows] != math.inf]
        if not len(watched):
            return
        w = self.state[watched, K.W:K.W + 3]
        w2 = (w * w).sum(axis=1)
        for row, sq in zip(watched[w2 > self.warn_sq[watched]].tolist(),
                           w2[w2 > self.warn_sq[watched]].tolist()):
            self.warn_sq[row] = math.inf
            warnings.warn(turn_message(self.method, self.dt, math.sqrt(sq), 'a body'),
                          TurnWarning, stacklevel=stacklevel)


class Stepper(FixedStep):
    """Advances one rigid body with a fixed step dt (s) under a held wrench.

    Time is ``step_count * dt``, never wall time. Every input is validated before anything
    changes; a failed call leaves the stepper as it was. The body is one row of the step
    kernel's arrays (``step_kernel``): a step is one compiled call.
    """

    ORTHONORMALIZE_EVERY = 1024
    # The most a body with unequal principal moments may turn in one step, |omega| dt (rad),
    # with any method: a step that ends faster raises IntegrationError. It is no accuracy
    # bound: the energy of a torque-free body is kept (within ENERGY_TOLERANCE over
    # ENERGY_STEPS steps) only up to TURN_BOUNDS, 0.02 to 0.1 rad a step by method, beyond
    # which a step warns (TurnWarning); from 0.3 to 0.7 rad a step, by method, the energy of
    # some bodies grows until this limit stops them (bench/energy_drift.py). Isotropic bodies
    # have no gyroscopic term (exp() turns them exactly at any rate), and no limit.
    MAX_TURN = 1.0

    def __init__(self, body: RigidBody, dt: float, state: State | None = None,
                 wrench: Wrench = ZERO_WRENCH,
                 method: multistep.Multistep | str = multistep.EQ27,
                 gravity: Any = (0.0, 0.0, 0.0), linear_damping: float = 0.0,
                 angular_damping: float = 0.0, specialize: bool = True,
                 store: BodyStore | None = None) -> None:
        """``gravity`` (m/s^2, world) accelerates the centre of mass; ``linear_damping`` c and
        ``angular_damping`` d (1/s) add -c v and -d omega to the accelerations. ``specialize``
        lets the kernel skip the translation or rotation update of a body at rest in that
        sense under no force or torque, and the gyroscopic term of an isotropic body; False
        always takes the general path (for comparison). ``store``: a ``BodyStore`` of the same
        dt and method with a free row, shared with other steppers (default: one of its own)."""
        if not isinstance(body, RigidBody):
            raise ValueError(f'body must be a RigidBody, got {body!r}')
        self._dt = check_dt(dt)
        gravity = finite_floats('gravity', gravity, 3)
        linear_damping = rate('linear_damping', linear_damping)
        angular_damping = rate('angular_damping', angular_damping)
        self._method = (multistep.method_by_name(method) if isinstance(method, str)
                        else method)
        if not isinstance(self._method, (multistep.Multistep, multistep.Splitting)):
            raise ValueError(f'method must be a Multistep or its name, got {method!r}')
        self._body = body
        self._inverse_mass = 1.0 / body.mass
        # The kernel works in principal axes: r = R Q (see euler_dynamics.principal_axes).
        moments, q = euler_dynamics.principal_axes(body.inertia)
        self._q = None if np.array_equal(q, np.eye(3)) else q
        # Q as 9 floats: products with it are written out (so3.mul9), not numpy's BLAS.
        self._q9 = None if self._q is None else tuple(float(c) for c in q.reshape(9))
        if store is None:
            store = BodyStore(1, self._dt, self._method)
        elif not isinstance(store, BodyStore):
            raise ValueError(f'store must be a BodyStore or None, got {store!r}')
        elif store.dt != self._dt or store.method != self._method:
            raise ValueError(f'store steps dt = {store.dt!r} s with {store.method.name}, this '
                             f'stepper dt = {self._dt!r} s with {self._method.name}')
        self._store, self._row = store, store.take_row()
        self._rows = np.array([self._row], dtype=np.int64)
        if self._q is not None:
            store.frames[self._row] = self._q9
            store.has_frame[self._row] = True
        set_body_params(store.params[self._row], moments, gravity, linear_damping,
                        angular_damping, bool(specialize), self.MAX_TURN, self._dt)
        store.warn_sq[self._row] = turn_warning_sq(
            self._method, self._dt, store.params[self._row, K.MAX_TURN_SQ] == math.inf)
        self._has_state = False
        self._wrench: Wrench | None = None
        self.set_wrench(wrench)
        self.set_state(State() if state is None else state)

    # -- read ------------------------------------------------------------------------------
    @property
    def body(self) -> RigidBody:
        return self._body

    @property
    def wrench(self) -> Wrench:
        """The wrench held now."""
        assert self._wrench is not None  # set in __init__
        return self._wrench

    @property
    def work(self) -> dict[str, int]:
        """What the kernel has done for this body so far: full steps, steps of translation
        only (a body that does not turn) and start-ups or history re-evaluations. A body at
        rest and unforced adds nothing."""
        full, translation, start_up = (int(c) for c in self._store.work[self._row])
        return {'full': full, 'translation': translation, 'start_up': start_up}

    @property
    def step_count(self) -> int:
        """Steps taken since construction (``set_state`` does not reset it)."""
        return int(self._store.clock[self._row])

    @property
    def store(self) -> BodyStore:
        """The ``BodyStore`` this stepper is a row of."""
        return self._store

    @property
    def row(self) -> int:
        """Its row of ``store``."""
        return self._row

    @property
    def state(self) -> State:
        """The current state (world frame), as a validated, immutable ``State``."""
        x, _, v, w = self._row_components()
        return State(x, self._rotation(), v, w)

    def pose_twist(self) -> tuple[tuple[float, ...], ...]:
        """(position m, quaternion x-y-z-w, linear velocity m/s, angular velocity rad/s), world
        frame, as tuples of floats: the cheap read for publishing."""
        x, r, v, w = self.components()
        return x, so3.quaternion_xyzw_from_components(*r), v, w

    def accelerations(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(a m/s^2, beta rad/s^2), world frame: Thm 1 at the current state under the held
        wrench, gravity and damping, the derivative every method integrates (whatever it keeps
        in its row: the splittings keep none)."""
        _, r, v, w = self._row_components()
        a0, a1, a2, b0, b1, b2 = K.accelerations(self._store.params, self._row, *r, *w, *v,
                                                 False)
        return (float(a0), float(a1), float(a2)), (float(b0), float(b1), float(b2))

    def rotation(self) -> np.ndarray:
        """R (body to world) as integrated: not projected onto SO(3) as ``State`` does, so
        its orthonormality error is the integrator's own."""
        return self._rotation()

    def _row_components(self):
        row = self._store.state[self._row].tolist()
        return tuple(row[K.X:K.X + 3]), tuple(row[K.R:K.R + 9]), tuple(row[K.V:K.V + 3]), \
            tuple(row[K.W:K.W + 3])

    def _rotation(self) -> np.ndarray:
        """R of the user's body frame: the principal-frame R Q, times Q^T."""
        return np.array(self.components()[1]).reshape(3, 3)

    def components(self):
        """(position m, R row-major (9 floats, body to world), linear velocity m/s, angular
        velocity rad/s), world frame, R as integrated: the cheap read of the collision world."""
        x, r, v, w = self._row_components()
        if self._q is not None:
            r = so3.mul9(r, self._q9, transpose_b=True)
        return x, r, v, w

    # -- write -----------------------------------------------------------------------------
    def set_state(self, state: State, previous: State | Sequence[State] | None = None) -> None:
        """Jump to ``state`` (world frame). The history restarts (start-up on the next step)
        unless ``previous`` is given: the exact states one dt, 2 dt, ... earlier, as many as
        the method keeps (``method.steps - 1``; one may be given as a State; a method that
        keeps none, flow2 or flow4, takes None only). For lie3 and lie4 a wrench set after
        this starts the history again from ``state`` (docs/integrators.md, "Wrench
        changes"); eq27 evaluates the given state again under it."""
        if not isinstance(state, State):
            raise ValueError(f'state must be a State, got {state!r}')
        if isinstance(previous, State):
            previous = (previous,)
        keep = self._method.steps - 1
        if previous is not None and (
                keep == 0 or not isinstance(previous, (list, tuple)) or len(previous) != keep
                or not all(isinstance(s, State) for s in previous)):
            raise ValueError(f'previous must be None or {keep} State(s), newest first '
                             f'({self._method.name} keeps {keep}), got {previous!r}')
        row = self._store.state[self._row]
        _write(row, K.X, _components(state, self._q))
        if previous is None:
            row[K.HISTORY] = K.HISTORY_NONE
        else:
            for j, before in enumerate(previous, 1):
                _write(row, K.slot_column(j), _components(before, self._q))
            if keep == 1:  # eq. (27)'s form: evaluated when it steps, under its wrench then
                row[K.HISTORY] = K.HISTORY_STALE
            else:
                K.evaluate_history(self._store.state, self._store.params, self._row, keep + 1)
                row[K.HISTORY] = K.HISTORY_VALID
        row[K.COUNTDOWN] = self.ORTHONORMALIZE_EVERY
        K.evaluate(self._store.state, self._store.params, self._row)
        self._has_state = True

    def apply_contact(self, position, rotation: np.ndarray, linear_velocity,
                      angular_velocity, step: int | None = None) -> None:
        """The collision world's write after an impulse or a position correction: ``set_state``
        without validating R (the values come from ``components`` and the contact solver; a
        non-finite one raises IntegrationError and changes nothing). rotation: 3x3 or 9
        row-major values, body to world. The history restarts; the orthonormalization count
        goes on, since a body resting in contact is written every step. ``step``: the index of
        the step whose contacts these are, for the error (default: ``step_count``)."""
        r = tuple(float(c) for c in np.asarray(rotation, dtype=float).reshape(9))
        if self._q is not None:
            r = so3.mul9(r, self._q9)
        x = tuple(float(c) for c in position)
        v = tuple(float(c) for c in linear_velocity)
        w = tuple(float(c) for c in angular_velocity)
        if not _finite(x, v, r, w):
            step = self.step_count if step is None else step
            raise IntegrationError(
                step, f'a contact made the state non-finite at step {step} '
                f'(t = {step * self._dt:.9g} s): x = {x}, v = {v}, omega = {w}; the body '
                'keeps its state before the contact')
        row = self._store.state[self._row]
        _write(row, K.X, (x, v, r, w))
        row[K.HISTORY] = K.HISTORY_NONE
        K.evaluate(self._store.state, self._store.params, self._row)

    def take_over(self, other: 'Stepper') -> None:
        """Go on with ``other``'s motion as if it had always been this stepper's: its row
        (state, history, held wrench, damping and gravity), clock and work counts are copied
        bit for bit. For a world rebuilt around its bodies (a body spawned or deleted): the
        same body, dt and method, else ValueError."""
        if not isinstance(other, Stepper) or other._dt != self._dt or \
                other._method != self._method or other._body.mass != self._body.mass or \
                not np.array_equal(other._body.inertia, self._body.inertia):
            raise ValueError('take_over needs a stepper of the same body, dt and method')
        store, row = self._store, self._row
        store.state[row] = other._store.state[other._row]
        store.params[row] = other._store.params[other._row]
        store.work[row] = other._store.work[other._row]
        store.clock[row] = other._store.clock[other._row]
        store.warn_sq[row] = other._store.warn_sq[other._row]
        self._wrench, self._has_state = other._wrench, other._has_state
        self._store.wrench_changes += 1

    def rest(self, n: int) -> None:
        """Count ``n`` >= 0 steps spent asleep (the collision world's): the clock advances,
        the state, at rest, does not."""
        check_steps(n)
        self._store.clock[self._row] += n

    def restart_history(self) -> None:
        """Forget the previous step (after an impulse: do not extrapolate across it)."""
        self._store.state[self._row, K.HISTORY] = K.HISTORY_NONE

    def set_wrench(self, wrench: Wrench) -> None:
        """Hold ``wrench`` from the next step on (zero-order hold)."""
        if not isinstance(wrench, Wrench):
            raise ValueError(f'wrench must be a Wrench, got {wrench!r}')
        if wrench == self._wrench:
            return
        self._wrench = wrench
        self._store.wrench_changes += 1
        in_body = wrench.frame is Frame.BODY
        components = wrench.components
        force: Any = components[:3]
        torque: Any = components[3:]
        if in_body and self._q is not None:
            force = so3.mul9_vec(self._q9, force, transpose=True)
            torque = so3.mul9_vec(self._q9, torque, transpose=True)
        set_wrench_params(self._store.params[self._row], self._inverse_mass, force, torque,
                          in_body)
        if self._has_state:
            state = self._store.state
            K.evaluate(state, self._store.params, self._row)
            if state[self._row, K.HISTORY] != K.HISTORY_NONE:
                state[self._row, K.HISTORY] = K.HISTORY_STALE

    def step(self, n: int = 1) -> None:
        """Advance ``n`` >= 0 steps.

        Raises IntegrationError, naming the step, if the state stops being finite or a body with
        unequal moments ends a step turning faster than MAX_TURN rad a step (where the method is
        unstable). The stepper is then left exactly as it was after the last good step: state,
        history and clock, so every read (``state``, ``pose_twist``, ``components``,
        ``rotation``, ``time``) gives that finite state, and ``set_state``, ``set_wrench`` or
        stepping on from there work as usual. The kernel checks the end state only; on failure
        the same steps are taken again from the unchanged start, checked one by one, to find
        the first bad one (the arithmetic repeats the first pass exactly).

        Warns (TurnWarning, once for the body) if the steps end with it turning faster than
        its method's energy bound, ``TURN_BOUNDS`` rad a step (checked at the end, as MAX_TURN).
        """
        if type(n) is not int or not 0 < n <= MAX_STEPS:  # (the common case, quickly)
            check_steps(n)
            if n == 0:
                return
        # BodyStore.advance of this one row, written out (a step costs less than a call)
        store = self._store
        code = store.one()[1](store.state, store.spare, store.params, store.coefficients,
                              self._row, n, store.status, store.taken, store.bad, store.work,
                              store.clock, store.warn_sq)
        if code == 2:
            store.check_turns(self._rows, 3)
        elif code == 1 and store.finish(self._rows, n, 4):
            raise self._error()

    def _error(self) -> IntegrationError:
        """The IntegrationError of this body's last failed run (the store's status)."""
        status = int(self._store.status[self._row])
        step = self.step_count
        _, _, v, w = self._row_components()
        if status == K.STATUS_START_UP:
            return IntegrationError(
                step, f'start-up became non-finite at step {step} '
                f'(t = {step * self._dt:.9g} s) from v = {v}, omega = {w}')
        if status == K.STATUS_TURN:
            w1 = self._store.bad[self._row]
            what = (f'turns faster than {self.MAX_TURN:g} rad a step '
                    f'(|omega| = {math.hypot(*(float(c) for c in w1)):.6g} rad/s): beyond it '
                    "the explicit update of Euler's equations of a body with unequal "
                    'moments is unstable (reduce dt)')
        else:
            what = 'became non-finite'
        return IntegrationError(
            step, f'state {what} at step {step} (t = {step * self._dt:.9g} s) from '
            f'v = {v}, omega = {w}; the body keeps its state before that step')


def coefficients(method: multistep.Multistep | multistep.Splitting, dt: float,
                 every: int) -> np.ndarray:
    """The kernel's coefficients (``step_kernel.coefficients``): the method's and eq27's
    start-up's (TAYLOR1), times powers of dt, the angle lift and the orthonormalisation
    period."""
    return K.coefficients(method, multistep.TAYLOR1, dt, so3.TINY_ANGLE_SQ, every)


def set_body_params(p: np.ndarray, moments, gravity, linear_damping: float,
                    angular_damping: float, specialize: bool, max_turn: float,
                    dt: float) -> None:
    """Fill a kernel params row with what does not depend on the wrench."""
    ix, iy, iz = moments
    p[K.MOMENTS:K.MOMENTS + 3] = moments
    p[K.INVERSE_MOMENTS:K.INVERSE_MOMENTS + 3] = (1.0 / ix, 1.0 / iy, 1.0 / iz)
    p[K.GRAVITY:K.GRAVITY + 3] = gravity
    p[K.LINEAR_DAMPING] = linear_damping
    p[K.ANGULAR_DAMPING] = angular_damping
    isotropic = ix == iy == iz
    p[K.MAX_TURN_SQ] = math.inf if isotropic else (max_turn / dt) ** 2
    flags = 0
    if specialize:
        flags |= K.SPECIALIZE | (K.ISOTROPIC if isotropic else 0)
    p[K.FLAGS] = flags


def set_wrench_params(p: np.ndarray, inverse_mass: float, force, torque,
                      in_body: bool) -> None:
    """Fill a kernel params row with a held wrench (force and torque in the principal body
    frame if ``in_body``, else world), as Thm 1 takes it: F / m, and F / m + g where constant."""
    f0, f1, f2 = force.tolist() if type(force) is np.ndarray else map(float, force)
    tx, ty, tz = torque.tolist() if type(torque) is np.ndarray else map(float, torque)
    fx, fy, fz = f0 * inverse_mass, f1 * inverse_mass, f2 * inverse_mass
    gx, gy, gz = p[K.GRAVITY:K.GRAVITY + 3].tolist()
    has_gravity = gx != 0.0 or gy != 0.0 or gz != 0.0
    torque_free = tx == 0.0 and ty == 0.0 and tz == 0.0
    force_free = not has_gravity and f0 == 0.0 and f1 == 0.0 and f2 == 0.0
    # FORCE, TORQUE (6 .. 11) in one write; WORLD_A (15 .. 17) in another.
    p[K.FORCE:K.TORQUE + 3] = (fx, fy, fz, tx, ty, tz)
    p[K.WORLD_A:K.WORLD_A + 3] = (fx + gx, fy + gy, fz + gz) if has_gravity else (fx, fy, fz)
    flags = int(p[K.FLAGS]) & (K.SPECIALIZE | K.ISOTROPIC)
    flags |= (K.FORCE_IN_BODY | K.TORQUE_IN_BODY) if in_body else 0
    flags |= (K.TORQUE_FREE if torque_free else 0) | (K.FORCE_FREE if force_free else 0)
    p[K.FLAGS] = flags


def _write(row: np.ndarray, at: int, components) -> None:
    """Write (x, v, r, w) at ``at`` of a kernel state row (the layout of step_kernel)."""
    x, v, r, w = components
    row[at:at + 3] = x
    row[at + 3:at + 6] = v
    row[at + 6:at + 15] = r
    row[at + 15:at + 18] = w


def _finite(*vectors) -> bool:
    return all(math.isfinite(c) for vec in vectors for c in vec)


def _components(state: State, q: np.ndarray | None):
    rot = tuple(float(c) for c in state.rotation.reshape(9))
    if q is not None:
        rot = so3.mul9(rot, tuple(float(c) for c in q.reshape(9)))
    return (tuple(float(c) for c in state.position),
            tuple(float(c) for c in state.linear_velocity),
            rot,
            tuple(float(c) for c in state.angular_velocity))
