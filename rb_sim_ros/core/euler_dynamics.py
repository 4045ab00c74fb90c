# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Thm 1 of the report: the accelerations of a rigid body under a wrench.

    a    = F / m                                     (+ g - c v with gravity and damping)
    beta = I^-1 tau - I^-1 [omega] I omega,    I = R I_body R^T          (eq. (10); - d omega)

Written over components so the same source runs on floats (one body) and on numpy arrays of
shape (N,) (a batch). Evaluated in the body's principal frame, where the inertia is constant and
diagonal: with I = R I_p R^T, eq. (10) is R I_p^-1 (R^T tau - (R^T omega) x I_p R^T omega),
three rotations and a few products instead of forming and inverting R I_body R^T. A body whose
inertia is not diagonal is integrated with R_p = R Q, Q from ``principal_axes``; the stepper
converts at its boundary, so users still see R of the body frame they gave.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core import so3


def principal_axes(inertia: np.ndarray) -> tuple[tuple[float, float, float], np.ndarray]:
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


def symmetric_eigen(a: list[list[float]]) -> tuple[tuple[float, float, float],
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


ZERO3 = (0.0, 0.0, 0.0)


def _all_zero(components) -> bool:
    """True when every component (a float or an array) is zero."""
    return all(bool(np.all(np.asarray(c) == 0.0)) for c in components)


def make_accelerations(inverse_mass, moments, force, torque, force_in_body: bool,
                       torque_in_body: bool, gravity=ZERO3, linear_damping=0.0,
                       angular_damping=0.0, specialize: bool = True):
    """The accelerations under a held wrench, as a function of components:

        accelerations(r, omega, v=ZERO3) -> (a, beta)

    a = F / m + g - c v (m/s^2) and beta of eq. (10) - d omega (rad/s^2), both world frame, for
    the orientation ``r`` of the principal frame (9 row-major components; see
    ``principal_axes``), omega (rad/s, world) and v (m/s, world; only read with damping).
    ``moments`` are the principal moments (kg m^2). The force (N) and torque (N m) are each in
    the world frame or, if its flag says so, in the principal body frame (then they turn with
    the body). ``gravity`` g (m/s^2, world); ``linear_damping`` c and ``angular_damping`` d are
    rates (1/s). Components may be floats or numpy arrays of one shape.

    With ``specialize`` (floats only) the function is built for what the body needs: no
    rotation of a world-frame force; for an isotropic body no gyroscopic term and no change of
    frame, beta = tau / I (a constant for a world-frame torque). The returned function carries
    ``force_free`` (a is 0 whenever v is: no force, no gravity), ``torque_free`` (beta is 0
    whenever omega is: no torque), which the stepper uses to skip whole updates, and
    ``linear_only``, the same function for a body that does not turn.
    """
    ix, iy, iz = moments
    jx, jy, jz = 1.0 / ix, 1.0 / iy, 1.0 / iz
    fx, fy, fz = force[0] * inverse_mass, force[1] * inverse_mass, force[2] * inverse_mass
    tx0, ty0, tz0 = torque
    gx, gy, gz = gravity
    has_gravity = any(c != 0.0 for c in gravity)
    force_free = not has_gravity and _all_zero(force)
    torque_free = _all_zero(torque)
    world_a = (fx + gx, fy + gy, fz + gz) if has_gravity else (fx, fy, fz)
    c_lin, c_ang = linear_damping, angular_damping
    isotropic = specialize and isinstance(ix, float) and ix == iy == iz
    damped = c_lin != 0.0 or c_ang != 0.0

    def accelerations(r, omega, v=ZERO3):
        """The general path: eq. (10) in principal axes."""
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
        wx, wy, wz = omega
        if force_in_body:
            a = (r00 * fx + r01 * fy + r02 * fz + gx,
                 r10 * fx + r11 * fy + r12 * fz + gy,
                 r20 * fx + r21 * fy + r22 * fz + gz)
        else:
            a = world_a
        # omega and tau in the body frame: R^T v.
        bx = r00 * wx + r10 * wy + r20 * wz
        by = r01 * wx + r11 * wy + r21 * wz
        bz = r02 * wx + r12 * wy + r22 * wz
        if torque_in_body or torque_free:  # no change of frame (none is needed for zero)
            tx, ty, tz = tx0, ty0, tz0
        else:
            tx = r00 * tx0 + r10 * ty0 + r20 * tz0
            ty = r01 * tx0 + r11 * ty0 + r21 * tz0
            tz = r02 * tx0 + r12 * ty0 + r22 * tz0
        # I_b^-1 (tau_b - omega_b x I_b omega_b): Euler's equations in principal axes.
        cx = (tx - (iz - iy) * by * bz) * jx
        cy = (ty - (ix - iz) * bz * bx) * jy
        cz = (tz - (iy - ix) * bx * by) * jz
        return a, (r00 * cx + r01 * cy + r02 * cz,
                   r10 * cx + r11 * cy + r12 * cz,
                   r20 * cx + r21 * cy + r22 * cz)

    if isotropic or damped:
        general = accelerations
        # beta of an isotropic body: no gyroscopic term ([w] I w = I w x w = 0), no frames.
        iso_world_beta = (tx0 * jx, ty0 * jx, tz0 * jx)

        def accelerations(r, omega, v=ZERO3):
            """A specialised path (see make_accelerations)."""
            if isotropic:
                if torque_in_body and not torque_free:
                    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
                    beta = ((r00 * tx0 + r01 * ty0 + r02 * tz0) * jx,
                            (r10 * tx0 + r11 * ty0 + r12 * tz0) * jx,
                            (r20 * tx0 + r21 * ty0 + r22 * tz0) * jx)
                else:
                    beta = iso_world_beta
                if force_in_body:
                    a = general(r, omega)[0]
                else:
                    a = world_a
            else:
                a, beta = general(r, omega)
            if c_lin:
                a = (a[0] - c_lin * v[0], a[1] - c_lin * v[1], a[2] - c_lin * v[2])
            if c_ang:
                beta = (beta[0] - c_ang * omega[0], beta[1] - c_ang * omega[1],
                        beta[2] - c_ang * omega[2])
            return a, beta

    def linear_only(r, omega, v=ZERO3):
        """For a body that does not turn (omega = 0, no torque): beta is 0."""
        if force_in_body:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
            a = (r00 * fx + r01 * fy + r02 * fz + gx,
                 r10 * fx + r11 * fy + r12 * fz + gy,
                 r20 * fx + r21 * fy + r22 * fz + gz)
        else:
            a = world_a
        if c_lin:
            a = (a[0] - c_lin * v[0], a[1] - c_lin * v[1], a[2] - c_lin * v[2])
        return a, ZERO3

    accelerations.force_free = force_free
    accelerations.torque_free = torque_free
    accelerations.linear_only = linear_only
    return accelerations


def angular_acceleration_world(inertia_world: np.ndarray, omega: np.ndarray,
                               torque: np.ndarray) -> np.ndarray:
    """eq. (10) literally, in the world frame, with numpy: a reference for tests."""
    rhs = torque - np.cross(omega, inertia_world @ omega)
    return np.linalg.solve(inertia_world, rhs)
