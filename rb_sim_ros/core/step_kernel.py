# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The step kernel: every body of a world, n steps of Proof 3, in one compiled call.

One structure of arrays holds the bodies (a row each): ``state`` (width STATE_WIDTH) with
x, v, R, omega, a, beta, the previous step's x, v, R, omega, a, beta (the method's history), the
orthonormalisation countdown and the history's status; ``params`` (width PARAM_WIDTH) with what
the held wrench and the body give Thm 1: principal moments and their inverses, force over mass,
torque, gravity, damping, the turn limit and flags. ``coefficients`` holds the method's
coefficients times powers of dt (``method_coefficients``), shared by the world. R is that of
the principal frame (see ``euler_dynamics.principal_axes``); vectors are world frame unless
their flag puts the force or torque in the body's principal frame.

``advance`` reads ``src`` and writes ``dst``: a run that fails leaves ``src`` as it was, so the
caller can commit (swap) or go back at no cost. What one body's n steps do, in order:

1. its history: start-up (a one-step Taylor prediction, a_{-1} = 2 a_0 - a_1*) when there is
   none, re-evaluation at the previous state under a new wrench when it is stale (NOTES.md 2);
2. the skips of a body that needs less (flag SPECIALIZE): at rest and unforced nothing is
   computed; not turning under no torque, only x and v are updated;
3. n steps of eq. (11)-(13) and (27); every ORTHONORMALIZE_EVERY steps R is pulled back to SO(3)
   by one Newton step of the polar decomposition.

Blocks. ``advance`` takes up to BLOCK bodies at a time side by side, in SIMD lanes, when
there are BLOCK_MIN or more; a lane calls what ``advance_body`` calls, in the same order, so a
body gets the same bits in a block as alone (see BLOCK below).

Checking. ``checked=False`` checks the end state only (finite, and a body with unequal moments
turning at most MAX_TURN rad a step): a non-finite value never becomes finite again in this
arithmetic. ``checked=True`` checks every step and stops before the first bad one, the state
before it written to ``dst``; ``status`` says why (STATUS_*), ``taken`` how many steps were good
and ``bad`` the omega that failed the turn check. The arithmetic is the same in both modes, so
a checked rerun repeats the unchecked run exactly up to the bad step.

Everything is plain + - * / sqrt sin cos on float64 (no BLAS, no fused multiply-add): the
compiled and interpreted paths (``NUMBA_DISABLE_JIT=1``) give the same bits, on every machine.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core.free_flow import flow_advance, flow_start, free_flow, invariants
from rb_sim_ros.core.jit import (
    inline_kernel, kernel, literal_switch, parallel_kernel, prange)
from rb_sim_ros.core.rotation_kernels import (
    exp_so3, exp_so3_small, mul33, orthonormalize, SMALL_ANGLE_SQ)

# -- state row ---------------------------------------------------------------------------------
X, V, R, W, A, B = 0, 3, 6, 15, 18, 21
XP, VP, RP, WP, AP, BP = 24, 27, 30, 39, 42, 45
COUNTDOWN = 48
HISTORY = 49  # HISTORY_NONE, HISTORY_VALID or HISTORY_STALE
STATE_WIDTH = 50
HISTORY_NONE, HISTORY_VALID, HISTORY_STALE = 0.0, 1.0, 2.0

# -- params row ---------------------------------------------------------------------------------
MOMENTS, INVERSE_MOMENTS, FORCE, TORQUE, GRAVITY, WORLD_A = 0, 3, 6, 9, 12, 15
LINEAR_DAMPING, ANGULAR_DAMPING, MAX_TURN_SQ, FLAGS = 18, 19, 20, 21
PARAM_WIDTH = 22
# flags
FORCE_IN_BODY, TORQUE_IN_BODY, TORQUE_FREE, ISOTROPIC, FORCE_FREE, SPECIALIZE = (
    1, 2, 4, 8, 16, 32)

# History slots of methods with k > 2 accelerations (lie3, lie4): the state j steps back,
# j = 1 .. k - 1, laid out as X .. B; slot 1 is XP (above), slots 2, 3 follow HISTORY. A store's
# row is ``state_width(k)`` wide.
SLOT_WIDTH = 24
MAX_STEPS = 4

# -- coefficients --------------------------------------------------------------------------------
# [0:8] a two-step method (dt, vn, vp, pn, pp, rn, rp, rc), [8:16] the start-up's TAYLOR1,
# [16] TINY_ANGLE_SQ, [17] ORTHONORMALIZE_EVERY, [18] the method's k (STEPS), then its weights
# padded to MAX_STEPS: velocity x dt, position x dt^2, rotation x dt^2, cross x dt^3.
STEPS, C_VELOCITY, C_POSITION, C_ROTATION, C_CROSS = 18, 19, 23, 27, 31
# A splitting (STEPS = 1): its weights from C_WEIGHTS, C_WEIGHT_COUNT of them. Its rows
# keep, where others keep history, the free flow's invariants (free_flow.invariants) and,
# while no torque acts, where the body is on its polhode (free_flow.flow_start): mode 1 when
# that is kept, the sign of m_r, u, the precession phi and the frame Q (9).
C_WEIGHTS, C_WEIGHT_COUNT = 19, 23
FLOW_E_LO, FLOW_E_HI, FLOW_MODE, FLOW_SIGN, FLOW_U, FLOW_PHI, FLOW_Q = (
    XP, XP + 1, XP + 2, XP + 3, XP + 4, XP + 5, XP + 6)
COEFFICIENTS = 35

# -- status --------------------------------------------------------------------------------------
STATUS_OK, STATUS_NON_FINITE, STATUS_TURN, STATUS_START_UP = 0, 1, 2, 3

# -- work counters (per body, added to) ----------------------------------------------------------
WORK_FULL, WORK_TRANSLATION, WORK_START_UP = 0, 1, 2
WORK_WIDTH = 3


def state_width(steps: int) -> int:
    """The width of a state row for a method of ``steps`` accelerations."""
    return STATE_WIDTH + max(steps - 2, 0) * SLOT_WIDTH


def slot_column(j: int) -> int:
    """The column of history slot j >= 1 (the state j steps back) in a state row (``_slot``
    in the kernels)."""
    return XP if j == 1 else STATE_WIDTH + (j - 2) * SLOT_WIDTH


def method_coefficients(method, dt: float) -> list[float]:
    """The 8 coefficients of a two-step ``multistep.Multistep`` times powers of dt, as
    make_step has them: dt, velocity (now, prev) dt, position (now, prev) dt^2, rotation
    (now, prev) dt^2, cross dt^3."""
    if method.steps != 2 or method.cross[1] != 0.0:
        raise ValueError(f"{method.name} is not a two-step method of eq. (27)'s form")
    return [dt, method.velocity[0] * dt, method.velocity[1] * dt,
            method.position[0] * dt * dt, method.position[1] * dt * dt,
            method.rotation[0] * dt * dt, method.rotation[1] * dt * dt,
            method.cross[0] * dt * dt * dt]


def coefficients(method, taylor1, dt: float, tiny: float, every: int) -> np.ndarray:
    """The kernel's coefficients (the layout above) of ``method``, with ``taylor1`` (the
    two-step form of the start-up), the angle lift and the orthonormalisation period."""
    k = method.steps
    if k == 1:  # a splitting of the free flow
        weights = list(method.weights)
        if not 1 <= len(weights) <= 4:
            raise ValueError(f'{method.name}: 1 to 4 weights, got {len(weights)}')
        head = [dt] + [0.0] * 7 + method_coefficients(taylor1, dt) + [tiny, float(every), 1.0]
        return np.array(head + weights + [0.0] * (4 - len(weights)) + [float(len(weights))]
                        + [0.0] * 11)
    if not 2 <= k <= MAX_STEPS:
        raise ValueError(f'{method.name}: {k} accelerations a step, the kernel takes 2 to '
                         f'{MAX_STEPS}')
    head = method_coefficients(method, dt) if k == 2 else [dt] + [0.0] * 7
    pad = [0.0] * (MAX_STEPS - k)
    return np.array(head + method_coefficients(taylor1, dt) + [tiny, float(every), float(k)]
                    + [c * dt for c in method.velocity] + pad
                    + [c * dt * dt for c in method.position] + pad
                    + [c * dt * dt for c in method.rotation] + pad
                    + [c * dt * dt * dt for c in method.cross] + pad)


@kernel
def accelerations(p, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
                  linear_only):
    """(a, beta) of Thm 1 for body i of ``p`` (params) at R (principal frame), omega, v: world
    frame. ``linear_only``: the body does not turn (omega = 0 under no torque): beta = 0."""
    return thm1(params_row(p, i), r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz,
                vx, vy, vz, linear_only)


