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
from rb_sim_ros.core import rotation_kernels as rk, so3, step_kernel as K
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


# -- the swept test of speculative contacts (docs/collisions.md, "Continuous collision") ------
# A pair's state in the test: to sweep, solved as found (its path reaches the other shape
# within the step, or it is not swept), or missed (its path passes the other shape: not
# solved, so it does not stop or turn a body that would not have touched).
PENDING, SOLVED, MISSED = 0, 1, 2
# Conservative advancement stops as a hit within this fraction of the pair's gap at the
# step's start, or within SWEEP_FLOOR (m): a path that comes within 10 um of a shape grazes it
# (and the pairs of a settling heap, micrometres apart and closing slowly, would otherwise
# creep towards each other for all SWEEP_STEPS); and after SWEEP_STEPS advances (then it is
# solved as found: a pair the test cannot settle is treated as before the test existed).
SWEEP_TOLERANCE = 1e-3
SWEEP_FLOOR = 1e-5
SWEEP_STEPS = 32


@inline_kernel
def _spin_speed(w, reach, b):
    """|omega| rho of moving body b (m/s): how fast its turn moves a point of its colliders."""
    wx, wy, wz = float(w[b, 0]), float(w[b, 1]), float(w[b, 2])
    return math.sqrt(wx * wx + wy * wy + wz * wz) * float(reach[b])


@inline_kernel
def body_speed(v, w, reach, b, nb):
    """|v| + |omega| rho of body slot b (m/s): how fast a point of its colliders can move;
    0 for the static slot nb."""
    if b >= nb:
        return 0.0
    vx, vy, vz = float(v[b, 0]), float(v[b, 1]), float(v[b, 2])
    return math.sqrt(vx * vx + vy * vy + vz * vz) + _spin_speed(w, reach, b)


@inline_kernel
def _closes(q, point, normal, depth, x, v, w, a, b, nb, dt):
    """Whether contact q (a gap) would close within the step at the bodies' velocities: its
    points' approach along its normal, -v_rel . n dt, more than its gap -depth. (A speculative
    contact that would not close holds nothing unless the solve turns a body towards it.)"""
    px, py, pz = float(point[q, 0]), float(point[q, 1]), float(point[q, 2])
    rx, ry, rz = 0.0, 0.0, 0.0
    if b < nb:
        bx, by, bz = px - float(x[b, 0]), py - float(x[b, 1]), pz - float(x[b, 2])
        rx = float(v[b, 0]) + float(w[b, 1]) * bz - float(w[b, 2]) * by
        ry = float(v[b, 1]) + float(w[b, 2]) * bx - float(w[b, 0]) * bz
        rz = float(v[b, 2]) + float(w[b, 0]) * by - float(w[b, 1]) * bx
    if a < nb:
        ax, ay, az = px - float(x[a, 0]), py - float(x[a, 1]), pz - float(x[a, 2])
        rx -= float(v[a, 0]) + float(w[a, 1]) * az - float(w[a, 2]) * ay
        ry -= float(v[a, 1]) + float(w[a, 2]) * ax - float(w[a, 0]) * az
        rz -= float(v[a, 2]) + float(w[a, 0]) * ay - float(w[a, 1]) * ax
    vn = rx * float(normal[q, 0]) + ry * float(normal[q, 1]) + rz * float(normal[q, 2])
    return -vn * dt > -float(depth[q])


@inline_kernel
def sweep_candidates(point, normal, depth, source, cbody, pair_a, pair_b, nc, nb, x, v, w,
                     fast, dt, state, gap0):
    """The pairs to sweep: state[k] (k < P, the pairs) PENDING for a pair whose contacts
    (point, normal, depth (M,), source (M,): the pair of each) are all gaps, one of which
    would close within the step (``_closes``), and one of whose bodies is ``fast``
    (``fast_bodies``), a pair of colliders (not one with a plane, index >= nc); else SOLVED.
    gap0[k]: its smallest gap (m). Returns how many are PENDING."""
    for k in range(state.shape[0]):
        state[k] = SOLVED
        gap0[k] = math.inf
    for q in range(depth.shape[0]):
        k = int(source[q])
        g = -float(depth[q])
        if g < gap0[k]:
            gap0[k] = g
    pending = 0
    for q in range(depth.shape[0]):
        k = int(source[q])
        i, j = int(pair_a[k]), int(pair_b[k])
        # A pair touching is solved as found, and so is one with a plane: a plane has no edge
        # that a path closing on it along its normal could pass.
        if state[k] == PENDING or not gap0[k] > 0.0 or j >= nc:
            continue
        a, b = int(cbody[i]), int(cbody[j])
        if (fast[a] or fast[b]) and _closes(q, point, normal, depth, x, v, w, a, b, nb, dt):
            state[k] = PENDING
            pending += 1
    return pending


