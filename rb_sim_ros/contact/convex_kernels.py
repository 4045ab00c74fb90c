# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The convex narrow phase: contacts of any two solid kinds through their cores, and of any
solid kind against a plane through its faces. The pairs of kinds with no closed-form test of
their own (the cylinder's, the hulls' to come) are rows of ``narrow_kernels.PAIR_TESTS`` that
call these.

A solid kind is a core rounded by a radius (``shapes``: a sphere is its centre rounded by its
radius, a capsule its segment; a box and a cylinder are their own cores, radius 0), read
through its module's ``core_point`` (the core's farthest point along a direction),
``core_face`` (the core's points facing a direction: a polygon, a segment or a point) and
``core_radius``.

``convex_pair``: the normal and depth of two shapes come from their cores,
* apart: GJK (Gilbert-Johnson-Keerthi) gives the distance d of the cores and their closest
  points a, b; the normal n = (b - a) / d, the depth ra + rb - d (exact: the closest points of
  rounded cores are those of the cores moved along n by the radii);
* overlapping cores: EPA (the expanding polytope) from GJK's last simplex gives the shortest
  way out, the face of the Minkowski difference A - B nearest the origin: its normal n and its
  distance d (the depth of the cores), the closest points from its barycentric coordinates;
and where either core is curved (``shapes.CURVED``: an ellipsoid), the normal refined
(``_refine``): EPA's polytope and GJK's simplices only approach a curved Minkowski difference
(an ellipsoid's contact point was 2-3 mm off at a 1 cm overlap), so n is moved to where the
reach of A - B along n is least, which is the depth (or minus the distance) of the cores;
then the manifold: the face of A facing n and the face of B facing -n (``core_face``); the
larger is the reference, the other (the incident face) is clipped to its sides
(Sutherland-Hodgman on the planes through its edges, or the ends of a segment), and each
clipped point within the margin of the reference face is a contact (its depth measured along
n to the reference's plane, or line), at most 4 (``contact_geometry.reduce_to_four``). Where
the faces give none (a point feature), the one contact of the closest points. So a box or a
cylinder resting on a face gets the corners of the overlap, and does not rock.

``convex_plane``: the face of the core facing the plane (along -n), each point whose height
above the plane (less the radius) is at most the margin, at most 4.

Conventions as ``narrow_kernels``: normal from A to B, depth > 0 overlapping, point midway,
world frame, rot row-major; the same bits compiled and interpreted (every reduction written
out, every division guarded); a bad input gives a meaningless contact, never an exception.
Features: ``FACE_FEATURES`` (+ ``REFERENCE_B`` when B's face is the reference) + the face
tags of the incident face (``core_face``, < 64) or the tags of its crossings with the
reference's sides (``_crossing_tag``, each its own), or ``POINT_FEATURE`` for the single
contact.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.contact_geometry import (apply as _apply, apply_t as _apply_t,
                                                 put as _put, TINY_LENGTH,
                                                 write_at_most_four as _write_four)
from rb_sim_ros.contact.shapes.base import NORMAL
from rb_sim_ros.core.jit import inline_kernel, kernel, stack_empty

# GJK stops when the distance can shrink by no more than this fraction of its square (a
# curved core converges linearly) or after GJK_ITERATIONS support points.
GJK_RELATIVE = 1e-12
GJK_ITERATIONS = 64
# A tetrahedron whose volume is below this fraction of the product of its edges from one
# vertex is flat: which side of a face the origin lies on is then rounding.
FLAT_RELATIVE = 1e-12
# Cores closer than this fraction of their size (the largest support point met) touch: EPA.
TOUCH_RELATIVE = 1e-10
# EPA: at most EPA_VERTICES points of the polytope (faces: 2 V - 4); it stops when the next
# support point lies no more than EPA_RELATIVE of the size beyond the nearest face (a curved
# core converges slowly: its depth is then within EPA_RELATIVE of the size, its normal within
# about sqrt(2 EPA_RELATIVE) rad), or when the nearest face would come nearer (rounding has
# bent the polytope), keeping the last good face.
EPA_VERTICES = 64
EPA_FACES = 2 * EPA_VERTICES - 4
EPA_EDGES = 3 * EPA_FACES  # the horizon's room (each face's three edges)
# The most points of a core's face (a global of this module: jit.stack_empty takes constants)
CORE_FACE = shapes.CORE_FACE_CAPACITY
EPA_RELATIVE = 1e-11
# The refinement of a curved pair's normal (``_refine``): at most REFINE_STEPS Newton steps,
# each turning n by at most REFINE_TURN (rad), its curvature by central differences of
# REFINE_DELTA (rad); it stops at a turn below REFINE_STOP (rad) or where neither the reach
# falls nor, within REFINE_ROUNDING of the size of the points, its slope.
REFINE_STEPS = 8
REFINE_TURN = 0.5
REFINE_DELTA = 1e-4
REFINE_STOP = 1e-12
REFINE_ROUNDING = 1e-15
# Clipping buffers: a convex face of at most 9 points clipped by at most 9 planes stays
# within 18 points. A clip at most doubles a polygon (each edge keeps its start and adds at
# most one crossing), so one of more than CLIP_ROOM / 2 points (rounding) is not clipped
# further: the single contact is used.
CLIP_ROOM = 64
# Faces are clipped only where the reference face is within acos(FACE_COS) (8 degrees) of the
# contact normal: a box or cylinder resting on a face, or tilted on it as far as it rocks.
FACE_COS = 0.99
POINT_FEATURE = 3000
FACE_FEATURES = 0
# The incident face's tags below CROSSINGS (a hull's vertex indices, < 64), its crossings'
# above (``_crossing_tag``, below 1378); B's face as the reference adds REFERENCE_B.
CROSSINGS = 64
SIDES = 9
REFERENCE_B = 1500


# -- supports -----------------------------------------------------------------------------------
@inline_kernel
def _support(kind, geom, centre, rot, pool, dx, dy, dz):
    """The world point of the core of a shape (kind, geom, centre, rot) farthest along the
    world direction d."""
    lx, ly, lz = _apply_t(rot, dx, dy, dz)
    px, py, pz = shapes.core_point_of(kind, geom, pool, lx, ly, lz)
    wx, wy, wz = _apply(rot, px, py, pz)
    return float(centre[0]) + wx, float(centre[1]) + wy, float(centre[2]) + wz


@inline_kernel
def _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, dx, dy, dz, k, W, PA, PB):
    """Row k of the simplex: a = A's core point along d, b = B's along -d, w = a - b (the
    point of A - B farthest along d)."""
    ax, ay, az = _support(ka, ga, ca, ra, pool, dx, dy, dz)
    bx, by, bz = _support(kb, gb, cb, rb, pool, -dx, -dy, -dz)
    PA[k, 0], PA[k, 1], PA[k, 2] = ax, ay, az
    PB[k, 0], PB[k, 1], PB[k, 2] = bx, by, bz
    W[k, 0], W[k, 1], W[k, 2] = ax - bx, ay - by, az - bz


@inline_kernel
def _square_to(x, y, z):
    """(x, y, z) x e for the world axis e least along it (the first on a tie): square to it,
    not normalised, of length at least sqrt(2/3) of its own."""
    mx, my, mz = abs(x), abs(y), abs(z)
    if mx <= my and mx <= mz:
        return 0.0, z, -y
    if my <= mz:
        return -z, 0.0, x
    return y, -x, 0.0


@inline_kernel
def _pair_support(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz):
    """A's core point along n, B's along -n (world): (ax, ay, az, bx, by, bz)."""
    ax, ay, az = _support(ka, ga, ca, ra, pool, nx, ny, nz)
    bx, by, bz = _support(kb, gb, cb, rb, pool, -nx, -ny, -nz)
    return ax, ay, az, bx, by, bz


@inline_kernel
def _turn(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz, tx, ty, tz):
    """How the farthest point of A - B moves as n turns towards t: (s(n + e t) - s(n - e t))
    / 2 e, e = REFINE_DELTA."""
    e = REFINE_DELTA
    px, py, pz, qx, qy, qz = _pair_support(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx + e * tx,
                                           ny + e * ty, nz + e * tz)
    ux, uy, uz, vx, vy, vz = _pair_support(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx - e * tx,
                                           ny - e * ty, nz - e * tz)
    k = 0.5 / e
    return (((px - qx) - (ux - vx)) * k, ((py - qy) - (uy - vy)) * k,
            ((pz - qz) - (uz - vz)) * k)


@kernel
def _refine(ka, ga, ca, ra, kb, gb, cb, rb, pool, curved_a, curved_b, nx, ny, nz, depth, ax,
            ay, az, bx, by, bz):
    """The normal of a pair with a curved core, from GJK's or EPA's (n, depth, a, b): the unit
    n where f(n), the reach of A - B along n (the farthest point s(n) = a(n) - b(-n) of the
    cores' supports, f = s . n), is least; its least value is the cores' depth (overlapping)
    or minus their distance (apart), and there s(n) lies along n. Newton's method on the unit
    sphere: in the plane of t1, t2 square to n, the step d solves H d = -g, g = (s . t1,
    s . t2), H = (ti . J tj) - f I with J the turn of s with n (``_turn``, made symmetric);
    a step is taken only where H is positive definite and f falls (or, where f is flat to
    rounding, g shrinks). Returns (n, f, a, b) as
    they stand after the last step taken, with a, b the contact points on the cores: a
    curved core's own support, the other's point the reach f back along n from it (a flat
    face's support is any of its corners); GJK's or EPA's, unchanged, if no step was."""
    cx, cy, cz, dx, dy, dz = _pair_support(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz)
    f = (cx - dx) * nx + (cy - dy) * ny + (cz - dz) * nz
    moved = False
    for _ in range(REFINE_STEPS):
        sx, sy, sz = cx - dx, cy - dy, cz - dz
        # t1 = n x e for the world axis e least aligned with n, t2 = n x t1
        t1x, t1y, t1z = _square_to(nx, ny, nz)
        size = math.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
        if not size > TINY_LENGTH:
            break
        t1x, t1y, t1z = t1x / size, t1y / size, t1z / size
        t2x, t2y, t2z = ny * t1z - nz * t1y, nz * t1x - nx * t1z, nx * t1y - ny * t1x
        g1 = sx * t1x + sy * t1y + sz * t1z
        g2 = sx * t2x + sy * t2y + sz * t2z
        px, py, pz = _turn(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz, t1x, t1y, t1z)
        qx, qy, qz = _turn(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz, t2x, t2y, t2z)
        h11 = px * t1x + py * t1y + pz * t1z - f
        h22 = qx * t2x + qy * t2y + qz * t2z - f
        h12 = 0.5 * ((px * t2x + py * t2y + pz * t2z) + (qx * t1x + qy * t1y + qz * t1z))
        det = h11 * h22 - h12 * h12
        if not (h11 > 0.0 and det > 0.0):
            break
        d1 = (h12 * g2 - h22 * g1) / det
        d2 = (h12 * g1 - h11 * g2) / det
        turn = math.sqrt(d1 * d1 + d2 * d2)
        if not turn <= REFINE_TURN:  # (a nan turn too)
            if not turn > 0.0:
                break
            d1, d2 = d1 * (REFINE_TURN / turn), d2 * (REFINE_TURN / turn)
        mx, my, mz = nx + d1 * t1x + d2 * t2x, ny + d1 * t1y + d2 * t2y, nz + d1 * t1z + d2 * t2z
        size = math.sqrt(mx * mx + my * my + mz * mz)
        mx, my, mz = mx / size, my / size, mz / size
        ux, uy, uz, vx, vy, vz = _pair_support(ka, ga, ca, ra, kb, gb, cb, rb, pool, mx, my, mz)
        wx, wy, wz = ux - vx, uy - vy, uz - vz
        reach = wx * mx + wy * my + wz * mz
        if not reach < f:
            # f is flat at its least (it falls by H d^2 / 2, below its rounding once the turn
            # is below about 1e-8): a step is also taken where f stays within its rounding
            # and the part of s square to n (f's slope, g) shrinks
            ex, ey, ez = wx - reach * mx, wy - reach * my, wz - reach * mz
            scale = (abs(cx) + abs(cy) + abs(cz) + abs(dx) + abs(dy) + abs(dz)
                     + abs(ux) + abs(uy) + abs(uz) + abs(vx) + abs(vy) + abs(vz))
            if not (reach <= f + REFINE_ROUNDING * scale
                    and ex * ex + ey * ey + ez * ez < g1 * g1 + g2 * g2):
                break
        nx, ny, nz, f = mx, my, mz, reach
        cx, cy, cz, dx, dy, dz = ux, uy, uz, vx, vy, vz
        moved = True
        if turn <= REFINE_STOP:
            break
    if not moved:
        return nx, ny, nz, depth, ax, ay, az, bx, by, bz
    if not curved_a:  # B's point is its own, A's the reach back along n from it
        cx, cy, cz = dx + f * nx, dy + f * ny, dz + f * nz
    elif not curved_b:
        dx, dy, dz = cx - f * nx, cy - f * ny, cz - f * nz
    return nx, ny, nz, f, cx, cy, cz, dx, dy, dz


@inline_kernel
def _dot(M, i, x, y, z):
    return float(M[i, 0]) * x + float(M[i, 1]) * y + float(M[i, 2]) * z


@inline_kernel
def _tetra_face(f):
    """Face f of a tetrahedron 0, 1, 2, 3: its vertices and the one opposite."""
    if f == 0:
        return 1, 2, 3, 0
    if f == 1:
        return 0, 3, 2, 1
    if f == 2:
        return 0, 1, 3, 2
    return 0, 2, 1, 3


# -- GJK --------------------------------------------------------------------------------------
@inline_kernel
def _triangle(W, i, j, k):
    """The point of the triangle W[i], W[j], W[k] nearest the origin (Ericson 5.1.5): its
    barycentric coordinates (u, v, w) and which vertices it needs (a mask of 1 i, 2 j, 4 k)."""
    ax, ay, az = float(W[i, 0]), float(W[i, 1]), float(W[i, 2])
    bx, by, bz = float(W[j, 0]), float(W[j, 1]), float(W[j, 2])
    cx, cy, cz = float(W[k, 0]), float(W[k, 1]), float(W[k, 2])
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0, 1
    d3 = -(abx * bx + aby * by + abz * bz)
    d4 = -(acx * bx + acy * by + acz * bz)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0, 2
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0 and d1 - d3 > 0.0:
        t = d1 / (d1 - d3)
        return 1.0 - t, t, 0.0, 3
    d5 = -(abx * cx + aby * cy + abz * cz)
    d6 = -(acx * cx + acy * cy + acz * cz)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0, 4
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0 and d2 - d6 > 0.0:
        t = d2 / (d2 - d6)
        return 1.0 - t, 0.0, t, 5
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0 and (d4 - d3) + (d5 - d6) > 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - t, t, 6
    total = va + vb + vc
    if not total > 0.0:  # degenerate (a sliver): its nearest vertex
        best, mask = _dot(W, i, ax, ay, az), 1
        if _dot(W, j, bx, by, bz) < best:
            best, mask = _dot(W, j, bx, by, bz), 2
        if _dot(W, k, cx, cy, cz) < best:
            mask = 4
        return (1.0 if mask == 1 else 0.0), (1.0 if mask == 2 else 0.0), \
            (1.0 if mask == 4 else 0.0), mask
    v, w = vb / total, vc / total
    return 1.0 - v - w, v, w, 7


@inline_kernel
def _det(ax, ay, az, bx, by, bz, cx, cy, cz):
    """a . (b x c)."""
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


@inline_kernel
def _keep(W, PA, PB, lam, idx, weights, count, scratch):
    """Reorder the simplex to the vertices idx[:count] with weights[:count] (in lam), through
    ``scratch`` (4, 9)."""
    for m in range(count):
        i = int(idx[m])
        for q in range(3):
            scratch[m, q], scratch[m, 3 + q], scratch[m, 6 + q] = W[i, q], PA[i, q], PB[i, q]
    for m in range(count):
        for q in range(3):
            W[m, q], PA[m, q], PB[m, q] = scratch[m, q], scratch[m, 3 + q], scratch[m, 6 + q]
        lam[m] = weights[m]


@inline_kernel
def _closest(W, PA, PB, lam, n, idx, weights, scratch):
    """Reduce the simplex W[:n] (n 1 to 4) to the fewest vertices whose hull holds its point
    nearest the origin, their weights in lam; returns (n, inside): inside when the origin is
    in the tetrahedron. idx, weights and scratch: room for the reduction."""
    if n == 1:
        lam[0] = 1.0
        return 1, False
    if n == 2:
        ex, ey, ez = (float(W[1, 0]) - float(W[0, 0]), float(W[1, 1]) - float(W[0, 1]),
                      float(W[1, 2]) - float(W[0, 2]))
        e2 = ex * ex + ey * ey + ez * ez
        t = -_dot(W, 0, ex, ey, ez) / e2 if e2 > 0.0 else 0.0
        if t <= 0.0:
            idx[0], weights[0] = 0, 1.0
            _keep(W, PA, PB, lam, idx, weights, 1, scratch)
            return 1, False
        if t >= 1.0:
            idx[0], weights[0] = 1, 1.0
            _keep(W, PA, PB, lam, idx, weights, 1, scratch)
            return 1, False
        lam[0], lam[1] = 1.0 - t, t
        return 2, False
    if n == 3:
        u, v, w, mask = _triangle(W, 0, 1, 2)
        return _apply_mask(W, PA, PB, lam, idx, weights, scratch, int(0), int(1), int(2), u, v, w,
                           mask), False
    # n == 4: the origin's barycentric coordinates in the tetrahedron (signed volumes):
    # all >= 0, it is inside; else the nearest of the faces opposite a negative one (of
    # every face when the tetrahedron is flat, where the signs mean nothing)
    ax, ay, az = float(W[0, 0]), float(W[0, 1]), float(W[0, 2])
    e1x, e1y, e1z = float(W[1, 0]) - ax, float(W[1, 1]) - ay, float(W[1, 2]) - az
    e2x, e2y, e2z = float(W[2, 0]) - ax, float(W[2, 1]) - ay, float(W[2, 2]) - az
    e3x, e3y, e3z = float(W[3, 0]) - ax, float(W[3, 1]) - ay, float(W[3, 2]) - az
    volume = _det(e1x, e1y, e1z, e2x, e2y, e2z, e3x, e3y, e3z)
    scale = (math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
             * math.sqrt(e2x * e2x + e2y * e2y + e2z * e2z)
             * math.sqrt(e3x * e3x + e3y * e3y + e3z * e3z))
    flat = not abs(volume) > FLAT_RELATIVE * scale
    b1 = b2 = b3 = b0 = -1.0
    if not flat:
        b1 = _det(-ax, -ay, -az, e2x, e2y, e2z, e3x, e3y, e3z) / volume
        b2 = _det(e1x, e1y, e1z, -ax, -ay, -az, e3x, e3y, e3z) / volume
        b3 = _det(e1x, e1y, e1z, e2x, e2y, e2z, -ax, -ay, -az) / volume
        b0 = 1.0 - b1 - b2 - b3
        if b0 >= 0.0 and b1 >= 0.0 and b2 >= 0.0 and b3 >= 0.0:
            return 4, True
    best, found = math.inf, False
    bu, bv, bw, bmask, bi, bj, bk = 0.0, 0.0, 0.0, 0, 0, 0, 0
    for f in range(4):
        i, j, k, o = _tetra_face(f)
        opposite = b0 if o == 0 else (b1 if o == 1 else (b2 if o == 2 else b3))
        if flat or opposite < 0.0:
            u, v, w, mask = _triangle(W, i, j, k)
            px = u * float(W[i, 0]) + v * float(W[j, 0]) + w * float(W[k, 0])
            py = u * float(W[i, 1]) + v * float(W[j, 1]) + w * float(W[k, 1])
            pz = u * float(W[i, 2]) + v * float(W[j, 2]) + w * float(W[k, 2])
            d2 = px * px + py * py + pz * pz
            if not found or d2 < best:
                best, found = d2, True
                bu, bv, bw, bmask, bi, bj, bk = u, v, w, mask, i, j, k
    if not found:
        return 4, True
    return _apply_mask(W, PA, PB, lam, idx, weights, scratch, bi, bj, bk, bu, bv, bw,
                       bmask), False


@inline_kernel
def _apply_mask(W, PA, PB, lam, idx, weights, scratch, i, j, k, u, v, w, mask):
    """Keep the vertices of i, j, k that ``mask`` names, with weights u, v, w."""
    count = 0
    if mask & 1:
        idx[count], weights[count] = i, u
        count += 1
    if mask & 2:
        idx[count], weights[count] = j, v
        count += 1
    if mask & 4:
        idx[count], weights[count] = k, w
        count += 1
    _keep(W, PA, PB, lam, idx, weights, count, scratch)
    return count


@kernel
def _gjk(ka, ga, ca, ra, kb, gb, cb, rb, pool, W, PA, PB, lam, beyond):
    """GJK on the cores of A and B: (n, overlap, size2), n = -1 when the cores are found
    farther apart than ``beyond`` (m: a plane square to v lies between them that far from
    one, so no nearer points need be found). On return W[:n], PA[:n], PB[:n] and lam[:n]
    give the closest points (a = sum lam PA, b = sum lam PB) when apart; overlap when the
    cores touch or overlap (then W[:n] is the last simplex, for EPA); size2 the largest
    squared support point met (the scale of the tolerances)."""
    vx = float(ca[0]) - float(cb[0])
    vy = float(ca[1]) - float(cb[1])
    vz = float(ca[2]) - float(cb[2])
    if vx * vx + vy * vy + vz * vz <= 0.0:
        vx, vy, vz = 1.0, 0.0, 0.0
    n = 0
    size2 = 0.0
    vv = math.inf
    W_back = stack_empty(4, 3, np.float64)
    PA_back = stack_empty(4, 3, np.float64)
    PB_back = stack_empty(4, 3, np.float64)
    lam_back = stack_empty(4, 0, np.float64)
    idx = stack_empty(4, 0, np.int64)
    weights = stack_empty(4, 0, np.float64)
    scratch = stack_empty(4, 9, np.float64)
    for _ in range(GJK_ITERATIONS):
        _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, -vx, -vy, -vz, n, W, PA, PB)
        wx, wy, wz = float(W[n, 0]), float(W[n, 1]), float(W[n, 2])
        w2 = wx * wx + wy * wy + wz * wz
        if w2 > size2:
            size2 = w2
        vw = vx * wx + vy * wy + vz * wz
        if vw > 0.0 and vw * vw > beyond * beyond * (vx * vx + vy * vy + vz * vz):
            # (the distance is at least vw / |v|)
            return -1, False, size2
        if n > 0 and vv - vw <= GJK_RELATIVE * vv:
            return n, False, size2  # w brings nothing: v is the nearest point
        for m in range(n):  # w is a vertex already: v is as near as it gets
            if W[m, 0] == wx and W[m, 1] == wy and W[m, 2] == wz:
                # apart only if the plane square to v through w separates (else rounding
                # stalled GJK on overlapping cores: EPA)
                return n, not vx * wx + vy * wy + vz * wz > 0.0, size2
        for m in range(n):  # kept, should the next simplex be no nearer (rounding)
            lam_back[m] = lam[m]
            for q in range(3):
                W_back[m, q], PA_back[m, q], PB_back[m, q] = W[m, q], PA[m, q], PB[m, q]
        before = n
        n += 1
        n, inside = _closest(W, PA, PB, lam, n, idx, weights, scratch)
        if inside:
            return n, True, size2
        nx, ny, nz = 0.0, 0.0, 0.0
        for m in range(n):
            nx += float(lam[m]) * float(W[m, 0])
            ny += float(lam[m]) * float(W[m, 1])
            nz += float(lam[m]) * float(W[m, 2])
        new = nx * nx + ny * ny + nz * nz
        if new <= TOUCH_RELATIVE * TOUCH_RELATIVE * size2:
            return n, True, size2
        if not new < vv:  # no progress (rounding): the last simplex is as near as it gets
            for m in range(before):
                lam[m] = lam_back[m]
                for q in range(3):
                    W[m, q], PA[m, q], PB[m, q] = W_back[m, q], PA_back[m, q], PB_back[m, q]
            return before, not vx * wx + vy * wy + vz * wz > 0.0, size2  # (as above)
        vx, vy, vz, vv = nx, ny, nz, new
    return n, False, size2


# -- EPA --------------------------------------------------------------------------------------
@inline_kernel
def _face_plane(V, FV, FN, FD, f):
    """Face f's unit outward normal and distance from the origin; False if degenerate (a
    sliver: normal 0, distance inf, so that it is never the nearest nor seen, but keeps its
    place between its neighbours)."""
    i, j, k = int(FV[f, 0]), int(FV[f, 1]), int(FV[f, 2])
    ax, ay, az = float(V[i, 0]), float(V[i, 1]), float(V[i, 2])
    e1x, e1y, e1z = float(V[j, 0]) - ax, float(V[j, 1]) - ay, float(V[j, 2]) - az
    e2x, e2y, e2z = float(V[k, 0]) - ax, float(V[k, 1]) - ay, float(V[k, 2]) - az
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if not length > TINY_LENGTH:
        FN[f, 0], FN[f, 1], FN[f, 2] = 0.0, 0.0, 0.0
        FD[f] = math.inf
        return False
    nx, ny, nz = nx / length, ny / length, nz / length
    FN[f, 0], FN[f, 1], FN[f, 2] = nx, ny, nz
    FD[f] = nx * ax + ny * ay + nz * az
    return True


@kernel
def _blow_up(ka, ga, ca, ra, kb, gb, cb, rb, pool, W, PA, PB, n, size2):
    """Grow GJK's simplex (the origin on or in it) to a tetrahedron of A - B; returns its
    vertex count (4, or less when A - B is flat there: no EPA)."""
    eps = 1e-9 * math.sqrt(size2)
    if n == 1:
        for q in range(6):
            dx = 1.0 if q == 0 else (-1.0 if q == 1 else 0.0)
            dy = 1.0 if q == 2 else (-1.0 if q == 3 else 0.0)
            dz = 1.0 if q == 4 else (-1.0 if q == 5 else 0.0)
            _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, dx, dy, dz, int(1), W, PA, PB)
            ex, ey, ez = (float(W[1, 0]) - float(W[0, 0]), float(W[1, 1]) - float(W[0, 1]),
                          float(W[1, 2]) - float(W[0, 2]))
            if ex * ex + ey * ey + ez * ez > eps * eps:
                n = 2
                break
        if n < 2:
            return n
    if n == 2:
        ex, ey, ez = (float(W[1, 0]) - float(W[0, 0]), float(W[1, 1]) - float(W[0, 1]),
                      float(W[1, 2]) - float(W[0, 2]))
        # a direction square to the segment: e x (the axis least along e)
        px, py, pz = _square_to(ex, ey, ez)
        qx, qy, qz = ey * pz - ez * py, ez * px - ex * pz, ex * py - ey * px
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        for q in range(4):
            dx, dy, dz = (px, py, pz) if q == 0 else ((-px, -py, -pz) if q == 1 else
                                                      ((qx, qy, qz) if q == 2 else
                                                       (-qx, -qy, -qz)))
            _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, dx, dy, dz, int(2), W, PA, PB)
            # its distance from the segment's line
            rx, ry, rz = (float(W[2, 0]) - float(W[0, 0]), float(W[2, 1]) - float(W[0, 1]),
                          float(W[2, 2]) - float(W[0, 2]))
            cx, cy, cz = ry * ez - rz * ey, rz * ex - rx * ez, rx * ey - ry * ex
            if math.sqrt(cx * cx + cy * cy + cz * cz) > eps * length:
                n = 3
                break
        if n < 3:
            return n
    if n == 3:
        ax, ay, az = float(W[0, 0]), float(W[0, 1]), float(W[0, 2])
        e1x, e1y, e1z = float(W[1, 0]) - ax, float(W[1, 1]) - ay, float(W[1, 2]) - az
        e2x, e2y, e2z = float(W[2, 0]) - ax, float(W[2, 1]) - ay, float(W[2, 2]) - az
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        if not length > 0.0:
            return n
        for q in range(2):
            s = 1.0 if q == 0 else -1.0
            _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, s * nx, s * ny, s * nz, int(3),
                       W, PA, PB)
            h = (_dot(W, 3, nx, ny, nz) - (nx * ax + ny * ay + nz * az)) / length
            if abs(h) > eps:
                return 4
        return n
    return n


