# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Thm 1 of the report: the accelerations of a rigid body under a wrench.

    a    = F / m
    beta = I^-1 tau - I^-1 [omega] I omega,    I = R I_body R^T          (eq. (10))

Written over components so the same source runs on floats (one body) and on numpy arrays of
shape (N,) (a batch). Evaluated in the body's principal frame, where the inertia is constant and
diagonal: with I = R I_p R^T, eq. (10) is R I_p^-1 (R^T tau - (R^T omega) x I_p R^T omega),
three rotations and a few products instead of forming and inverting R I_body R^T. A body whose
inertia is not diagonal is integrated with R_p = R Q, Q from ``principal_axes``; the stepper
converts at its boundary, so users still see R of the body frame they gave.
"""

from __future__ import annotations

import numpy as np


def principal_axes(inertia: np.ndarray) -> tuple[tuple[float, float, float], np.ndarray]:
    """Principal moments (kg m^2) and Q, a proper rotation with I_body = Q diag(moments) Q^T.

    Q's columns are the principal axes in the body frame. A diagonal inertia gives Q = I
    exactly, so a body given in principal axes is integrated with no change of frame at all.
    """
    inertia = np.asarray(inertia, dtype=float)
    if np.array_equal(inertia, np.diag(np.diag(inertia))):
        return tuple(float(c) for c in np.diag(inertia)), np.eye(3)
    moments, q = np.linalg.eigh(inertia)
    if np.linalg.det(q) < 0.0:
        q[:, 2] = -q[:, 2]
    return tuple(float(c) for c in moments), q


def make_accelerations(inverse_mass, moments, force, torque, force_in_body: bool,
                       torque_in_body: bool):
    """The accelerations under a held wrench, as a function of components:

        accelerations(r, omega) -> (a, beta)

    a = F / m (m/s^2) and beta of eq. (10) (rad/s^2), both world frame, for the orientation
    ``r`` of the principal frame (9 row-major components; see ``principal_axes``) and omega
    (rad/s, world). ``moments`` are the principal moments (kg m^2). The force (N) and torque
    (N m) are each in the world frame or, if its flag says so, in the principal body frame (then
    they turn with the body). Components may be floats or numpy arrays of one shape.
    """
    ix, iy, iz = moments
    jx, jy, jz = 1.0 / ix, 1.0 / iy, 1.0 / iz
    fx, fy, fz = force[0] * inverse_mass, force[1] * inverse_mass, force[2] * inverse_mass
    tx0, ty0, tz0 = torque

    def accelerations(r, omega):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
        wx, wy, wz = omega
        if force_in_body:
            a = (r00 * fx + r01 * fy + r02 * fz,
                 r10 * fx + r11 * fy + r12 * fz,
                 r20 * fx + r21 * fy + r22 * fz)
        else:
            a = (fx, fy, fz)
        # omega and tau in the body frame: R^T v.
        bx = r00 * wx + r10 * wy + r20 * wz
        by = r01 * wx + r11 * wy + r21 * wz
        bz = r02 * wx + r12 * wy + r22 * wz
        if torque_in_body:
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

    return accelerations


def angular_acceleration_world(inertia_world: np.ndarray, omega: np.ndarray,
                               torque: np.ndarray) -> np.ndarray:
    """eq. (10) literally, in the world frame, with numpy: a reference for tests."""
    rhs = torque - np.cross(omega, inertia_world @ omega)
    return np.linalg.solve(inertia_world, rhs)
