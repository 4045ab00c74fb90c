# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The contact solver's kernel: ``solve_arrays``, impulses and position correction on arrays.

``contact_solver`` holds the spec (its module docstring and docs/collisions.md, "Proof 2") and
the Python API (``solve`` on dataclasses); this module is the same solve on plain arrays, one
compiled call that other compiled code (a world step) can make. Every vector is in the world
frame, in SI units. With M contacts and N bodies (static ones, if any, with inverse mass 0 and
inverse inertia 0):

    body_a, body_b      int64 (M,)   the bodies of each contact (normal from a to b)
    point, normal       (M, 3)       contact point (m), unit normal
    depth               (M,)         m, > 0 penetrating, < 0 a gap (speculative contact)
    position            (N, 3)       centres of mass (m)
    velocity            (N, 3)       m/s
    angular_velocity    (N, 3)       rad/s
    inverse_mass        (N,)         1/kg
    inverse_inertia     (N, 9)       R I_body^-1 R^T row-major, 1/(kg m^2)
    settings            (SETTINGS_WIDTH,) float64, indices below (``contact_solver.
                                     settings_array``); iteration counts as floats
    warm_normal         (M,)         N s, accumulated normal impulse of the step before
    warm_tangent        (M, 3)       N s, accumulated tangent impulse (world vector)
    use_warm            bool         apply the warm start (else both are ignored)
    restitution         (M,)         e of each contact, in [0, 1]
    friction            (M,)         mu of each contact, >= 0

and the outputs, preallocated by the caller and overwritten: velocity, angular_velocity
(N, 3) after the impulses; displacement (N, 3, m) and rotation (N, 3, rad, a rotation vector)
of the position correction; normal_impulse (M,), tangent_impulse (M, 3, world) in N s;
position_impulse (M,) (kg m); touched (N,) bool. It returns (colours, velocity iterations,
position iterations). The kernel reads the per-contact ``restitution`` and ``friction``, not
the settings' RESTITUTION and FRICTION (``contact_solver.solve`` fills the arrays with those
when no materials are given).

How. The contacts are coloured in contact order (``_colour``: no moving body in two
contacts of one colour; greedy while a body has at most COLOUR_SCAN, O(1) a contact) and
stored colour by colour as rows (``_rows``: for the normal and the two tangents, the
Jacobian and the change of velocity per unit impulse). Gauss-Seidel then visits them in that
order, one after the other: the visit order is the colouring's, so the
result depends only on the inputs. The warm start, the targets, the energy guard, the rolling
and torsional couples and the position pass are those of the spec; the names in the
comments are its equations.

Determinism: only + - * / abs sqrt copysign on float64, each sum in the order written, no
BLAS, no numpy reduction, no fused multiply-add (``core.jit``): the compiled and the
interpreted path (``NUMBA_DISABLE_JIT=1``) give the same bits, on every machine
(``test/support/solver_fingerprint.py``). Divisions by what can be 0 for valid input (the
effective mass of a contact between static bodies, a singular inertia, a zero normal) are
guarded, so that neither path raises; the others are positive for valid input (dt > 0, mu >= 0).
Arguments passed from one kernel to another are never literal constants: numba would compile
the callee once more for each literal value.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core.jit import borrowed, keep_alive, kernel

# -- settings: indices into the settings array ---------------------------------------------------
RESTITUTION, FRICTION, DT = 0, 1, 2
VELOCITY_ITERATIONS, POSITION_ITERATIONS = 3, 4
SLOP, POSITION_FRACTION, BOUNCE_THRESHOLD, TOLERANCE = 5, 6, 7, 8
ROLLING_RESISTANCE, TORSIONAL_FRICTION = 9, 10
SETTINGS_WIDTH = 11

# The impact pass (``_impacts``): at most IMPACT_SWEEPS sweeps over the pairs, and
# IMPACT_ITERATIONS Gauss-Seidel iterations over a pair's contacts at each visit (it fails,
# and the step's contacts are solved at once, where either runs out).
IMPACT_SWEEPS = 64
IMPACT_ITERATIONS = 30
# A visit has settled when an iteration changes no contact's velocity by more than the
# solve's tolerance, or than IMPACT_SETTLE (m/s) where that is below it (a tolerance of 0
# would never be met: rounding).
IMPACT_SETTLE = 1e-9

# Relative gain of kinetic energy above which a velocity solve is taken to have created energy
# (rounding of the solve is ~1e-15 relative).
ENERGY_TOLERANCE = 1e-9

# -- the rows of a contact (one line of ``rows`` per contact, in colour order) -------------------
# For each of its 3 rows (NORMAL, T1, T2; ROW floats each, from the row's offset): the row's
# direction d (n, t1 or t2), GA = -(r_a x d) and GB = r_b x d, the angular parts of the
# Jacobian J = (-d, GA, d, GB), which maps (v_a, w_a, v_b, w_b) to the relative velocity of the
# contact points along d; HA = I_a^-1 GA and HB = I_b^-1 GB, the change of w_a and w_b per unit
# impulse (that of v_a and v_b is -d / m_a and d / m_b). Then, per contact: the inverse masses,
# 1 / K and K of the normal row, 1 / k_max and k_max of the tangent block, and mu.
NORMAL, T1, T2 = 0, 15, 30
ROW = 15
D, GA, GB, HA, HB = 0, 3, 6, 9, 12
MASS_A, MASS_B = 45, 46
INVERSE_K, K_NORMAL, INVERSE_KT, K_TANGENT, MU = 47, 48, 49, 50, 51
ROWS_WIDTH = 52

# The most earlier contacts of a body that ``_colour`` looks through for a free colour: a body
# resting in a pile has a dozen, a box on a box 8.
COLOUR_SCAN = 64


@kernel
def tangent_basis(n0, n1, n2):
    """Unit t1, t2 (6 floats) with (t1, t2, n) right-handed for the unit normal n: t1 =
    n x e / |n x e| for the world axis e least aligned with n (the first on a tie), t2 =
    n x t1. Depends on n only. |n x e|^2 = 1 - (n . e)^2 >= 2/3 for a unit n; a zero one
    gives t1 = 0 rather than a division by zero."""
    m0, m1, m2 = abs(n0), abs(n1), abs(n2)
    e0 = e1 = e2 = 0.0
    if m0 <= m1 and m0 <= m2:
        e0 = 1.0
    elif m1 <= m2:
        e1 = 1.0
    else:
        e2 = 1.0
    c0, c1, c2 = n1 * e2 - n2 * e1, n2 * e0 - n0 * e2, n0 * e1 - n1 * e0
    size = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if size > 0.0:
        c0, c1, c2 = c0 / size, c1 / size, c2 / size
    return (c0, c1, c2, n1 * c2 - n2 * c1, n2 * c0 - n0 * c2, n0 * c1 - n1 * c0)


