# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""N rigid bodies stepped together: the step kernel of ``Stepper``, on all of them at once.

    batch = BatchStepper(masses, inertias, dt=1e-3, angular_velocities=w)  # (N,), (N, 3, 3)
    batch.set_wrench([0, 5], torque=(0.0, 0.0, 0.01), frame='body')        # bodies 0 and 5
    batch.step(1000)
    batch.rotations()                                                      # (N, 3, 3)

Units are SI and every vector is in the world frame unless named otherwise; a rotation R maps
body-frame vectors to the world frame (``r_world = R @ r_body``), as everywhere in rb_sim_ros.

A batch is N rows of the step kernel's arrays (``step_kernel``): the same compiled function
that steps a ``Stepper`` (its one-row case) takes every body n steps in one call, the bodies
shared among the cores from ``chunk_size`` bodies on. So a body of a batch and a ``Stepper``
of the same body, state and wrench give the same bits (``test/core/test_batch.py``), read alike:
``rotations()`` is R as integrated, as ``Stepper.rotation()`` and ``components()`` are;
``state(i)`` is a ``State``, as ``Stepper.state`` is, whose R is that one projected onto SO(3)
(up to ~10 ulp away, the integrator's orthonormality error); ``quaternions_xyzw()`` are those
of ``Stepper.pose_twist()``.

Failures cost nothing until they happen: the kernel reads the committed arrays and writes
the spare ones, so a run in which some body failed (non-finite, or turning faster than
``Stepper.MAX_TURN`` rad a step with unequal moments) is not committed; the failed bodies are
taken again step by step to find the first bad step, every body takes the steps before it,
and ``BatchIntegrationError`` names that step and the bodies. Memory is two state rows and
one parameter row per body, allocated once (``nbytes``): nothing grows with the steps.
"""

from __future__ import annotations

import math
from typing import Any
import warnings

import numpy as np

from rb_sim_ros.core import euler_dynamics, multistep, so3
from rb_sim_ros.core import step_kernel as K
from rb_sim_ros.core.rigid_body import (finite_floats, Frame, RigidBody, ROTATION_TOLERANCE, short,
                                        State, SYMMETRY_TOLERANCE, TRIANGLE_TOLERANCE)
from rb_sim_ros.core.step_count import check_steps
from rb_sim_ros.core.stepper import (check_dt, coefficients, FixedStep, IntegrationError,
                                     set_body_params, set_wrench_params, Stepper,
                                     turn_message, turn_warning_sq, TurnWarning)

# From this many bodies on, a step shares them among the cores.
CHUNK_SIZE = 4096


class BatchIntegrationError(IntegrationError):
    """Some bodies went non-finite (or too fast) at ``step``; ``bodies`` lists them (ascending).
    No body took that step."""

    def __init__(self, step: int, bodies: list[int], message: str) -> None:
        super().__init__(step, message)
        self.bodies = bodies


def _indices(value: Any, n: int) -> np.ndarray:
    """Body indices (k,) from None (all), an int, a sequence of ints, or a boolean mask (N,)."""
    if value is None:
        return np.arange(n)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise ValueError(f'indices must be body indices, got {value!r}') from None
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise ValueError(f'indices as a mask must have shape ({n},), got {arr.shape}')
        return np.flatnonzero(arr)
    if arr.ndim > 1 or (arr.size and not np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f'indices must be ints or a boolean mask, got {value!r}')
    arr = arr.reshape(-1).astype(np.intp)
    if arr.size and (arr.min() < 0 or arr.max() >= n):
        raise ValueError(f'indices must be in [0, {n}), got {arr.tolist()[:10]}')
    if np.unique(arr).size != arr.size:
        raise ValueError('indices must not repeat a body')
    return arr


def _has_bool(value: Any) -> bool:
    """True when nested lists or tuples hold a bool (numpy would take it as 0 or 1)."""
    if isinstance(value, (list, tuple)):
        return any(type(c) is bool or (type(c) is not float and _has_bool(c)) for c in value)
    return isinstance(value, (bool, np.bool_))


def _numbers(value: Any) -> np.ndarray:
    """``value`` as a new float64 array; TypeError unless it holds only ints and floats (no
    bools, strings or ints too large for a float, which numpy would convert or choke on)."""
    arr = np.array(value)
    if arr.dtype.kind not in 'iuf' or (not isinstance(value, np.ndarray) and _has_bool(value)):
        raise TypeError('not numbers')
    return arr.astype(np.float64)


def _array(name: str, value: Any, shape: tuple[int, ...], broadcast: bool = False) -> np.ndarray:
    """A finite float64 array of ``shape`` (a copy); ``broadcast`` also takes one row for all."""
    try:
        arr = _numbers(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f'{name} must be numbers of shape {shape}, got {short(value)}'
                         ) from None
    if broadcast and arr.shape == shape[1:]:
        arr = np.broadcast_to(arr, shape).copy()
    if arr.shape != shape:
        raise ValueError(f'{name} must have shape {shape}, got {arr.shape}')
    bad = (~np.isfinite(arr)).reshape(shape[0], math.prod(shape[1:])).any(axis=1)
    if np.any(bad):
        raise ValueError(f'{name} must be finite (body {int(np.flatnonzero(bad)[0])})')
    return arr


def _rates(name: str, value: Any, n: int) -> np.ndarray:
    """A rate >= 0 (1/s) for all bodies, or one per body: (N,)."""
    arr = _array(name, value, (n,), broadcast=True)
    if np.any(arr < 0.0):
        raise ValueError(f'{name} must be >= 0 (1/s), got {arr[arr < 0.0][0]!r} '
                         f'(body {int(np.flatnonzero(arr < 0.0)[0])})')
    return arr


def _inertias(value: Any, n: int) -> np.ndarray:
    """(N, 3, 3) tensors from (N, 3, 3) or principal moments (N, 3), validated as RigidBody."""
    try:
        arr = _numbers(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f'inertias must be numbers, got {short(value)}') from None
    if arr.shape == (n, 3):
        moments, arr = arr, np.zeros((n, 3, 3))
        arr[:, (0, 1, 2), (0, 1, 2)] = moments
    if arr.shape != (n, 3, 3):
        raise ValueError(f'inertias must have shape ({n}, 3, 3) or ({n}, 3), got {arr.shape}')
    bad = ~np.isfinite(arr).all(axis=(1, 2))
    if np.any(bad):
        raise ValueError(f'inertias must be finite (body {int(np.flatnonzero(bad)[0])})')
    scale = np.abs(arr).max(axis=(1, 2))
    checks = [
        (scale == 0.0, 'positive definite, got the zero matrix'),
        (np.abs(arr - arr.transpose(0, 2, 1)).max(axis=(1, 2)) > SYMMETRY_TOLERANCE * scale,
         'symmetric'),
    ]
    for bad, why in checks:
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f'inertias must be {why} (body {i}: {arr[i].tolist()})')
    # As RigidBody: symmetrised and checked as each tensor times the power of two that
    # brings its largest entry into [0.5, 1), exactly (no overflow or underflow, and LAPACK
    # sees entries near 1).
    exponent = np.frexp(scale)[1][:, None]
    symmetric = np.ldexp(arr, -exponent[:, :, None])
    symmetric = 0.5 * (symmetric + symmetric.transpose(0, 2, 1))
    arr = np.ldexp(symmetric, exponent[:, :, None])
    scaled = np.linalg.eigvalsh(symmetric)
    with np.errstate(over='ignore'):
        moments = np.ldexp(scaled, exponent)
    flat = scaled[:, 0] + scaled[:, 1] < scaled[:, 2] * (1.0 - TRIANGLE_TOLERANCE)
    for bad, why in [(scaled[:, 0] <= 0.0, 'positive definite'),
                     (flat, 'such that the principal moments obey the triangle inequality '
                      'I1 + I2 >= I3')]:
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f'inertias must be {why} (body {i}: principal moments '
                             f'{moments[i].tolist()})')
    return arr


def _rotations(name: str, value: Any, k: int) -> np.ndarray:
    """(k, 3, 3) rotation matrices, refused beyond ROTATION_TOLERANCE and else projected onto
    SO(3) exactly as ``State`` does: the error of ``so3.orthonormality_error`` (the same
    operations, element by element), and where it is above 0, ``so3.orthonormalize``."""
    rot = _array(name, value, (k, 3, 3))
    r = rot.reshape(k, 9).T
    err = np.abs(so3.det9(r) - 1.0)
    for i in range(3):
        for j in range(3):
            dot = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j]
            err = np.maximum(err, np.abs(dot - (1.0 if i == j else 0.0)))
    if np.any(err > ROTATION_TOLERANCE):
        bad = int(np.flatnonzero(err > ROTATION_TOLERANCE)[0])
        raise ValueError(f'{name} must be rotation matrices (entry {bad}: |R^T R - I| = '
                         f'{err[bad]:.3g}, got {rot[bad].tolist()})')
    for row in np.flatnonzero(err > 0.0):  # as State: Newton's polar iteration, no LAPACK
        rot[row] = so3.orthonormalize(rot[row])
    return rot


def _quaternion_rotations(value: Any, k: int) -> np.ndarray:
    """Rotation matrices of quaternions of any non-zero length: each is scaled by a power of
    two that brings its largest component into [0.5, 1) (exact: the bits of the result do
    not change) before it is normalised, so that neither 1e200 nor 1e-200 overflows or
    underflows (as ``State.from_quaternion_xyzw``)."""
    q = _array('quaternions_xyzw', value, (k, 4))
    big = np.abs(q).max(axis=1) if k else np.zeros(0)
    if np.any(big == 0.0):
        raise ValueError('quaternions_xyzw must be non-zero '
                         f'(entry {int(np.flatnonzero(big == 0.0)[0])})')
    q = np.ldexp(q, -np.frexp(big)[1][:, None])
    n = np.sqrt((q * q).sum(axis=1))
    x, y, z, w = (q / n[:, None]).T
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                     2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                     2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
                    axis=1).reshape(k, 3, 3)


def _frames(value: Any, k: int, default: Frame) -> np.ndarray:
    """True where a wrench is in the body frame: one frame for all, or one per body."""
    if value is None:
        value = default
    if isinstance(value, (str, Frame)):
        return np.full(k, Frame.parse(value) is Frame.BODY)
    try:
        frames = [Frame.parse(v) for v in value]
    except TypeError:
        raise ValueError(f"frame must be 'world', 'body' or one per body, got {value!r}") from None
    if len(frames) != k:
        raise ValueError(f'frame must be one frame or {k} (one per body), got {len(frames)}')
    return np.array([fr is Frame.BODY for fr in frames], dtype=bool)


class BatchStepper(FixedStep):
    """N rigid bodies advanced together with a fixed step dt (s), each under its own held
    wrench (zero-order hold), by the method of ``Stepper``.

    masses: (N,) kg. inertias: (N, 3, 3) tensors about each centre of mass in its body frame,
    or (N, 3) principal moments, kg m^2 (validated as ``RigidBody``). The state is per body,
    world frame: positions (N, 3) m, rotations (N, 3, 3) body to world (or quaternions_xyzw
    (N, 4)), linear_velocities (N, 3) m/s, angular_velocities (N, 3) rad/s; omitted: at rest at
    the origin, R = I. ``gravity`` (3,) m/s^2, world frame, for every body;
    ``linear_damping`` c and ``angular_damping`` d (1/s), one for all or (N,): they add -c v and
    -d omega to the accelerations. ``wrench_frame`` is the frame of ``set_wrench`` when it
    names none. From ``chunk_size`` bodies on, a step shares them among the cores (speed only:
    the bits do not change). ``specialize`` as ``Stepper``'s.

    Every input is validated before anything changes (ValueError naming the argument and,
    where it applies, the body); read accessors return copies. Time is ``step_count * dt``.
    """

    ORTHONORMALIZE_EVERY = Stepper.ORTHONORMALIZE_EVERY

    def __init__(self, masses: Any, inertias: Any, dt: float, positions: Any = None,
                 rotations: Any = None, linear_velocities: Any = None,
                 angular_velocities: Any = None, *, quaternions_xyzw: Any = None,
                 method: multistep.Multistep | str = multistep.EQ27,
                 gravity: Any = (0.0, 0.0, 0.0), linear_damping: Any = 0.0,
                 angular_damping: Any = 0.0, wrench_frame: Frame | str = Frame.WORLD,
                 chunk_size: int = CHUNK_SIZE, specialize: bool = True) -> None:
        self._dt = check_dt(dt)
        self._method = multistep.METHODS.get(method, method) if isinstance(method, str) else method
        if not isinstance(self._method, (multistep.Multistep, multistep.Splitting)):
            raise ValueError(f'method must be a Multistep or one of {sorted(multistep.METHODS)},'
                             f' got {method!r}')
        try:
            masses = _numbers(masses)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f'masses must be numbers (kg), got {short(masses)}') from None
        if masses.ndim != 1 or masses.size == 0:
            raise ValueError(f'masses must have shape (N,) with N >= 1, got {masses.shape}')
        n = masses.size
        bad = ~(np.isfinite(masses) & (masses > 0.0))
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f'masses must be finite and > 0 kg (body {i}: {masses[i]!r})')
        inertias = _inertias(inertias, n)
        gravity = finite_floats('gravity', gravity, 3)
        linear_damping = _rates('linear_damping', linear_damping, n)
        angular_damping = _rates('angular_damping', angular_damping, n)
        try:
            self._wrench_frame = Frame.parse(wrench_frame)
        except ValueError:
            raise ValueError(f"wrench_frame must be 'world' or 'body', got {wrench_frame!r}"
                             ) from None
        if (not isinstance(chunk_size, int) or isinstance(chunk_size, bool)
                or chunk_size < 1):
            raise ValueError(f'chunk_size must be an int >= 1, got {chunk_size!r}')

        self._n, self._chunk_size = n, chunk_size
        self._masses, self._inertias = masses, inertias
        self._inverse_mass = 1.0 / masses
        self._state, self._params, self._work = K.new_arrays(n, self._method.steps)
        self._spare = np.zeros_like(self._state)
        self._status = np.zeros(n, dtype=np.int64)
        self._taken = np.zeros(n, dtype=np.int64)
        self._bad = np.zeros((n, 3))
        self._all = np.arange(n, dtype=np.int64)
        self._coefficients = coefficients(self._method, self._dt, self.ORTHONORMALIZE_EVERY)
        # The principal frame of each body (as Stepper: r = R Q); Q = I for a diagonal inertia.
        self._q = np.empty((n, 9))
        self._q_index = np.full(n, -1)  # body -> its row in self._q, -1 where Q = I
        rotated: list = []
        for i in range(n):
            moments, q = euler_dynamics.principal_axes(inertias[i])
            if not np.array_equal(q, np.eye(3)):
                self._q_index[i] = len(rotated)
                rotated.append(q.reshape(9))
            set_body_params(self._params[i], moments, gravity, float(linear_damping[i]),
                            float(angular_damping[i]), bool(specialize), Stepper.MAX_TURN,
                            self._dt)
        self._q = np.array(rotated).reshape(-1, 9)
        # Squared |omega| above which a step warns (TurnWarning, once for the batch); inf for
        # the isotropic bodies and methods with no energy bound.
        self._warn_sq = np.array([turn_warning_sq(self._method, self._dt, sq == math.inf)
                                  for sq in self._params[:, K.MAX_TURN_SQ]])
        self._forces = np.zeros((n, 3))
        self._torques = np.zeros((n, 3))
        self._in_body = np.full(n, self._wrench_frame is Frame.BODY)
        zero = (0.0, 0.0, 0.0)
        for i in range(n):
            set_wrench_params(self._params[i], float(self._inverse_mass[i]), zero, zero,
                              bool(self._in_body[i]))
        self._step_count = 0
        self._warned = not np.isfinite(self._warn_sq).any()
        self._state[:, K.R:K.R + 9] = np.eye(3).reshape(9)
        if self._q.size:  # R = I, stored as r = R Q = Q in the principal frame
            hit = self._q_index >= 0
            self._state[hit, K.R:K.R + 9] = self._q[self._q_index[hit]]
        self.set_state(None, positions, rotations, linear_velocities, angular_velocities,
                       quaternions_xyzw=quaternions_xyzw)

    @classmethod
    def from_bodies(cls, bodies: Any, dt: float, states: Any = None,
                    **kwargs: Any) -> 'BatchStepper':
        """A batch of ``RigidBody`` objects, optionally with one ``State`` each."""
        bodies = list(bodies)
        if not bodies or not all(isinstance(b, RigidBody) for b in bodies):
            raise ValueError('bodies must be one or more RigidBody objects')
        if states is not None:
            states = list(states)
            if len(states) != len(bodies) or not all(isinstance(s, State) for s in states):
                raise ValueError(f'states must be {len(bodies)} State objects, one per body')
            kwargs.update(positions=[s.position for s in states],
                          rotations=[s.rotation for s in states],
                          linear_velocities=[s.linear_velocity for s in states],
                          angular_velocities=[s.angular_velocity for s in states])
        return cls([b.mass for b in bodies], [b.inertia for b in bodies], dt, **kwargs)

    # -- read ------------------------------------------------------------------------------
    def __len__(self) -> int:
        return self._n

    @property
    def masses(self) -> np.ndarray:
        """(N,) kg (a copy)."""
        return self._masses.copy()

    @property
    def inertias(self) -> np.ndarray:
        """(N, 3, 3) kg m^2, body frame (a copy)."""
        return self._inertias.copy()

    @property
    def nbytes(self) -> int:
        """Bytes held in arrays (state, spare, parameters and the rest): fixed at
        construction."""
        arrays = [self._state, self._spare, self._params, self._work, self._status,
                  self._taken, self._bad, self._all, self._coefficients, self._masses,
                  self._inertias, self._inverse_mass, self._q, self._q_index, self._forces,
                  self._torques, self._in_body]
        return sum(a.nbytes for a in arrays)

    @property
    def work(self) -> dict[str, int]:
        """What the kernel has done, summed over the bodies: as ``Stepper.work``."""
        full, translation, start_up = (int(c) for c in self._work.sum(axis=0))
        return {'full': full, 'translation': translation, 'start_up': start_up}

    def positions(self) -> np.ndarray:
        """(N, 3) centre-of-mass positions (m), world frame."""
        return self._state[:, K.X:K.X + 3].copy()

    def linear_velocities(self) -> np.ndarray:
        """(N, 3) centre-of-mass velocities (m/s), world frame."""
        return self._state[:, K.V:K.V + 3].copy()

    def angular_velocities(self) -> np.ndarray:
        """(N, 3) angular velocities omega (rad/s), world frame."""
        return self._state[:, K.W:K.W + 3].copy()

    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices taking each body's frame to the world frame, as
        integrated: the bits of ``Stepper.rotation()``, not the projection onto SO(3) of
        ``state(i)`` and ``Stepper.state`` (a few ulp away)."""
        r = self._state[:, K.R:K.R + 9].copy()
        for i in np.flatnonzero(self._q_index >= 0):  # the principal-frame R Q, times Q^T
            r[i] = so3.mul9(r[i], self._q[self._q_index[i]], transpose_b=True)
        return r.reshape(self._n, 3, 3)

    def quaternions_xyzw(self) -> np.ndarray:
        """(N, 4) unit quaternions (x, y, z, w), w >= 0, of ``rotations()`` (Shepperd): the
        bits of ``Stepper.pose_twist()``'s."""
        r = self.rotations().reshape(self._n, 9).T
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
        tr = r00 + r11 + r22
        case = np.select([(tr >= r00) & (tr >= r11) & (tr >= r22),
                          (r00 >= r11) & (r00 >= r22), r11 >= r22], [0, 1, 2], 3)
        diag = np.choose(case, [1.0 + tr, 1.0 + r00 - r11 - r22, 1.0 + r11 - r00 - r22,
                                1.0 + r22 - r00 - r11])
        s = 2.0 * np.sqrt(np.maximum(diag, 0.0))
        q = np.empty((4, self._n))
        big = 0.25 * s
        q[0] = np.choose(case, [(r21 - r12) / s, big, (r01 + r10) / s, (r02 + r20) / s])
        q[1] = np.choose(case, [(r02 - r20) / s, (r01 + r10) / s, big, (r12 + r21) / s])
        q[2] = np.choose(case, [(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, big])
        q[3] = np.choose(case, [big, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s])
        q /= np.sqrt((q * q).sum(axis=0))
        q *= np.where(q[3] < 0.0, -1.0, 1.0)
        return q.T.copy()

    def state(self, i: int) -> State:
        """Body ``i``'s state as a ``State`` (world frame)."""
        (i,) = _indices([i], self._n)
        row = self._state[i]
        r = row[K.R:K.R + 9]
        if self._q_index[i] >= 0:  # the principal-frame R Q, times Q^T
            r = so3.mul9(r, self._q[self._q_index[i]], transpose_b=True)
        return State(row[K.X:K.X + 3], np.reshape(r, (3, 3)), row[K.V:K.V + 3],
                     row[K.W:K.W + 3])

    def wrenches(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The held wrenches as given: forces (N, 3) N, torques (N, 3) N m, and each one's
        frame, an (N,) array of 'world' or 'body'."""
        return (self._forces.copy(), self._torques.copy(),
                np.where(self._in_body, Frame.BODY.value, Frame.WORLD.value))

    # -- write -----------------------------------------------------------------------------
    def set_state(self, indices: Any = None, positions: Any = None, rotations: Any = None,
                  linear_velocities: Any = None, angular_velocities: Any = None, *,
                  quaternions_xyzw: Any = None) -> None:
        """Jump bodies ``indices`` (None: all) to a new state, world frame: positions (k, 3)
        m, rotations (k, 3, 3) body to world or quaternions_xyzw (k, 4), linear_velocities
        (k, 3) m/s, angular_velocities (k, 3) rad/s; one row (3,) stands for all k. A part
        left None keeps its current value. Their history restarts (start-up at the next
        step), and so does their orthonormalisation count, as ``Stepper.set_state``."""
        idx = _indices(indices, self._n)
        k = idx.size
        x = None if positions is None else _array('positions', positions, (k, 3), True)
        v = (None if linear_velocities is None
             else _array('linear_velocities', linear_velocities, (k, 3), True))
        w = (None if angular_velocities is None
             else _array('angular_velocities', angular_velocities, (k, 3), True))
        if rotations is not None and quaternions_xyzw is not None:
            raise ValueError('give rotations or quaternions_xyzw, not both')
        rot = None
        if rotations is not None:
            rot = _rotations('rotations', np.broadcast_to(rotations, (k, 3, 3))
                             if np.shape(rotations) == (3, 3) else rotations, k)
        elif quaternions_xyzw is not None:
            rot = _rotations('quaternions_xyzw', _quaternion_rotations(
                np.broadcast_to(quaternions_xyzw, (k, 4))
                if np.shape(quaternions_xyzw) == (4,) else quaternions_xyzw, k), k)
        if k == 0:
            return
        s = self._state
        for at, value in ((K.X, x), (K.V, v), (K.W, w)):
            if value is not None:
                s[idx, at:at + 3] = value
        if rot is not None:
            rot = rot.reshape(k, 9)
            for j in np.flatnonzero(self._q_index[idx] >= 0):  # the principal frame: r = R Q
                rot[j] = so3.mul9(rot[j], self._q[self._q_index[idx[j]]])
            s[idx, K.R:K.R + 9] = rot
        s[idx, K.HISTORY] = K.HISTORY_NONE
        s[idx, K.COUNTDOWN] = self.ORTHONORMALIZE_EVERY
        self._evaluate(idx)

    def restart_history(self, indices: Any = None) -> None:
        """Forget the previous step of bodies ``indices`` (after an impulse: do not
        extrapolate across it); the next step starts them up again."""
        self._state[_indices(indices, self._n), K.HISTORY] = K.HISTORY_NONE

    def set_wrench(self, indices: Any = None, force: Any = (0.0, 0.0, 0.0),
                   torque: Any = (0.0, 0.0, 0.0), frame: Any = None) -> None:
        """Hold force (k, 3) N at the centre of mass and torque (k, 3) N m about it on bodies
        ``indices`` (None: all) from the next step on; one row (3,) stands for all k.

        ``frame`` is 'world', 'body' (turns with the body, a thruster), a ``Frame``, one of
        these per body, or None for the batch's ``wrench_frame``. As ``Stepper.set_wrench``:
        for each body whose wrench changes, its accelerations at this step and, if it has
        taken a step since its start-up, at the previous step are evaluated again under the
        new wrench, so the multistep history never crosses the change."""
        idx = _indices(indices, self._n)
        k = idx.size
        force = _array('force', force, (k, 3), broadcast=True)
        torque = _array('torque', torque, (k, 3), broadcast=True)
        in_body = _frames(frame, k, self._wrench_frame)
        changed = ((force != self._forces[idx]).any(axis=1)
                   | (torque != self._torques[idx]).any(axis=1) | (in_body != self._in_body[idx]))
        idx, force, torque = idx[changed], force[changed], torque[changed]
        in_body = in_body[changed]
        if idx.size == 0:
            return
        self._forces[idx], self._torques[idx], self._in_body[idx] = force, torque, in_body
        for j, i in enumerate(idx):
            f, t = force[j], torque[j]
            if in_body[j] and self._q_index[i] >= 0:  # into the principal frame: Q^T f
                q9 = self._q[self._q_index[i]]
                f, t = so3.mul9_vec(q9, f, transpose=True), so3.mul9_vec(q9, t, transpose=True)
            set_wrench_params(self._params[i], float(self._inverse_mass[i]), f, t,
                              bool(in_body[j]))
        self._evaluate(idx)
        stepped = idx[self._state[idx, K.HISTORY] != K.HISTORY_NONE]
        self._state[stepped, K.HISTORY] = K.HISTORY_STALE

    def _evaluate(self, idx: np.ndarray) -> None:
        K.evaluate_bodies(self._state, self._params, np.asarray(idx, dtype=np.int64))

    # -- step ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance every body ``n`` >= 0 steps.

        Raises ``BatchIntegrationError`` (an ``IntegrationError``) naming the first step at
        which some body's x, v, R or omega stopped being finite (or a body with unequal
        moments turned faster than ``Stepper.MAX_TURN`` rad a step), and those bodies; that
        step is not taken, so every body is left at its state before it (the steps before
        stand).
        """
        check_steps(n)
        if n == 0:
            return
        self._advance(self._all, n, False)
        if not self._status.any():
            self._commit(n)
            self._check_turns()
            return
        failed = np.flatnonzero(self._status).astype(np.int64)
        self._advance(failed, n, True)
        bad_step = int(self._taken[failed].min())
        bodies = [int(i) for i in failed if self._taken[i] == bad_step]
        turned = all(self._status[i] == K.STATUS_TURN for i in bodies)
        if bad_step:
            self._advance(self._all, bad_step, False)  # the steps before it stand
            self._commit(bad_step)
        shown = bodies if len(bodies) <= 10 else bodies[:10] + ['...']
        s = self._step_count
        what = (f'turned faster than {Stepper.MAX_TURN:g} rad a step' if turned
                else 'became non-finite')
        raise BatchIntegrationError(
            s, bodies, f'state {what} at step {s} (t = {s * self._dt:.9g} s), bodies {shown}; '
            'no body took that step')

    def _advance(self, bodies: np.ndarray, n: int, checked: bool) -> None:
        K.advance(self._state, self._spare, self._params, self._coefficients, bodies, n,
                  checked, self._status, self._taken, self._bad, self._work,
                  parallel=bodies.size >= self._chunk_size)

    def _check_turns(self) -> None:
        """A TurnWarning, once for the batch, naming the bodies that now turn faster than
        the method's energy bound (``stepper.TURN_BOUNDS``)."""
        if self._warned:
            return
        w = self._state[:, K.W:K.W + 3]
        w2 = (w * w).sum(axis=1)
        over = np.flatnonzero(w2 > self._warn_sq)
        if not over.size:
            return
        self._warned = True
        shown = over.tolist() if over.size <= 10 else over[:10].tolist() + ['...']
        who = f'bodies {shown} of the batch (the fastest of them)'
        warnings.warn(turn_message(self._method, self._dt, math.sqrt(float(w2[over].max())),
                                   who), TurnWarning, stacklevel=3)

    def _commit(self, n: int) -> None:
        self._state, self._spare = self._spare, self._state
        self._step_count += n
