# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Proof 3 of the report: the multistep update of v, omega, x and R.

With a_n, beta_n the accelerations at step n and a_{n-1}, beta_{n-1} those of the step before:

    v_{n+1}     = v_n + (3 a_n - a_{n-1}) / 2 dt                                      (11)
    omega_{n+1} = omega_n + (3 beta_n - beta_{n-1}) / 2 dt                            (12)
    x_{n+1}     = x_n + v_n dt + (4 a_n - a_{n-1}) / 6 dt^2                           (13)
    R_{n+1}     = exp([omega_n + (4 beta_n - beta_{n-1}) / 6 dt
                       + (beta_n x omega_n) dt^2 / 12] dt) R_n          (27, last line)

Eq. (14) of the report, as printed, has the wrong sign and symmetry in its dt^3 term and is
not used (see ../shared/seed/NOTES.md): with eq. (27) the local error of R is O(dt^4).
Local errors are O(dt^3) for v and omega and O(dt^4) for x and R; globally the method is
second order.

The method is data: a ``Multistep`` holds the coefficients of a_n and a_{n-1} in each update,
so another explicit method of this family is another table, not another function.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

from rb_sim_ros.core import so3


@dataclass(frozen=True)
class Multistep:
    """Coefficients of one explicit two-step method of the form above.

    velocity_now, velocity_prev: weights of a_n, a_{n-1} (and beta) in v and omega, times dt.
    position_now, position_prev: weights of a_n, a_{n-1} in x, times dt^2.
    rotation_now, rotation_prev: weights of beta_n, beta_{n-1} in the rotation vector, times dt^2.
    rotation_cross: weight of beta_n x omega_n in the rotation vector, times dt^3.
    order: global order of accuracy; local_orders: (v and omega, x and R) one-step orders.
    """

    name: str
    order: int
    local_orders: tuple[int, int]
    velocity_now: float
    velocity_prev: float
    position_now: float
    position_prev: float
    rotation_now: float
    rotation_prev: float
    rotation_cross: float
    description: str = ''


# The report's method: eq. (11), (12), (13) and the last line of eq. (27).
EQ27 = Multistep(
    name='eq27', order=2, local_orders=(3, 4),
    velocity_now=1.5, velocity_prev=-0.5,
    position_now=4.0 / 6.0, position_prev=-1.0 / 6.0,
    rotation_now=4.0 / 6.0, rotation_prev=-1.0 / 6.0, rotation_cross=1.0 / 12.0,
    description='Adams-Bashforth 2 for v, omega; eq. (13) for x; eq. (27) exponential for R')

# Eq. (27) without its dt^2 correction: what the NOTES measured as local order 3 for R.
# Kept to show (in the tests and benchmarks) what the correction buys; not a default.
EQ27_NO_CROSS = Multistep(
    name='eq27-no-cross', order=2, local_orders=(3, 3),
    velocity_now=1.5, velocity_prev=-0.5,
    position_now=4.0 / 6.0, position_prev=-1.0 / 6.0,
    rotation_now=4.0 / 6.0, rotation_prev=-1.0 / 6.0, rotation_cross=0.0,
    description='eq27 without the (beta x omega) dt^2/12 term')

# One-step Taylor method (no history): v += a dt, x += v dt + a dt^2/2, R = exp((w + b dt/2) dt) R.
# First order globally; the cheap baseline of the benchmarks.
TAYLOR1 = Multistep(
    name='taylor1', order=1, local_orders=(2, 3),
    velocity_now=1.0, velocity_prev=0.0,
    position_now=0.5, position_prev=0.0,
    rotation_now=0.5, rotation_prev=0.0, rotation_cross=0.0,
    description='single-step Taylor: explicit Euler for v, omega; second order terms for x, R')

METHODS = {m.name: m for m in (EQ27, EQ27_NO_CROSS, TAYLOR1)}