@kernel
def _epa(ka, ga, ca, ra, kb, gb, cb, rb, pool, W, PA, PB, size2):
    """EPA from the tetrahedron W[:4], PA, PB (the origin in it): (ok, nx, ny, nz, depth, a, b)
    with n the normal (A to B) of the face of A - B nearest the origin, depth its distance and
    a, b the cores' points there (barycentric on the face)."""
    V = stack_empty(EPA_VERTICES, 3, np.float64)
    VA = stack_empty(EPA_VERTICES, 3, np.float64)
    VB = stack_empty(EPA_VERTICES, 3, np.float64)
    FV = stack_empty(EPA_FACES, 3, np.int64)
    FN = stack_empty(EPA_FACES, 3, np.float64)
    FD = stack_empty(EPA_FACES, 0, np.float64)
    alive = stack_empty(EPA_FACES, 0, np.bool_)
    alive[:] = False
    edges = stack_empty(EPA_EDGES, 2, np.int64)
    stack = stack_empty(EPA_FACES, 0, np.int64)
    for m in range(4):
        for q in range(3):
            V[m, q], VA[m, q], VB[m, q] = W[m, q], PA[m, q], PB[m, q]
    nv, nf = 4, 4
    for f in range(4):
        i, j, k, o = _tetra_face(f)
        FV[f, 0], FV[f, 1], FV[f, 2] = i, j, k
        if not _face_plane(V, FV, FN, FD, f):
            return False, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        if _dot(V, o, float(FN[f, 0]), float(FN[f, 1]), float(FN[f, 2])) > FD[f]:
            FV[f, 1], FV[f, 2] = k, j  # the fourth vertex above: turn it outward
            _face_plane(V, FV, FN, FD, f)
        alive[f] = True
    tolerance = EPA_RELATIVE * math.sqrt(size2)
    # the last good face: its normal, distance and the cores' points there
    good = False
    gx, gy, gz, gd = 0.0, 0.0, 1.0, 0.0
    gax, gay, gaz, gbx, gby, gbz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for _ in range(EPA_VERTICES):
        best, nearest = -1, math.inf
        for f in range(nf):
            if alive[f] and float(FD[f]) < nearest:
                best, nearest = f, float(FD[f])
        if best < 0 or (good and nearest < gd - tolerance):
            break  # no face, or the polytope went bad: the last good face stands
        nx, ny, nz = float(FN[best, 0]), float(FN[best, 1]), float(FN[best, 2])
        i, j, k = int(FV[best, 0]), int(FV[best, 1]), int(FV[best, 2])
        u, v, w = _barycentric(V, i, j, k, nearest * nx, nearest * ny, nearest * nz,
                               nx, ny, nz)
        good, gx, gy, gz, gd = True, nx, ny, nz, nearest
        gax = u * float(VA[i, 0]) + v * float(VA[j, 0]) + w * float(VA[k, 0])
        gay = u * float(VA[i, 1]) + v * float(VA[j, 1]) + w * float(VA[k, 1])
        gaz = u * float(VA[i, 2]) + v * float(VA[j, 2]) + w * float(VA[k, 2])
        gbx = u * float(VB[i, 0]) + v * float(VB[j, 0]) + w * float(VB[k, 0])
        gby = u * float(VB[i, 1]) + v * float(VB[j, 1]) + w * float(VB[k, 1])
        gbz = u * float(VB[i, 2]) + v * float(VB[j, 2]) + w * float(VB[k, 2])
        if nv == EPA_VERTICES:
            break
        _minkowski(ka, ga, ca, ra, kb, gb, cb, rb, pool, nx, ny, nz, nv, V, VA, VB)
        reach = _dot(V, nv, nx, ny, nz)
        if reach - nearest <= tolerance:
            break
        # remove the faces the new point sees, grown from the nearest one across its edges
        # (so the removed faces are one patch, even where rounding makes a far face look
        # seen); the edges where a removed face meets a kept one are the horizon, each
        # joined to the new point by a new face
        wx, wy, wz = float(V[nv, 0]), float(V[nv, 1]), float(V[nv, 2])
        ne = 0
        alive[best] = False
        stack[0] = best
        top = 1
        while top > 0:
            top -= 1
            f = int(stack[top])
            for q in range(3):
                s, t = int(FV[f, q]), int(FV[f, (q + 1) % 3])
                g = _face_across(FV, alive, nf, s, t)
                if g < 0:
                    continue  # removed already: an inner edge of the patch
                i0 = int(FV[g, 0])
                if (float(FN[g, 0]) * (wx - float(V[i0, 0]))
                        + float(FN[g, 1]) * (wy - float(V[i0, 1]))
                        + float(FN[g, 2]) * (wz - float(V[i0, 2]))) > 0.0:
                    alive[g] = False
                    stack[top] = g
                    top += 1
                else:
                    edges[ne, 0], edges[ne, 1] = s, t
                    ne += 1
        for e in range(ne):
            s, t = int(edges[e, 0]), int(edges[e, 1])
            slot = 0  # a removed face's place, else a new one
            while slot < nf and alive[slot]:
                slot += 1
            if slot == nf:
                if nf == EPA_FACES:
                    break
                nf += 1
            FV[slot, 0], FV[slot, 1], FV[slot, 2] = s, t, nv
            _face_plane(V, FV, FN, FD, slot)
            alive[slot] = True
        nv += 1
    return good, gx, gy, gz, gd, gax, gay, gaz, gbx, gby, gbz


