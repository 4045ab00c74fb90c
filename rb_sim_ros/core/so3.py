# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""SO(3) helpers: hat, exp, log and quaternion conversions.

Two layers live here:

* numpy functions for users and tests (``hat``, ``exp``, ``log``, ``quaternion_xyzw_from_matrix``,
  ``matrix_from_quaternion_xyzw``, ``orthonormalize``), which take and return ndarrays;
* component functions (``quaternion_xyzw_from_components``, ``orthonormalize_components``)
  written with plain arithmetic on floats, for the stepper's hot path.

Rotation matrices map body-frame vectors to world-frame vectors: ``r_world = R @ r_body``.
Quaternions are Hamilton, ordered x, y, z, w as in geometry_msgs/Quaternion.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core import step_kernel

# exp([p]) = I + A [p] + B [p]^2 with A = sin(t)/t and B = (1 - cos t)/t^2, t = |p|. The
# integrator's exp_so3 takes them from their series in t^2 below t = 0.25 (rotation_kernels)
# and above it in half-angle form, A = 2 sin(t/2) cos(t/2) / t and B = 2 sin^2(t/2) / t^2,
# with TINY_ANGLE_SQ added to t^2 (invisible there: it only keeps the division safe).
TINY_ANGLE_SQ = 1e-300
# Below this rotation angle (rad) log() uses its series: atan2(s, w)/s -> 1/w.
SMALL_ANGLE = 1e-12


def hat(v: np.ndarray) -> np.ndarray:
    """Return the skew matrix [v] with [v] @ u == np.cross(v, u) (eq. (1) of the report)."""
    x, y, z = np.asarray(v, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def vee(m: np.ndarray) -> np.ndarray:
    """Inverse of ``hat``: the vector of the skew-symmetric part of ``m``."""
    m = np.asarray(m, dtype=float)
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def exp(phi: np.ndarray) -> np.ndarray:
    """Rotation matrix exp([phi]) of a rotation vector phi (rad, axis times angle).

    Computed through the unit quaternion (sin(t/2) phi/t, cos(t/2)), independently of the
    Rodrigues form the integrator uses, so that each checks the other in the tests.
    """
    phi = np.asarray(phi, dtype=float).reshape(3)
    t = float(np.linalg.norm(phi))
    if t < SMALL_ANGLE:
        # sin(t/2)/t = 1/2 - t^2/48 + ...; the t^2 term is below 1e-25 here.
        return matrix_from_quaternion_xyzw((*(0.5 * phi), 1.0))
    return matrix_from_quaternion_xyzw((*(math.sin(0.5 * t) / t * phi), math.cos(0.5 * t)))


def log(rot: np.ndarray) -> np.ndarray:
    """Rotation vector phi (rad, |phi| <= pi) with exp([phi]) == rot."""
    rot = np.asarray(rot, dtype=float)
    q = quaternion_xyzw_from_matrix(rot)
    xyz, w = q[:3], q[3]
    if w < 0.0:
        xyz, w = -xyz, -w
    s = float(np.linalg.norm(xyz))
    if s < SMALL_ANGLE:
        # theta = 2 asin(s) ~ 2 s: phi = 2 xyz / w to second order.
        return 2.0 * xyz / w
    return 2.0 * math.atan2(s, w) * xyz / s


def angle_between(r1: np.ndarray, r2: np.ndarray) -> float:
    """Angle (rad) of the rotation taking r2 to r1: |log(r1 r2^T)|."""
    return float(np.linalg.norm(log(np.asarray(r1) @ np.asarray(r2).T)))


def matrix_from_quaternion_xyzw(q) -> np.ndarray:
    """Rotation matrix of a quaternion (x, y, z, w); it is normalised first."""
    x, y, z, w = np.asarray(q, dtype=float).reshape(4)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n) or n == 0.0:
        raise ValueError(f'quaternion must be finite and non-zero, got {q!r}')
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def rotation9_from_unit_quaternion(q) -> tuple[float, ...]:
    """9 row-major floats of the rotation of a unit quaternion (x, y, z, w), as given (not
    normalised): what the node and the pictures turn a published or recorded one into."""
    x, y, z, w = q
    return (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y))


