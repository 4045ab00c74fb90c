# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Thm 1 of the report: the accelerations of a rigid body under a wrench.

    a    = F / m                                     (+ g - c v with gravity and damping)
    beta = I^-1 tau - I^-1 [omega] I omega,    I = R I_body R^T          (eq. (10); - d omega)

The step kernel evaluates it (``step_kernel.accelerations``) in the body's principal frame,
where the inertia is constant and diagonal: with I = R I_p R^T, eq. (10) is
R I_p^-1 (R^T tau - (R^T omega) x I_p R^T omega), three rotations and a few products instead
of forming and inverting R I_body R^T. A body whose inertia is not diagonal is integrated with
R_p = R Q, Q from ``principal_axes``; the stepper converts at its boundary, so users still see
R of the body frame they gave.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core import so3


def principal_axes(inertia: np.ndarray) -> tuple[tuple[float, ...], np.ndarray]:
    """Principal moments (kg m^2) and Q, a proper rotation with I_body = Q diag(moments) Q^T.

    Q's columns are the principal axes in the body frame. A diagonal inertia gives Q = I
    exactly, so a body given in principal axes is integrated with no change of frame at all.
    Computed by cyclic Jacobi rotations in plain float arithmetic, not LAPACK: the bits of Q
    then do not depend on which BLAS kernel the machine picks, so a recording made on one
    machine replays bit for bit on another. Moments ascending, as numpy's eigh orders them.
    """
    inertia = np.asarray(inertia, dtype=float)
    if np.array_equal(inertia, np.diag(np.diag(inertia))):
        return tuple(float(c) for c in np.diag(inertia)), np.eye(3)
    moments, q = symmetric_eigen([[float(c) for c in row] for row in inertia])
    return moments, np.array(q)


def symmetric_eigen(a: list[list[float]]) -> tuple[tuple[float, ...],
                                                   list[list[float]]]:
    """Eigenvalues (ascending) and a proper rotation V (eigenvectors as columns) of a symmetric
    3x3 matrix given as nested lists (the upper triangle is read), A = V diag(lambda) V^T.

    Cyclic Jacobi (Golub & Van Loan, alg. 8.5.3): each rotation zeroes one off-diagonal entry;
    convergence is quadratic, so a few sweeps reach round-off. Only + - * / and sqrt, which
    IEEE 754 rounds exactly, so the result is the same on every machine.
    """
    # Scaled by a power of two to a largest entry in [0.5, 1): exact (and undone exactly at
    # the end), and every ratio the rotations use is unchanged, so the bits are those of the
    # unscaled iteration; but no sum of entries near 1e308 overflows, nor does one near 1e-310
    # lose digits as a subnormal.
    big = max(abs(a[i][j]) for i in range(3) for j in range(i, 3))
    if not math.isfinite(big):
        raise ValueError(f'symmetric_eigen needs finite entries, got {a}')
    e2 = math.frexp(big)[1] if big > 0.0 else 0
    a = [[math.ldexp(a[0][0], -e2), math.ldexp(a[0][1], -e2), math.ldexp(a[0][2], -e2)],
         [math.ldexp(a[0][1], -e2), math.ldexp(a[1][1], -e2), math.ldexp(a[1][2], -e2)],
         [math.ldexp(a[0][2], -e2), math.ldexp(a[1][2], -e2), math.ldexp(a[2][2], -e2)]]
    v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    for _ in range(64):
        scale = abs(a[0][0]) + abs(a[1][1]) + abs(a[2][2])
        if abs(a[0][1]) + abs(a[0][2]) + abs(a[1][2]) <= 1e-18 * scale:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            apq = a[p][q]
            if apq == 0.0:
                continue
            theta = (a[q][q] - a[p][p]) / (2.0 * apq)
            if abs(theta) > 1e150:  # theta^2 would overflow; t = 1/(2 theta) to round-off
                t = 0.5 / theta
            else:
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta
                                                                              + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            # A <- J^T A J with J the rotation by (c, s) in the (p, q) plane.
            for k in range(3):
                akp, akq = a[k][p], a[k][q]
                a[k][p] = c * akp - s * akq
                a[k][q] = s * akp + c * akq
            for k in range(3):
                apk, aqk = a[p][k], a[q][k]
                a[p][k] = c * apk - s * aqk
                a[q][k] = s * apk + c * aqk
            a[p][q] = a[q][p] = 0.0
            for k in range(3):
                vkp, vkq = v[k][p], v[k][q]
                v[k][p] = c * vkp - s * vkq
                v[k][q] = s * vkp + c * vkq
    order = sorted(range(3), key=lambda i: a[i][i])
    values = tuple(math.ldexp(a[i][i], e2) for i in order)
    vec = [[v[r][order[0]], v[r][order[1]], v[r][order[2]]] for r in range(3)]
    if so3.det9(vec[0] + vec[1] + vec[2]) < 0.0:
        for r in range(3):
            vec[r][2] = -vec[r][2]
    return values, vec


def angular_acceleration_world(inertia_world: np.ndarray, omega: np.ndarray,
                               torque: np.ndarray) -> np.ndarray:
    """eq. (10) literally, in the world frame, with numpy: a reference for tests (the kernel's
    principal-frame form must agree with it)."""
    rhs = torque - np.cross(omega, inertia_world @ omega)
    return np.linalg.solve(inertia_world, rhs)