@inline_kernel
def _face_across(FV, alive, nf, s, t):
    """The live face that has the edge t -> s (the other side of a face's edge s -> t), or
    -1."""
    for h in range(nf):
        if alive[h]:
            for r in range(3):
                if int(FV[h, r]) == t and int(FV[h, (r + 1) % 3]) == s:
                    return h
    return -1


@inline_kernel
def _barycentric(V, i, j, k, px, py, pz, nx, ny, nz):
    """The barycentric coordinates of p (in the plane of triangle V[i], V[j], V[k], unit
    normal n) by signed areas; the centroid's for a degenerate triangle."""
    ax, ay, az = float(V[i, 0]), float(V[i, 1]), float(V[i, 2])
    bx, by, bz = float(V[j, 0]), float(V[j, 1]), float(V[j, 2])
    cx, cy, cz = float(V[k, 0]), float(V[k, 1]), float(V[k, 2])
    total = _area(ax, ay, az, bx, by, bz, cx, cy, cz, nx, ny, nz)
    if not abs(total) > 0.0:
        return 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    u = _area(px, py, pz, bx, by, bz, cx, cy, cz, nx, ny, nz) / total
    v = _area(ax, ay, az, px, py, pz, cx, cy, cz, nx, ny, nz) / total
    return u, v, 1.0 - u - v