@inline_kernel
def _place_at(c, b, nb, tau, x, v, w, centres, rotations, kinds, geoms, r, kinds2, geoms2,
              centres2, rotations2):
    """Collider (or plane) c of body slot b where its body's straight-line motion puts it
    ``tau`` (s) on: centre x + v tau + Q (c - x), rotation Q R, Q = exp(omega tau); written to
    row r of the scratch arrays."""
    kinds2[r] = kinds[c]
    for q in range(geoms.shape[1]):
        geoms2[r, q] = geoms[c, q]
    if b >= nb:
        for q in range(3):
            centres2[r, q] = centres[c, q]
        for q in range(9):
            rotations2[r, q] = rotations[c, q]
        return
    wx, wy, wz = float(w[b, 0]) * tau, float(w[b, 1]) * tau, float(w[b, 2]) * tau
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = rk.exp_so3(wx, wy, wz, so3.TINY_ANGLE_SQ)
    dx = float(centres[c, 0]) - float(x[b, 0])
    dy = float(centres[c, 1]) - float(x[b, 1])
    dz = float(centres[c, 2]) - float(x[b, 2])
    centres2[r, 0] = float(x[b, 0]) + float(v[b, 0]) * tau + (q00 * dx + q01 * dy + q02 * dz)
    centres2[r, 1] = float(x[b, 1]) + float(v[b, 1]) * tau + (q10 * dx + q11 * dy + q12 * dz)
    centres2[r, 2] = float(x[b, 2]) + float(v[b, 2]) * tau + (q20 * dx + q21 * dy + q22 * dz)
    for col in range(3):
        r0, r1, r2 = (float(rotations[c, col]), float(rotations[c, 3 + col]),
                      float(rotations[c, 6 + col]))
        rotations2[r, col] = q00 * r0 + q01 * r1 + q02 * r2
        rotations2[r, 3 + col] = q10 * r0 + q11 * r1 + q12 * r2
        rotations2[r, 6 + col] = q20 * r0 + q21 * r1 + q22 * r2


@inline_kernel
def _closing_bound(a, b, nb, v, w, reach, g, dt):
    """How fast the two bodies' colliders can close on each other (m/s): |v_a - v_b| +
    |omega_a| rho_a + |omega_b| rho_b, plus |g| dt for what gravity adds within the step."""
    rx, ry, rz = 0.0, 0.0, 0.0
    spin = 0.0
    if a < nb:
        rx, ry, rz = rx + float(v[a, 0]), ry + float(v[a, 1]), rz + float(v[a, 2])
        spin += _spin_speed(w, reach, a)
    if b < nb:
        rx, ry, rz = rx - float(v[b, 0]), ry - float(v[b, 1]), rz - float(v[b, 2])
        spin += _spin_speed(w, reach, b)
    return math.sqrt(rx * rx + ry * ry + rz * rz) + spin + g * dt


@inline_kernel
def sweep_place(state, tau, gap0, pair_a, pair_b, cbody, nc, nb, x, v, w, reach, g, dt,
                centres, rotations, kinds, geoms, which, listed, kinds2, geoms2, centres2,
                rotations2, margins2):
    """Of the ``listed`` pairs which[:listed], those still PENDING, in order, kept in which
    (which[u] = k, u = 0, 1, ...; the others dropped), and for each its two colliders at its time
    tau[k] into rows 2u, 2u + 1 of the scratch arrays, and margins2[u]: the most its bodies
    can close in the rest of the step, plus gravity's offset and the tolerance. Returns the
    number placed."""
    u = 0
    for at in range(listed):
        k = int(which[at])
        if state[k] != PENDING:
            continue
        i, j = int(pair_a[k]), int(pair_b[k])
        a = int(cbody[i])
        b = int(cbody[j]) if j < nc else nb
        _place_at(i, a, nb, float(tau[k]), x, v, w, centres, rotations, kinds, geoms, 2 * u,
                  kinds2, geoms2, centres2, rotations2)
        _place_at(j, b, nb, float(tau[k]), x, v, w, centres, rotations, kinds, geoms,
                  2 * u + 1, kinds2, geoms2, centres2, rotations2)
        tolerance = max(SWEEP_TOLERANCE * float(gap0[k]), SWEEP_FLOOR)
        margins2[u] = _closing_bound(a, b, nb, v, w, reach, g, dt) * (dt - float(tau[k])) + (
            0.5 * g * dt * dt + 2.0 * tolerance)
        which[u] = k
        u += 1
    return u


