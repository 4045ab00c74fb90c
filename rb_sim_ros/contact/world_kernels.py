# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Compiled stages of the collision world's step, over the world's arrays (world frame, SI).

Bodies are rows of the step kernel's state (``step_kernel``; R there is that of the principal
frame, r = R Q); colliders are rows of per-collider arrays (the body slot they follow, their
placement in the body frame, their shape's sizes). The stages, in the order of a step:

* ``read_bodies``: x, R (the user's body frame), v, omega of the moving bodies with colliders;
* ``speculative_margins``: how far each body can move in a step, (|v| + |omega| rho) dt
  + |g| dt^2 (docs/collisions.md);
* ``place_colliders``: each collider's world centre, rotation and AABB (its kind's support,
  ``shapes.support_of``) widened by its body's margin (then ``broad_phase`` pairs them);
* ``write_contacts``: the solver's velocities and position correction back into the rows.

Plain + - * / sqrt sin cos on float64, no BLAS: compiled and interpreted (NUMBA_DISABLE_JIT=1)
give the same bits, on every machine.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.core import so3, step_kernel as K
from rb_sim_ros.core.jit import inline_kernel


@inline_kernel
def read_bodies(state, rows, q, has_q, x, rot, v, w):
    """x (m), R (9, row-major, body to world: the principal-frame r times Q^T where the body
    frame is not principal), v (m/s), omega (rad/s) of the bodies ``rows`` of ``state``, into
    row k of x, rot, v, w for rows[k]."""
    for k in range(rows.shape[0]):
        i = rows[k]
        for c in range(3):
            x[k, c] = state[i, K.X + c]
            v[k, c] = state[i, K.V + c]
            w[k, c] = state[i, K.W + c]
        if has_q[k]:
            for a in range(3):
                r0, r1, r2 = (float(state[i, K.R + 3 * a]), float(state[i, K.R + 3 * a + 1]),
                              float(state[i, K.R + 3 * a + 2]))
                for b in range(3):
                    # (r Q^T)[a, b] = r[a, 0] Q[b, 0] + r[a, 1] Q[b, 1] + r[a, 2] Q[b, 2]
                    rot[k, 3 * a + b] = (r0 * q[k, 3 * b] + r1 * q[k, 3 * b + 1]
                                         + r2 * q[k, 3 * b + 2])
        else:
            for c in range(9):
                rot[k, c] = state[i, K.R + c]


@inline_kernel
def speculative_margins(v, w, reach, count, dt, g, speculative, margin):
    """margin[k] = (|v_k| + |omega_k| reach_k) dt + g dt^2 for k < count (m), 0 for the static
    slot(s) after them and for every body when not ``speculative``."""
    for k in range(margin.shape[0]):
        margin[k] = 0.0
    if not speculative:
        return
    for k in range(count):
        vx, vy, vz = float(v[k, 0]), float(v[k, 1]), float(v[k, 2])
        wx, wy, wz = float(w[k, 0]), float(w[k, 1]), float(w[k, 2])
        speed = math.sqrt(vx * vx + vy * vy + vz * vz) + math.sqrt(
            wx * wx + wy * wy + wz * wz) * float(reach[k])
        margin[k] = speed * dt + g * dt * dt


@inline_kernel
def place_colliders(colliders, body, x, rot, local_pos, local_rot, kinds, geoms, pool, margin,
                    centres, rotations, lower, upper):
    """World centre (m), rotation (9) and AABB [lower, upper] of each collider of
    ``colliders`` on its body ``body[c]``: centre = x + R p_local, rotation = R R_local, each
    half width the support of its kind along that axis, widened by the body's margin."""
    for k in range(colliders.shape[0]):
        c = colliders[k]
        b = body[c]
        for a in range(3):
            ra0, ra1 = float(rot[b, 3 * a]), float(rot[b, 3 * a + 1])
            ra2 = float(rot[b, 3 * a + 2])
            centres[c, a] = float(x[b, a]) + (ra0 * float(local_pos[c, 0])
                                              + ra1 * float(local_pos[c, 1])
                                              + ra2 * float(local_pos[c, 2]))
            for j in range(3):
                rotations[c, 3 * a + j] = (ra0 * float(local_rot[c, j])
                                           + ra1 * float(local_rot[c, 3 + j])
                                           + ra2 * float(local_rot[c, 6 + j]))
        extents(c, rotations, kinds, geoms, pool, float(margin[b]), centres, lower, upper)


@inline_kernel
def extents(c, rotations, kinds, geoms, pool, widen, centres, lower, upper):
    """The AABB of collider c at its world pose, widened by ``widen`` (m): along world axis a
    its kind's supports (``shapes.support_of``) in the directions whose components in its
    axes are + and - row a of its rotation."""
    kind = int(kinds[c])
    for a in range(3):
        r0, r1, r2 = (float(rotations[c, 3 * a]), float(rotations[c, 3 * a + 1]),
                      float(rotations[c, 3 * a + 2]))
        up = shapes.support_of(kind, geoms, pool, c, r0, r1, r2) + widen
        down = shapes.support_of(kind, geoms, pool, c, -r0, -r1, -r2) + widen
        lower[c, a] = float(centres[c, a]) - down
        upper[c, a] = float(centres[c, a]) + up


@inline_kernel
def write_contacts(state, params, rows, q, has_q, bodies, x, rot, velocity, angular_velocity,
                   displacement, rotation, min_turn, failed):
    """The solver's result into the step kernel's rows of ``bodies`` (indices into x, rot,
    ...: the moving bodies with colliders; rows[k] their rows): x + displacement; R turned by
    exp([rotation]) when the correction turns by more than ``min_turn`` rad, omega turned with
    it (omega in the body frame kept: turning R under a fixed world omega would change
    1/2 w . I w); v and omega of the velocity pass. The history restarts (no extrapolation
    across an impulse), the accelerations are evaluated at the new state. A body whose new
    state would not be finite is not written: failed[m] says so."""
    new = np.empty(18)
    for m in range(bodies.shape[0]):
        k = bodies[m]
        i = rows[k]
        failed[m] = False
        px, py, pz = float(rotation[k, 0]), float(rotation[k, 1]), float(rotation[k, 2])
        r = (float(rot[k, 0]), float(rot[k, 1]), float(rot[k, 2]), float(rot[k, 3]),
             float(rot[k, 4]), float(rot[k, 5]), float(rot[k, 6]), float(rot[k, 7]),
             float(rot[k, 8]))
        wx, wy, wz = (float(angular_velocity[k, 0]), float(angular_velocity[k, 1]),
                      float(angular_velocity[k, 2]))
        t2 = px * px + py * py + pz * pz
        if not t2 <= 1.7976931348623157e308:  # non-finite: not a rotation
            failed[m] = True
            continue
        if t2 > min_turn * min_turn:
            e = K.exp_so3(px, py, pz, so3.TINY_ANGLE_SQ)
            r = K.mul33(*e, *r)
            wx, wy, wz = (e[0] * wx + e[1] * wy + e[2] * wz, e[3] * wx + e[4] * wy + e[5] * wz,
                          e[6] * wx + e[7] * wy + e[8] * wz)
        if has_q[k]:  # to the principal frame: r Q
            r = K.mul33(*r, float(q[k, 0]), float(q[k, 1]), float(q[k, 2]), float(q[k, 3]),
                        float(q[k, 4]), float(q[k, 5]), float(q[k, 6]), float(q[k, 7]),
                        float(q[k, 8]))
        for c in range(3):
            new[c] = float(x[k, c]) + float(displacement[k, c])
            new[3 + c] = velocity[k, c]
        for c in range(9):
            new[6 + c] = r[c]
        new[15], new[16], new[17] = wx, wy, wz
        total = 0.0
        for c in range(18):
            total += new[c] * 0.0  # nan if any is inf or nan
        if total != 0.0:
            failed[m] = True
            continue
        for c in range(18):
            state[i, K.X + c] = new[c]
        state[i, K.HISTORY] = K.HISTORY_NONE
        K.evaluate(state, params, i)