@inline_kernel
def _area(ax, ay, az, bx, by, bz, cx, cy, cz, nx, ny, nz):
    """Twice the signed area of the triangle a, b, c seen along n."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    return ((e1y * e2z - e1z * e2y) * nx + (e1z * e2x - e1x * e2z) * ny
            + (e1x * e2y - e1y * e2x) * nz)


# -- the manifold -------------------------------------------------------------------------------
@inline_kernel
def _world_face(kind, geom, centre, rot, pool, dx, dy, dz, shift, out, tags):
    """The world points of the core's face along the world direction d (unit), each moved by
    ``shift`` along d (the rounding radius); their count."""
    lx, ly, lz = _apply_t(rot, dx, dy, dz)
    count = shapes.core_face_of(kind, geom, pool, lx, ly, lz, out, tags)
    for m in range(count):
        wx, wy, wz = _apply(rot, float(out[m, 0]), float(out[m, 1]), float(out[m, 2]))
        out[m, 0] = float(centre[0]) + wx + shift * dx
        out[m, 1] = float(centre[1]) + wy + shift * dy
        out[m, 2] = float(centre[2]) + wz + shift * dz
    return count


# (the name the terrain's contact test reads it by)
world_face = _world_face


@kernel
def _manifold(ref, nref, inc, inc_tags, ninc, ux, uy, uz, margin, deepest, sign, base,
              point, normal, depth, feature, row):
    """The incident face inc[:ninc] clipped to the sides of the reference face ref[:nref]
    (a polygon of 3 or more points, or a segment of 2 with a parallel segment of 2 as the
    incident face), u the unit normal out of the
    reference face towards the incident one: each clipped point whose depth (its distance
    below the reference face, along u) is at least -margin is a contact, moved halfway up,
    at most 4; normal sign * u (A to B). A reference face more than acos(FACE_COS) off u does
    not touch flat (an edge or a rim does): -1. No depth is more than ``deepest`` (the
    overlap of the shapes along u: no point of them overlaps more). Returns the count, or -1
    when the clip fails (then the caller writes the single contact)."""
    poly = stack_empty(CLIP_ROOM, 3, np.float64)
    tags = stack_empty(CLIP_ROOM, 0, np.int64)
    other = stack_empty(CLIP_ROOM, 3, np.float64)
    other_tags = stack_empty(CLIP_ROOM, 0, np.int64)
    for m in range(ninc):
        poly[m, 0], poly[m, 1], poly[m, 2] = inc[m, 0], inc[m, 1], inc[m, 2]
        tags[m] = inc_tags[m]
    count = ninc
    # the reference's centroid (inside every side plane)
    gx, gy, gz = 0.0, 0.0, 0.0
    for m in range(nref):
        gx += float(ref[m, 0])
        gy += float(ref[m, 1])
        gz += float(ref[m, 2])
    gx, gy, gz = gx / nref, gy / nref, gz / nref
    # the reference face's plane normal f (polygon: Newell's; segment: u itself)
    fx, fy, fz = ux, uy, uz
    if nref >= 3:
        fx, fy, fz = 0.0, 0.0, 0.0
        for m in range(nref):
            q = m + 1 if m + 1 < nref else 0
            fx += (float(ref[m, 1]) - float(ref[q, 1])) * (float(ref[m, 2]) + float(ref[q, 2]))
            fy += (float(ref[m, 2]) - float(ref[q, 2])) * (float(ref[m, 0]) + float(ref[q, 0]))
            fz += (float(ref[m, 0]) - float(ref[q, 0])) * (float(ref[m, 1]) + float(ref[q, 1]))
        length = math.sqrt(fx * fx + fy * fy + fz * fz)
        if not length > TINY_LENGTH:
            return -1
        fx, fy, fz = fx / length, fy / length, fz / length
        if fx * ux + fy * uy + fz * uz < 0.0:
            fx, fy, fz = -fx, -fy, -fz
    cos = fx * ux + fy * uy + fz * uz
    if not cos >= FACE_COS:  # the face is not what touches: an edge or a rim does
        return -1
    if nref == 2:  # two lines touch along a length only where they are parallel
        if ninc != 2:
            return -1
        ex = float(ref[1, 0]) - float(ref[0, 0])
        ey = float(ref[1, 1]) - float(ref[0, 1])
        ez = float(ref[1, 2]) - float(ref[0, 2])
        dx = float(inc[1, 0]) - float(inc[0, 0])
        dy = float(inc[1, 1]) - float(inc[0, 1])
        dz = float(inc[1, 2]) - float(inc[0, 2])
        along = ex * dx + ey * dy + ez * dz
        if not along * along >= (FACE_COS * FACE_COS * (ex * ex + ey * ey + ez * ez)
                                 * (dx * dx + dy * dy + dz * dz)):
            return -1
    planes = nref if nref >= 3 else 2
    for e in range(planes):
        if nref >= 3:
            q = e + 1 if e + 1 < nref else 0
            ex = float(ref[q, 0]) - float(ref[e, 0])
            ey = float(ref[q, 1]) - float(ref[e, 1])
            ez = float(ref[q, 2]) - float(ref[e, 2])
            sx, sy, sz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
            ox, oy, oz = float(ref[e, 0]), float(ref[e, 1]), float(ref[e, 2])
        else:  # a segment: the planes square to it through its ends
            ex = float(ref[1, 0]) - float(ref[0, 0])
            ey = float(ref[1, 1]) - float(ref[0, 1])
            ez = float(ref[1, 2]) - float(ref[0, 2])
            sx, sy, sz = (ex, ey, ez) if e == 1 else (-ex, -ey, -ez)
            ox, oy, oz = float(ref[e, 0]), float(ref[e, 1]), float(ref[e, 2])
        length = math.sqrt(sx * sx + sy * sy + sz * sz)
        if not length > TINY_LENGTH:
            continue  # a repeated point: no side
        sx, sy, sz = sx / length, sy / length, sz / length
        if sx * (gx - ox) + sy * (gy - oy) + sz * (gz - oz) > 0.0:
            sx, sy, sz = -sx, -sy, -sz
        limit = sx * ox + sy * oy + sz * oz
        if count == 1:  # a point: kept or not
            if sx * float(poly[0, 0]) + sy * float(poly[0, 1]) + sz * float(poly[0, 2]) > limit:
                return 0
            continue
        if count == 2:  # a segment: cut at the plane
            if _clip_segment(poly, tags, sx, sy, sz, limit, e) == 0:
                return 0
            continue
        if count > CLIP_ROOM // 2:  # (before the clip writes: it could overrun)
            return -1
        count = _clip_polygon(poly, tags, count, other, other_tags, sx, sy, sz, limit, e)
        if count == 0:
            return 0
        for m in range(count):
            poly[m, 0], poly[m, 1], poly[m, 2] = other[m, 0], other[m, 1], other[m, 2]
            tags[m] = other_tags[m]
    # each point's depth below the reference: along u to its plane (or to its line)
    depths = stack_empty(CLIP_ROOM, 0, np.float64)
    kept = 0
    rx, ry, rz = float(ref[0, 0]), float(ref[0, 1]), float(ref[0, 2])
    for m in range(count):
        px, py, pz = float(poly[m, 0]), float(poly[m, 1]), float(poly[m, 2])
        if nref >= 3:
            s = ((px - rx) * fx + (py - ry) * fy + (pz - rz) * fz) / cos
        else:  # the nearest point of the segment's line, then along u
            ex = float(ref[1, 0]) - rx
            ey = float(ref[1, 1]) - ry
            ez = float(ref[1, 2]) - rz
            e2 = ex * ex + ey * ey + ez * ez
            t = ((px - rx) * ex + (py - ry) * ey + (pz - rz) * ez) / e2 if e2 > 0.0 else 0.0
            gx_ = px - (rx + t * ex)
            gy_ = py - (ry + t * ey)
            gz_ = pz - (rz + t * ez)
            s = gx_ * ux + gy_ * uy + gz_ * uz
            # the offset across u: lines that pass each other aside do not touch there
            ax_, ay_, az_ = gx_ - s * ux, gy_ - s * uy, gz_ - s * uz
            if ax_ * ax_ + ay_ * ay_ + az_ * az_ > margin * margin + TOUCH_RELATIVE * e2:
                continue
        if -s >= -margin:
            if -s > deepest:
                s = -deepest
            h = 0.5 * s
            other[kept, 0], other[kept, 1], other[kept, 2] = px - h * ux, py - h * uy, pz - h * uz
            other_tags[kept] = tags[m]
            depths[kept] = -s
            kept += 1
    return _write_four(other, depths, other_tags, kept, ux, uy, uz, sign, base,
                       point, normal, depth, feature, row)


@inline_kernel
def _edge_from(tag):
    """The edge that starts at the clipped face's point tagged ``tag``: the face's own edge
    from its corner ``tag`` (< 64), or, from a crossing, the edge it was on (entering: the
    face's edge goes on) or the line of the side it crossed (leaving: the clipped face runs
    along that side), 64 + the side."""
    if tag < CROSSINGS:
        return tag
    crossing = (tag - CROSSINGS) // 2
    if (tag - CROSSINGS) % 2 == 1:  # entering
        return crossing // SIDES
    return CROSSINGS + crossing % SIDES


@inline_kernel
def _crossing_tag(start, side, entering):
    """The feature of the point where the edge from the point tagged ``start`` crosses the
    reference's side ``side`` (0 to 8), entering (1) or leaving (0) it: CROSSINGS + 2 (9 e +
    side) + entering, e the edge (``_edge_from``), below CROSSINGS + 2 * 9 * 73 = 1378. An
    edge (a face's or a side's line) crosses a side's plane once, so each crossing of a face
    has a tag of its own."""
    return CROSSINGS + 2 * (SIDES * _edge_from(start) + side) + entering


@inline_kernel
def _clip_polygon(src, src_tag, count, dst, dst_tag, ux, uy, uz, limit, side):
    """Sutherland-Hodgman: the part of the polygon src[:count] with u . p <= limit, into
    dst; its count. A crossing is tagged ``_crossing_tag`` of its edge's start."""
    out = 0
    for k in range(count):
        q = k + 1 if k + 1 < count else 0
        px, py, pz = float(src[k, 0]), float(src[k, 1]), float(src[k, 2])
        qx, qy, qz = float(src[q, 0]), float(src[q, 1]), float(src[q, 2])
        dp = ux * px + uy * py + uz * pz - limit
        dq = ux * qx + uy * qy + uz * qz - limit
        if dp <= 0.0:
            dst[out, 0], dst[out, 1], dst[out, 2] = px, py, pz
            dst_tag[out] = src_tag[k]
            out += 1
        if (dp < 0.0 and dq > 0.0) or (dq < 0.0 and dp > 0.0):
            t = dp / (dp - dq)  # strictly opposite signs: dp - dq != 0
            dst[out, 0] = px + t * (qx - px)
            dst[out, 1] = py + t * (qy - py)
            dst[out, 2] = pz + t * (qz - pz)
            dst_tag[out] = _crossing_tag(int(src_tag[k]), side, 1 if dp > 0.0 else 0)
            out += 1
    return out