@inline_kernel
def _reach_along(c, nx, ny, nz, kinds, geoms, pool, rotations):
    """How far collider c (row c of the arrays) reaches from its centre along the world
    direction n (its kind's support along R^T n)."""
    l0 = float(rotations[c, 0]) * nx + float(rotations[c, 3]) * ny + float(rotations[c, 6]) * nz
    l1 = float(rotations[c, 1]) * nx + float(rotations[c, 4]) * ny + float(rotations[c, 7]) * nz
    l2 = float(rotations[c, 2]) * nx + float(rotations[c, 5]) * ny + float(rotations[c, 8]) * nz
    return shapes.support_of(int(kinds[c]), geoms, pool, c, l0, l1, l2)


@inline_kernel
def separation(i, j, nx, ny, nz, kinds, geoms, pool, centres, rotations):
    """The gap between colliders i and j along n (from i to j, m): the least of (b - a) . n
    over their points, a lower bound of their distance whatever the narrow phase's manifold
    reports (a clipped corner reports more)."""
    ci = float(centres[i, 0]) * nx + float(centres[i, 1]) * ny + float(centres[i, 2]) * nz
    cj = float(centres[j, 0]) * nx + float(centres[j, 1]) * ny + float(centres[j, 2]) * nz
    return (cj - _reach_along(j, -nx, -ny, -nz, kinds, geoms, pool, rotations)) - (
        ci + _reach_along(i, nx, ny, nz, kinds, geoms, pool, rotations))


@inline_kernel
def _advance(k, d, nx, ny, nz, state, tau, gap0, pair_a, pair_b, cbody, nc, nb, v, w, reach, g,
             dt, last):
    """One advance of pair k (conservative advancement, Mirtich 1996) from its separation d
    (m) along n (from its first collider to its second) on the straight-line paths at its
    time tau[k]: less what gravity may have added by then, g tau^2 / 2, it is a hit (SOLVED)
    if within the tolerance; else it advances by that / (its bound of the approach along n),
    and is MISSED if that passes the step's end or if it does not approach. ``last``:
    SOLVED if still pending (the test could not settle it). Returns 1 if it is still
    PENDING, else 0."""
    d = d - 0.5 * g * float(tau[k]) * float(tau[k])
    if d <= max(SWEEP_TOLERANCE * float(gap0[k]), SWEEP_FLOOR):
        state[k] = SOLVED
        return 0
    i, j = int(pair_a[k]), int(pair_b[k])
    a = int(cbody[i])
    b = int(cbody[j]) if j < nc else nb
    # The approach along n bounds how fast d can shrink: the separation along a fixed n is a
    # lower bound of the distance, and falls at most this fast.
    approach = g * dt
    if a < nb:
        approach += (float(v[a, 0]) * nx + float(v[a, 1]) * ny + float(v[a, 2]) * nz
                     + _spin_speed(w, reach, a))
    if b < nb:
        approach += (_spin_speed(w, reach, b)
                     - (float(v[b, 0]) * nx + float(v[b, 1]) * ny + float(v[b, 2]) * nz))
    if not approach > 0.0:
        state[k] = MISSED
        return 0
    t = float(tau[k]) + d / approach
    if t >= dt:
        state[k] = MISSED
        return 0
    tau[k] = t
    if last:
        state[k] = SOLVED
        return 0
    return 1