# The colours a body's contacts hold, as bits: HELD_WORDS words of HELD_BITS (63: an int64's
# bits but its sign, so no shift makes a negative number). A contact whose bodies have at most
# COLOUR_SCAN earlier contacts each sees at most 2 COLOUR_SCAN colours held, so the lowest
# free one is at most 2 COLOUR_SCAN: inside the words, whatever higher colours are held.
HELD_BITS = 63
HELD_WORDS = (2 * COLOUR_SCAN) // HELD_BITS + 1
_ALL_HELD = (1 << HELD_BITS) - 1


@kernel
def _colour(body_a, body_b, moving, colour):
    """Colouring in contact order: no moving body in two contacts of one colour (static bodies
    may repeat within a colour; they never move). Writes ``colour`` (M,), returns the number
    of colours. A contact whose moving bodies have at most COLOUR_SCAN earlier contacts each
    gets the lowest colour none of those has (greedy: the colours each body's contacts hold
    are kept as bits, ``held``, and the lowest free one is the lowest bit clear in both
    bodies' words); past that, the colour after the highest its bodies hold. So a contact
    costs O(1), and M contacts O(M), however many one body has (the greedy colouring by a
    scan of each body's earlier contacts cost d^2 / 2 for a body in d contacts: 122,500
    made an 18 s step)."""
    m, n = body_a.shape[0], moving.shape[0]
    earlier = np.zeros(n, dtype=np.int64)  # the contacts of each body coloured so far
    top = np.full(n, -1, dtype=np.int64)  # the highest colour of each body's contacts so far
    held = np.zeros((n, HELD_WORDS), dtype=np.int64)
    count = 0
    for k in range(m):
        a, b = int(body_a[k]), int(body_b[k])
        move_a, move_b = bool(moving[a]), bool(moving[b])
        few = not ((move_a and earlier[a] > COLOUR_SCAN) or (move_b and earlier[b] > COLOUR_SCAN))
        c = 0
        if few:
            for word in range(HELD_WORDS):
                bits = 0
                if move_a:
                    bits |= held[a, word]
                if move_b:
                    bits |= held[b, word]
                if bits != _ALL_HELD:
                    c = word * HELD_BITS
                    while bits & 1:
                        bits >>= 1
                        c += 1
                    break
        else:
            if move_a and top[a] + 1 > c:
                c = top[a] + 1
            if move_b and top[b] + 1 > c:
                c = top[b] + 1
        colour[k] = c
        word, bit = c // HELD_BITS, c % HELD_BITS
        for body in (a, b):
            if moving[body]:
                earlier[body] += 1
                if c > top[body]:
                    top[body] = c
                if word < HELD_WORDS:
                    held[body, word] |= 1 << bit
        if c + 1 > count:
            count = c + 1
    return count