@kernel
def params_row(p, i):
    """Row i of ``p`` (params) as a tuple of PARAM_WIDTH floats."""
    return (float(p[i, 0]), float(p[i, 1]), float(p[i, 2]), float(p[i, 3]), float(p[i, 4]),
            float(p[i, 5]), float(p[i, 6]), float(p[i, 7]), float(p[i, 8]), float(p[i, 9]),
            float(p[i, 10]), float(p[i, 11]), float(p[i, 12]), float(p[i, 13]),
            float(p[i, 14]), float(p[i, 15]), float(p[i, 16]), float(p[i, 17]),
            float(p[i, 18]), float(p[i, 19]), float(p[i, 20]), float(p[i, 21]))


@inline_kernel
def thm1(row, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
         linear_only):
    """``accelerations`` from a params row as a tuple (``params_row``): arithmetic only,
    written into its caller, so that a block's lanes (``_lanes_step``) run it side by side."""
    (ix, iy, iz, jx, jy, jz, fx, fy, fz, tx0, ty0, tz0, gx, gy, gz, wa0, wa1, wa2, c_lin, c_ang,
     _, flag_bits) = row
    flags = int(flag_bits)
    if flags & FORCE_IN_BODY:
        a0 = r00 * fx + r01 * fy + r02 * fz + gx
        a1 = r10 * fx + r11 * fy + r12 * fz + gy
        a2 = r20 * fx + r21 * fy + r22 * fz + gz
    else:
        a0, a1, a2 = wa0, wa1, wa2
    if c_lin != 0.0:
        a0, a1, a2 = a0 - c_lin * vx, a1 - c_lin * vy, a2 - c_lin * vz
    if linear_only:
        return a0, a1, a2, 0.0, 0.0, 0.0
    if flags & ISOTROPIC:
        # No gyroscopic term ([w] I w = I w x w = 0) and no change of frame.
        if (flags & TORQUE_IN_BODY) and not (flags & TORQUE_FREE):
            b0 = (r00 * tx0 + r01 * ty0 + r02 * tz0) * jx
            b1 = (r10 * tx0 + r11 * ty0 + r12 * tz0) * jx
            b2 = (r20 * tx0 + r21 * ty0 + r22 * tz0) * jx
        else:
            b0, b1, b2 = tx0 * jx, ty0 * jx, tz0 * jx
    else:
        # omega and tau in the body frame: R^T v.
        bx = r00 * wx + r10 * wy + r20 * wz
        by = r01 * wx + r11 * wy + r21 * wz
        bz = r02 * wx + r12 * wy + r22 * wz
        if (flags & TORQUE_IN_BODY) or (flags & TORQUE_FREE):
            tx, ty, tz = tx0, ty0, tz0
        else:
            tx = r00 * tx0 + r10 * ty0 + r20 * tz0
            ty = r01 * tx0 + r11 * ty0 + r21 * tz0
            tz = r02 * tx0 + r12 * ty0 + r22 * tz0
        # I_b^-1 (tau_b - omega_b x I_b omega_b): Euler's equations in principal axes.
        cx = (tx - (iz - iy) * by * bz) * jx
        cy = (ty - (ix - iz) * bz * bx) * jy
        cz = (tz - (iy - ix) * bx * by) * jz
        b0 = r00 * cx + r01 * cy + r02 * cz
        b1 = r10 * cx + r11 * cy + r12 * cz
        b2 = r20 * cx + r21 * cy + r22 * cz
    if c_ang != 0.0:
        b0, b1, b2 = b0 - c_ang * wx, b1 - c_ang * wy, b2 - c_ang * wz
    return a0, a1, a2, b0, b1, b2


@kernel
def rotation_vector(dt, rn, rp, rc, wx, wy, wz, bx, by, bz, bpx, bpy, bpz):
    """p of eq. (27), last line: omega dt + rn beta + rp beta_prev + rc (beta x omega)."""
    px = wx * dt + rn * bx + rp * bpx + rc * (by * wz - bz * wy)
    py = wy * dt + rn * by + rp * bpy + rc * (bz * wx - bx * wz)
    pz = wz * dt + rn * bz + rp * bpz + rc * (bx * wy - by * wx)
    return px, py, pz