@inline_kernel
def sweep_start(normal, depth, source, state, tau, gap0, pair_a, pair_b, cbody, nc, nb, v, w,
                reach, g, dt, kinds, geoms, pool, centres, rotations):
    """The first advance of each PENDING pair (its time tau 0), along the normal of the
    deepest of the contacts the narrow phase found for it (normal, depth, source (M,)): no
    narrow phase of its own. Returns the number still PENDING."""
    pending = 0
    q = 0
    m = depth.shape[0]
    while q < m:
        k = int(source[q])
        best, at = float(depth[q]), q
        q += 1
        while q < m and int(source[q]) == k:   # (a pair's contacts are consecutive)
            if float(depth[q]) > best:
                best, at = float(depth[q]), q
            q += 1
        if state[k] != PENDING:
            continue
        nx, ny, nz = float(normal[at, 0]), float(normal[at, 1]), float(normal[at, 2])
        d = min(-best, separation(int(pair_a[k]), int(pair_b[k]), nx, ny, nz, kinds, geoms,
                                  pool, centres, rotations))
        pending += _advance(k, d, nx, ny, nz, state, tau, gap0, pair_a, pair_b, cbody, nc, nb,
                            v, w, reach, g, dt, False)
    return pending


@inline_kernel
def sweep_advance(count, which, found, source2, normal2, depth2, state, tau, gap0, pair_a,
                  pair_b, cbody, nc, nb, v, w, reach, g, dt, last, kinds2, geoms2, pool,
                  centres2, rotations2):
    """One advance (``_advance``) of each placed pair (which[u] = k, u < count; its colliders
    rows 2u, 2u + 1 of the scratch arrays), along the normal of the deepest of the ``found``
    rows of source2 u that its narrow phase found; MISSED if it found none within the pair's
    margin (all it can close in the rest of the step). Returns the number still PENDING."""
    row = 0
    pending = 0
    for u in range(count):
        k = int(which[u])
        best, nx, ny, nz = -math.inf, 0.0, 0.0, 0.0
        while row < found and int(source2[row]) == u:
            if float(depth2[row]) > best:
                best = float(depth2[row])
                nx, ny, nz = float(normal2[row, 0]), float(normal2[row, 1]), float(normal2[row, 2])
            row += 1
        if best == -math.inf:
            state[k] = MISSED
            continue
        d = min(-best, separation(2 * u, 2 * u + 1, nx, ny, nz, kinds2, geoms2, pool, centres2,
                                  rotations2))
        pending += _advance(k, d, nx, ny, nz, state, tau, gap0, pair_a, pair_b, cbody, nc, nb,
                            v, w, reach, g, dt, last)
    return pending


@inline_kernel
def fast_bodies(v, w, reach, sweep_speed, asleep, nb, fast):
    """fast[b]: whether awake moving body b moves faster than its sweep_speed (then its
    speculative contacts are swept; a scene without one pays nothing more); False for the
    static slot nb. Returns how many are."""
    count = 0
    for b in range(nb):
        fast[b] = not asleep[b] and body_speed(v, w, reach, b, nb) > float(sweep_speed[b])
        if fast[b]:
            count += 1
    fast[nb] = False
    return count


@inline_kernel
def sweep_again(state, tau, pair_a, pair_b, cbody, nc, nb, v1, w1, v0, w0):
    """After a solve: each MISSED pair one of whose bodies it changed (v1, w1 against v0, w0)
    is PENDING again, from the step's start. Returns how many."""
    pending = 0
    for k in range(state.shape[0]):
        if state[k] != MISSED:
            continue
        i, j = int(pair_a[k]), int(pair_b[k])
        a = int(cbody[i])
        b = int(cbody[j]) if j < nc else nb
        changed = False
        for c in range(3):
            if a < nb and (v1[a, c] != v0[a, c] or w1[a, c] != w0[a, c]):
                changed = True
            if b < nb and (v1[b, c] != v0[b, c] or w1[b, c] != w0[b, c]):
                changed = True
        if changed:
            state[k] = PENDING
            tau[k] = 0.0
            pending += 1
    return pending


@inline_kernel
def live_first(state, source, order):
    """order (M,): the contacts whose pair (source) is not MISSED, in their order, then the
    others in theirs. Returns the number of the first (those solved)."""
    live = 0
    for q in range(source.shape[0]):
        if state[int(source[q])] != MISSED:
            order[live] = q
            live += 1
    at = live
    for q in range(source.shape[0]):
        if state[int(source[q])] == MISSED:
            order[at] = q
            at += 1
    return live