@kernel
def _rows(order, body_a, body_b, point, normal, depth, position, inverse_mass,
          inverse_inertia, friction, rows, slot_a, slot_b):
    """Fill ``rows`` (M, ROWS_WIDTH) and the bodies ``slot_a``, ``slot_b`` (M,) of each slot s,
    the contact ``order[s]`` (see the layout above)."""
    k_pair = np.empty(4)
    for s in range(order.shape[0]):
        k = int(order[s])
        a, b = int(body_a[k]), int(body_b[k])
        slot_a[s], slot_b[s] = a, b
        nx, ny, nz = float(normal[k, 0]), float(normal[k, 1]), float(normal[k, 2])
        t1x, t1y, t1z, t2x, t2y, t2z = tangent_basis(nx, ny, nz)
        px, py, pz = float(point[k, 0]), float(point[k, 1]), float(point[k, 2])
        # Lever arms r_a = p - x_a, r_b = p - x_b.
        rax, ray, raz = (px - float(position[a, 0]), py - float(position[a, 1]),
                         pz - float(position[a, 2]))
        rbx, rby, rbz = (px - float(position[b, 0]), py - float(position[b, 1]),
                         pz - float(position[b, 2]))
        # The tangent rows hold a moving body against a static one at the moving body's own
        # surface, depth / 2 from p along the normal (p is the middle of the overlap): no-slip
        # there, so a ball rolls at v = omega R, not omega (R - depth / 2). Between two moving
        # bodies the rows stay at p (one point for both: their angular momentum is kept).
        half = 0.5 * float(depth[k])
        sax, say, saz = rax, ray, raz
        sbx, sby, sbz = rbx, rby, rbz
        if float(inverse_mass[b]) == 0.0:
            sax, say, saz = rax + half * nx, ray + half * ny, raz + half * nz
        elif float(inverse_mass[a]) == 0.0:
            sbx, sby, sbz = rbx - half * nx, rby - half * ny, rbz - half * nz
        for r in range(3):
            o = r * ROW
            if r == 0:
                dx, dy, dz = nx, ny, nz
            elif r == 1:
                dx, dy, dz = t1x, t1y, t1z
                rax, ray, raz, rbx, rby, rbz = sax, say, saz, sbx, sby, sbz
            else:
                dx, dy, dz = t2x, t2y, t2z
            rows[s, o + D], rows[s, o + D + 1], rows[s, o + D + 2] = dx, dy, dz
            # (28): d . (w_b x r_b - w_a x r_a) = w_b . (r_b x d) - w_a . (r_a x d).
            gax = -(ray * dz - raz * dy)
            gay = -(raz * dx - rax * dz)
            gaz = -(rax * dy - ray * dx)
            gbx, gby, gbz = rby * dz - rbz * dy, rbz * dx - rbx * dz, rbx * dy - rby * dx
            rows[s, o + GA], rows[s, o + GA + 1], rows[s, o + GA + 2] = gax, gay, gaz
            rows[s, o + GB], rows[s, o + GB + 1], rows[s, o + GB + 2] = gbx, gby, gbz
            # (29): an impulse j along the row turns a by I_a^-1 (r_a x (-j d)) = j I_a^-1 GA.
            for c in range(3):
                rows[s, o + HA + c] = (float(inverse_inertia[a, 3 * c]) * gax
                                       + float(inverse_inertia[a, 3 * c + 1]) * gay
                                       + float(inverse_inertia[a, 3 * c + 2]) * gaz)
                rows[s, o + HB + c] = (float(inverse_inertia[b, 3 * c]) * gbx
                                       + float(inverse_inertia[b, 3 * c + 1]) * gby
                                       + float(inverse_inertia[b, 3 * c + 2]) * gbz)
        ma, mb = float(inverse_mass[a]), float(inverse_mass[b])
        rows[s, MASS_A], rows[s, MASS_B] = ma, mb
        # Effective masses J_p M^-1 J_q^T (the relative velocity along row p per unit impulse
        # along row q) of the pairs (n, n), (t1, t1), (t1, t2), (t2, t2), each summed over its
        # 12 components: -d_p . (-m_a d_q) + GA_p . HA_q + d_p . (m_b d_q) + GB_p . HB_q.
        for pair in range(4):
            p = ROW * ((pair + 1) // 2)          # rows 0, 1, 1, 2
            q = p + ROW if pair == 2 else p      # rows 0, 1, 2, 2
            total = 0.0
            for c in range(3):
                total += -float(rows[s, p + D + c]) * (-ma * float(rows[s, q + D + c]))
            for c in range(3):
                total += float(rows[s, p + GA + c]) * float(rows[s, q + HA + c])
            for c in range(3):
                total += float(rows[s, p + D + c]) * (mb * float(rows[s, q + D + c]))
            for c in range(3):
                total += float(rows[s, p + GB + c]) * float(rows[s, q + HB + c])
            k_pair[pair] = total
        # (30): K = J_n M^-1 J_n^T > 0 (Lemma 6) unless both bodies are static.
        kn = float(k_pair[0])
        rows[s, K_NORMAL] = kn
        rows[s, INVERSE_K] = 1.0 / kn if kn > 0.0 else 0.0
        # (34): friction steps along -v_t with 1 / k_max, k_max the largest eigenvalue of the
        # 2x2 tangent block K_t: (k11 + k22) / 2 + sqrt(((k11 - k22) / 2)^2 + k12^2).
        k11, k12, k22 = float(k_pair[1]), float(k_pair[2]), float(k_pair[3])
        half_trace, half_diff = 0.5 * (k11 + k22), 0.5 * (k11 - k22)
        kt = half_trace + math.sqrt(half_diff * half_diff + k12 * k12)
        rows[s, K_TANGENT] = kt
        rows[s, INVERSE_KT] = 1.0 / kt if kt > 0.0 else 0.0
        rows[s, MU] = float(friction[k])


@kernel
def _targets(rows, order, slot_a, slot_b, u0, depth, restitution, dt, bounce_threshold,
             target, plastic):
    """The normal rows' targets (M, by slot) from the velocities before, ``u0`` (N, 6):
    ``plastic`` without restitution, ``target`` with it (the module doc of contact_solver)."""
    for s in range(rows.shape[0]):
        k = int(order[s])
        a, b = int(slot_a[s]), int(slot_b[s])
        vn0 = _normal_velocity(rows, s, u0, a, b)
        gap = float(depth[k])
        # Speculative: close the gap -depth within the step but not more (no tunnelling); a
        # contact that was separating (vn0 > 0) may be pressed back at most at -vn0, so its
        # impulse does no positive work (docs/collisions.md, "Energy").
        closing = gap / dt if gap < 0.0 else 0.0
        floor = closing if closing < -vn0 else -vn0
        plastic[s] = floor
        e = float(restitution[k])
        # An impact (approach faster than the bounce threshold and than the gap closes)
        # bounces, -e vn0; without restitution the target stays the plastic one, so a fast
        # body closes a speculative gap and stops on the surface, not where the gap began.
        bounce = vn0 < -bounce_threshold and vn0 < floor and e > 0.0
        target[s] = -e * vn0 if bounce else floor


@kernel
def _normal_velocity(rows, s, u, a, b):
    """(28): v_rel . n = J_n . (v_a, w_a, v_b, w_b) of slot s's contact at the velocities u
    (N, 6) of its bodies a, b, summed as in _gauss_seidel."""
    dx, dy, dz = float(rows[s, D]), float(rows[s, D + 1]), float(rows[s, D + 2])
    return (-dx * float(u[a, 0]) - dy * float(u[a, 1]) - dz * float(u[a, 2])
            + float(rows[s, GA]) * float(u[a, 3]) + float(rows[s, GA + 1]) * float(u[a, 4])
            + float(rows[s, GA + 2]) * float(u[a, 5])
            + dx * float(u[b, 0]) + dy * float(u[b, 1]) + dz * float(u[b, 2])
            + float(rows[s, GB]) * float(u[b, 3]) + float(rows[s, GB + 1]) * float(u[b, 4])
            + float(rows[s, GB + 2]) * float(u[b, 5]))


@kernel
def _push(rows, s, u, a, b, dn):
    """u += dn M^-1 J_n^T: the normal impulse dn (N s) at slot s's contact, on a and b."""
    ma, mb = float(rows[s, MASS_A]), float(rows[s, MASS_B])
    dx, dy, dz = float(rows[s, D]), float(rows[s, D + 1]), float(rows[s, D + 2])
    u[a, 0] = float(u[a, 0]) + dn * (-ma * dx)
    u[a, 1] = float(u[a, 1]) + dn * (-ma * dy)
    u[a, 2] = float(u[a, 2]) + dn * (-ma * dz)
    u[a, 3] = float(u[a, 3]) + dn * float(rows[s, HA])
    u[a, 4] = float(u[a, 4]) + dn * float(rows[s, HA + 1])
    u[a, 5] = float(u[a, 5]) + dn * float(rows[s, HA + 2])
    u[b, 0] = float(u[b, 0]) + dn * (mb * dx)
    u[b, 1] = float(u[b, 1]) + dn * (mb * dy)
    u[b, 2] = float(u[b, 2]) + dn * (mb * dz)
    u[b, 3] = float(u[b, 3]) + dn * float(rows[s, HB])
    u[b, 4] = float(u[b, 4]) + dn * float(rows[s, HB + 1])
    u[b, 5] = float(u[b, 5]) + dn * float(rows[s, HB + 2])


@kernel
def _closing(gap, dt):
    """The normal velocity that closes a gap (depth < 0) within the step, gap / dt; 0 for
    an overlap."""
    if gap < 0.0:
        return gap / dt
    return 0.0


@kernel
def _impacts(rows, body_a, body_b, slot_of, slot_a, slot_b, depth, restitution, dt,
             bounce_threshold, tolerance, u, lam, target, plastic):
    """Simultaneous impacts as the sequence of pairwise ones (docs/collisions.md, "Impacts"):
    sweeps over the pairs of bodies (the contacts of one pair, whichever body is named first,
    visited together, pairs in the order of their first contact); a pair one of whose
    contacts approaches as an impact (faster than the bounce threshold and than its gap
    closes, e > 0) collides alone: Gauss-Seidel over its own contacts' normal rows (at most
    IMPACT_ITERATIONS), each towards -e v_n at the visit's start (an impact) or its gap's
    closing (the others), with impulses that only push, summed from 0 at each visit. So an
    impact passes down a chain of touching bodies one collision after another (a cradle's
    last ball leaves with the first's velocity), while a body landing on several points of one
    other (a box on its face) bounces from all of them at once. Until a sweep finds no
    impact. The impulses are added to ``lam`` (normal) and ``u``; the normal ``target`` of
    the Gauss-Seidel after it (by slot) becomes, for a contact pushed here, its normal
    velocity now (no less than its gap's closing), so that the solve keeps the bounce, and
    for the others their ``plastic`` one. Where the pass fails, it leaves ``u``, ``lam`` and
    ``target`` as they were (the simultaneous solve): a visit whose Gauss-Seidel does not
    settle (its targets cannot all hold: a body wedged between two
    others), or IMPACT_SWEEPS sweeps that still find an impact (``tolerance``: the solve's,
    at least IMPACT_SETTLE). Returns the sweeps run, or
    -1 where it failed."""
    m = body_a.shape[0]
    settle = tolerance if tolerance > IMPACT_SETTLE else IMPACT_SETTLE
    # the pairs: contacts sorted (stably) by their unordered pair of bodies
    top = 0
    for k in range(m):
        if int(body_a[k]) > top:
            top = int(body_a[k])
        if int(body_b[k]) > top:
            top = int(body_b[k])
    key = np.empty(m, dtype=np.int64)
    for k in range(m):
        a, b = int(body_a[k]), int(body_b[k])
        key[k] = (a * (top + 1) + b) if a < b else (b * (top + 1) + a)
    by_pair = np.argsort(key, kind='mergesort')
    # what a failed pass restores
    u_before = u.copy()
    lam_before = np.empty(m)
    target_before = np.empty(m)
    for s in range(m):
        lam_before[s] = lam[s, 0]
        target_before[s] = target[s]
    pushed = np.zeros(2 * m)  # by contact: the sum over visits, then this visit's
    sweeps = 0
    failed = False
    while True:
        if sweeps == IMPACT_SWEEPS:
            failed = True
            break
        sweeps += 1
        struck = False
        first = 0
        while first < m and not failed:
            end = first + 1
            while end < m and key[by_pair[end]] == key[by_pair[first]]:
                end += 1
            impact = False
            for q in range(first, end):
                j = int(by_pair[q])
                s = int(slot_of[j])
                vn = _normal_velocity(rows, s, u, int(slot_a[s]), int(slot_b[s]))
                closing = _closing(float(depth[j]), dt)
                e = float(restitution[j])
                if e > 0.0 and vn < -bounce_threshold and vn < closing:
                    impact = True
                    target[s] = -e * vn
                else:
                    target[s] = closing
            if impact:
                struck = True
                for q in range(first, end):
                    pushed[m + int(by_pair[q])] = 0.0
                settled = False
                for _ in range(IMPACT_ITERATIONS):
                    change = 0.0
                    for q in range(first, end):
                        j = int(by_pair[q])
                        s = int(slot_of[j])
                        a, b = int(slot_a[s]), int(slot_b[s])
                        vn = _normal_velocity(rows, s, u, a, b)
                        have = float(pushed[m + j])
                        new = have + (float(target[s]) - vn) * float(rows[s, INVERSE_K])
                        if new < 0.0:
                            new = 0.0
                        pushed[m + j] = new
                        _push(rows, s, u, a, b, new - have)
                        c = abs(new - have) * float(rows[s, K_NORMAL])
                        if c > change:
                            change = c
                    if change <= settle:
                        settled = True
                        break
                if not settled:
                    failed = True
                for q in range(first, end):
                    j = int(by_pair[q])
                    pushed[j] = float(pushed[j]) + float(pushed[m + j])
            first = end
        if failed or not struck:
            break
    if failed:
        for i in range(u.shape[0]):
            for c in range(6):
                u[i, c] = u_before[i, c]
        for s in range(m):
            lam[s, 0] = lam_before[s]
            target[s] = target_before[s]
        return -1
    for k in range(m):
        s = int(slot_of[k])
        if float(pushed[k]) > 0.0:
            lam[s, 0] = float(lam[s, 0]) + float(pushed[k])
            vn = _normal_velocity(rows, s, u, int(slot_a[s]), int(slot_b[s]))
            closing = _closing(float(depth[k]), dt)
            target[s] = vn if vn > closing else closing
        else:
            target[s] = plastic[s]
    return sweeps


@kernel
def _gauss_seidel(rows, slot_a, slot_b, u, lam, target, iterations, friction, tolerance):
    """Projected Gauss-Seidel on the accumulated impulses ``lam`` (M, 3: normal, t1, t2, by
    slot) and the velocities ``u`` (N, 6: v, w), both updated in place, slot by slot (colour
    order) towards the normal ``target`` (M,): the tangent rows first (34), then the normal
    row. Stops after ``iterations`` or after an iteration in which no row changed its velocity
    by more than ``tolerance``; returns the iterations run. Each change is a pair of equal and
    opposite impulses at the contact point (Theorem 2 after every update)."""
    m = rows.shape[0]
    done = 0
    while done < iterations:
        done += 1
        change = 0.0
        for s in range(m):
            a, b = int(slot_a[s]), int(slot_b[s])
            ma, mb = float(rows[s, MASS_A]), float(rows[s, MASS_B])
            a0, a1, a2 = float(u[a, 0]), float(u[a, 1]), float(u[a, 2])
            a3, a4, a5 = float(u[a, 3]), float(u[a, 4]), float(u[a, 5])
            b0, b1, b2 = float(u[b, 0]), float(u[b, 1]), float(u[b, 2])
            b3, b4, b5 = float(u[b, 3]), float(u[b, 4]), float(u[b, 5])
            ln = float(lam[s, 0])
            if friction:
                o1, o2 = T1, T2
                v1 = (-float(rows[s, o1 + D]) * a0 - float(rows[s, o1 + D + 1]) * a1
                      - float(rows[s, o1 + D + 2]) * a2 + float(rows[s, o1 + GA]) * a3
                      + float(rows[s, o1 + GA + 1]) * a4 + float(rows[s, o1 + GA + 2]) * a5
                      + float(rows[s, o1 + D]) * b0 + float(rows[s, o1 + D + 1]) * b1
                      + float(rows[s, o1 + D + 2]) * b2 + float(rows[s, o1 + GB]) * b3
                      + float(rows[s, o1 + GB + 1]) * b4 + float(rows[s, o1 + GB + 2]) * b5)
                v2 = (-float(rows[s, o2 + D]) * a0 - float(rows[s, o2 + D + 1]) * a1
                      - float(rows[s, o2 + D + 2]) * a2 + float(rows[s, o2 + GA]) * a3
                      + float(rows[s, o2 + GA + 1]) * a4 + float(rows[s, o2 + GA + 2]) * a5
                      + float(rows[s, o2 + D]) * b0 + float(rows[s, o2 + D + 1]) * b1
                      + float(rows[s, o2 + D + 2]) * b2 + float(rows[s, o2 + GB]) * b3
                      + float(rows[s, o2 + GB + 1]) * b4 + float(rows[s, o2 + GB + 2]) * b5)
                # (34): a step along -v_t / k_max, projected onto the disc |lambda_t| <= mu
                # lambda_n (s2 > limit^2 >= 0, so sqrt(s2) > 0).
                ikt = float(rows[s, INVERSE_KT])
                old1, old2 = float(lam[s, 1]), float(lam[s, 2])
                l1 = old1 - v1 * ikt
                l2 = old2 - v2 * ikt
                limit = float(rows[s, MU]) * ln
                s2 = l1 * l1 + l2 * l2
                if s2 > limit * limit:
                    f = limit / math.sqrt(s2)
                    l1, l2 = l1 * f, l2 * f
                d1, d2 = l1 - old1, l2 - old2
                lam[s, 1], lam[s, 2] = l1, l2
                c = (abs(d1) + abs(d2)) * float(rows[s, K_TANGENT])  # bounds the change of |v_t|
                if c > change:
                    change = c
                # u += d1 M^-1 J_t1^T + d2 M^-1 J_t2^T.
                a0 = (a0 + d1 * (-ma * float(rows[s, o1 + D]))
                      + d2 * (-ma * float(rows[s, o2 + D])))
                a1 = (a1 + d1 * (-ma * float(rows[s, o1 + D + 1]))
                      + d2 * (-ma * float(rows[s, o2 + D + 1])))
                a2 = (a2 + d1 * (-ma * float(rows[s, o1 + D + 2]))
                      + d2 * (-ma * float(rows[s, o2 + D + 2])))
                a3 = a3 + d1 * float(rows[s, o1 + HA]) + d2 * float(rows[s, o2 + HA])
                a4 = a4 + d1 * float(rows[s, o1 + HA + 1]) + d2 * float(rows[s, o2 + HA + 1])
                a5 = a5 + d1 * float(rows[s, o1 + HA + 2]) + d2 * float(rows[s, o2 + HA + 2])
                b0 = (b0 + d1 * (mb * float(rows[s, o1 + D]))
                      + d2 * (mb * float(rows[s, o2 + D])))
                b1 = (b1 + d1 * (mb * float(rows[s, o1 + D + 1]))
                      + d2 * (mb * float(rows[s, o2 + D + 1])))
                b2 = (b2 + d1 * (mb * float(rows[s, o1 + D + 2]))
                      + d2 * (mb * float(rows[s, o2 + D + 2])))
                b3 = b3 + d1 * float(rows[s, o1 + HB]) + d2 * float(rows[s, o2 + HB])
                b4 = b4 + d1 * float(rows[s, o1 + HB + 1]) + d2 * float(rows[s, o2 + HB + 1])
                b5 = b5 + d1 * float(rows[s, o1 + HB + 2]) + d2 * float(rows[s, o2 + HB + 2])
            dx, dy, dz = float(rows[s, D]), float(rows[s, D + 1]), float(rows[s, D + 2])
            vn = (-dx * a0 - dy * a1 - dz * a2 + float(rows[s, GA]) * a3
                  + float(rows[s, GA + 1]) * a4 + float(rows[s, GA + 2]) * a5
                  + dx * b0 + dy * b1 + dz * b2 + float(rows[s, GB]) * b3
                  + float(rows[s, GB + 1]) * b4 + float(rows[s, GB + 2]) * b5)
            # The impulse that makes v_n meet its target with the others held (31), clamped
            # so that the accumulated one only pushes.
            new = ln + (float(target[s]) - vn) * float(rows[s, INVERSE_K])
            if new < 0.0:
                new = 0.0
            dn = new - ln
            lam[s, 0] = new
            c = abs(dn) * float(rows[s, K_NORMAL])
            if c > change:
                change = c
            u[a, 0], u[a, 1], u[a, 2] = (a0 + dn * (-ma * dx), a1 + dn * (-ma * dy),
                                         a2 + dn * (-ma * dz))
            u[a, 3] = a3 + dn * float(rows[s, HA])
            u[a, 4] = a4 + dn * float(rows[s, HA + 1])
            u[a, 5] = a5 + dn * float(rows[s, HA + 2])
            u[b, 0], u[b, 1], u[b, 2] = (b0 + dn * (mb * dx), b1 + dn * (mb * dy),
                                         b2 + dn * (mb * dz))
            u[b, 3] = b3 + dn * float(rows[s, HB])
            u[b, 4] = b4 + dn * float(rows[s, HB + 1])
            u[b, 5] = b5 + dn * float(rows[s, HB + 2])
        if change <= tolerance:
            break
    return done


@kernel
def _couples(rows, slot_a, slot_b, u, lam, inverse_inertia, mu_r, mu_t):
    """Rolling resistance (36) and torsional friction (37): one pass over the pressed contacts
    (lambda_n > 0), slot by slot, each a couple (+L on a, -L on b, no force) on the angular
    velocities of ``u`` (N, 6), in place."""
    for s in range(rows.shape[0]):
        ln = float(lam[s, 0])
        if not ln > 0.0:
            continue
        a, b = int(slot_a[s]), int(slot_b[s])
        nx, ny, nz = float(rows[s, NORMAL + D]), float(rows[s, NORMAL + D + 1]), float(
            rows[s, NORMAL + D + 2])
        t1x, t1y, t1z = float(rows[s, T1 + D]), float(rows[s, T1 + D + 1]), float(
            rows[s, T1 + D + 2])
        t2x, t2y, t2z = float(rows[s, T2 + D]), float(rows[s, T2 + D + 1]), float(
            rows[s, T2 + D + 2])
        a3, a4, a5 = float(u[a, 3]), float(u[a, 4]), float(u[a, 5])
        b3, b4, b5 = float(u[b, 3]), float(u[b, 4]), float(u[b, 5])
        # I_a^-1 and I_b^-1 applied to t1, t2 and n (row-major 3x3).
        p = inverse_inertia[a]
        q = inverse_inertia[b]
        pa1x = float(p[0]) * t1x + float(p[1]) * t1y + float(p[2]) * t1z
        pa1y = float(p[3]) * t1x + float(p[4]) * t1y + float(p[5]) * t1z
        pa1z = float(p[6]) * t1x + float(p[7]) * t1y + float(p[8]) * t1z
        pa2x = float(p[0]) * t2x + float(p[1]) * t2y + float(p[2]) * t2z
        pa2y = float(p[3]) * t2x + float(p[4]) * t2y + float(p[5]) * t2z
        pa2z = float(p[6]) * t2x + float(p[7]) * t2y + float(p[8]) * t2z
        pb1x = float(q[0]) * t1x + float(q[1]) * t1y + float(q[2]) * t1z
        pb1y = float(q[3]) * t1x + float(q[4]) * t1y + float(q[5]) * t1z
        pb1z = float(q[6]) * t1x + float(q[7]) * t1y + float(q[8]) * t1z
        pb2x = float(q[0]) * t2x + float(q[1]) * t2y + float(q[2]) * t2z
        pb2y = float(q[3]) * t2x + float(q[4]) * t2y + float(q[5]) * t2z
        pb2z = float(q[6]) * t2x + float(q[7]) * t2y + float(q[8]) * t2z
        if mu_r > 0.0:
            # K_t, the 2x2 block of I_a^-1 + I_b^-1 on (t1, t2): positive definite when a
            # moving body can turn (else nothing is done).
            k11 = t1x * (pa1x + pb1x) + t1y * (pa1y + pb1y) + t1z * (pa1z + pb1z)
            k12 = t1x * (pa2x + pb2x) + t1y * (pa2y + pb2y) + t1z * (pa2z + pb2z)
            k22 = t2x * (pa2x + pb2x) + t2y * (pa2y + pb2y) + t2z * (pa2z + pb2z)
            det = k11 * k22 - k12 * k12
            r0, r1, r2 = b3 - a3, b4 - a4, b5 - a5
            w1 = r0 * t1x + r1 * t1y + r2 * t1z
            w2 = r0 * t2x + r1 * t2y + r2 * t2z
            if (w1 != 0.0 or w2 != 0.0) and det > 0.0:
                # (36): L = s K_t^-1 w_t with s = min(1, mu_r lambda_n / |K_t^-1 w_t|).
                l1 = (k22 * w1 - k12 * w2) / det
                l2 = (k11 * w2 - k12 * w1) / det
                size = math.sqrt(l1 * l1 + l2 * l2)
                budget = mu_r * ln
                if size > budget:
                    f = budget / size
                    l1, l2 = l1 * f, l2 * f
                a3 = a3 + (l1 * pa1x + l2 * pa2x)
                a4 = a4 + (l1 * pa1y + l2 * pa2y)
                a5 = a5 + (l1 * pa1z + l2 * pa2z)
                b3 = b3 - (l1 * pb1x + l2 * pb2x)
                b4 = b4 - (l1 * pb1y + l2 * pb2y)
                b5 = b5 - (l1 * pb1z + l2 * pb2z)
        if mu_t > 0.0:
            pan_x = float(p[0]) * nx + float(p[1]) * ny + float(p[2]) * nz
            pan_y = float(p[3]) * nx + float(p[4]) * ny + float(p[5]) * nz
            pan_z = float(p[6]) * nx + float(p[7]) * ny + float(p[8]) * nz
            pbn_x = float(q[0]) * nx + float(q[1]) * ny + float(q[2]) * nz
            pbn_y = float(q[3]) * nx + float(q[4]) * ny + float(q[5]) * nz
            pbn_z = float(q[6]) * nx + float(q[7]) * ny + float(q[8]) * nz
            k_n = nx * (pan_x + pbn_x) + ny * (pan_y + pbn_y) + nz * (pan_z + pbn_z)
            w_n = (b3 - a3) * nx + (b4 - a4) * ny + (b5 - a5) * nz
            if w_n != 0.0 and k_n > 0.0:
                # (37): L_n = sign(w_n) min(|w_n| / k_n, mu_t lambda_n).
                c = w_n / k_n
                budget = mu_t * ln
                if abs(c) > budget:
                    c = math.copysign(budget, c)
                a3, a4, a5 = a3 + c * pan_x, a4 + c * pan_y, a5 + c * pan_z
                b3, b4, b5 = b3 - c * pbn_x, b4 - c * pbn_y, b5 - c * pbn_z
        u[a, 3], u[a, 4], u[a, 5] = a3, a4, a5
        u[b, 3], u[b, 4], u[b, 5] = b3, b4, b5


@kernel
def _warm_start(rows, slot_a, slot_b, slot_of, warm_normal, warm_tangent, friction, u, lam):
    """Start ``lam`` (M, 3, by slot) from the impulses of the step before (by contact), the
    tangent one (with ``friction`` only) on (t1, t2) and clamped to the friction disc of the
    normal one, and apply them to ``u`` (N, 6) in contact order (a body may get several)."""
    for k in range(slot_of.shape[0]):
        s = int(slot_of[k])
        wn = float(warm_normal[k])
        l0 = wn if wn > 0.0 else 0.0
        l1 = l2 = 0.0
        if friction:
            wx, wy, wz = (float(warm_tangent[k, 0]), float(warm_tangent[k, 1]),
                          float(warm_tangent[k, 2]))
            l1 = (wx * float(rows[s, T1 + D]) + wy * float(rows[s, T1 + D + 1])
                  + wz * float(rows[s, T1 + D + 2]))
            l2 = (wx * float(rows[s, T2 + D]) + wy * float(rows[s, T2 + D + 1])
                  + wz * float(rows[s, T2 + D + 2]))
            limit = float(rows[s, MU]) * l0
            size = math.sqrt(l1 * l1 + l2 * l2)
            if size > limit:
                f = limit / size
                l1, l2 = l1 * f, l2 * f
        lam[s, 0], lam[s, 1], lam[s, 2] = l0, l1, l2
        a, b = int(slot_a[s]), int(slot_b[s])
        ma, mb = float(rows[s, MASS_A]), float(rows[s, MASS_B])
        for c in range(3):  # u += M^-1 J^T lambda, the rows n, t1, t2 in turn
            u[a, c] += ((l0 * (-ma * float(rows[s, NORMAL + D + c]))
                         + l1 * (-ma * float(rows[s, T1 + D + c])))
                        + l2 * (-ma * float(rows[s, T2 + D + c])))
            u[a, 3 + c] += ((l0 * float(rows[s, NORMAL + HA + c])
                             + l1 * float(rows[s, T1 + HA + c]))
                            + l2 * float(rows[s, T2 + HA + c]))
            u[b, c] += ((l0 * (mb * float(rows[s, NORMAL + D + c]))
                         + l1 * (mb * float(rows[s, T1 + D + c])))
                        + l2 * (mb * float(rows[s, T2 + D + c])))
            u[b, 3 + c] += ((l0 * float(rows[s, NORMAL + HB + c])
                             + l1 * float(rows[s, T1 + HB + c]))
                            + l2 * float(rows[s, T2 + HB + c]))


@kernel
def _energy(u, inverse_mass, inertia, which):
    """Kinetic energy (J) of the bodies ``which`` at velocities ``u`` (N, 6): the sum, in the
    order of ``which``, of 1/2 m v.v + 1/2 w . I w (I the world inertia, (N, 9))."""
    total = 0.0
    for k in range(which.shape[0]):
        i = int(which[k])
        vx, vy, vz = float(u[i, 0]), float(u[i, 1]), float(u[i, 2])
        wx, wy, wz = float(u[i, 3]), float(u[i, 4]), float(u[i, 5])
        iwx = float(inertia[i, 0]) * wx + float(inertia[i, 1]) * wy + float(inertia[i, 2]) * wz
        iwy = float(inertia[i, 3]) * wx + float(inertia[i, 4]) * wy + float(inertia[i, 5]) * wz
        iwz = float(inertia[i, 6]) * wx + float(inertia[i, 7]) * wy + float(inertia[i, 8]) * wz
        total += 0.5 * ((vx * vx + vy * vy + vz * vz) / float(inverse_mass[i])
                        + (wx * iwx + wy * iwy + wz * iwz))
    return total


@kernel
def _largest_step(start, end, limit, inverse_mass, inertia, which, work):
    """The largest s in [0, 1] with kinetic energy at start + s (end - start) <= ``limit``,
    given that of ``start`` is (0 if it is not). ``work`` (N, 6) is scratch."""
    e_start = _energy(start, inverse_mass, inertia, which)
    e_end = _energy(end, inverse_mass, inertia, which)
    if e_end <= limit:
        return 1.0
    if not e_start <= limit:
        return 0.0
    for k in range(which.shape[0]):
        i = int(which[k])
        for c in range(6):
            work[i, c] = float(end[i, c]) - float(start[i, c])
    # E(s) = e_start + b s + a s^2 with a the energy of (end - start); the root of
    # E(s) = limit in [0, 1).
    a = _energy(work, inverse_mass, inertia, which)
    b = e_end - e_start - a
    if not a > 0.0:
        return 0.0
    disc = b * b + 4.0 * a * (limit - e_start)
    if not disc > 0.0:
        disc = 0.0
    s = (-b + math.sqrt(disc)) / (2.0 * a)
    if not s > 0.0:
        s = 0.0
    if s > 1.0:
        s = 1.0
    return s * (1.0 - 1e-12)


@kernel
def solve_arrays(body_a, body_b, point, normal, depth, position, velocity, angular_velocity,
                 inverse_mass, inverse_inertia, settings, warm_normal, warm_tangent, use_warm,
                 restitution, friction, out_velocity, out_angular_velocity, out_displacement,
                 out_rotation, out_normal_impulse, out_tangent_impulse, out_position_impulse,
                 out_touched):
    """Impulses and position correction of M contacts between N bodies (see the module doc
    for the arrays); returns (colours, velocity iterations, position iterations)."""
    m, n = body_a.shape[0], position.shape[0]
    dt = float(settings[DT])
    v_iterations = int(settings[VELOCITY_ITERATIONS])
    p_iterations = int(settings[POSITION_ITERATIONS])
    tolerance = float(settings[TOLERANCE])
    mu_r, mu_t = float(settings[ROLLING_RESISTANCE]), float(settings[TORSIONAL_FRICTION])
    # The solve's own arrays, carved from three made at once and borrowed (jit.borrowed):
    # three allocations where there were eighteen, and no reference count of them taken as
    # they pass to the stages (kept alive to the end: jit.keep_alive).
    own_f = np.empty(n * 27 + m * (ROWS_WIDTH + 9))
    own_i = np.empty(6 * m + n + 1, dtype=np.int64)
    own_b = np.empty(2 * n, dtype=np.bool_)
    fs, ints, flags = borrowed(own_f), borrowed(own_i), borrowed(own_b)
    u0 = fs[:6 * n].reshape((n, 6))
    u = fs[6 * n:12 * n].reshape((n, 6))
    q = fs[12 * n:18 * n].reshape((n, 6))
    inertia = fs[18 * n:27 * n].reshape((n, 9))
    at = 27 * n
    rows = fs[at:at + m * ROWS_WIDTH].reshape((m, ROWS_WIDTH))
    at += m * ROWS_WIDTH
    lam = fs[at:at + 3 * m].reshape((m, 3))
    p_lam = fs[at + 3 * m:at + 6 * m].reshape((m, 3))
    target = fs[at + 6 * m:at + 7 * m]
    plastic = fs[at + 7 * m:at + 8 * m]
    p_target = fs[at + 8 * m:at + 9 * m]
    colour, order, slot_of = ints[:m], ints[m:2 * m], ints[2 * m:3 * m]
    slot_a, slot_b = ints[3 * m:4 * m], ints[4 * m:5 * m]
    first = ints[5 * m:6 * m + 1]
    which_all = ints[6 * m + 1:6 * m + 1 + n]
    moving, involved = flags[:n], flags[n:]
    for i in range(n):
        for c in range(3):
            u0[i, c] = float(velocity[i, c])
            u0[i, 3 + c] = float(angular_velocity[i, c])
        moving[i] = float(inverse_mass[i]) > 0.0
    if m == 0:
        for i in range(n):
            for c in range(3):
                out_velocity[i, c] = u0[i, c]
                out_angular_velocity[i, c] = u0[i, 3 + c]
                out_displacement[i, c] = 0.0
                out_rotation[i, c] = 0.0
            out_touched[i] = False
        keep_alive(own_f, own_i, own_b)  # (u0 is a view of own_f: numba frees it after this)
        return 0, 0, 0
    # Colour, then the rows in colour order: slot s holds contact order[s].
    colours = _colour(body_a, body_b, moving, colour)
    first = first[:colours + 1]
    first[:] = 0
    for k in range(m):
        first[colour[k] + 1] += 1
    for c in range(colours):
        first[c + 1] += first[c]
    for k in range(m):  # a stable sort by colour
        s = int(first[colour[k]])
        first[colour[k]] += 1
        order[s], slot_of[k] = k, s
    _rows(order, body_a, body_b, point, normal, depth, position, inverse_mass, inverse_inertia,
          friction, rows, slot_a, slot_b)
    largest_mu = 0.0
    for k in range(m):
        if float(friction[k]) > largest_mu:
            largest_mu = float(friction[k])
    # Flags for other kernels are computed, not literal (see the module doc).
    with_friction = largest_mu > 0.0
    no_friction = m < 0  # False

    _targets(rows, order, slot_a, slot_b, u0, depth, restitution, dt,
             float(settings[BOUNCE_THRESHOLD]), target, plastic)

    # The velocity pass: warm start, Gauss-Seidel, then the couples.
    u[:] = u0
    lam[:] = 0.0
    if use_warm:
        _warm_start(rows, slot_a, slot_b, slot_of, warm_normal, warm_tangent, with_friction,
                    u, lam)
    impacts = False
    for s in range(m):
        if target[s] != plastic[s]:
            impacts = True
    if impacts:  # a bounce: passed on from pair to pair first
        _impacts(rows, body_a, body_b, slot_of, slot_a, slot_b, depth, restitution, dt,
                 float(settings[BOUNCE_THRESHOLD]), tolerance, u, lam, target, plastic)
    v_done = _gauss_seidel(rows, slot_a, slot_b, u, lam, target, v_iterations, with_friction,
                           tolerance)
    if mu_r > 0.0 or mu_t > 0.0:
        _couples(rows, slot_a, slot_b, u, lam, inverse_inertia, mu_r, mu_t)

    # Energy guard: Newton's law with friction or with simultaneous contacts (Kane's
    # paradox), or a warm start the iterations did not undo, can create energy; then the
    # solve is blended with the plastic one (docs/collisions.md, "Energy").
    involved[:] = False
    for k in range(m):
        involved[int(body_a[k])] = True
        involved[int(body_b[k])] = True
    count = 0
    for i in range(n):
        if involved[i] and moving[i]:
            count += 1
    which = which_all[:count]
    inertia[:] = 0.0
    count = 0
    for i in range(n):
        if involved[i] and moving[i]:
            which[count] = i
            count += 1
            # I = (I^-1)^-1 = adj(I^-1) / det(I^-1), a singular one taken as 0 (no turning).
            p = inverse_inertia[i]
            c00 = float(p[4]) * float(p[8]) - float(p[5]) * float(p[7])
            c01 = float(p[2]) * float(p[7]) - float(p[1]) * float(p[8])
            c02 = float(p[1]) * float(p[5]) - float(p[2]) * float(p[4])
            c10 = float(p[5]) * float(p[6]) - float(p[3]) * float(p[8])
            c11 = float(p[0]) * float(p[8]) - float(p[2]) * float(p[6])
            c12 = float(p[2]) * float(p[3]) - float(p[0]) * float(p[5])
            c20 = float(p[3]) * float(p[7]) - float(p[4]) * float(p[6])
            c21 = float(p[1]) * float(p[6]) - float(p[0]) * float(p[7])
            c22 = float(p[0]) * float(p[4]) - float(p[1]) * float(p[3])
            det = float(p[0]) * c00 + float(p[1]) * c10 + float(p[2]) * c20
            if det > 0.0:
                inertia[i, 0], inertia[i, 1], inertia[i, 2] = c00 / det, c01 / det, c02 / det
                inertia[i, 3], inertia[i, 4], inertia[i, 5] = c10 / det, c11 / det, c12 / det
                inertia[i, 6], inertia[i, 7], inertia[i, 8] = c20 / det, c21 / det, c22 / det
    e0 = _energy(u0, inverse_mass, inertia, which)
    if _energy(u, inverse_mass, inertia, which) > e0 * (1.0 + ENERGY_TOLERANCE):
        # The plastic solve (every target the one without restitution, no warm start), or if
        # even that gained, the blend of u0 towards it that keeps the energy; then from there
        # towards u by the largest s in [0, 1] that keeps it. Each is a set of equal and
        # opposite impulses with lambda_n >= 0 in the cones, and so is a blend (convex
        # constraints): momentum is kept, s scales the restitution down.
        base = u0.copy()
        base_lam = np.zeros((m, 3))
        v_done += _gauss_seidel(rows, slot_a, slot_b, base, base_lam, plastic, v_iterations,
                                with_friction, tolerance)
        if mu_r > 0.0 or mu_t > 0.0:
            _couples(rows, slot_a, slot_b, base, base_lam, inverse_inertia, mu_r, mu_t)
        work = np.zeros((n, 6))
        step = _largest_step(u0, base, e0, inverse_mass, inertia, which, work)
        for i in range(n):
            for c in range(6):
                base[i, c] = float(u0[i, c]) + step * (float(base[i, c]) - float(u0[i, c]))
        for j in range(m):
            for c in range(3):
                base_lam[j, c] = step * float(base_lam[j, c])
        step = _largest_step(base, u, e0, inverse_mass, inertia, which, work)
        for i in range(n):
            for c in range(6):
                u[i, c] = float(base[i, c]) + step * (float(u[i, c]) - float(base[i, c]))
        for j in range(m):
            for c in range(3):
                old_lam = float(base_lam[j, c])
                lam[j, c] = old_lam + step * (float(lam[j, c]) - old_lam)

    # Position correction (35) on pseudo-velocities (displacements, rotation vectors), normal
    # rows only, towards position_fraction of the penetration beyond the slop.
    q[:] = 0.0
    p_lam[:] = 0.0
    p_done = 0
    if p_iterations > 0:
        fraction, slop = float(settings[POSITION_FRACTION]), float(settings[SLOP])
        pressed = False
        for s in range(m):
            p_target[s] = fraction * (float(depth[int(order[s])]) - slop)
            if p_target[s] > 0.0:
                pressed = True
        if pressed:
            p_done = _gauss_seidel(rows, slot_a, slot_b, q, p_lam, p_target, p_iterations,
                                   no_friction, tolerance * dt)

    for i in range(n):
        changed = False
        for c in range(3):
            out_velocity[i, c] = u[i, c]
            out_angular_velocity[i, c] = u[i, 3 + c]
            out_displacement[i, c] = q[i, c]
            out_rotation[i, c] = q[i, 3 + c]
        for c in range(6):
            if u[i, c] != u0[i, c] or q[i, c] != 0.0:
                changed = True
        out_touched[i] = changed
    for k in range(m):
        s = int(slot_of[k])
        l1, l2 = float(lam[s, 1]), float(lam[s, 2])
        out_normal_impulse[k] = lam[s, 0]
        for c in range(3):  # lambda_1 t1 + lambda_2 t2
            out_tangent_impulse[k, c] = (l1 * float(rows[s, T1 + D + c])
                                         + l2 * float(rows[s, T2 + D + c]))
        out_position_impulse[k] = p_lam[s, 0]
    keep_alive(own_f, own_i, own_b)
    return colours, v_done, p_done