def quaternion_xyzw_from_components(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """Unit quaternion (x, y, z, w), w >= 0, of a rotation matrix given row-major (floats)."""
    tr = r00 + r11 + r22
    # Shepperd's method: take the largest of 4 candidates to divide by, for accuracy.
    if tr >= r00 and tr >= r11 and tr >= r22:
        s = 2.0 * math.sqrt(max(1.0 + tr, 0.0))
        q = ((r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s)
    elif r00 >= r11 and r00 >= r22:
        s = 2.0 * math.sqrt(max(1.0 + r00 - r11 - r22, 0.0))
        q = (0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s)
    elif r11 >= r22:
        s = 2.0 * math.sqrt(max(1.0 + r11 - r00 - r22, 0.0))
        q = ((r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s)
    else:
        s = 2.0 * math.sqrt(max(1.0 + r22 - r00 - r11, 0.0))
        q = ((r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    sign = -1.0 if q[3] < 0.0 else 1.0
    return (sign * q[0] / n, sign * q[1] / n, sign * q[2] / n, sign * q[3] / n)


def quaternion_xyzw_from_matrix(rot: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) with w >= 0 of a rotation matrix."""
    comps = (float(c) for c in np.asarray(rot, dtype=float).reshape(9))
    return np.array(quaternion_xyzw_from_components(*comps))


# One Newton step of the polar decomposition, R <- R (3 I - R^T R) / 2, on the 9 components:
# for R within e of SO(3) the result is within O(e^2). The step kernel's own function (it is
# what the integrator applies every ``Stepper.ORTHONORMALIZE_EVERY`` steps).
orthonormalize_components = step_kernel.orthonormalize


def orthonormalize(rot: np.ndarray) -> np.ndarray:
    """The nearest rotation matrix to ``rot`` (its polar factor), for ``rot`` with det > 0.

    Newton's iteration for the polar factor, X <- (X + X^-T) / 2, in plain float arithmetic
    until it stops changing: no LAPACK, so the bits do not depend on the machine's BLAS kernel
    (a recording replays bit for bit on another machine). Quadratic convergence: from a
    nearly orthonormal R, two or three iterations. A matrix far from orthonormal is first
    scaled towards det 1 (by |det|^(-1/3) while |det - 1| > 1e-3, the usual acceleration);
    ValueError if it does not converge (a nearly singular matrix).
    """
    x = [float(c) for c in np.asarray(rot, dtype=float).reshape(9)]
    big = max(abs(c) for c in x) if all(math.isfinite(c) for c in x) else math.inf
    if not math.isfinite(big) or big == 0.0:
        raise ValueError(f'orthonormalize needs a finite matrix with det > 0, got {x}')
    if not 0.5 <= big < 2.0:  # a power of two first: exact, and the determinant stays finite
        x = [math.ldexp(c, -math.frexp(big)[1]) for c in x]
    if not det9(x) > 0.0:
        raise ValueError(f'orthonormalize needs a finite matrix with det > 0, got {x}')
    for _ in range(100):
        d = det9(x)
        if abs(d - 1.0) > 1e-3:
            g = abs(d) ** (-1.0 / 3.0)
            x = [g * c for c in x]
        inv_t = _inverse_transpose(x)
        new = [0.5 * (a + b) for a, b in zip(x, inv_t)]
        change = max(abs(a - b) for a, b in zip(new, x))
        x = new
        if change <= 4e-16:
            break
    out = np.array(x).reshape(3, 3)
    if not orthonormality_error(out) < 1e-12:
        raise ValueError(f'orthonormalize did not converge (a nearly singular matrix?), got '
                         f'{rot!r}')
    return out


def det9(r) -> float:
    """det R of 9 row-major floats, in plain float arithmetic."""
    return (r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6])
            + r[2] * (r[3] * r[7] - r[4] * r[6]))


def _inverse_transpose(r) -> list[float]:
    """(R^-1)^T of 9 row-major floats: the cofactor matrix over the determinant."""
    d = det9(r)
    return [(r[4] * r[8] - r[5] * r[7]) / d, (r[5] * r[6] - r[3] * r[8]) / d,
            (r[3] * r[7] - r[4] * r[6]) / d,
            (r[2] * r[7] - r[1] * r[8]) / d, (r[0] * r[8] - r[2] * r[6]) / d,
            (r[1] * r[6] - r[0] * r[7]) / d,
            (r[1] * r[5] - r[2] * r[4]) / d, (r[2] * r[3] - r[0] * r[5]) / d,
            (r[0] * r[4] - r[1] * r[3]) / d]


def orthonormality_error(rot: np.ndarray) -> float:
    """max |R^T R - I| entry and |det R - 1|, whichever is larger (plain float arithmetic,
    so the same bits on every machine)."""
    r = [float(c) for c in np.asarray(rot, dtype=float).reshape(9)]
    if not all(math.isfinite(c) for c in r):
        return math.inf
    worst = abs(det9(r) - 1.0)
    for i in range(3):
        for j in range(3):
            s = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j]
            worst = max(worst, abs(s - (1.0 if i == j else 0.0)))
    return worst


def mul9(a, b, transpose_b: bool = False) -> tuple[float, ...]:
    """A B (or A B^T) of two 3x3 matrices given as 9 row-major floats, in plain float
    arithmetic: numpy's ``@`` calls BLAS, whose bits depend on the kernel the machine picks."""
    a = [float(c) for c in a]
    b = [float(c) for c in b]
    if transpose_b:
        b = [b[0], b[3], b[6], b[1], b[4], b[7], b[2], b[5], b[8]]
    return tuple(a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]
                 for i in range(3) for j in range(3))


def mul9_vec(a, v, transpose: bool = False) -> tuple[float, float, float]:
    """A v (or A^T v) of a 3x3 matrix as 9 row-major floats, in plain float arithmetic."""
    x, y, z = v
    x, y, z = float(x), float(y), float(z)
    if transpose:
        return (a[0] * x + a[3] * y + a[6] * z, a[1] * x + a[4] * y + a[7] * z,
                a[2] * x + a[5] * y + a[8] * z)
    return (a[0] * x + a[1] * y + a[2] * z, a[3] * x + a[4] * y + a[5] * z,
            a[6] * x + a[7] * y + a[8] * z)
