# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""N rigid bodies stepped together: the method of ``Stepper``, on structure-of-arrays buffers.

    batch = BatchStepper(masses, inertias, dt=1e-3, angular_velocities=w)  # (N,), (N, 3, 3)
    batch.set_wrench([0, 5], torque=(0.0, 0.0, 0.01), frame='body')        # bodies 0 and 5
    batch.step(1000)
    batch.rotations()                                                      # (N, 3, 3)

Units are SI and every vector is in the world frame unless named otherwise; a rotation R maps
body-frame vectors to the world frame (``r_world = R @ r_body``), as everywhere in rb_sim_ros.

The maths is the single-body path's, per body, with nothing changed: Thm 1 in principal axes
(``euler_dynamics.make_accelerations``: r = R Q for a non-diagonal inertia, Q from
``principal_axes``), the update of Proof 3 / eq. (27) with the coefficients of the
``multistep.Multistep`` table, the start-up predictor (one TAYLOR1 step, extrapolate back),
the history evaluated again at the previous state under a new wrench, one Newton step of the
polar decomposition every ``Stepper.ORTHONORMALIZE_EVERY`` steps after each body's
``set_state``, gravity and damping as the core defines them. ``test/test_batch.py`` checks the
results against N ``Stepper`` objects to 1e-12, and this kernel's single step against
``multistep.make_step``'s component formulas.

How it is fast (``bench/batch_bench.py``). The state lives in five preallocated levels: the
committed step, the step before it, and a ring of three that a run of ``step(n)`` writes.
A level holds 28 rows of one value per body (structure of arrays): the components of x, v, R
(row-major), omega, beta and a. The bodies are cut into chunks of about ``chunk_size``, each
chunk's rows stored as one contiguous (28, width) block, and each chunk takes all n steps
while it is in cache, then the next one.
Every operation is an in-place ufunc (``out=``) on a stacked (3, C) or (3, 3, C) view, with
temporaries in one chunk-sized scratch set: the 3x3 products (R^T omega, R^T tau, R c, E R)
are single ``np.einsum`` calls, and cross products come from rows stored twice (x y z x y), so
that ``u[1:4] * v[2:5]`` is (u_y v_z, u_z v_x, u_x v_y). Three choices differ from the
single-body code in rounding only:

* exp([p]) = I + A [p] + B [p]^2 takes A = sin(t)/t and B = (1 - cos t)/t^2 from their Taylor
  series, with as many terms as the chunk's largest angle needs for the first term left out
  to be below 2^-56 (sin and cos would cost 17 ns per body here); a body turning more than
  0.4 rad in one step takes the half-angle form of ``multistep.make_step`` instead;
* while a = a_prev = F/m + g is a constant (no body-frame force, no linear damping), x and v
  take the precomputed increments pn a + pp a and vn a + vp a;
* einsum may sum with fused multiply-adds.