@inline_kernel
def _clip_segment(seg, tags, sx, sy, sz, limit, plane):
    """The part of the segment seg[0], seg[1] with s . p <= limit, in place; 0 if none, else
    2 (a cut end gets the tag of a crossing, ``_crossing_tag``)."""
    d0 = sx * float(seg[0, 0]) + sy * float(seg[0, 1]) + sz * float(seg[0, 2]) - limit
    d1 = sx * float(seg[1, 0]) + sy * float(seg[1, 1]) + sz * float(seg[1, 2]) - limit
    if d0 > 0.0 and d1 > 0.0:
        return 0
    if d0 <= 0.0 and d1 <= 0.0:
        return 2
    t = d0 / (d0 - d1)  # opposite signs: d0 - d1 != 0
    px = float(seg[0, 0]) + t * (float(seg[1, 0]) - float(seg[0, 0]))
    py = float(seg[0, 1]) + t * (float(seg[1, 1]) - float(seg[0, 1]))
    pz = float(seg[0, 2]) + t * (float(seg[1, 2]) - float(seg[0, 2]))
    end = 0 if d0 > 0.0 else 1
    tag = _crossing_tag(int(tags[0]), plane, 1 if end == 0 else 0)
    seg[end, 0], seg[end, 1], seg[end, 2] = px, py, pz
    tags[end] = tag
    return 2