def method_by_name(name: str) -> Multistep:
    """The method called ``name``; ValueError lists the known ones."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(
            f'integrator must be one of {sorted(METHODS)}, got {name!r}') from None


def make_step(method: Multistep, dt, functions=math, rotate: bool = True):
    """One step of ``method`` with a fixed dt (s), as a function of components:

        step(x, v, r, w, a, b, a_prev, b_prev) -> (x, v, r, w) at t + dt

    x (m), v (m/s), w (rad/s) are world-frame 3-tuples and r the 9 row-major components of R;
    a, b are the linear (m/s^2) and angular (rad/s^2) accelerations at t, a_prev and b_prev those
    at t - dt, all world frame. Components may be floats (``functions`` = math) or numpy arrays
    of one shape (``functions`` = numpy, which supplies sqrt, sin, cos). The coefficients times
    powers of dt are computed once here.

    ``rotate=False`` builds a step that leaves R and omega as they are, for a body that does
    not turn (omega = beta = beta_prev = 0 under no torque), where the full update would give
    them back (omega bit for bit, R up to the sign of a zero entry) at four times the cost.
    (A body at rest is not stepped at all; one that only does not translate takes the full
    step: translation is 3% of it.)
    """
    vn, vp = method.velocity_now * dt, method.velocity_prev * dt
    pn, pp = method.position_now * dt * dt, method.position_prev * dt * dt
    rn, rp = method.rotation_now * dt * dt, method.rotation_prev * dt * dt
    rc = method.rotation_cross * dt * dt * dt
    sqrt, sin, cos = functions.sqrt, functions.sin, functions.cos
    tiny = so3.TINY_ANGLE_SQ

    def step(x, v, r, w, a, b, a_prev, b_prev):
        ax, ay, az = a
        bx, by, bz = b
        apx, apy, apz = a_prev
        bpx, bpy, bpz = b_prev
        xx, xy, xz = x
        vx, vy, vz = v
        wx, wy, wz = w
        # Rotation vector of eq. (27), last line.
        px = wx * dt + rn * bx + rp * bpx + rc * (by * wz - bz * wy)
        py = wy * dt + rn * by + rp * bpy + rc * (bz * wx - bx * wz)
        pz = wz * dt + rn * bz + rp * bpz + rc * (bx * wy - by * wx)
        # exp([p]) = I + A [p] + B [p]^2 (Rodrigues), A = sin(t)/t, B = (1 - cos t)/t^2, in
        # half-angle form (see so3.TINY_ANGLE_SQ): no branch, so it runs on arrays too.
        xx2, yy2, zz2 = px * px, py * py, pz * pz
        t2 = xx2 + yy2 + zz2 + tiny
        t = sqrt(t2)
        s = sin(0.5 * t)
        ca = 2.0 * s * cos(0.5 * t) / t
        cb = 2.0 * s * s / t2
        bxy, bxz, byz = cb * px * py, cb * px * pz, cb * py * pz
        ax_, ay_, az_ = ca * px, ca * py, ca * pz
        e00, e01, e02 = 1.0 - cb * (yy2 + zz2), bxy - az_, bxz + ay_
        e10, e11, e12 = bxy + az_, 1.0 - cb * (xx2 + zz2), byz - ax_
        e20, e21, e22 = bxz - ay_, byz + ax_, 1.0 - cb * (xx2 + yy2)
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
        return (
            (xx + vx * dt + pn * ax + pp * apx,
             xy + vy * dt + pn * ay + pp * apy,
             xz + vz * dt + pn * az + pp * apz),
            (vx + vn * ax + vp * apx, vy + vn * ay + vp * apy, vz + vn * az + vp * apz),
            (e00 * r00 + e01 * r10 + e02 * r20, e00 * r01 + e01 * r11 + e02 * r21,
             e00 * r02 + e01 * r12 + e02 * r22,
             e10 * r00 + e11 * r10 + e12 * r20, e10 * r01 + e11 * r11 + e12 * r21,
             e10 * r02 + e11 * r12 + e12 * r22,
             e20 * r00 + e21 * r10 + e22 * r20, e20 * r01 + e21 * r11 + e22 * r21,
             e20 * r02 + e21 * r12 + e22 * r22),
            (wx + vn * bx + vp * bpx, wy + vn * by + vp * bpy, wz + vn * bz + vp * bpz),
        )

    if rotate:
        return step

    def translation(x, v, r, w, a, b, a_prev, b_prev):
        ax, ay, az = a
        apx, apy, apz = a_prev
        xx, xy, xz = x
        vx, vy, vz = v
        return ((xx + vx * dt + pn * ax + pp * apx,
                 xy + vy * dt + pn * ay + pp * apy,
                 xz + vz * dt + pn * az + pp * apz),
                (vx + vn * ax + vp * apx, vy + vn * ay + vp * apy, vz + vn * az + vp * apz),
                r, w)
    return translation