Failures cost nothing until they happen: the committed levels are never written by a run, so
a run that produced a non-finite state is simply not committed, the failed chunk is taken
again step by step to find the first bad step, and the batch is left just before it
(``BatchIntegrationError`` names the step and the bodies). Memory is the levels, the per-body
parameters and the scratch of one chunk, allocated once: nothing grows with the number of
steps (``nbytes``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rb_sim_ros.core import multistep, so3
from rb_sim_ros.core.rigid_body import (finite_floats, Frame, RigidBody, ROTATION_TOLERANCE, short,
                                        State, SYMMETRY_TOLERANCE, TRIANGLE_TOLERANCE)
from rb_sim_ros.core.stepper import check_dt, FixedStep, IntegrationError, Stepper

CHUNK_SIZE = 8192
# Rows of one level (one step's state of every body): x, v, R (row-major), omega, beta, a.
# Omega and beta are stored with their x and y repeated (x y z x y) for the cross products.
_X, _V, _R, _W, _W5, _B, _B5, _A = (slice(0, 3), slice(3, 6), slice(6, 15), slice(15, 18),
                                    slice(15, 20), slice(20, 23), slice(20, 25), slice(25, 28))
_LEVEL_ROWS = 28
_CHECKED_ROWS = slice(0, 18)  # x, v, R, omega: what Stepper checks
# Levels held: the committed step and the one before it, and a ring of three for a run.
_SLOTS = 5

# A(t^2) = sum (-t^2)^k / (2k+1)!, B(t^2) = sum (-t^2)^k / (2k+2)!, over k < K, with K chosen
# per chunk from its largest t^2: the first term left out, t^2K / (2K+1)!, is below 2^-56
# (A and B are near 1 and 1/2) while t^2 <= (2^-56 (2K+1)!)^(1/K), the limit listed for K;
# K = 7 serves up to SERIES_MAX_T2 (t = 0.4 rad in one step), and beyond it the half-angle
# form of multistep.make_step is used, body by body.
SERIES_MAX_T2 = 0.16
_SERIES_LIMITS = [(k, (2.0 ** -56 * math.factorial(2 * k + 1)) ** (1.0 / k)) for k in range(1, 7)]
_SERIES = np.array([[[(-1.0) ** k / math.factorial(2 * k + 1)],
                     [(-1.0) ** k / math.factorial(2 * k + 2)]] for k in range(7)])


class BatchIntegrationError(IntegrationError):
    """A body's state became non-finite at ``step`` (from 0); ``bodies`` lists which ones.

    The step was not taken: every body is left at its state before it."""

    def __init__(self, step: int, bodies: list[int], message: str) -> None:
        super().__init__(step, message)
        self.bodies = bodies


class _Views:
    """Named views of one chunk of one level (or of the parameters, or the scratch)."""

    def __init__(self, **views: np.ndarray) -> None:
        self.__dict__.update(views)


class _Columns:
    """An array stored as (chunks, rows, width) blocks, each chunk's columns contiguous,
    indexed as if it were (rows, chunks * width): ``[rows, body]`` or ``[rows, bodies]``."""

    def __init__(self, blocks: np.ndarray) -> None:
        self.blocks = blocks
        self.width = blocks.shape[2]

    def _where(self, cols):
        if isinstance(cols, slice):
            cols = np.arange(*cols.indices(self.blocks.shape[0] * self.width))
        return np.divmod(cols, self.width)

    def __getitem__(self, key):
        rows, cols = key
        chunk, col = self._where(cols)
        out = self.blocks[chunk, rows, col]  # (k, rows) for k bodies
        return out.T if np.ndim(chunk) else out

    def __setitem__(self, key, value) -> None:
        rows, cols = key
        chunk, col = self._where(cols)
        self.blocks[chunk, rows, col] = np.asarray(value).T if np.ndim(chunk) else value


def _blocked(arr: np.ndarray, chunks: int) -> np.ndarray:
    """(rows, chunks * width) to (chunks, rows, width)."""
    return np.ascontiguousarray(arr.reshape(arr.shape[0], chunks, -1).transpose(1, 0, 2))


def _level_views(c: np.ndarray) -> _Views:
    """Named views of one chunk's block of a level, (28, width)."""
    r33 = c[_R].reshape(3, 3, c.shape[1])
    assert np.shares_memory(r33, c)  # a view, not a copy: einsum writes through it
    return _Views(x=c[_X], v=c[_V], r9=c[_R], r33=r33, w=c[_W], w5=c[_W5], a=c[_A], b=c[_B],
                  b5=c[_B5], checked=c[_CHECKED_ROWS])


def _scratch(n: int) -> _Views:
    e9 = np.empty((9, n))
    return _Views(p5=np.empty((5, n)), q5=np.empty((5, n)), t2=np.empty(n),
                  ab=np.empty((2, n)), e9=e9, e33=e9.reshape(3, 3, n), t3=np.empty((3, n)),
                  u3=np.empty((3, n)), o3=np.empty((3, n)), wb5=np.empty((5, n)),
                  g3=np.empty((3, n)), c3=np.empty((3, n)))


class _Flags:
    """What the current wrenches and environment need; decides which terms are computed.

    ``a_varies``: some body's a depends on its state (a force in the body frame, or linear
    damping); otherwise a = a_prev = F/m + g for every body, a parameter, and x, v take the
    increments ``dx``, ``dv`` formed once per wrench. ``force_free``: that constant is 0."""

    __slots__ = ('any_body_force', 'any_world_torque', 'any_body_torque', 'linear_damped',
                 'angular_damped', 'a_varies', 'force_free')


def _accelerations(r33, w, v, a_out, b5_out, p: _Views, s: _Views, f: _Flags) -> None:
    """a (m/s^2) and beta (rad/s^2), world frame, at principal-frame orientations ``r33``
    (3, 3, C), omega ``w`` (3, C) rad/s and v (3, C) m/s: ``make_accelerations``, in place.

    beta = R I_p^-1 (R^T tau - (R^T omega) x I_p R^T omega) - d omega (eq. (10) in principal
    axes); a = F / m + g - c v. ``p`` holds the per-body parameters, ``s`` the scratch. beta is
    written to b5_out (5, C) with its x and y repeated; a to a_out only when it varies (else
    it is the constant ``p.fwg``, see ``_Flags``).
    """
    mul, einsum = np.multiply, np.einsum
    wb5, g, c = s.wb5, s.g3, s.c3
    einsum('ijn,in->jn', r33, w, out=wb5[0:3])       # omega in the principal frame
    wb5[3:5] = wb5[0:2]
    mul(wb5[1:4], p.d, out=g)                         # (I_z - I_y) w_y w_z, and cyclic
    mul(g, wb5[2:5], out=g)
    if f.any_world_torque:
        einsum('ijn,in->jn', r33, p.tw, out=c)       # tau in the principal frame
        if f.any_body_torque:
            np.add(c, p.tb, out=c)
        np.subtract(c, g, out=c)
        mul(c, p.j, out=c)
    elif f.any_body_torque:
        np.subtract(p.tb, g, out=c)
        mul(c, p.j, out=c)
    else:
        mul(g, p.nj, out=c)                           # (0 - g) / I = g * (-1 / I), exactly
    b = b5_out[0:3]
    einsum('ijn,jn->in', r33, c, out=b)               # back to the world frame
    if f.angular_damped:
        mul(w, p.cang, out=g)
        np.subtract(b, g, out=b)
    b5_out[3:5] = b5_out[0:2]
    # Gravity and damping enter here and only here, as in euler_dynamics: a = F/m + g - c v.
    if f.a_varies:
        if f.any_body_force:
            einsum('ijn,jn->in', r33, p.fb, out=a_out)
            np.add(a_out, p.fwg, out=a_out)
        else:
            a_out[...] = p.fwg
        if f.linear_damped:
            mul(v, p.clin, out=g)
            np.subtract(a_out, g, out=a_out)


def _rodrigues_coefficients(t2, ab) -> None:
    """ab[0] = sin(t)/t and ab[1] = (1 - cos t)/t^2 of t = sqrt(t2), into ab (2, C)."""
    largest = t2.max()  # nan if a body is non-finite: it stays so and is caught later
    terms = 7
    for k, limit in _SERIES_LIMITS:
        if largest <= limit:
            terms = k
            break
    if terms == 1:
        ab[...] = _SERIES[0]
    else:
        np.multiply(t2, _SERIES[terms - 1], out=ab)
        for k in range(terms - 2, -1, -1):
            np.add(ab, _SERIES[k], out=ab)
            if k:
                np.multiply(ab, t2, out=ab)
    if largest > SERIES_MAX_T2:
        big = np.flatnonzero(t2 > SERIES_MAX_T2)
        ab[0, big], ab[1, big] = _half_angle_coefficients(t2[big])


def _half_angle_coefficients(t2):
    """A and B as ``multistep.make_step`` computes them (half-angle form, no branch)."""
    t2 = t2 + so3.TINY_ANGLE_SQ
    t = np.sqrt(t2)
    s = np.sin(0.5 * t)
    return 2.0 * s * np.cos(0.5 * t) / t, 2.0 * s * s / t2


def _advance(cur: _Views, prev: _Views, nxt: _Views, p: _Views, s: _Views, f: _Flags,
             k: tuple[float, ...]) -> None:
    """One step of the multistep method for one chunk: x, v, R, omega at s + 1 into ``nxt``,
    from the state and accelerations at s (``cur``) and the accelerations at s - 1 (``prev``).
    The update of ``multistep.make_step``, term for term (see there)."""
    dt, vn, vp, pn, pp, rn, rp, rc = k
    mul, add, sub = np.multiply, np.add, np.subtract
    w, w5, b, b5, bp = cur.w, cur.w5, cur.b, cur.b5, prev.b
    p5, q5, t, u = s.p5, s.q5, s.t3, s.u3
    pv = p5[0:3]
    # Rotation vector of eq. (27), last line: w dt + rn b + rp b_prev + rc (b x w).
    mul(w, dt, out=pv)
    mul(b, rn, out=t)
    add(pv, t, out=pv)
    mul(bp, rp, out=t)
    add(pv, t, out=pv)
    if rc:
        mul(b5[1:4], w5[2:5], out=t)
        mul(b5[2:5], w5[1:4], out=u)
        sub(t, u, out=t)
        mul(t, rc, out=t)
        add(pv, t, out=pv)
    p5[3:5] = p5[0:2]
    # exp([p]) = I + A [p] + B [p]^2 (Rodrigues): E, then R <- E R.
    mul(p5, p5, out=q5)
    t2, ab = s.t2, s.ab
    add(q5[0], q5[1], out=t2)
    add(t2, q5[2], out=t2)
    _rodrigues_coefficients(t2, ab)
    ca, cb = ab[0], ab[1]
    e9, o3 = s.e9, s.o3
    mul(pv, cb, out=u)                       # B p
    mul(u, p5[1:4], out=o3)                  # B p_x p_y, B p_y p_z, B p_z p_x
    mul(pv, ca, out=u)                       # A p
    add(q5[1:4], q5[2:5], out=t)             # p_y^2 + p_z^2, and cyclic
    mul(t, cb, out=t)
    sub(1.0, t, out=e9[0::4])                # the diagonal
    sub(o3[0], u[2], out=e9[1])
    add(o3[0], u[2], out=e9[3])
    sub(o3[1], u[0], out=e9[5])
    add(o3[1], u[0], out=e9[7])
    sub(o3[2], u[1], out=e9[6])
    add(o3[2], u[1], out=e9[2])
    np.einsum('ikn,kjn->ijn', s.e33, cur.r33, out=nxt.r33)
    # x (eq. (13)) and v (eq. (11)).
    mul(cur.v, dt, out=t)
    add(cur.x, t, out=nxt.x)
    if f.a_varies:
        a, ap = cur.a, prev.a
        mul(a, pn, out=t)
        add(nxt.x, t, out=nxt.x)
        mul(ap, pp, out=t)
        add(nxt.x, t, out=nxt.x)
        mul(a, vn, out=t)
        add(cur.v, t, out=nxt.v)
        mul(ap, vp, out=t)
        add(nxt.v, t, out=nxt.v)
    elif f.force_free:
        nxt.v[...] = cur.v
    else:  # a = a_prev, a constant: pn a + pp a_prev and vn a + vp a_prev are too
        add(nxt.x, p.dx, out=nxt.x)
        add(cur.v, p.dv, out=nxt.v)
    # omega (eq. (12)).
    mul(b, vn, out=t)
    add(w, t, out=nxt.w)
    mul(bp, vp, out=t)
    add(nxt.w, t, out=nxt.w)
    nxt.w5[3:5] = nxt.w5[0:2]


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


def _principal_axes(inertias: np.ndarray):
    """``euler_dynamics.principal_axes`` for each body: moments (N, 3), and Q (k, 3, 3) for the
    k bodies whose inertia is not diagonal (listed in the returned index array)."""
    diagonal = (inertias * (1.0 - np.eye(3)) == 0.0).all(axis=(1, 2))
    moments = np.diagonal(inertias, axis1=1, axis2=2).copy()
    rotated = np.flatnonzero(~diagonal)
    q = np.empty((0, 3, 3))
    if rotated.size:
        moments[rotated], q = np.linalg.eigh(inertias[rotated])
        flip = np.linalg.det(q) < 0.0
        q[flip, :, 2] = -q[flip, :, 2]
    return moments, rotated, q


def _rotations(name: str, value: Any, k: int) -> np.ndarray:
    """(k, 3, 3) rotation matrices, refused beyond ROTATION_TOLERANCE and else projected onto
    SO(3) (as ``State`` does: any error above 0 is removed, by SVD)."""
    rot = _array(name, value, (k, 3, 3))
    err = np.maximum(np.abs(np.einsum('kji,kjl->kil', rot, rot) - np.eye(3)).max(axis=(1, 2)),
                     np.abs(np.linalg.det(rot) - 1.0))
    if np.any(err > ROTATION_TOLERANCE):
        i = int(np.flatnonzero(err > ROTATION_TOLERANCE)[0])
        raise ValueError(f'{name} must be rotation matrices (entry {i}: |R^T R - I| = '
                         f'{err[i]:.3g}, got {rot[i].tolist()})')
    fix = np.flatnonzero(err > 0.0)
    if fix.size:
        u, _, vt = np.linalg.svd(rot[fix])
        r = u @ vt
        neg = np.linalg.det(r) < 0.0
        u[neg, :, -1] = -u[neg, :, -1]
        rot[fix] = np.where(neg[:, None, None], u @ vt, r)
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
    names none. ``chunk_size`` is the number of bodies processed per numpy call (speed only).

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
                 chunk_size: int = CHUNK_SIZE) -> None:
        self._dt = check_dt(dt)
        self._method = multistep.METHODS.get(method, method) if isinstance(method, str) else method
        if not isinstance(self._method, multistep.Multistep):
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
        gravity = np.array(finite_floats('gravity', gravity, 3))
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

        self._n = n
        self._masses, self._inertias = masses, inertias
        self._inverse_mass = 1.0 / masses
        self._gravity = gravity
        moments, self._rotated, self._q = _principal_axes(inertias)
        self._q_index = np.full(n, -1)  # body -> its Q in self._q, -1 if Q = I
        self._q_index[self._rotated] = np.arange(self._rotated.size)
        # Chunks of equal width c covering N (the last columns, fewer than the number of
        # chunks, are padding: a unit body at rest that nothing acts on).
        chunks = -(-n // chunk_size)
        width = -(-n // chunks)
        padded = chunks * width
        self._chunks = [slice(i * width, (i + 1) * width) for i in range(chunks)]
        # Each level is stored chunk by chunk, (chunks, 28, width): a chunk's rows are one
        # contiguous block.
        self._levels = np.zeros((_SLOTS, chunks, _LEVEL_ROWS, width))
        self._levels[:, :, _R][:, :, 0::4] = 1.0  # r = I everywhere (the padding's R)
        self._now, self._before = 0, 1  # the levels of the committed step and the one before
        ones = np.ones((3, padded))
        m = ones.copy()
        m[:, :n] = moments.T
        # Per-body parameters, (rows, padded): differences of moments as Euler's equations
        # use them, inverse moments, and the held wrench split by frame (see set_wrench).
        params = {
            'd': np.stack([m[2] - m[1], m[0] - m[2], m[1] - m[0]]), 'j': 1.0 / m,
            'nj': -1.0 / m, 'fwg': np.zeros((3, padded)), 'fb': np.zeros((3, padded)),
            'tw': np.zeros((3, padded)), 'tb': np.zeros((3, padded)),
            'clin': np.zeros((1, padded)), 'cang': np.zeros((1, padded)),
            'dx': np.zeros((3, padded)), 'dv': np.zeros((3, padded))}
        params['clin'][0, :n] = linear_damping
        params['cang'][0, :n] = angular_damping
        params = {k: _blocked(v, chunks) for k, v in params.items()}
        self._p = _Views(**{k: _Columns(v) for k, v in params.items()})
        self._pchunks = [_Views(**{k: v[c] for k, v in params.items()}) for c in range(chunks)]
        if self._rotated.size:  # R = I, stored as r = R Q = Q in the principal frame
            for slot in range(_SLOTS):
                self._level(slot)[_R, self._rotated] = self._q.reshape(-1, 9).T
        self._views = [[_level_views(block) for block in level] for level in self._levels]
        self._scratch = _scratch(width)
        m, dt = self._method, self._dt
        # Exactly as multistep.make_step forms them.
        self._coefficients = (dt, m.velocity_now * dt, m.velocity_prev * dt,
                              m.position_now * dt * dt, m.position_prev * dt * dt,
                              m.rotation_now * dt * dt, m.rotation_prev * dt * dt,
                              m.rotation_cross * dt * dt * dt)
        self._startup = multistep.make_step(multistep.TAYLOR1, self._dt, np)
        self._set_linear(np.arange(n), np.zeros((3, n)))  # the zero wrench: a = 0 / m + g
        self._step_count = 0
        self._pending = np.ones(n, dtype=bool)  # start-up due at the next step
        self._phase = np.zeros(n, dtype=np.int64)  # step_count % 1024 at the last set_state
        self._groups: dict[int, list] | None = None
        self._forces = np.zeros((n, 3))
        self._torques = np.zeros((n, 3))
        self._in_body = np.full(n, self._wrench_frame is Frame.BODY)
        self._flags = _Flags()
        self._update_flags()
        self._fill_constant_accelerations()
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
        """Bytes held in arrays (levels, parameters, scratch): fixed at construction."""
        arrays = [self._levels, self._masses, self._inertias, self._inverse_mass, self._q,
                  self._rotated, self._q_index, self._pending, self._phase, self._forces,
                  self._torques, self._in_body, *(c.blocks for c in self._p.__dict__.values()),
                  *self._scratch.__dict__.values()]
        roots = {}
        for a in arrays:
            while isinstance(a.base, np.ndarray):
                a = a.base
            roots[id(a)] = a.nbytes
        return sum(roots.values())

    def _level(self, slot: int) -> _Columns:
        return _Columns(self._levels[slot])

    def _current(self) -> _Columns:
        return self._level(self._now)

    def positions(self) -> np.ndarray:
        """(N, 3) centre-of-mass positions (m), world frame."""
        return self._current()[_X, :self._n].T.copy()

    def linear_velocities(self) -> np.ndarray:
        """(N, 3) centre-of-mass velocities (m/s), world frame."""
        return self._current()[_V, :self._n].T.copy()

    def angular_velocities(self) -> np.ndarray:
        """(N, 3) angular velocities omega (rad/s), world frame."""
        return self._current()[_W, :self._n].T.copy()

    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices taking each body's frame to the world frame."""
        r = self._current()[_R, :self._n].T.copy().reshape(self._n, 3, 3)
        if self._rotated.size:  # the principal-frame R Q, times Q^T
            r[self._rotated] = r[self._rotated] @ self._q.transpose(0, 2, 1)
        return r

    def quaternions_xyzw(self) -> np.ndarray:
        """(N, 4) unit quaternions (x, y, z, w), w >= 0, of ``rotations()`` (Shepperd)."""
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
        lv = self._current()
        rot = lv[_R, i].reshape(3, 3)
        if self._q_index[i] >= 0:
            rot = rot @ self._q[self._q_index[i]].T
        return State(lv[_X, i], rot, lv[_V, i], lv[_W, i])

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
        lv = self._current()
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
        for rows, value in ((_X, x), (_V, v), (_W, w)):
            if value is not None:
                lv[rows, idx] = value.T
        lv[_W5.start + 3:_W5.stop, idx] = lv[_W.start:_W.start + 2, idx]
        if rot is not None:
            qi = self._q_index[idx]
            hit = qi >= 0
            if np.any(hit):  # the principal frame: r = R Q
                rot[hit] = rot[hit] @ self._q[qi[hit]]
            lv[_R, idx] = rot.reshape(k, 9).T
        self._evaluate(lv, idx)
        self._pending[idx] = True
        self._phase[idx] = self._step_count % self.ORTHONORMALIZE_EVERY
        self._groups = None

    def restart_history(self, indices: Any = None) -> None:
        """Forget the previous step of bodies ``indices`` (after an impulse: do not
        extrapolate across it); the next step starts them up again."""
        self._pending[_indices(indices, self._n)] = True

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
        # Into the principal frame (Q^T f) where the wrench turns with the body, as Stepper.
        qi = self._q_index[idx]
        hit = in_body & (qi >= 0)
        fb, tb = force.copy(), torque.copy()
        if np.any(hit):
            qt = self._q[qi[hit]].transpose(0, 2, 1)
            fb[hit] = (qt @ fb[hit, :, None])[:, :, 0]
            tb[hit] = (qt @ tb[hit, :, None])[:, :, 0]
        inv_m = self._inverse_mass[idx, None]
        world = ~in_body[:, None]
        p = self._p
        # a = f/m + g for a world-frame force (euler_dynamics' world_a), R (f/m) + g for a
        # body-frame one; tau in the principal frame is R^T tau_world + tau_body.
        self._set_linear(idx, np.where(world, force * inv_m, 0.0).T)
        p.fb[:, idx] = np.where(world, 0.0, fb * inv_m).T
        p.tw[:, idx] = np.where(world, torque, 0.0).T
        p.tb[:, idx] = np.where(world, 0.0, tb).T
        was_varying = self._flags.a_varies
        self._update_flags()
        if self._flags.a_varies and not was_varying:
            self._fill_constant_accelerations()
        self._evaluate(self._level(self._now), idx)
        stepped = idx[~self._pending[idx]]
        if stepped.size:  # the history, evaluated again at the previous state
            self._evaluate(self._level(self._before), stepped)

    def _set_linear(self, idx: np.ndarray, f_over_m: np.ndarray) -> None:
        """a = F/m + g of bodies ``idx`` (world frame, constant while ``a_varies`` is not),
        and the increments of x and v it gives: pn a + pp a_prev and vn a + vp a_prev."""
        p = self._p
        _, vn, vp, pn, pp = self._coefficients[:5]
        a = f_over_m + self._gravity[:, None]
        p.fwg[:, idx] = a
        p.dx[:, idx] = pn * a + pp * a
        p.dv[:, idx] = vn * a + vp * a

    # -- step ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance every body ``n`` >= 0 steps.

        Raises ``BatchIntegrationError`` (an ``IntegrationError``) naming the first step at
        which some body's x, v, R or omega stopped being finite, and those bodies; that step
        is not taken, so every body is left at its state before it (the steps before stand).

        Each chunk of bodies takes all ``n`` steps while it is in cache, then the next chunk.
        The levels of the committed step and the one before are not written during a run
        (the run uses the other three as a ring), so a failed run is undone by not committing
        it. Steps are not checked one by one: a non-finite value never becomes finite again
        in this arithmetic, so each chunk's end state is checked, and only a chunk that failed
        is taken again from the committed step, one step at a time, to find the first bad one.
        """
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise ValueError(f'n must be an int >= 0, got {n!r}')
        if n == 0:
            return
        if self._groups is None:
            self._groups = self._orthonormalization_groups()
        with np.errstate(all='ignore'):  # non-finite values are looked for after the run
            if self._pending.any():
                self._start_up()
            failed = [c for c in range(len(self._chunks)) if not self._run(c, n)]
            if failed:
                first = [self._first_failure(c, n) for c in failed]
                bad_step = min(s for s, _ in first)
                bodies = sorted(b for s, found in first if s == bad_step for b in found)
                good = bad_step - self._step_count  # the steps before it stand
                for c in range(len(self._chunks)):
                    self._run(c, good)
                self._commit(good)
                shown = bodies if len(bodies) <= 10 else bodies[:10] + ['...']
                s = self._step_count
                raise BatchIntegrationError(
                    s, bodies, f'state became non-finite at step {s} (t = {s * self._dt:.9g} '
                    f's), bodies {shown}; no body took that step')
        self._commit(n)

    def _slot(self, j: int) -> int:
        """The level holding step s + j of a run from the committed step s (j >= -1)."""
        if j <= 0:
            return self._now if j == 0 else self._before
        ring = [k for k in range(_SLOTS) if k != self._now and k != self._before]
        return ring[(j - 1) % 3]

    def _run(self, c: int, n: int, start: int = 0) -> bool:
        """Take steps ``start`` to ``n`` - 1 of a run of chunk ``c`` from the committed step
        (``start`` > 0 continues one); True if its state at the end is finite."""
        views = [level[c] for level in self._views]
        before, now = views[self._before], views[self._now]
        ring = [views[self._slot(j)] for j in (1, 2, 3)]
        params, scratch, flags = self._pchunks[c], self._scratch, self._flags
        k, groups, s = self._coefficients, self._groups, self._step_count
        every = self.ORTHONORMALIZE_EVERY
        for j in range(start, n):
            cur = now if j == 0 else ring[(j - 1) % 3]
            prev = before if j == 0 else now if j == 1 else ring[(j - 2) % 3]
            nxt = ring[j % 3]
            _advance(cur, prev, nxt, params, scratch, flags, k)
            due = groups.get((s + j + 1) % every)
            if due is not None and due[c] is not None:
                cols, r = due[c], nxt.r9
                r[:, cols] = so3.orthonormalize_components(*r[:, cols])
            _accelerations(nxt.r33, nxt.w, nxt.v, nxt.a, nxt.b5, params, scratch, flags)
        if n == 0:
            return True
        checked = views[self._slot(n)].checked
        # One sum is the cheap test; it can overflow where every value is finite.
        return math.isfinite(checked.sum()) or bool(np.isfinite(checked).all())

    def _first_failure(self, c: int, n: int) -> tuple[int, list[int]]:
        """The first step at which chunk ``c`` goes non-finite in a run of ``n`` steps, and
        which of its bodies do: the run taken again one step at a time."""
        first = self._chunks[c].start
        for j in range(n):
            if not self._run(c, j + 1, start=j):
                checked = self._views[self._slot(j + 1)][c].checked
                bad = np.flatnonzero(~np.isfinite(checked).all(axis=0)) + first
                return self._step_count + j, [int(i) for i in bad if i < self._n]
        raise AssertionError('a chunk that failed ran finite when taken again')

    def _commit(self, n: int) -> None:
        if n:
            self._now, self._before = self._slot(n), self._slot(n - 1)
            self._step_count += n
            self._pending[:] = False

    def _start_up(self) -> None:
        """The start-up of Stepper for pending bodies: predict with one TAYLOR1 step
        (``multistep.make_step`` itself, on their columns), take the accelerations there and
        extrapolate back, a_{-1} = 2 a_0 - a_1*, into the level before the committed one."""
        idx = np.flatnonzero(self._pending)
        lv, lp = self._level(self._now), self._level(self._before)
        a = lv[_A, idx] if self._flags.a_varies else self._p.fwg[:, idx]
        b = lv[_B, idx]
        comps = [tuple(lv[rows, idx]) for rows in (_X, _V, _R, _W)] + [tuple(a), tuple(b)] * 2
        _, v1, r1, w1 = self._startup(*comps)
        a1, b1 = self._accelerations_at(idx, np.array(r1), np.array(w1), np.array(v1))
        if self._flags.a_varies:
            lp[_A, idx] = 2.0 * a - a1
        lp[_B, idx] = 2.0 * b - b1
        lp[_B5.start + 3:_B5.stop, idx] = lp[_B.start:_B.start + 2, idx]

    def _accelerations_at(self, idx, r9, w, v):
        """(a, beta), each (3, k), of bodies ``idx`` at r (9, k), omega, v (3, k): the kernel
        on gathered columns."""
        k = idx.size
        p = _Views(**{name: arr[:, idx] for name, arr in self._p.__dict__.items()})
        a = (np.empty((3, k)) if self._flags.a_varies else p.fwg.copy())
        b5 = np.empty((5, k))
        _accelerations(r9.reshape(3, 3, k), w, v, a, b5, p, _scratch(k), self._flags)
        return a, b5[0:3]

    def _evaluate(self, level: _Columns, idx: np.ndarray) -> None:
        """Write the accelerations of bodies ``idx`` at their state in ``level`` there."""
        if idx.size == 0:
            return
        with np.errstate(all='ignore'):
            a, b = self._accelerations_at(idx, level[_R, idx], level[_W, idx], level[_V, idx])
        if self._flags.a_varies:
            level[_A, idx] = a
        level[_B, idx] = b
        level[_B5.start + 3:_B5.stop, idx] = b[0:2]

    def _fill_constant_accelerations(self) -> None:
        """While no force turns with a body and nothing damps, a = a_prev = F/m + g for every
        body, a parameter; the rows of a in the levels are filled when that stops holding."""
        self._levels[:, :, _A] = self._p.fwg.blocks

    def _update_flags(self) -> None:
        p, f = self._p, self._flags
        f.any_body_force = bool(p.fb.blocks.any())
        f.any_world_torque = bool(p.tw.blocks.any())
        f.any_body_torque = bool(p.tb.blocks.any())
        f.linear_damped = bool(p.clin.blocks.any())
        f.angular_damped = bool(p.cang.blocks.any())
        f.a_varies = f.any_body_force or f.linear_damped
        f.force_free = not f.a_varies and not p.fwg.blocks.any()  # padding has no force

    def _orthonormalization_groups(self) -> dict[int, list]:
        """step_count % 1024 -> per chunk, the columns to orthonormalise at that step."""
        groups = {}
        order = np.argsort(self._phase, kind='stable')
        phases = self._phase[order]
        starts = np.flatnonzero(np.r_[True, phases[1:] != phases[:-1]])
        for lo, hi in zip(starts, np.r_[starts[1:], order.size]):
            idx = order[lo:hi]  # ascending: a stable sort of ascending indices
            per_chunk = []
            for cols in self._chunks:
                inside = idx[(idx >= cols.start) & (idx < cols.stop)] - cols.start
                per_chunk.append(inside if inside.size else None)
            groups[int(phases[lo])] = per_chunk
        return groups