# -- the pair tests ---------------------------------------------------------------------------
@kernel
def convex_pair(ka, ga, ca, rota, kb, gb, cb, rotb, pool, margin, point, normal, depth, feature,
                row):
    """The contacts of two solid shapes (see the module doc) within ``margin``: written from
    ``row``; their count (0 to 4)."""
    W = stack_empty(4, 3, np.float64)
    PA = stack_empty(4, 3, np.float64)
    PB = stack_empty(4, 3, np.float64)
    lam = stack_empty(4, 0, np.float64)
    rad_a = shapes.core_radius_of(ka, ga)
    rad_b = shapes.core_radius_of(kb, gb)
    n, overlap, size2 = _gjk(ka, ga, ca, rota, kb, gb, cb, rotb, pool, W, PA, PB, lam,
                             rad_a + rad_b + margin)
    if n < 0:  # apart by more than the margin
        return 0
    ok = False
    nx, ny, nz, core_depth = 0.0, 0.0, 1.0, 0.0
    ax, ay, az, bx, by, bz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if not overlap:
        for m in range(n):
            ax += float(lam[m]) * float(PA[m, 0])
            ay += float(lam[m]) * float(PA[m, 1])
            az += float(lam[m]) * float(PA[m, 2])
            bx += float(lam[m]) * float(PB[m, 0])
            by += float(lam[m]) * float(PB[m, 1])
            bz += float(lam[m]) * float(PB[m, 2])
        dx, dy, dz = bx - ax, by - ay, bz - az
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        if rad_a + rad_b - dist < -margin:
            return 0
        if dist > TINY_LENGTH:
            nx, ny, nz, core_depth, ok = dx / dist, dy / dist, dz / dist, -dist, True
    if not ok:
        if _blow_up(ka, ga, ca, rota, kb, gb, cb, rotb, pool, W, PA, PB, n, size2) == 4:
            ok, nx, ny, nz, core_depth, ax, ay, az, bx, by, bz = _epa(
                ka, ga, ca, rota, kb, gb, cb, rotb, pool, W, PA, PB, size2)
    if not ok:  # flat or failed: the centres' direction and the overlap along it
        nx, ny, nz = float(cb[0]) - float(ca[0]), float(cb[1]) - float(ca[1]), \
            float(cb[2]) - float(ca[2])
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        if length > TINY_LENGTH:
            nx, ny, nz = nx / length, ny / length, nz / length
        else:
            nx, ny, nz = 0.0, 0.0, 1.0
        ax, ay, az = _support(ka, ga, ca, rota, pool, nx, ny, nz)
        bx, by, bz = _support(kb, gb, cb, rotb, pool, -nx, -ny, -nz)
        core_depth = (ax - bx) * nx + (ay - by) * ny + (az - bz) * nz
    curved_a, curved_b = shapes.CURVED[ka], shapes.CURVED[kb]
    if curved_a or curved_b:
        nx, ny, nz, core_depth, ax, ay, az, bx, by, bz = _refine(
            ka, ga, ca, rota, kb, gb, cb, rotb, pool, curved_a, curved_b, nx, ny, nz, core_depth,
            ax, ay, az, bx, by, bz)
    deepest = core_depth + rad_a + rad_b
    if deepest < -margin:
        return 0
    # the faces: A's along n, B's along -n, each on its rounded surface
    face_a = stack_empty(CORE_FACE, 3, np.float64)
    tags_a = stack_empty(CORE_FACE, 0, np.int64)
    face_b = stack_empty(CORE_FACE, 3, np.float64)
    tags_b = stack_empty(CORE_FACE, 0, np.int64)
    na = _world_face(ka, ga, ca, rota, pool, nx, ny, nz, rad_a, face_a, tags_a)
    nb = _world_face(kb, gb, cb, rotb, pool, -nx, -ny, -nz, rad_b, face_b, tags_b)
    count = -1  # (a point against anything: the one contact of the closest points is exact)
    if na >= 2 and nb >= 2 and na >= nb:
        count = _manifold(face_a, na, face_b, tags_b, nb, nx, ny, nz, margin, deepest, 1.0,
                          FACE_FEATURES, point, normal, depth, feature, row)
    elif na >= 2 and nb >= 2:
        count = _manifold(face_b, nb, face_a, tags_a, na, -nx, -ny, -nz, margin, deepest, -1.0,
                          FACE_FEATURES + REFERENCE_B, point, normal, depth, feature, row)
    if count > 0:
        return count
    # one contact: the closest points on the rounded surfaces
    _put(point, normal, depth, feature, row, ax + rad_a * nx, ay + rad_a * ny, az + rad_a * nz,
         bx - rad_b * nx, by - rad_b * ny, bz - rad_b * nz, nx, ny, nz, POINT_FEATURE)
    return 1