@inline_kernel
def rotation_step(dt, rn, rp, rc, tiny, small, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                  wx, wy, wz, bx, by, bz, bpx, bpy, bpz):
    """R_{n+1} of eq. (27), last line: exp([p]) R with p from ``rotation_vector``, exp by
    ``exp_so3`` (``small``: the caller knows |p|^2 < SMALL_ANGLE_SQ, ``exp_so3_small``)."""
    px, py, pz = rotation_vector(dt, rn, rp, rc, wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = (
        exp_so3_small(px, py, pz) if small else exp_so3(px, py, pz, tiny))
    return mul33(e00, e01, e02, e10, e11, e12, e20, e21, e22,
                 r00, r01, r02, r10, r11, r12, r20, r21, r22)


@kernel
def multistep_step(dt, vn, vp, pn, pp, rn, rp, rc, tiny, small, rotate,
                   xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                   wx, wy, wz, ax, ay, az, bx, by, bz, apx, apy, apz, bpx, bpy, bpz):
    """One step of Proof 3 (eq. (11)-(13) and (27)) with the coefficients of a method times
    powers of dt (``method_coefficients``): (x, v, R, omega) at t + dt, 18 floats, from the
    state and the accelerations at t (a, beta) and t - dt (a_prev, beta_prev), world frame.
    ``rotate=False``: a body that does not turn (omega = beta = beta_prev = 0), whose R and
    omega the full update would give back, keeps them. ``small``: see ``rotation_step``."""
    nx0, nx1, nx2, nv0, nv1, nv2 = translation_step(
        dt, vn, vp, pn, pp, xx, xy, xz, vx, vy, vz, ax, ay, az, apx, apy, apz)
    if not rotate:
        return (nx0, nx1, nx2, nv0, nv1, nv2, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                wx, wy, wz)
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = rotation_step(
        dt, rn, rp, rc, tiny, small, r00, r01, r02, r10, r11, r12, r20, r21, r22,
        wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
    nw0, nw1, nw2 = omega_step(vn, vp, wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
    return (nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12, q20, q21, q22,
            nw0, nw1, nw2)


@inline_kernel
def translation_step(dt, vn, vp, pn, pp, xx, xy, xz, vx, vy, vz, ax, ay, az, apx, apy, apz):
    """x and v at t + dt of ``multistep_step``: 6 floats."""
    return (xx + vx * dt + pn * ax + pp * apx, xy + vy * dt + pn * ay + pp * apy,
            xz + vz * dt + pn * az + pp * apz,
            vx + vn * ax + vp * apx, vy + vn * ay + vp * apy, vz + vn * az + vp * apz)


@inline_kernel
def omega_step(vn, vp, wx, wy, wz, bx, by, bz, bpx, bpy, bpz):
    """omega at t + dt of ``multistep_step``: 3 floats."""
    return wx + vn * bx + vp * bpx, wy + vn * by + vp * bpy, wz + vn * bz + vp * bpz


@kernel
def evaluate(state, params, i):
    """Store a and beta of body i at its state (after a write of the state or the wrench)."""
    s = state
    a0, a1, a2, b0, b1, b2 = accelerations(
        params, i, float(s[i, R]), float(s[i, R + 1]), float(s[i, R + 2]), float(s[i, R + 3]),
        float(s[i, R + 4]), float(s[i, R + 5]), float(s[i, R + 6]), float(s[i, R + 7]),
        float(s[i, R + 8]), float(s[i, W]), float(s[i, W + 1]), float(s[i, W + 2]),
        float(s[i, V]), float(s[i, V + 1]), float(s[i, V + 2]), bool(False))
    s[i, A], s[i, A + 1], s[i, A + 2] = a0, a1, a2
    s[i, B], s[i, B + 1], s[i, B + 2] = b0, b1, b2


@kernel
def evaluate_bodies(state, params, bodies):
    """``evaluate`` for each body listed in ``bodies`` (int64 indices)."""
    for k in range(bodies.shape[0]):
        evaluate(state, params, bodies[k])


@kernel
def _finite(*values):
    total = 0.0
    for c in values:
        total += c * 0.0  # nan if c is inf or nan
    return total == 0.0


@kernel
def _step_status(nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12, q20, q21, q22,
                 nw0, nw1, nw2, max_turn_sq):
    """STATUS_OK for a new state that may be taken; else why not: not finite, or turning
    faster than the body's limit (a checked run's test of each step)."""
    if not _finite(nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12, q20, q21, q22,
                   nw0, nw1, nw2):
        return STATUS_NON_FINITE
    if not (nw0 * nw0 + nw1 * nw1 + nw2 * nw2 <= max_turn_sq):
        return STATUS_TURN
    return STATUS_OK


@inline_kernel
def _copy_row(dst, src, i):
    """dst[i] = src[i], element by element: a slice assignment would compile numba's shape
    check and its message (some 2 s of string code at a first start)."""
    for c in range(dst.shape[1]):
        dst[i, c] = src[i, c]


@kernel
def advance_body_2(src, dst, p, c, i, n, checked, status, taken, bad, work):
    """``advance_body`` for a two-step method of eq. (27)'s form (c[STEPS] = 2)."""
    dt, vn, vp, pn, pp = float(c[0]), float(c[1]), float(c[2]), float(c[3]), float(c[4])
    rn, rp, rc = float(c[5]), float(c[6]), float(c[7])
    tiny, every = float(c[16]), int(c[17])
    flags = int(p[i, FLAGS])
    max_turn_sq = float(p[i, MAX_TURN_SQ])
    s = src
    (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
     wx, wy, wz) = _get(s, i)
    ax, ay, az = float(s[i, A]), float(s[i, A + 1]), float(s[i, A + 2])
    bx, by, bz = float(s[i, B]), float(s[i, B + 1]), float(s[i, B + 2])
    countdown = int(s[i, COUNTDOWN])
    history = float(s[i, HISTORY])
    status[i] = STATUS_OK
    taken[i] = 0
    if n <= 0:
        _copy_row(dst, src, i)
        return
    # 1. The history a_{n-1}, beta_{n-1}.
    if history == HISTORY_NONE:
        # Start-up: one TAYLOR1 step (a_prev = a), the accelerations there, extrapolate back.
        (_, _, _, v10, v11, v12, q00, q01, q02, q10, q11, q12, q20, q21, q22,
         w10, w11, w12) = multistep_step(
            float(c[8]), float(c[9]), float(c[10]), float(c[11]), float(c[12]),
            float(c[13]), float(c[14]), float(c[15]), tiny, bool(False), bool(True),
            xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
            wx, wy, wz, ax, ay, az, bx, by, bz, ax, ay, az, bx, by, bz)
        a10, a11, a12, b10, b11, b12 = accelerations(
            p, i, q00, q01, q02, q10, q11, q12, q20, q21, q22, w10, w11, w12, v10, v11, v12,
            bool(False))
        apx, apy, apz = 2.0 * ax - a10, 2.0 * ay - a11, 2.0 * az - a12
        bpx, bpy, bpz = 2.0 * bx - b10, 2.0 * by - b11, 2.0 * bz - b12
        work[i, WORK_START_UP] += 1
    elif history == HISTORY_STALE:
        # A new wrench: the previous step's accelerations again, under it.
        apx, apy, apz, bpx, bpy, bpz = accelerations(
            p, i, float(s[i, RP]), float(s[i, RP + 1]), float(s[i, RP + 2]),
            float(s[i, RP + 3]), float(s[i, RP + 4]), float(s[i, RP + 5]),
            float(s[i, RP + 6]), float(s[i, RP + 7]), float(s[i, RP + 8]),
            float(s[i, WP]), float(s[i, WP + 1]), float(s[i, WP + 2]),
            float(s[i, VP]), float(s[i, VP + 1]), float(s[i, VP + 2]), bool(False))
        work[i, WORK_START_UP] += 1
    else:
        apx, apy, apz = float(s[i, AP]), float(s[i, AP + 1]), float(s[i, AP + 2])
        bpx, bpy, bpz = float(s[i, BP]), float(s[i, BP + 1]), float(s[i, BP + 2])
    if checked and not _finite(apx, apy, apz, bpx, bpy, bpz):
        _copy_row(dst, src, i)
        status[i] = STATUS_START_UP
        return
    # 2. The skips.
    frozen_rotation = False
    if flags & SPECIALIZE:
        frozen_rotation = ((flags & TORQUE_FREE) != 0 and wx == 0.0 and wy == 0.0
                           and wz == 0.0 and bx == 0.0 and by == 0.0 and bz == 0.0
                           and bpx == 0.0 and bpy == 0.0 and bpz == 0.0)
        frozen_translation = ((flags & FORCE_FREE) != 0 and vx == 0.0 and vy == 0.0
                              and vz == 0.0 and ax == 0.0 and ay == 0.0 and az == 0.0
                              and apx == 0.0 and apy == 0.0 and apz == 0.0)
        if frozen_rotation and frozen_translation:  # at rest, unforced: nothing moves
            _copy_row(dst, src, i)
            for k in range(XP, XP + 24):
                dst[i, k] = src[i, k - XP]  # the previous step is this one
            dst[i, HISTORY] = HISTORY_VALID
            taken[i] = n
            return
    # 3. The steps.
    pxx, pxy, pxz = xx, xy, xz
    pvx, pvy, pvz = vx, vy, vz
    p00, p01, p02, p10, p11, p12, p20, p21, p22 = r00, r01, r02, r10, r11, r12, r20, r21, r22
    pwx, pwy, pwz = wx, wy, wz
    good = 0
    for _ in range(n):
        (nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12, q20, q21, q22,
         nw0, nw1, nw2) = multistep_step(
            dt, vn, vp, pn, pp, rn, rp, rc, tiny, bool(False), not frozen_rotation,
            xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
            wx, wy, wz, ax, ay, az, bx, by, bz, apx, apy, apz, bpx, bpy, bpz)
        work[i, WORK_TRANSLATION if frozen_rotation else WORK_FULL] += 1
        if checked:
            code = _step_status(nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12,
                                q20, q21, q22, nw0, nw1, nw2, max_turn_sq)
            if code != STATUS_OK:
                status[i] = code
                bad[i, 0], bad[i, 1], bad[i, 2] = nw0, nw1, nw2
                break
        countdown -= 1
        if countdown <= 0 and not frozen_rotation:
            q00, q01, q02, q10, q11, q12, q20, q21, q22 = orthonormalize(
                q00, q01, q02, q10, q11, q12, q20, q21, q22)
            countdown = every
        pxx, pxy, pxz, pvx, pvy, pvz = xx, xy, xz, vx, vy, vz
        p00, p01, p02, p10, p11, p12, p20, p21, p22 = r00, r01, r02, r10, r11, r12, r20, r21, r22
        pwx, pwy, pwz = wx, wy, wz
        apx, apy, apz, bpx, bpy, bpz = ax, ay, az, bx, by, bz
        xx, xy, xz, vx, vy, vz = nx0, nx1, nx2, nv0, nv1, nv2
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = q00, q01, q02, q10, q11, q12, q20, q21, q22
        wx, wy, wz = nw0, nw1, nw2
        ax, ay, az, bx, by, bz = accelerations(
            p, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
            frozen_rotation)
        good += 1
    taken[i] = good
    if good == 0:  # the first step failed: none taken, the row as it was
        _copy_row(dst, src, i)
        return
    d = dst
    _put(d, i, X, xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz)
    d[i, A], d[i, A + 1], d[i, A + 2] = ax, ay, az
    d[i, B], d[i, B + 1], d[i, B + 2] = bx, by, bz
    _put(d, i, XP, pxx, pxy, pxz, pvx, pvy, pvz, p00, p01, p02, p10, p11, p12, p20, p21, p22,
         pwx, pwy, pwz)
    d[i, AP], d[i, AP + 1], d[i, AP + 2] = apx, apy, apz
    d[i, BP], d[i, BP + 1], d[i, BP + 2] = bpx, bpy, bpz
    d[i, COUNTDOWN] = countdown
    d[i, HISTORY] = HISTORY_VALID
    if not checked and not (
            _finite(xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                    wx, wy, wz)
            and wx * wx + wy * wy + wz * wz <= max_turn_sq):
        status[i] = STATUS_NON_FINITE  # somewhere in the run: a checked run finds where


@kernel
def _cross(ax, ay, az, bx, by, bz):
    """a x b."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@kernel
def _dexpinv(ux, uy, uz, wx, wy, wz):
    """dexp^-1 of the rotation vector u applied to w, to second order in u (what a
    fourth-order RKMK step needs): w - (u x w) / 2 + u x (u x w) / 12."""
    cx, cy, cz = _cross(ux, uy, uz, wx, wy, wz)
    dx, dy, dz = _cross(ux, uy, uz, cx, cy, cz)
    return (wx - 0.5 * cx + dx / 12.0, wy - 0.5 * cy + dy / 12.0,
            wz - 0.5 * cz + dz / 12.0)


@kernel
def _turned(ux, uy, uz, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """exp([u]) R, 9 row-major floats."""
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = exp_so3(ux, uy, uz, tiny)
    return mul33(e00, e01, e02, e10, e11, e12, e20, e21, e22,
                 r00, r01, r02, r10, r11, r12, r20, r21, r22)


@kernel
def _rkmk_stage(p, i, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy,
                vz, ux, uy, uz, c, ax, ay, az, bx, by, bz):
    """A stage of ``rkmk4_step``: at R = exp([u]) R_0, omega_0 + c beta, v_0 + c a, the
    accelerations there, K = dexp^-1_u(omega) and v: 12 floats."""
    s00, s01, s02, s10, s11, s12, s20, s21, s22 = _turned(
        ux, uy, uz, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    sx, sy, sz = wx + c * bx, wy + c * by, wz + c * bz
    tx, ty, tz = vx + c * ax, vy + c * ay, vz + c * az
    a0, a1, a2, b0, b1, b2 = accelerations(
        p, i, s00, s01, s02, s10, s11, s12, s20, s21, s22, sx, sy, sz, tx, ty, tz, bool(False))
    kx, ky, kz = _dexpinv(ux, uy, uz, sx, sy, sz)
    return a0, a1, a2, b0, b1, b2, kx, ky, kz, tx, ty, tz


@kernel
def rkmk4_step(p, i, h, tiny, xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21,
               r22, wx, wy, wz):
    """One step of h (s, negative: back in time) of the classical fourth-order Runge-Kutta
    method in Munthe-Kaas form on SO(3) x R^9 (R = exp([u]) R_0, u' = dexp^-1_u(omega)): the
    start-up of the methods with k > 2. Returns (x, v, R, omega), 18 floats."""
    hh = 0.5 * h
    a1x, a1y, a1z, b1x, b1y, b1z = accelerations(
        p, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz, bool(False))
    # stage 2: u = h/2 K1 (K1 = omega_0); stage 3: u = h/2 K2; stage 4: u = h K3
    (a2x, a2y, a2z, b2x, b2y, b2z, k2x, k2y, k2z, v2x, v2y, v2z) = _rkmk_stage(
        p, i, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
        hh * wx, hh * wy, hh * wz, hh, a1x, a1y, a1z, b1x, b1y, b1z)
    (a3x, a3y, a3z, b3x, b3y, b3z, k3x, k3y, k3z, v3x, v3y, v3z) = _rkmk_stage(
        p, i, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
        hh * k2x, hh * k2y, hh * k2z, hh, a2x, a2y, a2z, b2x, b2y, b2z)
    (a4x, a4y, a4z, b4x, b4y, b4z, k4x, k4y, k4z, v4x, v4y, v4z) = _rkmk_stage(
        p, i, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, vx, vy, vz,
        h * k3x, h * k3y, h * k3z, h, a3x, a3y, a3z, b3x, b3y, b3z)
    h6 = h / 6.0
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = _turned(
        h6 * (wx + 2.0 * k2x + 2.0 * k3x + k4x), h6 * (wy + 2.0 * k2y + 2.0 * k3y + k4y),
        h6 * (wz + 2.0 * k2z + 2.0 * k3z + k4z), tiny,
        r00, r01, r02, r10, r11, r12, r20, r21, r22)
    return (xx + h6 * (vx + 2.0 * v2x + 2.0 * v3x + v4x),
            xy + h6 * (vy + 2.0 * v2y + 2.0 * v3y + v4y),
            xz + h6 * (vz + 2.0 * v2z + 2.0 * v3z + v4z),
            vx + h6 * (a1x + 2.0 * a2x + 2.0 * a3x + a4x),
            vy + h6 * (a1y + 2.0 * a2y + 2.0 * a3y + a4y),
            vz + h6 * (a1z + 2.0 * a2z + 2.0 * a3z + a4z),
            q00, q01, q02, q10, q11, q12, q20, q21, q22,
            wx + h6 * (b1x + 2.0 * b2x + 2.0 * b3x + b4x),
            wy + h6 * (b1y + 2.0 * b2y + 2.0 * b3y + b4y),
            wz + h6 * (b1z + 2.0 * b2z + 2.0 * b3z + b4z))


@kernel
def _slot(j):
    """``slot_column``, compiled."""
    return XP if j == 1 else STATE_WIDTH + (j - 2) * SLOT_WIDTH


@kernel
def _evaluate_ring(p, i, ring, e):
    """a and beta of ring entry e (a state laid out as X .. B) at its R, omega, v."""
    a0, a1, a2, b0, b1, b2 = accelerations(
        p, i, float(ring[e, R]), float(ring[e, R + 1]), float(ring[e, R + 2]),
        float(ring[e, R + 3]), float(ring[e, R + 4]), float(ring[e, R + 5]),
        float(ring[e, R + 6]), float(ring[e, R + 7]), float(ring[e, R + 8]),
        float(ring[e, W]), float(ring[e, W + 1]), float(ring[e, W + 2]),
        float(ring[e, V]), float(ring[e, V + 1]), float(ring[e, V + 2]), bool(False))
    ring[e, A], ring[e, A + 1], ring[e, A + 2] = a0, a1, a2
    ring[e, B], ring[e, B + 1], ring[e, B + 2] = b0, b1, b2


@kernel
def evaluate_history(state, params, i, k):
    """a and beta, under the held wrench, of the k - 1 states kept in the history slots of
    body i (``Stepper.set_state`` with the exact states before)."""
    ring = np.empty((1, SLOT_WIDTH))
    for j in range(1, k):
        at = _slot(j)
        for col in range(SLOT_WIDTH):
            ring[0, col] = state[i, at + col]
        _evaluate_ring(params, i, ring, 0)
        for col in range(A, B + 3):
            state[i, at + col] = ring[0, col]


@kernel
def _start_up_ring(p, i, k, dt, tiny, ring):
    """The k - 1 states before the current one (ring[0]) by RKMK4 steps back in time under
    the held wrench, each with its accelerations: the state j steps back into ring[k - j]."""
    r = ring
    (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
     wx, wy, wz) = _get(r, 0)
    for j in range(1, k):
        (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
         wx, wy, wz) = rkmk4_step(p, i, -dt, tiny, xx, xy, xz, vx, vy, vz, r00, r01, r02,
                                  r10, r11, r12, r20, r21, r22, wx, wy, wz)
        _put(ring, k - j, X, xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
             wx, wy, wz)
        _evaluate_ring(p, i, ring, k - j)


@kernel
def _put(a, e, at, xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
         wx, wy, wz):
    """x, v, R, omega into row e of ``a`` from column ``at`` (X: a state row or a ring
    entry; XP: the previous step's), in the layout X, V, R, W."""
    a[e, at + X], a[e, at + X + 1], a[e, at + X + 2] = xx, xy, xz
    a[e, at + V], a[e, at + V + 1], a[e, at + V + 2] = vx, vy, vz
    a[e, at + R], a[e, at + R + 1], a[e, at + R + 2] = r00, r01, r02
    a[e, at + R + 3], a[e, at + R + 4], a[e, at + R + 5] = r10, r11, r12
    a[e, at + R + 6], a[e, at + R + 7], a[e, at + R + 8] = r20, r21, r22
    a[e, at + W], a[e, at + W + 1], a[e, at + W + 2] = wx, wy, wz


@kernel
def _get(a, e):
    """x, v, R, omega of row e of ``a`` (a state row or a ring entry): 18 floats."""
    return (float(a[e, X]), float(a[e, X + 1]), float(a[e, X + 2]),
            float(a[e, V]), float(a[e, V + 1]), float(a[e, V + 2]),
            float(a[e, R]), float(a[e, R + 1]), float(a[e, R + 2]),
            float(a[e, R + 3]), float(a[e, R + 4]), float(a[e, R + 5]),
            float(a[e, R + 6]), float(a[e, R + 7]), float(a[e, R + 8]),
            float(a[e, W]), float(a[e, W + 1]), float(a[e, W + 2]))


@kernel
def advance_body_k(src, dst, p, c, i, n, checked, status, taken, bad, work):
    """``advance_body`` for a method of k = c[STEPS] > 2 accelerations (lie3, lie4): the same
    stages, checks and skips, with the k - 1 states before the current one as the history
    (slots 1 .. k - 1 of the row), started (``_start_up_ring``) when there is none and
    again under a new wrench. While stepping, the k states are a ring: step m is in
    ring[m % k]."""
    k = int(c[STEPS])
    dt = float(c[0])
    tiny, every = float(c[16]), int(c[17])
    flags = int(p[i, FLAGS])
    max_turn_sq = float(p[i, MAX_TURN_SQ])
    width = src.shape[1]
    status[i] = STATUS_OK
    taken[i] = 0
    if n <= 0:
        for col in range(width):
            dst[i, col] = src[i, col]
        return
    ring = np.empty((MAX_STEPS, SLOT_WIDTH))
    for col in range(SLOT_WIDTH):
        ring[0, col] = src[i, col]
    # 1. The history: the state j steps back in ring[k - j]. Under a new wrench (STALE) it
    # starts again: evaluated again at the kept states, it would be the old wrench's path
    # under the new law, O(dt) off in omega, and the order would fall to 2
    # (docs/integrators.md).
    if float(src[i, HISTORY]) != HISTORY_VALID:
        _start_up_ring(p, i, k, dt, tiny, ring)
        work[i, WORK_START_UP] += 1
    else:
        for j in range(1, k):
            at = _slot(j)
            for col in range(SLOT_WIDTH):
                ring[k - j, col] = src[i, at + col]
    if checked:
        total = 0.0
        for e in range(1, k):
            for col in range(A, B + 3):
                total += ring[e, col] * 0.0
        if total != 0.0:
            for col in range(width):
                dst[i, col] = src[i, col]
            status[i] = STATUS_START_UP
            return
    # 2. The skips (every state of the history at rest in that sense).
    frozen_rotation = False
    if flags & SPECIALIZE:
        frozen_rotation = (flags & TORQUE_FREE) != 0
        frozen_translation = (flags & FORCE_FREE) != 0
        for e in range(k):
            for col in range(3):
                if ring[e, W + col] != 0.0 or ring[e, B + col] != 0.0:
                    frozen_rotation = False
                if ring[e, V + col] != 0.0 or ring[e, A + col] != 0.0:
                    frozen_translation = False
        if frozen_rotation and frozen_translation:  # at rest, unforced: nothing moves
            for col in range(width):
                dst[i, col] = src[i, col]
            for j in range(1, k):
                at = _slot(j)
                for col in range(SLOT_WIDTH):
                    dst[i, at + col] = src[i, col]  # the steps before are this one
            dst[i, HISTORY] = HISTORY_VALID
            taken[i] = n
            return
    # 3. The steps.
    countdown = int(src[i, COUNTDOWN])
    top = 0
    good = 0
    for _ in range(n):
        g = ring
        xx, xy, xz = float(g[top, X]), float(g[top, X + 1]), float(g[top, X + 2])
        vx, vy, vz = float(g[top, V]), float(g[top, V + 1]), float(g[top, V + 2])
        wx, wy, wz = float(g[top, W]), float(g[top, W + 1]), float(g[top, W + 2])
        nx0, nx1, nx2 = xx + vx * dt, xy + vy * dt, xz + vz * dt
        nv0, nv1, nv2 = vx, vy, vz
        nw0, nw1, nw2 = wx, wy, wz
        px, py, pz = wx * dt, wy * dt, wz * dt
        sx, sy, sz = 0.0, 0.0, 0.0
        for j in range(k):
            e = (top - j + k) % k
            cv, cp = float(c[C_VELOCITY + j]), float(c[C_POSITION + j])
            cr, cc = float(c[C_ROTATION + j]), float(c[C_CROSS + j])
            ax, ay, az = float(g[e, A]), float(g[e, A + 1]), float(g[e, A + 2])
            bx, by, bz = float(g[e, B]), float(g[e, B + 1]), float(g[e, B + 2])
            nx0, nx1, nx2 = nx0 + cp * ax, nx1 + cp * ay, nx2 + cp * az
            nv0, nv1, nv2 = nv0 + cv * ax, nv1 + cv * ay, nv2 + cv * az
            if not frozen_rotation:
                nw0, nw1, nw2 = nw0 + cv * bx, nw1 + cv * by, nw2 + cv * bz
                px, py, pz = px + cr * bx, py + cr * by, pz + cr * bz
                sx, sy, sz = sx + cc * bx, sy + cc * by, sz + cc * bz
        r00, r01, r02 = float(g[top, R]), float(g[top, R + 1]), float(g[top, R + 2])
        r10, r11, r12 = float(g[top, R + 3]), float(g[top, R + 4]), float(g[top, R + 5])
        r20, r21, r22 = float(g[top, R + 6]), float(g[top, R + 7]), float(g[top, R + 8])
        if frozen_rotation:
            q00, q01, q02, q10, q11, q12, q20, q21, q22 = (r00, r01, r02, r10, r11, r12,
                                                           r20, r21, r22)
        else:
            cx, cy, cz = _cross(sx, sy, sz, wx, wy, wz)
            q00, q01, q02, q10, q11, q12, q20, q21, q22 = _turned(
                px + cx, py + cy, pz + cz, tiny, r00, r01, r02, r10, r11, r12, r20, r21, r22)
        work[i, WORK_TRANSLATION if frozen_rotation else WORK_FULL] += 1
        if checked:
            code = _step_status(nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12,
                                q20, q21, q22, nw0, nw1, nw2, max_turn_sq)
            if code != STATUS_OK:
                status[i] = code
                bad[i, 0], bad[i, 1], bad[i, 2] = nw0, nw1, nw2
                break
        countdown -= 1
        if not frozen_rotation and countdown <= 0:
            (q00, q01, q02, q10, q11, q12, q20, q21, q22) = orthonormalize(
                q00, q01, q02, q10, q11, q12, q20, q21, q22)
            countdown = every
        top = (top + 1) % k
        _put(ring, top, X, nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11, q12, q20, q21,
             q22, nw0, nw1, nw2)
        a0, a1, a2, b0, b1, b2 = accelerations(
            p, i, q00, q01, q02, q10, q11, q12, q20, q21, q22, nw0, nw1, nw2, nv0, nv1, nv2,
            frozen_rotation)
        ring[top, A], ring[top, A + 1], ring[top, A + 2] = a0, a1, a2
        ring[top, B], ring[top, B + 1], ring[top, B + 2] = b0, b1, b2
        good += 1
    taken[i] = good
    if good == 0:  # the first step failed: none taken, the row as it was
        for col in range(width):
            dst[i, col] = src[i, col]
        return
    for col in range(SLOT_WIDTH):
        dst[i, col] = ring[top, col]
    for j in range(1, k):
        at, e = _slot(j), (top - j + k) % k
        for col in range(SLOT_WIDTH):
            dst[i, at + col] = ring[e, col]
    dst[i, COUNTDOWN] = countdown
    dst[i, HISTORY] = HISTORY_VALID
    if not checked:
        total = 0.0
        for col in range(W + 3):  # x, v, R, omega
            total += ring[top, col] * 0.0
        w2 = ring[top, W] * ring[top, W] + ring[top, W + 1] * ring[top, W + 1] + (
            ring[top, W + 2] * ring[top, W + 2])
        if not (total == 0.0 and w2 <= max_turn_sq):
            status[i] = STATUS_NON_FINITE  # somewhere in the run: a checked run finds where


@kernel
def _kick(p, i, h, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz):
    """A kick of the splitting methods: time h (s, any sign) with R held, v under the force
    (and gravity) and the angular momentum under the torque, linear and angular damping
    solved exactly (v' = f - c v: v + (1 - e^(-c h)) (f / c - v)). Returns v, omega."""
    flags = int(p[i, FLAGS])
    c_lin, c_ang = float(p[i, LINEAR_DAMPING]), float(p[i, ANGULAR_DAMPING])
    if not (flags & FORCE_FREE) or c_lin != 0.0:
        fx, fy, fz, _, _, _ = accelerations(p, i, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, bool(True))
        if c_lin == 0.0:
            vx, vy, vz = vx + h * fx, vy + h * fy, vz + h * fz
        else:
            e = -math.expm1(-c_lin * h)
            vx, vy, vz = (vx + e * (fx / c_lin - vx), vy + e * (fy / c_lin - vy),
                          vz + e * (fz / c_lin - vz))
    if (flags & TORQUE_FREE) and c_ang == 0.0:
        return vx, vy, vz, wx, wy, wz
    ix, iy, iz = float(p[i, MOMENTS]), float(p[i, MOMENTS + 1]), float(p[i, MOMENTS + 2])
    tx, ty, tz = float(p[i, TORQUE]), float(p[i, TORQUE + 1]), float(p[i, TORQUE + 2])
    if not (flags & TORQUE_IN_BODY):  # world torque to the principal frame: R^T tau
        tx, ty, tz = (r00 * tx + r10 * ty + r20 * tz, r01 * tx + r11 * ty + r21 * tz,
                      r02 * tx + r12 * ty + r22 * tz)
    mx = ix * (r00 * wx + r10 * wy + r20 * wz)
    my = iy * (r01 * wx + r11 * wy + r21 * wz)
    mz = iz * (r02 * wx + r12 * wy + r22 * wz)
    if c_ang == 0.0:
        mx, my, mz = mx + h * tx, my + h * ty, mz + h * tz
    else:
        e = -math.expm1(-c_ang * h)
        mx, my, mz = (mx + e * (tx / c_ang - mx), my + e * (ty / c_ang - my),
                      mz + e * (tz / c_ang - mz))
    bx, by, bz = mx / ix, my / iy, mz / iz
    return (vx, vy, vz, r00 * bx + r01 * by + r02 * bz, r10 * bx + r11 * by + r12 * bz,
            r20 * bx + r21 * by + r22 * bz)


@kernel
def advance_body_split(src, dst, p, c, i, n, checked, status, taken, bad, work):
    """``advance_body`` for a splitting method (c[STEPS] = 1, multistep.Splitting): each step
    is, for each weight w, a kick of w dt / 2, the exact free flow of w dt with x += v w dt,
    a kick of w dt / 2. No history, no start-up, no turn limit (the free flow is exact at
    any rate); the end state is checked finite, and step by step when ``checked``."""
    dt = float(c[0])
    tiny = float(c[16])
    count = int(c[C_WEIGHT_COUNT])
    width = src.shape[1]
    status[i] = STATUS_OK
    taken[i] = 0
    for col in range(width):
        dst[i, col] = src[i, col]
    if n <= 0:
        return
    s = src
    ix, iy, iz = float(p[i, MOMENTS]), float(p[i, MOMENTS + 1]), float(p[i, MOMENTS + 2])
    (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
     wx, wy, wz) = _get(s, i)
    countdown = int(s[i, COUNTDOWN])
    flags = int(p[i, FLAGS])
    # The invariants stay as stored while no torque acts: a torque-free body keeps them
    # exactly, step after step; they are read again after a state was written (no history).
    torqued = not ((flags & TORQUE_FREE) and float(p[i, ANGULAR_DAMPING]) == 0.0)
    # Torque-free, the motion is kept as where it is on its polhode (u, phi, Q: mode 1) and
    # R, omega are evaluated from that: no rounding builds up in L, energy or R.
    fq = np.empty(9)
    mode, sign_r, u, phi = 0.0, 1.0, 0.0, 0.0
    if float(s[i, HISTORY]) == HISTORY_VALID:
        e_lo, e_hi = float(s[i, FLOW_E_LO]), float(s[i, FLOW_E_HI])
        mode, sign_r = float(s[i, FLOW_MODE]), float(s[i, FLOW_SIGN])
        u, phi = float(s[i, FLOW_U]), float(s[i, FLOW_PHI])
        for k in range(9):
            fq[k] = s[i, FLOW_Q + k]
    else:
        e_lo, e_hi = invariants(ix, iy, iz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                wx, wy, wz)
        if not torqued:
            (elliptic, sign_r, u, fq[0], fq[1], fq[2], fq[3], fq[4], fq[5], fq[6], fq[7],
             fq[8]) = flow_start(ix, iy, iz, e_lo, e_hi, r00, r01, r02, r10, r11, r12, r20,
                                 r21, r22, wx, wy, wz)
            mode = 1.0 if elliptic else 0.0
    if torqued:
        mode = 0.0
    good = 0
    for _ in range(n):
        ne_lo, ne_hi, nu, nphi = e_lo, e_hi, u, phi
        nx0, nx1, nx2, nv0, nv1, nv2 = xx, xy, xz, vx, vy, vz
        q00, q01, q02, q10, q11, q12, q20, q21, q22 = r00, r01, r02, r10, r11, r12, r20, r21, r22
        nw0, nw1, nw2 = wx, wy, wz
        for j in range(count):
            h = float(c[C_WEIGHTS + j]) * dt
            nv0, nv1, nv2, nw0, nw1, nw2 = _kick(p, i, 0.5 * h, nv0, nv1, nv2, q00, q01, q02,
                                                 q10, q11, q12, q20, q21, q22, nw0, nw1, nw2)
            nx0, nx1, nx2 = nx0 + h * nv0, nx1 + h * nv1, nx2 + h * nv2
            if mode == 1.0:
                (nu, nphi, q00, q01, q02, q10, q11, q12, q20, q21, q22, nw0, nw1,
                 nw2) = flow_advance(ix, iy, iz, ne_lo, ne_hi, sign_r, nu, nphi, fq[0], fq[1],
                                     fq[2], fq[3], fq[4], fq[5], fq[6], fq[7], fq[8], h)
            else:
                if torqued:
                    ne_lo, ne_hi = invariants(ix, iy, iz, q00, q01, q02, q10, q11, q12, q20,
                                              q21, q22, nw0, nw1, nw2)
                (q00, q01, q02, q10, q11, q12, q20, q21, q22, nw0, nw1, nw2) = free_flow(
                    ix, iy, iz, ne_lo, ne_hi, q00, q01, q02, q10, q11, q12, q20, q21, q22, nw0,
                    nw1, nw2, h, tiny)
            nv0, nv1, nv2, nw0, nw1, nw2 = _kick(p, i, 0.5 * h, nv0, nv1, nv2, q00, q01, q02,
                                                 q10, q11, q12, q20, q21, q22, nw0, nw1, nw2)
        work[i, WORK_FULL] += 1
        if checked and not _finite(nx0, nx1, nx2, nv0, nv1, nv2, q00, q01, q02, q10, q11,
                                   q12, q20, q21, q22, nw0, nw1, nw2):
            status[i] = STATUS_NON_FINITE
            bad[i, 0], bad[i, 1], bad[i, 2] = nw0, nw1, nw2
            break
        if mode != 1.0:
            # R pulled back to SO(3) every step: it costs little beside the flow, and a drift
            # of R off SO(3) would move L = R m, which the flow keeps otherwise.
            (q00, q01, q02, q10, q11, q12, q20, q21, q22) = orthonormalize(
                q00, q01, q02, q10, q11, q12, q20, q21, q22)
        u, phi = nu, nphi
        xx, xy, xz, vx, vy, vz = nx0, nx1, nx2, nv0, nv1, nv2
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = q00, q01, q02, q10, q11, q12, q20, q21, q22
        wx, wy, wz = nw0, nw1, nw2
        e_lo, e_hi = ne_lo, ne_hi
        good += 1
    taken[i] = good
    if good == 0:
        return
    d = dst
    _put(d, i, X, xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz)
    d[i, COUNTDOWN] = countdown
    d[i, FLOW_E_LO], d[i, FLOW_E_HI] = e_lo, e_hi
    d[i, FLOW_MODE], d[i, FLOW_SIGN], d[i, FLOW_U], d[i, FLOW_PHI] = mode, sign_r, u, phi
    for k in range(9):
        d[i, FLOW_Q + k] = fq[k]
    d[i, HISTORY] = HISTORY_VALID
    evaluate(dst, p, i)  # a and beta at the new state, for the readers of accelerations
    if not checked and not _finite(xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12,
                                   r20, r21, r22, wx, wy, wz):
        status[i] = STATUS_NON_FINITE  # somewhere in the run: a checked run finds where


# -- blocks: bodies side by side ------------------------------------------------------------
# ``advance`` steps up to BLOCK bodies at once: their rows are copied into lanes (one array,
# field f of lane k at f * BLOCK + k), each step is a loop over the lanes, which LLVM turns
# into SIMD, and the rows are written back. A lane does what ``advance_body`` does, with the
# same functions in the same order, so it gives the same bits; what a lane leaves out goes to
# ``advance_body``: a body without a valid history (start-up, a new wrench), one whose rotation
# is skipped, a checked run, a method other than a two-step one. A step whose lanes all have a
# rotation vector below SMALL_ANGLE_SQ and no orthonormalisation due is taken branch-free
# (``_lanes_fast``); any other step takes the lanes one by one with the full branches.
# -- one body, by family -----------------------------------------------------------------------
# A method's family is the body step it takes: FAMILY_TWO (eq. (27)'s form), FAMILY_K (k > 2
# accelerations) or FAMILY_SPLIT (a splitting). A kernel that steps bodies takes the family as a
# compile-time constant (``body_step``), so that a run compiles its own family's step only.
FAMILY_SPLIT, FAMILY_TWO, FAMILY_K = 1, 2, 3
FAMILIES = (FAMILY_TWO, FAMILY_K, FAMILY_SPLIT)
# Their names, in the names of the kernel parts (``sim/precompile.py``).
FAMILY_NAMES = {FAMILY_TWO: 'two-step', FAMILY_K: 'k-step', FAMILY_SPLIT: 'splitting'}


def family_of(steps: int) -> int:
    """The family of a method of ``steps`` accelerations a step (1: a splitting)."""
    return FAMILY_K if steps > 2 else FAMILY_SPLIT if steps == 1 else FAMILY_TWO


def family(coefficients) -> int:
    """The family of the method whose ``coefficients`` these are."""
    return family_of(int(coefficients[STEPS]))


@kernel
def advance_body(src, dst, p, c, i, n, checked, status, taken, bad, work):
    """n steps of body i from row i of ``src`` into row i of ``dst`` (see the module), its
    family read from ``c`` as it runs (it compiles every family's step: for tests and tools;
    the stepping kernels use ``body_step``)."""
    if c[STEPS] > 2.0:
        advance_body_k(src, dst, p, c, i, n, checked, status, taken, bad, work)
    elif c[STEPS] == 1.0:
        advance_body_split(src, dst, p, c, i, n, checked, status, taken, bad, work)
    else:
        advance_body_2(src, dst, p, c, i, n, checked, status, taken, bad, work)


def _two_step(family, src, dst, p, c, i, n, checked, status, taken, bad, work):
    advance_body_2(src, dst, p, c, i, n, checked, status, taken, bad, work)


def _k_step(family, src, dst, p, c, i, n, checked, status, taken, bad, work):
    advance_body_k(src, dst, p, c, i, n, checked, status, taken, bad, work)


def _split_step(family, src, dst, p, c, i, n, checked, status, taken, bad, work):
    advance_body_split(src, dst, p, c, i, n, checked, status, taken, bad, work)


@literal_switch({FAMILY_TWO: _two_step, FAMILY_K: _k_step, FAMILY_SPLIT: _split_step})
def body_step(family, src, dst, p, c, i, n, checked, status, taken, bad, work):
    """``advance_body`` of a body of ``family`` (a compile-time constant in a kernel: a
    global, or a closure's constant as in world_step's entries), which compiles that
    family's step alone."""
    if family == FAMILY_K:
        advance_body_k(src, dst, p, c, i, n, checked, status, taken, bad, work)
    elif family == FAMILY_SPLIT:
        advance_body_split(src, dst, p, c, i, n, checked, status, taken, bad, work)
    else:
        advance_body_2(src, dst, p, c, i, n, checked, status, taken, bad, work)


BLOCK = 32
BLOCK_MIN = 4  # fewer bodies: one by one
L_X, L_A, L_B, L_AP, L_BP, L_COUNTDOWN, L_XP = 0, 18, 21, 24, 27, 30, 31  # L_X .. : as X ..
LANE_FIELDS = 49


@kernel
def _lanes_step(S, P, m, dt, vn, vp, pn, pp, rn, rp, rc, tiny, every, fast):
    """One step of the m lanes of ``S`` (params ``P``): ``advance_body``'s loop body,
    unchecked and rotating, with the same functions. ``fast``: ``_lanes_fast`` found every
    rotation vector small and no orthonormalisation due. No array is passed to a function in
    the loop (numba would count a reference to it in each pass, and LLVM would not make SIMD
    of the loop)."""
    for k in range(m):
        (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz,
         ax, ay, az, bx, by, bz, apx, apy, apz, bpx, bpy, bpz) = (
            float(S[0 * BLOCK + k]), float(S[1 * BLOCK + k]), float(S[2 * BLOCK + k]),
            float(S[3 * BLOCK + k]), float(S[4 * BLOCK + k]), float(S[5 * BLOCK + k]),
            float(S[6 * BLOCK + k]), float(S[7 * BLOCK + k]), float(S[8 * BLOCK + k]),
            float(S[9 * BLOCK + k]), float(S[10 * BLOCK + k]), float(S[11 * BLOCK + k]),
            float(S[12 * BLOCK + k]), float(S[13 * BLOCK + k]), float(S[14 * BLOCK + k]),
            float(S[15 * BLOCK + k]), float(S[16 * BLOCK + k]), float(S[17 * BLOCK + k]),
            float(S[18 * BLOCK + k]), float(S[19 * BLOCK + k]), float(S[20 * BLOCK + k]),
            float(S[21 * BLOCK + k]), float(S[22 * BLOCK + k]), float(S[23 * BLOCK + k]),
            float(S[24 * BLOCK + k]), float(S[25 * BLOCK + k]), float(S[26 * BLOCK + k]),
            float(S[27 * BLOCK + k]), float(S[28 * BLOCK + k]), float(S[29 * BLOCK + k]))
        row = (
            float(P[0 * BLOCK + k]), float(P[1 * BLOCK + k]), float(P[2 * BLOCK + k]),
            float(P[3 * BLOCK + k]), float(P[4 * BLOCK + k]), float(P[5 * BLOCK + k]),
            float(P[6 * BLOCK + k]), float(P[7 * BLOCK + k]), float(P[8 * BLOCK + k]),
            float(P[9 * BLOCK + k]), float(P[10 * BLOCK + k]), float(P[11 * BLOCK + k]),
            float(P[12 * BLOCK + k]), float(P[13 * BLOCK + k]), float(P[14 * BLOCK + k]),
            float(P[15 * BLOCK + k]), float(P[16 * BLOCK + k]), float(P[17 * BLOCK + k]),
            float(P[18 * BLOCK + k]), float(P[19 * BLOCK + k]), float(P[20 * BLOCK + k]),
            float(P[21 * BLOCK + k]))
        # multistep_step's parts, as it calls them
        nx0, nx1, nx2, nv0, nv1, nv2 = translation_step(
            dt, vn, vp, pn, pp, xx, xy, xz, vx, vy, vz, ax, ay, az, apx, apy, apz)
        q00, q01, q02, q10, q11, q12, q20, q21, q22 = rotation_step(
            dt, rn, rp, rc, tiny, fast, r00, r01, r02, r10, r11, r12, r20, r21, r22,
            wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
        nw0, nw1, nw2 = omega_step(vn, vp, wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
        countdown = float(S[L_COUNTDOWN * BLOCK + k]) - 1.0
        if not fast and countdown <= 0.0:
            q00, q01, q02, q10, q11, q12, q20, q21, q22 = orthonormalize(
                q00, q01, q02, q10, q11, q12, q20, q21, q22)
            countdown = every
        na0, na1, na2, nb0, nb1, nb2 = thm1(
            row, q00, q01, q02, q10, q11, q12, q20, q21, q22, nw0, nw1, nw2, nv0, nv1, nv2,
            bool(False))
        # the new x, v, R, omega, a, beta; a_prev, beta_prev: this step's a, beta
        S[0 * BLOCK + k], S[1 * BLOCK + k], S[2 * BLOCK + k] = nx0, nx1, nx2
        S[3 * BLOCK + k], S[4 * BLOCK + k], S[5 * BLOCK + k] = nv0, nv1, nv2
        S[6 * BLOCK + k], S[7 * BLOCK + k], S[8 * BLOCK + k] = q00, q01, q02
        S[9 * BLOCK + k], S[10 * BLOCK + k], S[11 * BLOCK + k] = q10, q11, q12
        S[12 * BLOCK + k], S[13 * BLOCK + k], S[14 * BLOCK + k] = q20, q21, q22
        S[15 * BLOCK + k], S[16 * BLOCK + k], S[17 * BLOCK + k] = nw0, nw1, nw2
        S[18 * BLOCK + k], S[19 * BLOCK + k], S[20 * BLOCK + k] = na0, na1, na2
        S[21 * BLOCK + k], S[22 * BLOCK + k], S[23 * BLOCK + k] = nb0, nb1, nb2
        S[24 * BLOCK + k], S[25 * BLOCK + k], S[26 * BLOCK + k] = ax, ay, az
        S[27 * BLOCK + k], S[28 * BLOCK + k], S[29 * BLOCK + k] = bx, by, bz
        S[L_COUNTDOWN * BLOCK + k] = countdown


@kernel
def _lanes_fast(S, m, dt, rn, rp, rc):
    """Whether every one of the m lanes has a rotation vector below SMALL_ANGLE_SQ (the same
    p, to the bit, as its step will have) and no orthonormalisation due this step."""
    slow = 0
    for k in range(m):
        wx, wy, wz = float(S[15 * BLOCK + k]), float(S[16 * BLOCK + k]), float(S[17 * BLOCK + k])
        bx, by, bz = float(S[21 * BLOCK + k]), float(S[22 * BLOCK + k]), float(S[23 * BLOCK + k])
        bpx, bpy, bpz = (float(S[27 * BLOCK + k]), float(S[28 * BLOCK + k]),
                         float(S[29 * BLOCK + k]))
        px, py, pz = rotation_vector(dt, rn, rp, rc, wx, wy, wz, bx, by, bz, bpx, bpy, bpz)
        small = px * px + py * py + pz * pz < SMALL_ANGLE_SQ
        slow += 0 if small and float(S[L_COUNTDOWN * BLOCK + k]) > 1.0 else 1
    return slow == 0


@kernel
def _lane_ready(src, p, i):
    """Whether body i takes its steps in a lane: a valid history and a rotation to step
    (``advance_body``'s skip of a body that does not turn is not a lane's)."""
    if float(src[i, HISTORY]) != HISTORY_VALID:
        return False
    flags = int(p[i, FLAGS])
    if not (flags & SPECIALIZE) or not (flags & TORQUE_FREE):
        return True
    for col in range(W, W + 3):
        if src[i, col] != 0.0:
            return True
    for col in range(B, B + 3):
        if src[i, col] != 0.0 or src[i, col + (BP - B)] != 0.0:
            return True
    return False


@kernel
def _advance_block(src, dst, p, c, bodies, start, stop, n, status, taken, bad, work):
    """n steps (n >= 1, unchecked) of the bodies bodies[start:stop] (at most BLOCK), in lanes
    where they can be (see BLOCK)."""
    S = np.empty(LANE_FIELDS * BLOCK)
    P = np.empty(PARAM_WIDTH * BLOCK)
    rows = np.empty(BLOCK, dtype=np.int64)
    m = 0
    for j in range(start, stop):
        i = bodies[j]
        if not _lane_ready(src, p, i):
            advance_body_2(src, dst, p, c, i, n, bool(False), status, taken, bad, work)
            continue
        for f in range(L_AP):  # x, v, R, omega, a, beta
            S[f * BLOCK + m] = src[i, X + f]
        for f in range(6):  # a_prev, beta_prev
            S[(L_AP + f) * BLOCK + m] = src[i, AP + f]
        S[L_COUNTDOWN * BLOCK + m] = float(int(src[i, COUNTDOWN]))
        for f in range(PARAM_WIDTH):
            P[f * BLOCK + m] = p[i, f]
        rows[m] = i
        m += 1
    if m == 0:
        return
    dt, vn, vp, pn, pp = float(c[0]), float(c[1]), float(c[2]), float(c[3]), float(c[4])
    rn, rp, rc = float(c[5]), float(c[6]), float(c[7])
    tiny, every = float(c[16]), float(int(c[17]))
    for step in range(n):
        if step == n - 1:  # the state before the last step is the history's
            for f in range(18):
                for k in range(m):
                    S[(L_XP + f) * BLOCK + k] = S[(L_X + f) * BLOCK + k]
        if _lanes_fast(S, m, dt, rn, rp, rc):
            # A literal True (not bool(True)) on purpose: the fast copy is compiled with its
            # branches folded away, which is what lets LLVM make SIMD of its loop.
            _lanes_step(S, P, m, dt, vn, vp, pn, pp, rn, rp, rc, tiny, every, True)
        else:
            _lanes_step(S, P, m, dt, vn, vp, pn, pp, rn, rp, rc, tiny, every, bool(False))
    for k in range(m):
        i = rows[k]
        for f in range(L_AP):
            dst[i, X + f] = S[f * BLOCK + k]
        for f in range(18):
            dst[i, XP + f] = S[(L_XP + f) * BLOCK + k]
        for f in range(6):
            dst[i, AP + f] = S[(L_AP + f) * BLOCK + k]
        dst[i, COUNTDOWN] = S[L_COUNTDOWN * BLOCK + k]
        dst[i, HISTORY] = HISTORY_VALID
        work[i, WORK_FULL] += n
        taken[i] = n
        status[i] = STATUS_OK
        (xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
         wx, wy, wz) = _get(dst, i)
        if not (_finite(xx, xy, xz, vx, vy, vz, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                        wx, wy, wz)
                and wx * wx + wy * wy + wz * wz <= float(p[i, MAX_TURN_SQ])):
            status[i] = STATUS_NON_FINITE  # somewhere in the run: a checked run finds where


def blocked(coefficients, count: int, n: int, checked: bool) -> bool:
    """Whether ``advance`` takes ``count`` bodies in blocks (BLOCK)."""
    return (not checked and n >= 1 and float(coefficients[STEPS]) == 2.0
            and count >= BLOCK_MIN)


def advance(src, dst, params, coefficients, bodies, n, checked, status, taken, bad, work,
            parallel=False):
    """n steps of each body listed in ``bodies`` (int64 indices), one after the other, or a
    block after the other (BLOCK); ``parallel``: shared among the cores (the bodies are
    independent). The kernel it calls compiles the method's family only."""
    args = (src, dst, params, coefficients, bodies, n)
    out = (status, taken, bad, work)
    if blocked(coefficients, bodies.shape[0], n, checked):
        (advance_blocks_parallel if parallel else advance_blocks)(*args, *out)
    else:
        kernel_of = globals()[ADVANCE_BODIES[parallel, family(coefficients)]]
        kernel_of(*args, checked, *out)


# The stepping kernels of free bodies, one a family (the family is known where the kernel is
# chosen, in Python: ``ADVANCE_BODIES``), so that a run compiles its own family's step only.
# (One kernel taking the family as an argument would need it as a compile-time constant; from
# Python it is not one, and numba would enter its compiler at every call: 15 ms a step.)


@kernel
def advance_bodies_two(src, dst, params, coefficients, bodies, n, checked, status, taken, bad,
                       work):
    """n steps of each body of ``bodies``, one after the other, of a two-step method."""
    for k in range(bodies.shape[0]):
        advance_body_2(src, dst, params, coefficients, bodies[k], n, checked, status, taken,
                       bad, work)


@kernel
def advance_bodies_k(src, dst, params, coefficients, bodies, n, checked, status, taken, bad,
                     work):
    """``advance_bodies_two`` for a method of k > 2 accelerations."""
    for k in range(bodies.shape[0]):
        advance_body_k(src, dst, params, coefficients, bodies[k], n, checked, status, taken,
                       bad, work)


@kernel
def advance_bodies_split(src, dst, params, coefficients, bodies, n, checked, status, taken, bad,
                         work):
    """``advance_bodies_two`` for a splitting method."""
    for k in range(bodies.shape[0]):
        advance_body_split(src, dst, params, coefficients, bodies[k], n, checked, status, taken,
                           bad, work)


@parallel_kernel
def advance_bodies_parallel_two(src, dst, params, coefficients, bodies, n, checked, status,
                                taken, bad, work):
    """``advance_bodies_two`` with the bodies shared among the cores (they are independent)."""
    for k in prange(bodies.shape[0]):
        advance_body_2(src, dst, params, coefficients, bodies[k], n, checked, status, taken,
                       bad, work)


@parallel_kernel
def advance_bodies_parallel_k(src, dst, params, coefficients, bodies, n, checked, status,
                              taken, bad, work):
    """``advance_bodies_k`` with the bodies shared among the cores."""
    for k in prange(bodies.shape[0]):
        advance_body_k(src, dst, params, coefficients, bodies[k], n, checked, status, taken,
                       bad, work)


@parallel_kernel
def advance_bodies_parallel_split(src, dst, params, coefficients, bodies, n, checked, status,
                                  taken, bad, work):
    """``advance_bodies_split`` with the bodies shared among the cores."""
    for k in prange(bodies.shape[0]):
        advance_body_split(src, dst, params, coefficients, bodies[k], n, checked, status,
                           taken, bad, work)


# One body's step from Python (``BodyStore.advance`` of one row, each ``Stepper.step``): the
# step, and what Python did after it, in the same call, a kernel a family. The row's new state
# is copied back into ``src`` (a store of one row swapped the arrays instead: the same values);
# returns 0, 1 if the row failed (``src`` untouched, the clock not moved: Python takes the
# steps again, checked), or 2 if it now turns faster than its warn_sq allows (Python warns).


def _step_one_of(family, name):
    # (the family an int constant of the closure, as world_step's entries have it: numba keys
    # a closure's cache entry on its constants, and a kernel there would pickle differently
    # in each process, so that each compiled it again)
    def step_one(src, dst, params, coefficients, row, n, status, taken, bad, work, clock,
                 warn_sq):
        if n <= 0:
            return 0
        body_step(family, src, dst, params, coefficients, row, n, bool(False), status, taken,
                  bad, work)
        if status[row] != STATUS_OK:
            return 1
        for c in range(src.shape[1]):
            src[row, c] = dst[row, c]
        clock[row] += n
        wx, wy, wz = float(src[row, W]), float(src[row, W + 1]), float(src[row, W + 2])
        if wx * wx + wy * wy + wz * wz > float(warn_sq[row]):
            return 2
        return 0

    step_one.__name__ = step_one.__qualname__ = name
    return kernel(step_one)


step_one_two = _step_one_of(FAMILY_TWO, 'step_one_two')
step_one_k = _step_one_of(FAMILY_K, 'step_one_k')
step_one_split = _step_one_of(FAMILY_SPLIT, 'step_one_split')
STEP_ONE = {FAMILY_TWO: 'step_one_two', FAMILY_K: 'step_one_k', FAMILY_SPLIT: 'step_one_split'}

# (parallel, family) -> the name of the kernel: looked up in the module's globals at each call,
# which ``jit.run_interpreted`` rebinds to the Python functions.
ADVANCE_BODIES = {(parallel, f): f'advance_bodies{"_parallel" if parallel else ""}_{name}'
                  for parallel in (False, True)
                  for f, name in ((FAMILY_TWO, 'two'), (FAMILY_K, 'k'), (FAMILY_SPLIT, 'split'))}


@kernel
def advance_blocks(src, dst, params, coefficients, bodies, n, status, taken, bad, work):
    """n >= 1 unchecked steps of a two-step method's ``bodies``, a block after the other."""
    count = bodies.shape[0]
    for start in range(0, count, BLOCK):
        _advance_block(src, dst, params, coefficients, bodies, start, min(start + BLOCK, count),
                       n, status, taken, bad, work)


@parallel_kernel
def advance_blocks_parallel(src, dst, params, coefficients, bodies, n, status, taken, bad,
                            work):
    """``advance_blocks`` with the blocks shared among the cores."""
    count = bodies.shape[0]
    for b in prange((count + BLOCK - 1) // BLOCK):
        start = b * BLOCK
        _advance_block(src, dst, params, coefficients, bodies, start, min(start + BLOCK, count),
                       n, status, taken, bad, work)


@kernel
def copy_rows(dst, src, rows):
    """dst[i] = src[i] for each row i of ``rows`` (a run's commit of some rows of a store)."""
    for k in range(rows.shape[0]):
        i = rows[k]
        for c in range(dst.shape[1]):
            dst[i, c] = src[i, c]


def new_arrays(count: int, steps: int = 2):
    """(state, params, work) for ``count`` bodies of a method of ``steps`` accelerations,
    zeroed; R to be written by the caller."""
    return (np.zeros((count, state_width(steps))), np.zeros((count, PARAM_WIDTH)),
            np.zeros((count, WORK_WIDTH), dtype=np.int64))
