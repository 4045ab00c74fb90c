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
from typing import Any

import numpy as np

from rb_sim_ros.core import euler_dynamics, multistep, so3
from rb_sim_ros.core.rigid_body import (finite_floats, Frame, rate, RigidBody, State, Wrench,
                                        ZERO_WRENCH)


class IntegrationError(RuntimeError):
    """The state became non-finite; ``step`` is the step number (from 0) that produced it."""

    def __init__(self, step: int, message: str) -> None:
        super().__init__(message)
        self.step = step


def step_all(steppers, n: int) -> None:
    """Step every stepper n steps; if one goes non-finite the others still advance, and the
    first IntegrationError is raised after (that stepper stays at its last finite state)."""
    error = None
    for s in steppers:
        try:
            s.step(n)
        except IntegrationError as e:
            error = error or e
    if error is not None:
        raise error


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

    @property
    def dt(self) -> float:
        """The fixed step (s)."""
        return self._dt

    @property
    def method(self) -> multistep.Multistep:
        return self._method

    @property
    def step_count(self) -> int:
        """Steps taken since construction (``set_state`` does not reset it)."""
        return self._step_count

    @property
    def time(self) -> float:
        """Simulated time (s): step_count * dt."""
        return self._step_count * self._dt


class Stepper(FixedStep):
    """Advances one rigid body with a fixed step dt (s) under a held wrench.

    Time is ``step_count * dt``, never wall time. Every input is validated before anything
    changes; a failed call leaves the stepper as it was.
    """

    ORTHONORMALIZE_EVERY = 1024
    # The most a body with unequal principal moments may turn in one step, |omega| dt (rad).
    # The explicit update of Euler's equations (the gyroscopic term) is unstable beyond about
    # this: measured over random inertias and axes, free rotation keeps its energy to 2000
    # steps at |omega| dt <= 0.7, while from 1 rad a step on some bodies, and from 3 on nearly
    # all, the energy grows without bound (x30 in two steps at 3 rad). A step that ends faster
    # raises IntegrationError rather than publish that. Isotropic bodies have no gyroscopic
    # term (exp() turns them exactly at any rate) and no limit.
    MAX_TURN = 1.0

    def __init__(self, body: RigidBody, dt: float, state: State | None = None,
                 wrench: Wrench = ZERO_WRENCH,
                 method: multistep.Multistep | str = multistep.EQ27,
                 gravity: Any = (0.0, 0.0, 0.0), linear_damping: float = 0.0,
                 angular_damping: float = 0.0, specialize: bool = True) -> None:
        """``gravity`` (m/s^2, world) accelerates the centre of mass; ``linear_damping`` c and
        ``angular_damping`` d (1/s) add -c v and -d omega to the accelerations. ``specialize``
        builds the step for what the body needs (see ``euler_dynamics.make_accelerations``)
        and skips the translation or rotation update of a body at rest in that sense under no
        force or torque; False always takes the general path (for comparison)."""
        if not isinstance(body, RigidBody):
            raise ValueError(f'body must be a RigidBody, got {body!r}')
        self._dt = check_dt(dt)
        self._gravity = finite_floats('gravity', gravity, 3)
        self._linear_damping = rate('linear_damping', linear_damping)
        self._angular_damping = rate('angular_damping', angular_damping)
        self._specialize = bool(specialize)
        self._method = (multistep.method_by_name(method) if isinstance(method, str)
                        else method)
        if not isinstance(self._method, multistep.Multistep):
            raise ValueError(f'method must be a Multistep or its name, got {method!r}')
        self._body = body
        self._inverse_mass = 1.0 / body.mass
        # The hot path works in principal axes: r = R Q (see euler_dynamics.principal_axes).
        self._moments, q = euler_dynamics.principal_axes(body.inertia)
        isotropic = self._moments[0] == self._moments[1] == self._moments[2]
        self._max_turn_rate_sq = math.inf if isotropic else (self.MAX_TURN / self._dt) ** 2
        self._q = None if np.array_equal(q, np.eye(3)) else q
        # Q as 9 floats: products with it are written out (so3.mul9), not numpy's BLAS.
        self._q9 = None if self._q is None else tuple(float(c) for c in q.reshape(9))
        self._advance = multistep.make_step(self._method, self._dt)
        # The step of a body that does not turn (see make_step).
        self._no_rotation = multistep.make_step(self._method, self._dt, rotate=False)
        self._startup = multistep.make_step(multistep.TAYLOR1, self._dt)
        self._step_count = 0
        self._wrench = ZERO_WRENCH
        self.set_wrench(wrench)
        self.set_state(State() if state is None else state)

    # -- read ------------------------------------------------------------------------------
    @property
    def body(self) -> RigidBody:
        return self._body

    @property
    def wrench(self) -> Wrench:
        """The wrench held now."""
        return self._wrench

    @property
    def state(self) -> State:
        """The current state (world frame), as a validated, immutable ``State``."""
        return State(self._x, self._rotation(), self._v, self._w)

    def pose_twist(self) -> tuple[tuple[float, ...], ...]:
        """(position m, quaternion x-y-z-w, linear velocity m/s, angular velocity rad/s), world
        frame, as tuples of floats: the cheap read for publishing."""
        r = self._r if self._q is None else tuple(float(c) for c in self._rotation().reshape(9))
        return self._x, so3.quaternion_xyzw_from_components(*r), self._v, self._w

    def rotation(self) -> np.ndarray:
        """R (body to world) as integrated: not projected onto SO(3) as ``State`` does, so
        its orthonormality error is the integrator's own."""
        return self._rotation()

    def _rotation(self) -> np.ndarray:
        """R of the user's body frame: the principal-frame R Q, times Q^T."""
        r = self._r if self._q is None else so3.mul9(self._r, self._q9, transpose_b=True)
        return np.array(r).reshape(3, 3)

    # -- write -----------------------------------------------------------------------------
    def set_state(self, state: State, previous: State | None = None) -> None:
        """Jump to ``state`` (world frame). The history restarts (start-up on the next step)
        unless ``previous``, the exact state one dt earlier, is given."""
        if not isinstance(state, State):
            raise ValueError(f'state must be a State, got {state!r}')
        if previous is not None and not isinstance(previous, State):
            raise ValueError(f'previous must be a State or None, got {previous!r}')
        self._x, self._v, self._r, self._w = _components(state, self._q)
        self._a, self._b = self._accelerations(self._r, self._w, self._v)
        self._prev = None if previous is None else _components(previous, self._q)
        self._pa = self._pb = None
        self._history_stale = previous is not None
        self._orthonormalize_countdown = self.ORTHONORMALIZE_EVERY

    def components(self):
        """(position m, R row-major (9 floats, body to world), linear velocity m/s, angular
        velocity rad/s), world frame, R as integrated: the cheap read of the collision world."""
        r = self._r if self._q is None else tuple(float(c) for c in self._rotation().reshape(9))
        return self._x, r, self._v, self._w

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
            step = self._step_count if step is None else step
            raise IntegrationError(
                step, f'a contact made the state non-finite at step {step} '
                f'(t = {step * self._dt:.9g} s): x = {x}, v = {v}, omega = {w}; the body '
                'keeps its state before the contact')
        self._x, self._v, self._r, self._w = x, v, r, w
        self._a, self._b = self._accelerations(self._r, self._w, self._v)
        self._prev = None
        self._pa = self._pb = None
        self._history_stale = False

    def rest(self, n: int) -> None:
        """Count ``n`` >= 0 steps spent asleep (the collision world's): the clock advances,
        the state, at rest, does not."""
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise ValueError(f'n must be an int >= 0, got {n!r}')
        self._step_count += n

    def restart_history(self) -> None:
        """Forget the previous step (after an impulse: do not extrapolate across it)."""
        self._prev = None
        self._history_stale = False

    def set_wrench(self, wrench: Wrench) -> None:
        """Hold ``wrench`` from the next step on (zero-order hold)."""
        if not isinstance(wrench, Wrench):
            raise ValueError(f'wrench must be a Wrench, got {wrench!r}')
        if wrench == self._wrench and hasattr(self, '_accelerations'):
            return
        self._wrench = wrench
        in_body = wrench.frame is Frame.BODY
        force, torque = wrench.force, wrench.torque
        if in_body and self._q is not None:
            force = so3.mul9_vec(self._q9, force, transpose=True)
            torque = so3.mul9_vec(self._q9, torque, transpose=True)
        self._accelerations = euler_dynamics.make_accelerations(
            self._inverse_mass, self._moments, tuple(float(c) for c in force),
            tuple(float(c) for c in torque), in_body, in_body, self._gravity,
            self._linear_damping, self._angular_damping, self._specialize)
        if hasattr(self, '_r'):
            self._a, self._b = self._accelerations(self._r, self._w, self._v)
            self._history_stale = self._prev is not None

    def step(self, n: int = 1) -> None:
        """Advance ``n`` >= 0 steps.

        Raises IntegrationError, naming the step, if the state stops being finite or a body with
        unequal moments ends a step turning faster than MAX_TURN rad a step (where the method is
        unstable). The stepper is then left exactly as it was after the last good step: state,
        history and clock, so every read (``state``, ``pose_twist``, ``components``,
        ``rotation``, ``time``) gives that finite state, and ``set_state``, ``set_wrench`` or
        stepping on from there work as usual. The loop itself does not test each step: a
        non-finite value never becomes finite again in this arithmetic (nan absorbs, inf meets
        sin() which raises; the first pass lets that exception through), so the end state is
        checked, and only on failure are the same steps taken again from the saved start, one
        by one, to find the first bad one. The arithmetic is deterministic, so the second pass
        repeats the first exactly.
        """
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise ValueError(f'n must be an int >= 0, got {n!r}')
        if n == 0:
            return
        saved = self._save()
        try:
            self._run(n, check=False)
            if _finite(self._x, self._v, self._r, self._w) and self._turn_ok(self._w):
                return
        except (ValueError, OverflowError):
            pass
        self._restore(saved)
        try:
            self._run(n, check=True)
        except IntegrationError:
            if self._step_count == saved[STEP_COUNT]:  # the first step failed: none taken
                self._restore(saved)  # (start-up may have left a non-finite history)
            raise

    def _run(self, n: int, check: bool) -> None:
        accelerations, advance = self._accelerations, self._advance
        x, v, r, w, a, b = self._x, self._v, self._r, self._w, self._a, self._b
        try:
            ap, bp = self._history()
        except (ValueError, OverflowError):
            if not check:
                raise
            raise IntegrationError(
                self._step_count, f'start-up became non-finite at step {self._step_count} '
                f'(t = {self._step_count * self._dt:.9g} s) from v = {v}, omega = {w}') from None
        xp, vp, rp, wp = self._prev or (x, v, r, w)
        countdown = self._orthonormalize_countdown
        frozen_rotation = False
        if self._specialize:
            zero = euler_dynamics.ZERO3
            frozen_rotation = (accelerations.torque_free and w == zero and b == zero
                               and bp == zero)
            frozen_translation = (accelerations.force_free and v == zero and a == zero
                                  and ap == zero)
            if frozen_rotation and frozen_translation:  # at rest, unforced: nothing moves
                self._store(n, x, v, r, w, a, b, x, v, r, w, a, b, countdown)
                return
            if frozen_rotation:
                advance = self._no_rotation
                accelerations = accelerations.linear_only
        for i in range(n):
            try:
                x1, v1, r1, w1 = advance(x, v, r, w, a, b, ap, bp)
            except (ValueError, OverflowError):
                if not check:  # step() goes back to the start and finds the first bad step
                    raise
                x1 = None
            if check and (x1 is None or not _finite(x1, v1, r1, w1)
                          or not self._turn_ok(w1)):
                # Only checked steps get here, so x .. w, the state before, are finite.
                self._store(i, x, v, r, w, a, b, xp, vp, rp, wp, ap, bp, countdown)
                step = self._step_count
                what = ('became non-finite' if x1 is None or not _finite(x1, v1, r1, w1)
                        else f'turns faster than {self.MAX_TURN:g} rad a step '
                        f'(|omega| = {math.sqrt(sum(c * c for c in w1)):.6g} rad/s): beyond it '
                        "the explicit update of Euler's equations of a body with unequal "
                        'moments is unstable (reduce dt)')
                raise IntegrationError(
                    step, f'state {what} at step {step} (t = {step * self._dt:.9g} s) from '
                    f'v = {v}, omega = {w}; the body keeps its state before that step')
            countdown -= 1
            if not countdown and not frozen_rotation:
                r1 = so3.orthonormalize_components(*r1)
                countdown = self.ORTHONORMALIZE_EVERY
            xp, vp, rp, wp, ap, bp = x, v, r, w, a, b
            x, v, r, w = x1, v1, r1, w1
            a, b = accelerations(r, w, v)
        self._store(n, x, v, r, w, a, b, xp, vp, rp, wp, ap, bp, countdown)

    def _turn_ok(self, w) -> bool:
        """Whether omega turns the body at most MAX_TURN rad a step (or it is isotropic)."""
        return w[0] * w[0] + w[1] * w[1] + w[2] * w[2] <= self._max_turn_rate_sq

    def _save(self):
        return (self._x, self._v, self._r, self._w, self._a, self._b, self._prev, self._pa,
                self._pb, self._history_stale, self._step_count, self._orthonormalize_countdown)

    def _restore(self, saved) -> None:
        (self._x, self._v, self._r, self._w, self._a, self._b, self._prev, self._pa,
         self._pb, self._history_stale, self._step_count,
         self._orthonormalize_countdown) = saved

    def _history(self):
        """(a_{n-1}, beta_{n-1}) for the next step, world frame: start-up or re-evaluation."""
        x, v, r, w, a, b = self._x, self._v, self._r, self._w, self._a, self._b
        if self._prev is None:
            # Start-up: predict with a one-step Taylor step, extrapolate back.
            _, v1, r1, w1 = self._startup(x, v, r, w, a, b, a, b)
            a1, b1 = self._accelerations(r1, w1, v1)
            self._pa = (2.0 * a[0] - a1[0], 2.0 * a[1] - a1[1], 2.0 * a[2] - a1[2])
            self._pb = (2.0 * b[0] - b1[0], 2.0 * b[1] - b1[1], 2.0 * b[2] - b1[2])
        elif self._history_stale:
            _, vp, rp, wp = self._prev
            self._pa, self._pb = self._accelerations(rp, wp, vp)
        self._history_stale = False
        return self._pa, self._pb

    def _store(self, steps, x, v, r, w, a, b, xp, vp, rp, wp, ap, bp, countdown):
        self._x, self._v, self._r, self._w, self._a, self._b = x, v, r, w, a, b
        if steps:
            self._prev = (xp, vp, rp, wp)
            self._pa, self._pb = ap, bp
            self._step_count += steps
        self._orthonormalize_countdown = countdown


STEP_COUNT = 10  # the index of step_count in Stepper._save()


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