@kernel
def convex_plane(kind, geom, centre, rot, pool, p, n, margin, point, normal, depth, feature, row):
    """A solid shape against a half-space (point p, unit normal n = geom[NORMAL:]): the points
    of its core's face along -n whose height s above the plane less the radius is at most
    ``margin``, halfway to the plane, normal -n, depth -s, features the face's tags; at most
    4 (``contact_geometry.write_at_most_four``)."""
    nx, ny, nz = float(n[NORMAL]), float(n[NORMAL + 1]), float(n[NORMAL + 2])
    px, py, pz = float(p[0]), float(p[1]), float(p[2])
    radius = shapes.core_radius_of(kind, geom)
    face = stack_empty(CORE_FACE, 3, np.float64)
    tags = stack_empty(CORE_FACE, 0, np.int64)
    count = _world_face(kind, geom, centre, rot, pool, -nx, -ny, -nz, radius, face, tags)
    kept = 0
    depths = stack_empty(CORE_FACE, 0, np.float64)
    for m in range(count):
        vx, vy, vz = float(face[m, 0]), float(face[m, 1]), float(face[m, 2])
        s = (vx - px) * nx + (vy - py) * ny + (vz - pz) * nz
        if -s >= -margin:
            h = 0.5 * s
            face[kept, 0], face[kept, 1], face[kept, 2] = vx - h * nx, vy - h * ny, vz - h * nz
            tags[kept] = tags[m]
            depths[kept] = -s
            kept += 1
    return _write_four(face, depths, tags, kept, -nx, -ny, -nz, 1.0, int(0),
                       point, normal, depth, feature, row)
