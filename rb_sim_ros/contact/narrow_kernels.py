# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The narrow phase as compiled float kernels: the contacts of placed shapes, on arrays.

A shape is four values (or one row of four per-collider arrays): its kind (KIND_*), ``geom``
float64[5] = (radius, half_length, hx, hy, hz) in m, ``centre`` float64[3] (m, world frame)
and ``rot`` float64[9], the rotation from the shape's frame to the world, row-major:
rot[3 i + j] = R_ij, so local axis j is the world vector (rot[j], rot[3 + j], rot[6 + j]). A
sphere uses the radius; a capsule the radius and half_length (its segment runs along its local
z axis); a box its half extents; a plane (static only) has centre = one of its points and
geom[2:5] = its unit normal (world frame, out of the solid); rot is not read.

``collide_pair_of`` and ``collide_pairs_of`` take first a set of contact tests (``PAIR_BIT``,
one bit a pair of kinds), a constant where a kernel calls them: only those tests are compiled
into the caller, and a pair outside the set is a ValueError, in either tier (a world's step
is compiled for the pairs its shapes can meet: ``pair_set``). ``collide_pair`` and
``collide_pairs`` are them with every test.

``collide_pair`` writes the contacts of one pair to rows start, start + 1, ... of point (K, 3)
(m), normal (K, 3) (unit), depth (K,) (m), feature (K,) int64 (world frame) and returns how
many; the outputs must have MAX_CONTACTS_PER_PAIR rows from ``start`` (ValueError otherwise).
``collide_pairs`` does so for P candidate pairs of colliders, in pair order, and
``sphere_batch`` for many ball-ball or ball-plane pairs without the per-pair dispatch (the
batches of narrow_phase, for large scenes). Conventions: those of narrow_phase's module doc
(normal from A to B; depth > 0 overlapping, < 0 a gap of at most ``margin``; point midway
between the surfaces). KIND_* are collision_shapes.RANK: a pair is computed with rank(A) <=
rank(B) (a plane is B but for the cylinder, which comes after it) and a pair given the other
way round is computed swapped, its normals negated. The cylinder's pairs are the convex
narrow phase's (``convex_kernels``).

Features (stable while the same features touch; ``collision_world`` keys warm starts on them):
0 for every pair with a sphere; capsule-plane 0, 1 the end balls at -h, +h; capsule-capsule 0
the closest points, 1, 2 the ends of the overlap of parallel segments; capsule-box 10 the
nearest point, 0, 1 the segment's ends, 2 + 2 i + s the crossing of the box face plane
x_i = -h_i (s = 0) or +h_i (s = 1), 20, 21 the ends of a segment inside the box; box-plane the
vertex 4 ix + 2 iy + iz (index 1 at +h along that axis); box-box 200 + 3 i + j an edge of A
along its axis i against one of B along j, else 1000 (reference axis + 1) + 500 (incident
face on the -side of its axis k) + 10 k + the clipping tag (``_clip``), plus 100 when B holds
the reference face; the cylinder's pairs as ``convex_kernels`` says.

Everything is + - * / abs sqrt on float64, loops written out, sums in a written order, no numpy
call that could use BLAS or SIMD reductions: the compiled and interpreted (NUMBA_DISABLE_JIT=1)
paths give the same bits. Every division and square root is guarded so that neither path
raises on any input: non-finite inputs give meaningless contacts, never an exception or a
write out of bounds (indices and output sizes are checked).

numba compiles a kernel once more for each literal int or bool argument a call passes it
(Literal[int](0)), and type inference passes a loop variable first set to a constant as that
literal: so an int handed to a kernel is never a bare constant nor a variable first set to
one, but ``int(0)`` (a plain int64 to numba, the same 0 to the interpreter), and a flag is a
float sign. Each kernel is compiled once.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.contact import convex_kernels, shapes, terrain_kernels
from rb_sim_ros.contact.contact_geometry import (apply as _apply, apply_t as _apply_t,
                                                 clamp as _clamp, clip as _clip,
                                                 column as _column, put as _put, TINY_LENGTH,
                                                 unit as _unit, write as _write,
                                                 write_at_most_four as _write_four)
from rb_sim_ros.contact.shapes.base import GEOM_WIDTH, HALF_LENGTH, HX, HY, HZ, NORMAL, RADIUS
from rb_sim_ros.core.jit import (generated_kernel, inline_kernel, kernel, literal_entry,
                                 literal_gate, made_global, stack_empty)

KIND_SPHERE, KIND_CAPSULE, KIND_BOX, KIND_PLANE, KIND_CYLINDER, KIND_HULL, KIND_ELLIPSOID = (
    shapes.sphere.KIND, shapes.capsule.KIND, shapes.box.KIND, shapes.plane.KIND,
    shapes.cylinder.KIND, shapes.hull.KIND, shapes.ellipsoid.KIND)
KIND_TERRAIN = shapes.terrain.KIND
# The most contacts of one pair: capsule-box, its nearest point and 8 candidates (2 ends, 6
# face crossings) on the same face. (Box-plane 8 vertices, box-box 4, capsule-capsule 2.)
MAX_CONTACTS_PER_PAIR = 9
if terrain_kernels.WRITTEN != MAX_CONTACTS_PER_PAIR:
    raise ImportError('terrain_kernels.WRITTEN must be narrow_kernels.MAX_CONTACTS_PER_PAIR')

# Two directions whose cross product is shorter than this are parallel (no edge-edge axis).
PARALLEL_EPS = 1e-6
# A face axis is kept over a better edge axis unless the edge one separates by more than
# EDGE_RELATIVE * face + EDGE_ABSOLUTE (m) where they overlap (face < 0), (2 - EDGE_RELATIVE) *
# face + EDGE_ABSOLUTE where they are apart (``_better``): an edge contact on a resting face is
# the classic source of jitter; the same tolerance prefers A's face over B's.
EDGE_RELATIVE = 0.95
EDGE_ABSOLUTE = 1e-5
# Contacts of a capsule lying on a box face: candidates whose normal is within this cosine of
# the deepest one's count as the same face (two ends of a resting capsule).
SAME_FACE_COS = 0.999
# Squared segment length (m^2) below which a segment is a point (Ericson's epsilon).
SEGMENT_TINY = 1e-30
# Sutherland-Hodgman on one plane keeps the I vertices inside (d <= 0) and adds X crossings;
# each crossing edge has one end strictly outside (O of them, 2 edges each) and one strictly
# inside, so X <= min(2 O, 2 I) and I + X <= n + n / 2. From the 4 corners: 6, 9, 13, 19.
CLIP_CAPACITY = 19
# The copies of a pair's two rows collide_pairs hands its test: geoms, centres, rotations.
ROW_COPIES = 2 * GEOM_WIDTH + 24


# -- small helpers -----------------------------------------------------------------------------
@kernel
def _segment_point(cx, cy, cz, ux, uy, uz, h, px, py, pz):
    """The point of the segment c + t u, |t| <= h (u unit) nearest p: t = (p - c) . u clamped."""
    t = (px - cx) * ux + (py - cy) * uy + (pz - cz) * uz
    t = _clamp(t, -h, h)
    return cx + t * ux, cy + t * uy, cz + t * uz


@kernel
def closest_segment_parameters(p1x, p1y, p1z, d1x, d1y, d1z, p2x, p2y, p2z, d2x, d2y, d2z):
    """(s, t, parallel): the points p1 + s d1 and p2 + t d2, s and t in [0, 1], closest to each
    other (Ericson, Real-Time Collision Detection, 5.1.9); parallel is True when the segments
    are (then (s, t) is one of the closest pairs) or one is a point.

    With r = p1 - p2, the squared distance |r + s d1 - t d2|^2 is least, over the two whole
    lines, where its gradient vanishes: a s - b t = -c and b s - e t = -f (a = d1.d1,
    b = d1.d2, c = d1.r, e = d2.d2, f = d2.r), so s = (b f - c e) / (a e - b^2); s is clamped
    to [0, 1], t = (b s + f) / e is the nearest point of the second line to p1 + s d1, and a
    t outside [0, 1] is clamped and s recomputed for it (s = (b t - c) / a, clamped)."""
    rx, ry, rz = p1x - p2x, p1y - p2y, p1z - p2z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    if a <= SEGMENT_TINY and e <= SEGMENT_TINY:
        return 0.0, 0.0, True
    if a <= SEGMENT_TINY:
        return 0.0, _clamp(f / e, 0.0, 1.0), True
    c = d1x * rx + d1y * ry + d1z * rz
    if e <= SEGMENT_TINY:
        return _clamp(-c / a, 0.0, 1.0), 0.0, True
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b          # |d1|^2 |d2|^2 sin^2(angle) >= 0
    parallel = denom <= PARALLEL_EPS * PARALLEL_EPS * a * e
    s = 0.0
    if not parallel:               # then denom > 0
        s = _clamp((b * f - c * e) / denom, 0.0, 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, _clamp(-c / a, 0.0, 1.0)
    elif t > 1.0:
        t, s = 1.0, _clamp((b - c) / a, 0.0, 1.0)
    return s, t, parallel


# -- sphere ------------------------------------------------------------------------------------
@kernel
def _sphere_sphere(ax, ay, az, ra, bx, by, bz, rb, margin, tag, fx, fy, fz,
                   point, normal, depth, feature, row):
    """Balls of radii ra, rb (m) at centres a, b (m): 0 or 1 contact, at ``row``. The normal is
    (b - a) / |b - a|, the fallback f when the centres coincide; pA = a + ra n, pB = b - rb n,
    so depth = ra + rb - |b - a|."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if ra + rb - dist < -margin:
        return 0
    nx, ny, nz = fx, fy, fz
    if dist > TINY_LENGTH:
        nx, ny, nz = dx / dist, dy / dist, dz / dist
    _put(point, normal, depth, feature, row, ax + ra * nx, ay + ra * ny, az + ra * nz,
         bx - rb * nx, by - rb * ny, bz - rb * nz, nx, ny, nz, tag)
    return 1


@kernel
def _sphere_plane(cx, cy, cz, r, px, py, pz, nx, ny, nz, margin, tag,
                  point, normal, depth, feature, row):
    """A ball (centre c, radius r, m) against the half-space through p with unit normal n out
    of the solid: s = (c - p) . n is the height of the centre, pA = c - r n, pB = c - s n (the
    foot on the plane), normal -n, depth r - s."""
    s = (cx - px) * nx + (cy - py) * ny + (cz - pz) * nz
    if r - s < -margin:
        return 0
    _put(point, normal, depth, feature, row, cx - r * nx, cy - r * ny, cz - r * nz,
         cx - s * nx, cy - s * ny, cz - s * nz, -nx, -ny, -nz, tag)
    return 1


@kernel
def _sphere_box(c, r, cb, rot, g, margin, point, normal, depth, feature, row):
    """A ball (centre c, radius r) against a box (centre cb, rotation rot, half extents
    g[2:5]). In the box frame l = R^T (c - cb) and the nearest box point is q = clamp(l, -h,
    h): outside the box the normal m (box frame, towards the ball) is (l - q) / |l - q|; a
    centre inside leaves through the nearest face (least h_i - |l_i|, the first axis on a tie),
    q on that face. pA = l - r m, pB = q, normal -R m."""
    hx, hy, hz = float(g[HX]), float(g[HY]), float(g[HZ])
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    lx, ly, lz = _apply_t(rot, float(c[0]) - cbx, float(c[1]) - cby, float(c[2]) - cbz)
    qx, qy, qz = _clamp(lx, -hx, hx), _clamp(ly, -hy, hy), _clamp(lz, -hz, hz)
    ex, ey, ez = lx - qx, ly - qy, lz - qz
    dist2 = ex * ex + ey * ey + ez * ez
    if dist2 > 0.0:
        dist = math.sqrt(dist2)    # > 0, as the square root of any positive double
        if r - dist < -margin:
            return 0
        mx, my, mz = ex / dist, ey / dist, ez / dist
    else:
        fx, fy, fz = hx - abs(lx), hy - abs(ly), hz - abs(lz)
        mx, my, mz = 0.0, 0.0, 0.0
        qx, qy, qz = lx, ly, lz
        if fx <= fy and fx <= fz:
            mx = 1.0 if lx >= 0.0 else -1.0
            qx = mx * hx
        elif fy <= fz:
            my = 1.0 if ly >= 0.0 else -1.0
            qy = my * hy
        else:
            mz = 1.0 if lz >= 0.0 else -1.0
            qz = mz * hz
    ax, ay, az = _apply(rot, lx - r * mx, ly - r * my, lz - r * mz)
    bx, by, bz = _apply(rot, qx, qy, qz)
    nx, ny, nz = _apply(rot, mx, my, mz)
    _put(point, normal, depth, feature, row, cbx + ax, cby + ay, cbz + az,
         cbx + bx, cby + by, cbz + bz, -nx, -ny, -nz, int(0))
    return 1


@kernel
def _sphere_capsule(c, r, cb, rot, rb, hb, margin, point, normal, depth, feature, row):
    """A ball (centre c, radius r) against a capsule (centre cb, rotation rot, radius rb, half
    length hb): sphere-sphere with the point of the capsule's segment nearest the centre. A
    centre on the segment leaves sideways: along u x up (u the axis, normalised), or along x
    when the axis is within acos(0.9) (26 degrees) of up."""
    ux, uy, uz = _column(rot, int(2))
    cx, cy, cz = float(c[0]), float(c[1]), float(c[2])
    sx, sy, sz = _segment_point(float(cb[0]), float(cb[1]), float(cb[2]), ux, uy, uz, hb,
                                cx, cy, cz)
    fx, fy, fz = 1.0, 0.0, 0.0
    if abs(uz) < 0.9:
        fx, fy, fz = _unit(uy, -ux, 0.0, 0.0, 0.0, 1.0)    # u x (0, 0, 1)
    return _sphere_sphere(cx, cy, cz, r, sx, sy, sz, rb, margin, int(0), fx, fy, fz,
                          point, normal, depth, feature, row)


# -- capsule -----------------------------------------------------------------------------------
@kernel
def _capsule_plane(c, rot, r, h, p, n, margin, point, normal, depth, feature, row):
    """A capsule against a half-space (point p, unit normal n = geom[2:5]): each end ball
    c -+ h u that touches, features 0 and 1 (one ball, feature 0, for a zero-length one)."""
    ux, uy, uz = _column(rot, int(2))
    cx, cy, cz = float(c[0]), float(c[1]), float(c[2])
    px, py, pz = float(p[0]), float(p[1]), float(p[2])
    nx, ny, nz = float(n[NORMAL]), float(n[NORMAL + 1]), float(n[NORMAL + 2])
    if not h > 0.0:
        return _sphere_plane(cx, cy, cz, r, px, py, pz, nx, ny, nz, margin, int(0),
                             point, normal, depth, feature, row)
    count = _sphere_plane(cx - h * ux, cy - h * uy, cz - h * uz, r, px, py, pz, nx, ny, nz,
                          margin, int(0), point, normal, depth, feature, row)
    return count + _sphere_plane(cx + h * ux, cy + h * uy, cz + h * uz, r, px, py, pz,
                                 nx, ny, nz, margin, int(1), point, normal, depth, feature,
                                 row + count)


@kernel
def _capsule_capsule(ca, rota, ra, ha, cb, rotb, rb, hb, margin,
                     point, normal, depth, feature, row):
    """Two capsules: their segments p1 + s d1 (p1 = ca - ha ua, d1 = 2 ha ua) and p2 + t d2, as
    two balls at the closest points. Parallel segments that overlap along their length touch at
    both ends of the overlap (features 1, 2): the overlap is [lo, hi] of s, from the
    projections s = (q - p1) . d1 / |d1|^2 of the second segment's ends q. Touching segments
    leave along ua x ub, or for parallel ones the part of cb - ca across ua (facing B)."""
    uax, uay, uaz = _column(rota, int(2))
    ubx, uby, ubz = _column(rotb, int(2))
    cax, cay, caz = float(ca[0]), float(ca[1]), float(ca[2])
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    p1x, p1y, p1z = cax - ha * uax, cay - ha * uay, caz - ha * uaz
    d1x, d1y, d1z = 2.0 * ha * uax, 2.0 * ha * uay, 2.0 * ha * uaz
    p2x, p2y, p2z = cbx - hb * ubx, cby - hb * uby, cbz - hb * ubz
    d2x, d2y, d2z = 2.0 * hb * ubx, 2.0 * hb * uby, 2.0 * hb * ubz
    s, t, parallel = closest_segment_parameters(p1x, p1y, p1z, d1x, d1y, d1z,
                                                p2x, p2y, p2z, d2x, d2y, d2z)
    wx, wy, wz = cbx - cax, cby - cay, cbz - caz
    along = wx * uax + wy * uay + wz * uaz
    gx, gy, gz = _unit(wx - along * uax, wy - along * uay, wz - along * uaz, 0.0, 0.0, 1.0)
    fx, fy, fz = _unit(uay * ubz - uaz * uby, uaz * ubx - uax * ubz, uax * uby - uay * ubx,
                       gx, gy, gz)
    if fx * wx + fy * wy + fz * wz < 0.0:
        fx, fy, fz = -fx, -fy, -fz
    a = d1x * d1x + d1y * d1y + d1z * d1z
    # (a > 0: |d1|^2 underflows to 0 for a capsule shorter than 1e-154 m.)
    if parallel and ha > 0.0 and hb > 0.0 and a > 0.0:
        s0 = ((p2x - p1x) * d1x + (p2y - p1y) * d1y + (p2z - p1z) * d1z) / a
        s1 = ((p2x + d2x - p1x) * d1x + (p2y + d2y - p1y) * d1y + (p2z + d2z - p1z) * d1z) / a
        lo = s1 if s1 < s0 else s0
        hi = s1 if s1 > s0 else s0
        lo = lo if lo > 0.0 else 0.0
        hi = hi if hi < 1.0 else 1.0
        if hi - lo > 1e-9:
            count = 0
            for k in range(2):
                sk = lo if k == 0 else hi
                pax, pay, paz = p1x + sk * d1x, p1y + sk * d1y, p1z + sk * d1z
                qx, qy, qz = _segment_point(cbx, cby, cbz, ubx, uby, ubz, hb, pax, pay, paz)
                count += _sphere_sphere(pax, pay, paz, ra, qx, qy, qz, rb, margin, k + 1,
                                        fx, fy, fz, point, normal, depth, feature, row + count)
            return count
    return _sphere_sphere(p1x + s * d1x, p1y + s * d1y, p1z + s * d1z, ra,
                          p2x + t * d2x, p2y + t * d2y, p2z + t * d2z, rb, margin, int(0),
                          fx, fy, fz, point, normal, depth, feature, row)


@kernel
def segment_box_distance(p0x, p0y, p0z, dx, dy, dz, hx, hy, hz):
    """(t, distance^2): the point p0 + t d, t in [0, 1], nearest the box |x_i| <= h_i (box
    frame, m), and its squared distance (m^2).

    The squared distance sum_i max(0, |x_i| - h_i)^2 is convex and piecewise quadratic in t,
    with breaks where a coordinate crosses a face plane x_i = -+h_i. On a piece each coordinate
    outside the box stays on one side, at the offset o_i = p0_i -+ h_i from its face, so the
    distance is sum (o_i + t d_i)^2 over those i, least at t = -sum d_i o_i / sum d_i^2
    (clamped to the piece); the sides are read at the middle of the piece. The first best t
    wins ties."""
    p0 = (p0x, p0y, p0z)
    d = (dx, dy, dz)
    half = (hx, hy, hz)
    breaks = stack_empty(8, 0, np.float64)
    breaks[0], breaks[1] = 0.0, 1.0
    count = 2
    for i in range(3):
        if d[i] != 0.0:
            for side in range(2):
                bound = half[i] if side == 1 else -half[i]
                t = (bound - p0[i]) / d[i]
                if t > 0.0 and t < 1.0:
                    breaks[count] = t
                    count += 1
    for i in range(1, count):          # insertion sort: at most 8
        x = float(breaks[i])
        j = i - 1
        while j >= 0 and float(breaks[j]) > x:
            breaks[j + 1] = breaks[j]
            j -= 1
        breaks[j + 1] = x
    best_t, best = 0.0, math.inf
    for k in range(count - 1):
        t0, t1 = float(breaks[k]), float(breaks[k + 1])
        if t1 <= t0:
            continue
        tm = 0.5 * (t0 + t1)
        qa, qb = 0.0, 0.0
        for i in range(3):
            x = p0[i] + tm * d[i]
            if x > half[i]:
                off = p0[i] - half[i]
            elif x < -half[i]:
                off = p0[i] + half[i]
            else:
                continue
            qa += d[i] * d[i]
            qb += d[i] * off
        t = t0
        if qa > 0.0:
            t = _clamp(-qb / qa, t0, t1)
        dist2 = 0.0
        for i in range(3):
            excess = abs(p0[i] + t * d[i]) - half[i]
            if excess > 0.0:
                dist2 += excess * excess
        if dist2 < best:
            best_t, best = t, dist2
    return best_t, best


@kernel
def _ball_box(px, py, pz, r, hx, hy, hz, rotb, cbx, cby, cbz, margin):
    """The contact of the ball of radius r at box-frame p (outside the box) with the box, as
    (found, pA, pB, normal), world frame: the nearest box point q = clamp(p), m = (p - q) /
    |p - q|, pA = p - r m, pB = q, normal -R m. Not found when p is within 1e-12 m of the box
    or further than r + margin."""
    qx, qy, qz = _clamp(px, -hx, hx), _clamp(py, -hy, hy), _clamp(pz, -hz, hz)
    ex, ey, ez = px - qx, py - qy, pz - qz
    dist = math.sqrt(ex * ex + ey * ey + ez * ez)
    if not dist > 1e-12 or r - dist < -margin:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    mx, my, mz = ex / dist, ey / dist, ez / dist
    ax, ay, az = _apply(rotb, px - r * mx, py - r * my, pz - r * mz)
    bx, by, bz = _apply(rotb, qx, qy, qz)
    nx, ny, nz = _apply(rotb, mx, my, mz)
    return (True, cbx + ax, cby + ay, cbz + az, cbx + bx, cby + by, cbz + bz, -nx, -ny, -nz)


@kernel
def _capsule_box_near(p0x, p0y, p0z, dx, dy, dz, t_best, r, h, rotb, cb, g, margin,
                      point, normal, depth, feature, row):
    """Capsule-box, the segment p0 + t d (box frame, t in [0, 1]) outside the box, nearest it
    at t_best: that contact (feature 10), plus the ends and the face-plane crossings whose
    contact has the same normal (to SAME_FACE_COS): a capsule lying on a face touches it at
    both ends of its span, not at one point that wanders."""
    hx, hy, hz = float(g[HX]), float(g[HY]), float(g[HZ])
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    found, ax, ay, az, bx, by, bz, nx, ny, nz = _ball_box(
        p0x + t_best * dx, p0y + t_best * dy, p0z + t_best * dz, r, hx, hy, hz, rotb,
        cbx, cby, cbz, margin)
    if not found:
        # The caller found this very distance (the same terms, summed in the same order) within
        # r + margin and its square above 1e-24: only a square within rounding of 1e-24, whose
        # root rounds to 1e-12 itself, gets here. No contact then.
        return 0
    _put(point, normal, depth, feature, row, ax, ay, az, bx, by, bz, nx, ny, nz, int(10))
    count = 1
    p0 = (p0x, p0y, p0z)
    d = (dx, dy, dz)
    half = (hx, hy, hz)
    for k in range(8):
        # Candidate k: 0, 1 the ends (1 only for h > 0), 2 + 2 i + s the crossing of the face
        # plane x_i = -h_i (s = 0) or +h_i (s = 1) inside the segment.
        if k == 0:
            t = 0.0
        elif k == 1:
            if not h > 0.0:
                continue
            t = 1.0
        else:
            i = (k - 2) // 2
            if d[i] == 0.0:
                continue
            bound = half[i] if (k - 2) % 2 == 1 else -half[i]
            t = (bound - p0[i]) / d[i]
            if not (t > 0.0 and t < 1.0):
                continue
        if abs(t - t_best) <= 1e-9:
            continue
        found, qax, qay, qaz, qbx, qby, qbz, mx, my, mz = _ball_box(
            p0x + t * dx, p0y + t * dy, p0z + t * dz, r, hx, hy, hz, rotb, cbx, cby, cbz,
            margin)
        if found and mx * nx + my * ny + mz * nz >= SAME_FACE_COS:
            _put(point, normal, depth, feature, row + count, qax, qay, qaz, qbx, qby, qbz,
                 mx, my, mz, k)
            count += 1
    return count


@kernel
def _capsule_box_deep(p0x, p0y, p0z, p1x, p1y, p1z, r, h, rotb, cb, g, margin,
                      point, normal, depth, feature, row):
    """Capsule-box, the segment p0 p1 (box frame) meeting the box (deep, after a failure of
    position correction): the axis of least penetration among the box's 3 face normals and the
    3 cross products u x e_i (u the segment's direction), separation along an axis a being
    |mid . a| - h . |a| - |d . a| / 2 (the projections of the two centres apart less the two
    half widths); the deeper end(s) as contact points (features 20, 21)."""
    hx, hy, hz = float(g[HX]), float(g[HY]), float(g[HZ])
    dx, dy, dz = p1x - p0x, p1y - p0y, p1z - p0z
    ux, uy, uz = _unit(dx, dy, dz, 0.0, 0.0, 1.0)
    mx, my, mz = 0.5 * (p0x + p1x), 0.5 * (p0y + p1y), 0.5 * (p0z + p1z)
    best_sep = -math.inf
    lx, ly, lz = 1.0, 0.0, 0.0
    for k in range(6):
        if k < 3:
            ax = 1.0 if k == 0 else 0.0
            ay = 1.0 if k == 1 else 0.0
            az = 1.0 if k == 2 else 0.0
        else:
            if k == 3:
                ax, ay, az = 0.0, uz, -uy          # u x (1, 0, 0)
            elif k == 4:
                ax, ay, az = -uz, 0.0, ux          # u x (0, 1, 0)
            else:
                ax, ay, az = uy, -ux, 0.0          # u x (0, 0, 1)
            length2 = ax * ax + ay * ay + az * az
            if not length2 > PARALLEL_EPS * PARALLEL_EPS:
                continue
            length = math.sqrt(length2)
            ax, ay, az = ax / length, ay / length, az / length
        sep = (abs(mx * ax + my * ay + mz * az)
               - (hx * abs(ax) + hy * abs(ay) + hz * abs(az))
               - 0.5 * abs(dx * ax + dy * ay + dz * az))
        if sep > best_sep:
            best_sep = sep
            lx, ly, lz = ax, ay, az
    if mx * lx + my * ly + mz * lz < 0.0:
        lx, ly, lz = -lx, -ly, -lz                 # the axis from the box's centre outwards
    support = hx * abs(lx) + hy * abs(ly) + hz * abs(lz)
    wx, wy, wz = _apply(rotb, lx, ly, lz)
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    ends = 2 if h > 0.0 else 1
    v0 = p0x * lx + p0y * ly + p0z * lz
    v1 = p1x * lx + p1y * ly + p1z * lz
    deepest = v1 if ends == 2 and v1 < v0 else v0
    count = 0
    for e in range(ends):
        px, py, pz, v = p0x, p0y, p0z, v0
        if e == 1:
            px, py, pz, v = p1x, p1y, p1z, v1
        s = v - support                            # the end's height over the face along l
        if r - s < -margin and v > deepest:
            continue
        ax, ay, az = _apply(rotb, px - r * lx, py - r * ly, pz - r * lz)
        bx, by, bz = _apply(rotb, px - s * lx, py - s * ly, pz - s * lz)
        _put(point, normal, depth, feature, row + count, cbx + ax, cby + ay, cbz + az,
             cbx + bx, cby + by, cbz + bz, -wx, -wy, -wz, 20 + e)
        count += 1
    return count


@kernel
def _capsule_box(c, rot, r, h, cb, rotb, g, margin, point, normal, depth, feature, row):
    """A capsule (A: centre c, rotation rot, radius r, half length h) against a box (B): its
    segment's ends in the box frame, p = R_b^T (c -+ h u - cb), then the exact segment-box
    distance decides between the separated and the deep case."""
    ux, uy, uz = _column(rot, int(2))
    cx, cy, cz = float(c[0]), float(c[1]), float(c[2])
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    p0x, p0y, p0z = _apply_t(rotb, cx - h * ux - cbx, cy - h * uy - cby, cz - h * uz - cbz)
    p1x, p1y, p1z = _apply_t(rotb, cx + h * ux - cbx, cy + h * uy - cby, cz + h * uz - cbz)
    dx, dy, dz = p1x - p0x, p1y - p0y, p1z - p0z
    t_best, dist2 = segment_box_distance(p0x, p0y, p0z, dx, dy, dz,
                                         float(g[HX]), float(g[HY]), float(g[HZ]))
    if dist2 > 1e-24:
        if r - math.sqrt(dist2) < -margin:
            return 0
        return _capsule_box_near(p0x, p0y, p0z, dx, dy, dz, t_best, r, h, rotb, cb, g, margin,
                                 point, normal, depth, feature, row)
    return _capsule_box_deep(p0x, p0y, p0z, p1x, p1y, p1z, r, h, rotb, cb, g, margin,
                             point, normal, depth, feature, row)


# -- box ---------------------------------------------------------------------------------------
@kernel
def _box_plane(c, rot, g, p, n, margin, point, normal, depth, feature, row):
    """A box against a half-space (point p, unit normal n = geom[2:5]): every vertex
    v = c + R (+-hx, +-hy, +-hz) whose height s = (v - p) . n is at most ``margin``; point
    v - s n / 2 (midway to the plane), normal -n, depth -s, feature the vertex index."""
    hx, hy, hz = float(g[HX]), float(g[HY]), float(g[HZ])
    cx, cy, cz = float(c[0]), float(c[1]), float(c[2])
    px, py, pz = float(p[0]), float(p[1]), float(p[2])
    nx, ny, nz = float(n[NORMAL]), float(n[NORMAL + 1]), float(n[NORMAL + 2])
    count = 0
    for k in range(8):
        vx, vy, vz = _apply(rot, hx if k & 4 else -hx, hy if k & 2 else -hy,
                            hz if k & 1 else -hz)
        vx, vy, vz = cx + vx, cy + vy, cz + vz
        s = (vx - px) * nx + (vy - py) * ny + (vz - pz) * nz
        if -s >= -margin:
            h = 0.5 * s
            _write(point, normal, depth, feature, row + count, vx - h * nx, vy - h * ny,
                   vz - h * nz, -nx, -ny, -nz, -s, k)
            count += 1
    return count


@kernel
def _edge_contact(ca, rota, ga, cb, rotb, gb, i, j, lx, ly, lz, sep,
                  point, normal, depth, feature, row):
    """Box-box on the edge axis a_i x b_j (l: its unit vector in A's frame), separation sep:
    the edge of A along a_i through A's vertex furthest along n and the edge of B along b_j
    through B's vertex furthest along -n, touching at their closest points."""
    cax, cay, caz = float(ca[0]), float(ca[1]), float(ca[2])
    cbx, cby, cbz = float(cb[0]), float(cb[1]), float(cb[2])
    nx, ny, nz = _apply(rota, lx, ly, lz)
    if nx * (cbx - cax) + ny * (cby - cay) + nz * (cbz - caz) < 0.0:
        nx, ny, nz = -nx, -ny, -nz
    ex, ey, ez = cax, cay, caz
    fx, fy, fz = cbx, cby, cbz
    for k in range(3):
        if k != i:
            ux, uy, uz = _column(rota, k)
            h = float(ga[HX + k])
            w = h if ux * nx + uy * ny + uz * nz > 0.0 else -h
            ex, ey, ez = ex + w * ux, ey + w * uy, ez + w * uz
        if k != j:
            ux, uy, uz = _column(rotb, k)
            h = float(gb[HX + k])
            w = -h if ux * nx + uy * ny + uz * nz > 0.0 else h
            fx, fy, fz = fx + w * ux, fy + w * uy, fz + w * uz
    ux, uy, uz = _column(rota, i)
    vx, vy, vz = _column(rotb, j)
    ha, hb = float(ga[HX + i]), float(gb[HX + j])
    p1x, p1y, p1z = ex - ha * ux, ey - ha * uy, ez - ha * uz
    d1x, d1y, d1z = 2.0 * ha * ux, 2.0 * ha * uy, 2.0 * ha * uz
    p2x, p2y, p2z = fx - hb * vx, fy - hb * vy, fz - hb * vz
    d2x, d2y, d2z = 2.0 * hb * vx, 2.0 * hb * vy, 2.0 * hb * vz
    s, t, _ = closest_segment_parameters(p1x, p1y, p1z, d1x, d1y, d1z,
                                         p2x, p2y, p2z, d2x, d2y, d2z)
    _write(point, normal, depth, feature, row,
           0.5 * ((p1x + s * d1x) + (p2x + t * d2x)), 0.5 * ((p1y + s * d1y) + (p2y + t * d2y)),
           0.5 * ((p1z + s * d1z) + (p2z + t * d2z)), nx, ny, nz, -sep, 200 + 3 * i + j)
    return 1


@kernel
def _face_contacts(cr, rotr, gr, axis, ci, roti, gi, margin, sign,
                   point, normal, depth, feature, row):
    """Box-box on a face axis: the reference box's face ``axis`` that faces the incident box
    (outward normal n, from reference to incident), and the incident box's face most against
    n, clipped to the reference face's 4 side planes; the points within ``margin`` of the
    reference face (height s = n . p - (n . c_r + h_axis)), moved halfway to it, depth -s, at
    most 4 (``contact_geometry.write_at_most_four``). ``sign`` -1: the reference box is B, so
    the normals are negated (A to B) and the features get 100 more."""
    crx, cry, crz = float(cr[0]), float(cr[1]), float(cr[2])
    cix, ciy, ciz = float(ci[0]), float(ci[1]), float(ci[2])
    nx, ny, nz = _column(rotr, axis)
    if nx * (cix - crx) + ny * (ciy - cry) + nz * (ciz - crz) < 0.0:
        nx, ny, nz = -nx, -ny, -nz
    # The incident face: that of the incident box's axis k most along n, on the side facing -n.
    k, best = int(0), -1.0
    dk = 0.0
    for m in range(3):
        ux, uy, uz = _column(roti, m)
        dot = ux * nx + uy * ny + uz * nz
        if m == 0 or abs(dot) > best:
            k, best, dk = m, abs(dot), dot
    sk = -1.0 if dk > 0.0 else 1.0
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    ux, uy, uz = _column(roti, k)
    w = sk * float(gi[HX + k])
    ox, oy, oz = cix + w * ux, ciy + w * uy, ciz + w * uz
    ux, uy, uz = _column(roti, k1)
    w = float(gi[HX + k1])
    e1x, e1y, e1z = w * ux, w * uy, w * uz
    ux, uy, uz = _column(roti, k2)
    w = float(gi[HX + k2])
    e2x, e2y, e2z = w * ux, w * uy, w * uz
    poly = stack_empty(CLIP_CAPACITY, 3, np.float64)
    tags = stack_empty(CLIP_CAPACITY, 0, np.int64)
    other = stack_empty(CLIP_CAPACITY, 3, np.float64)
    other_tags = stack_empty(CLIP_CAPACITY, 0, np.int64)
    for m in range(4):                 # corners o + e1 + e2, o - e1 + e2, o - e1 - e2, o + e1 - e2
        s1 = 1.0 if m == 0 or m == 3 else -1.0
        s2 = 1.0 if m < 2 else -1.0
        poly[m, 0] = ox + s1 * e1x + s2 * e2x
        poly[m, 1] = oy + s1 * e1y + s2 * e2y
        poly[m, 2] = oz + s1 * e1z + s2 * e2z
        tags[m] = m
    count = int(4)
    # The side planes of the reference face: u . p <= u . c_r + h along its two other axes.
    a1, a2 = (axis + 1) % 3, (axis + 2) % 3
    for plane in range(4):
        ux, uy, uz = _column(rotr, a1 if plane < 2 else a2)
        h = float(gr[HX + (a1 if plane < 2 else a2)])
        offset = ux * crx + uy * cry + uz * crz
        limit = offset + h
        if plane % 2 == 1:
            ux, uy, uz, limit = -ux, -uy, -uz, h - offset
        if plane % 2 == 0:
            count = _clip(poly, tags, count, other, other_tags, ux, uy, uz, limit, plane)
        else:
            count = _clip(other, other_tags, count, poly, tags, ux, uy, uz, limit, plane)
        if count == 0:
            return 0
    # poly[:count] now holds the clipped face; keep the points within the margin, in other.
    face_offset = nx * crx + ny * cry + nz * crz + float(gr[HX + axis])
    depths = stack_empty(CLIP_CAPACITY, 0, np.float64)
    kept = int(0)
    for m in range(count):
        px, py, pz = float(poly[m, 0]), float(poly[m, 1]), float(poly[m, 2])
        s = nx * px + ny * py + nz * pz - face_offset      # > 0 above the reference face
        if -s >= -margin:
            h = 0.5 * s
            other[kept, 0], other[kept, 1], other[kept, 2] = px - h * nx, py - h * ny, pz - h * nz
            other_tags[kept] = tags[m]
            depths[kept] = -s
            kept += 1
    base = 1000 * (axis + 1) + (0 if sk > 0.0 else 500) + 10 * k + (100 if sign < 0.0 else 0)
    return _write_four(other, depths, other_tags, kept, nx, ny, nz, sign, base,
                       point, normal, depth, feature, row)


@kernel
def _better(sep):
    """The separation an axis must pass to be taken over one separating by ``sep`` (m):
    EDGE_RELATIVE of it closer to 0 (less deep) when they overlap, as much further when they
    are apart (a speculative contact), plus EDGE_ABSOLUTE. (EDGE_RELATIVE * sep for a gap was
    less than sep: an edge axis parallel to a face axis, with the same separation, won, and
    a box falling flat on another got one edge contact off to the side, which spun both.)"""
    if sep > 0.0:
        return (2.0 - EDGE_RELATIVE) * sep + EDGE_ABSOLUTE
    return EDGE_RELATIVE * sep + EDGE_ABSOLUTE


@kernel
def _box_box(ca, rota, ga, cb, rotb, gb, margin, point, normal, depth, feature, row):
    """Two boxes by separating axes: the 3 + 3 face normals and the 9 edge cross products
    a_i x b_j. With C_ij = a_i . b_j and d = cb - ca in A's frame (da) and B's (db), the
    separation along a_i is |da_i| - ha_i - sum_j |C_ij| hb_j (the boxes' half widths along the
    axis subtracted from the centres' distance), along b_j likewise; along a_i x b_j, whose
    components in A's frame are (e_i x C[:, j]), the half widths are ha_i1 |C_i2j| + ha_i2
    |C_i1j| and hb_j1 |C_ij2| + hb_j2 |C_ij1| and the distance |da_i2 C_i1j - da_i1 C_i2j|,
    all divided by the axis' length sqrt(C_i1j^2 + C_i2j^2) (i1, i2 = i + 1, i + 2 mod 3). Any
    separation above ``margin``: no contact. Else the greatest: a face axis (A's unless B's is
    better by the tolerance) gives the clipped face, an edge axis better than it by the
    tolerance the closest points of the two edges."""
    cax, cay, caz = float(ca[0]), float(ca[1]), float(ca[2])
    dx, dy, dz = float(cb[0]) - cax, float(cb[1]) - cay, float(cb[2]) - caz
    ha = (float(ga[HX]), float(ga[HY]), float(ga[HZ]))
    hb = (float(gb[HX]), float(gb[HY]), float(gb[HZ]))
    cm = stack_empty(9, 0, np.float64)
    am = stack_empty(9, 0, np.float64)
    for i in range(3):
        for j in range(3):
            v = (float(rota[i]) * float(rotb[j]) + float(rota[3 + i]) * float(rotb[3 + j])
                 + float(rota[6 + i]) * float(rotb[6 + j]))
            cm[3 * i + j] = v
            am[3 * i + j] = abs(v)
    da = _apply_t(rota, dx, dy, dz)
    db = _apply_t(rotb, dx, dy, dz)
    ia, face_a = int(0), 0.0
    ib, face_b = int(0), 0.0
    for i in range(3):
        sep = abs(da[i]) - ha[i] - (float(am[3 * i]) * hb[0] + float(am[3 * i + 1]) * hb[1]
                                    + float(am[3 * i + 2]) * hb[2])
        if i == 0 or sep > face_a:
            ia, face_a = i, sep
        sep = abs(db[i]) - hb[i] - (float(am[i]) * ha[0] + float(am[3 + i]) * ha[1]
                                    + float(am[6 + i]) * ha[2])
        if i == 0 or sep > face_b:
            ib, face_b = i, sep
    if face_a > margin or face_b > margin:
        return 0
    edge_i, edge_j = int(-1), int(-1)
    edge_sep = -math.inf
    lx, ly, lz = 0.0, 0.0, 0.0
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            c1, c2 = float(cm[3 * i1 + j]), float(cm[3 * i2 + j])
            length = math.sqrt(c1 * c1 + c2 * c2)
            if not length >= PARALLEL_EPS:
                continue
            ra = ha[i1] * float(am[3 * i2 + j]) + ha[i2] * float(am[3 * i1 + j])
            rb = hb[j1] * float(am[3 * i + j2]) + hb[j2] * float(am[3 * i + j1])
            proj = da[i2] * c1 - da[i1] * c2
            sep = (abs(proj) - ra - rb) / length
            if sep > margin:
                return 0
            if sep > edge_sep:
                edge_i, edge_j, edge_sep = i, j, sep
                # e_i x C[:, j] in A's frame, unit: -C_i2j along e_i1, C_i1j along e_i2.
                u1, u2 = -c2 / length, c1 / length
                if i == 0:
                    lx, ly, lz = 0.0, u1, u2
                elif i == 1:
                    lx, ly, lz = u2, 0.0, u1
                else:
                    lx, ly, lz = u1, u2, 0.0
    face = face_a
    use_b = face_b > _better(face_a)
    if use_b:
        face = face_b
    if edge_i >= 0 and edge_sep > _better(face):
        return _edge_contact(ca, rota, ga, cb, rotb, gb, edge_i, edge_j, lx, ly, lz, edge_sep,
                             point, normal, depth, feature, row)
    if use_b:   # B's face is the reference, A's the incident one
        return _face_contacts(cb, rotb, gb, ib, ca, rota, ga, margin, -1.0,
                              point, normal, depth, feature, row)
    return _face_contacts(ca, rota, ga, ia, cb, rotb, gb, margin, 1.0,
                          point, normal, depth, feature, row)


# -- dispatch ----------------------------------------------------------------------------------
# The contact tests, one for each pair of kinds (low rank, high rank), written ``_pair_*`` below
# with one signature: the arrays of the two shapes in the order the pair is given and
# ``swap`` (the pair given high kind first, so computed B as A). A set of pairs is an int, one
# bit a pair (``PAIR_BIT``, a row's place in ``PAIR_TESTS``): the kernels of a world are
# compiled for the pairs its scene can meet (``pair_set``), each test outside them compiled as
# a "no test" (``jit.literal_gate``). ``PAIR_TESTS`` (after the tests) is the table: a new kind
# adds its rows at its end (the bits of the others stay), and ``_pair_dispatch`` is written
# from it.
KIND_NAMES = shapes.NAMES


def pair_set(kinds_of_bodies, moving) -> int:
    """The set of pairs (bits of ``PAIR_BIT``) a world can test: a pair of kinds (a, b) if a
    moving body has a collider of kind a and another body one of kind b. ``kinds_of_bodies``:
    for each body the kinds (KIND_*) of its colliders; ``moving``: for each body whether it
    moves (planes are on static bodies only; static bodies never meet each other)."""
    bodies_of: dict = {}   # kind -> the bodies with a collider of that kind
    moving_of: dict = {}   # kind -> the moving ones
    for i, (kinds, m) in enumerate(zip(kinds_of_bodies, moving)):
        for k in set(kinds):
            bodies_of.setdefault(k, set()).add(i)
            if m:
                moving_of.setdefault(k, set()).add(i)
    bits = 0
    for a, movers in moving_of.items():
        for b, others in bodies_of.items():
            # some moving body of kind a and another body of kind b: unless b's only body
            # is a's only mover
            if len(others) > 1 or others != movers:
                bits |= PAIR_BIT[(min(a, b), max(a, b))]
    return bits


def checked_tests(tests, what: str = 'tests') -> int:
    """``tests`` if it is a set of contact tests (an int of ``PAIR_BIT`` bits), else a
    ValueError naming ``what``."""
    if isinstance(tests, bool) or not isinstance(tests, int) or not 0 <= tests <= PAIRS_ALL:
        raise ValueError(f'{what} must be a set of narrow_kernels.PAIR_BIT (an int in '
                         f'[0, {PAIRS_ALL}]), got {tests!r}')
    return tests


def pair_names(pairs: int) -> list[str]:
    """The pairs of the set ``pairs`` as 'sphere-box' and the like, in ``PAIR_KINDS`` order."""
    return [f'{KIND_NAMES[a]}-{KIND_NAMES[b]}' for (a, b) in PAIR_KINDS
            if pairs & PAIR_BIT[(a, b)]]


def pairs_named(names) -> int:
    """The set of the pairs ``names`` ('sphere-box', ...; the other order too); ValueError for
    a name that is no pair of kinds with a contact test."""
    bits = 0
    for name in names:
        a, _, b = name.partition('-')
        if a not in KIND_NAMES or b not in KIND_NAMES:
            raise ValueError(f'no pair of kinds {name!r}: kinds are {", ".join(KIND_NAMES)}')
        low, high = sorted((KIND_NAMES.index(a), KIND_NAMES.index(b)))
        if (low, high) not in PAIR_BIT:
            raise ValueError(f'no contact test between {name!r} (two planes are static)')
        bits |= PAIR_BIT[(low, high)]
    return bits


def _pair_sphere_sphere(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                        margin, point, normal, depth, feature, start):
    return _sphere_sphere(float(centre_a[0]), float(centre_a[1]), float(centre_a[2]),
                          float(geom_a[RADIUS]), float(centre_b[0]), float(centre_b[1]),
                          float(centre_b[2]), float(geom_b[RADIUS]), margin, int(0),
                          0.0, 0.0, 1.0, point, normal, depth, feature, start)


def _pair_sphere_capsule(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                         margin, point, normal, depth, feature, start):
    if swap:
        return _sphere_capsule(centre_b, float(geom_b[RADIUS]), centre_a, rot_a,
                               float(geom_a[RADIUS]), float(geom_a[HALF_LENGTH]), margin,
                               point, normal, depth, feature, start)
    return _sphere_capsule(centre_a, float(geom_a[RADIUS]), centre_b, rot_b,
                           float(geom_b[RADIUS]), float(geom_b[HALF_LENGTH]), margin,
                           point, normal, depth, feature, start)


def _pair_sphere_box(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                     point, normal, depth, feature, start):
    if swap:
        return _sphere_box(centre_b, float(geom_b[RADIUS]), centre_a, rot_a, geom_a, margin,
                           point, normal, depth, feature, start)
    return _sphere_box(centre_a, float(geom_a[RADIUS]), centre_b, rot_b, geom_b, margin,
                       point, normal, depth, feature, start)


def _pair_sphere_plane(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                       point, normal, depth, feature, start):
    if swap:
        return _sphere_plane(float(centre_b[0]), float(centre_b[1]), float(centre_b[2]),
                             float(geom_b[RADIUS]), float(centre_a[0]), float(centre_a[1]),
                             float(centre_a[2]), float(geom_a[NORMAL]),
                             float(geom_a[NORMAL + 1]), float(geom_a[NORMAL + 2]), margin,
                             int(0), point, normal, depth, feature, start)
    return _sphere_plane(float(centre_a[0]), float(centre_a[1]), float(centre_a[2]),
                         float(geom_a[RADIUS]), float(centre_b[0]), float(centre_b[1]),
                         float(centre_b[2]), float(geom_b[NORMAL]),
                         float(geom_b[NORMAL + 1]), float(geom_b[NORMAL + 2]), margin,
                         int(0), point, normal, depth, feature, start)


def _pair_capsule_capsule(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                          margin, point, normal, depth, feature, start):
    return _capsule_capsule(centre_a, rot_a, float(geom_a[RADIUS]), float(geom_a[HALF_LENGTH]),
                            centre_b, rot_b, float(geom_b[RADIUS]), float(geom_b[HALF_LENGTH]),
                            margin, point, normal, depth, feature, start)


def _pair_capsule_box(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                      point, normal, depth, feature, start):
    if swap:
        return _capsule_box(centre_b, rot_b, float(geom_b[RADIUS]), float(geom_b[HALF_LENGTH]),
                            centre_a, rot_a, geom_a, margin, point, normal, depth, feature,
                            start)
    return _capsule_box(centre_a, rot_a, float(geom_a[RADIUS]), float(geom_a[HALF_LENGTH]),
                        centre_b, rot_b, geom_b, margin, point, normal, depth, feature, start)


def _pair_capsule_plane(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                        margin, point, normal, depth, feature, start):
    if swap:
        return _capsule_plane(centre_b, rot_b, float(geom_b[RADIUS]),
                              float(geom_b[HALF_LENGTH]), centre_a, geom_a, margin,
                              point, normal, depth, feature, start)
    return _capsule_plane(centre_a, rot_a, float(geom_a[RADIUS]), float(geom_a[HALF_LENGTH]),
                          centre_b, geom_b, margin, point, normal, depth, feature, start)


def _pair_box_box(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                  point, normal, depth, feature, start):
    return _box_box(centre_a, rot_a, geom_a, centre_b, rot_b, geom_b, margin,
                    point, normal, depth, feature, start)


def _pair_box_plane(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                    point, normal, depth, feature, start):
    if swap:
        return _box_plane(centre_b, rot_b, geom_b, centre_a, geom_a, margin,
                          point, normal, depth, feature, start)
    return _box_plane(centre_a, rot_a, geom_a, centre_b, geom_b, margin,
                      point, normal, depth, feature, start)


@kernel
def _pair_convex(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                 point, normal, depth, feature, start, low, high):
    """Two solid kinds by the convex narrow phase (``convex_kernels.convex_pair``), the lower
    kind first."""
    if swap:
        return convex_kernels.convex_pair(low, geom_b, centre_b, rot_b, high, geom_a, centre_a,
                                          rot_a, pool, margin, point, normal, depth, feature,
                                          start)
    return convex_kernels.convex_pair(low, geom_a, centre_a, rot_a, high, geom_b, centre_b,
                                      rot_b, pool, margin, point, normal, depth, feature, start)


def _convex_row(low, high):
    """The test of a row of two solid kinds (low, high) served by the convex narrow phase."""
    def test(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
             point, normal, depth, feature, start):
        return _pair_convex(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                            margin, point, normal, depth, feature, start, int(low), int(high))
    test.__name__ = test.__qualname__ = f'_pair_{KIND_NAMES[low]}_{KIND_NAMES[high]}'
    return test


def _plane_row(kind):
    """The test of the row (plane, ``kind``) for a solid kind ranked after the plane: the
    solid's contacts (``convex_plane``, normals from the solid) turned to run from the plane."""
    def test(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
             point, normal, depth, feature, start):
        if swap:
            count = convex_kernels.convex_plane(int(kind), geom_a, centre_a, rot_a, pool,
                                                centre_b, geom_b, margin, point, normal, depth,
                                                feature, start)
        else:
            count = convex_kernels.convex_plane(int(kind), geom_b, centre_b, rot_b, pool,
                                                centre_a, geom_a, margin, point, normal, depth,
                                                feature, start)
        for row in range(start, start + count):
            normal[row, 0], normal[row, 1], normal[row, 2] = (
                -normal[row, 0], -normal[row, 1], -normal[row, 2])
        return count
    test.__name__ = test.__qualname__ = f'_pair_plane_{KIND_NAMES[kind]}'
    return test


@kernel
def _pair_terrain(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
                  point, normal, depth, feature, start, kind):
    """A solid kind against a terrain (``terrain_kernels.terrain_pair``), the solid first."""
    if swap:
        return terrain_kernels.terrain_pair(kind, geom_b, centre_b, rot_b, geom_a, centre_a,
                                            rot_a, pool, margin, point, normal, depth, feature,
                                            start)
    return terrain_kernels.terrain_pair(kind, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b,
                                        pool, margin, point, normal, depth, feature, start)


def _terrain_row(kind):
    """The test of the row (``kind``, terrain) of a solid kind."""
    def test(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin,
             point, normal, depth, feature, start):
        return _pair_terrain(tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool,
                             margin, point, normal, depth, feature, start, int(kind))
    test.__name__ = test.__qualname__ = f'_pair_{KIND_NAMES[kind]}_terrain'
    return test


# (low kind, high kind, test): a row's index is its bit in a set of tests. Not plane-plane: two
# planes are both static (nor plane-terrain, terrain-terrain).
PAIR_TESTS = (
    (KIND_SPHERE, KIND_SPHERE, _pair_sphere_sphere),
    (KIND_SPHERE, KIND_CAPSULE, _pair_sphere_capsule),
    (KIND_SPHERE, KIND_BOX, _pair_sphere_box),
    (KIND_SPHERE, KIND_PLANE, _pair_sphere_plane),
    (KIND_CAPSULE, KIND_CAPSULE, _pair_capsule_capsule),
    (KIND_CAPSULE, KIND_BOX, _pair_capsule_box),
    (KIND_CAPSULE, KIND_PLANE, _pair_capsule_plane),
    (KIND_BOX, KIND_BOX, _pair_box_box),
    (KIND_BOX, KIND_PLANE, _pair_box_plane),
    (KIND_SPHERE, KIND_CYLINDER, _convex_row(KIND_SPHERE, KIND_CYLINDER)),
    (KIND_CAPSULE, KIND_CYLINDER, _convex_row(KIND_CAPSULE, KIND_CYLINDER)),
    (KIND_BOX, KIND_CYLINDER, _convex_row(KIND_BOX, KIND_CYLINDER)),
    (KIND_PLANE, KIND_CYLINDER, _plane_row(KIND_CYLINDER)),
    (KIND_CYLINDER, KIND_CYLINDER, _convex_row(KIND_CYLINDER, KIND_CYLINDER)),
    (KIND_SPHERE, KIND_HULL, _convex_row(KIND_SPHERE, KIND_HULL)),
    (KIND_CAPSULE, KIND_HULL, _convex_row(KIND_CAPSULE, KIND_HULL)),
    (KIND_BOX, KIND_HULL, _convex_row(KIND_BOX, KIND_HULL)),
    (KIND_PLANE, KIND_HULL, _plane_row(KIND_HULL)),
    (KIND_CYLINDER, KIND_HULL, _convex_row(KIND_CYLINDER, KIND_HULL)),
    (KIND_HULL, KIND_HULL, _convex_row(KIND_HULL, KIND_HULL)),
    (KIND_SPHERE, KIND_ELLIPSOID, _convex_row(KIND_SPHERE, KIND_ELLIPSOID)),
    (KIND_CAPSULE, KIND_ELLIPSOID, _convex_row(KIND_CAPSULE, KIND_ELLIPSOID)),
    (KIND_BOX, KIND_ELLIPSOID, _convex_row(KIND_BOX, KIND_ELLIPSOID)),
    (KIND_PLANE, KIND_ELLIPSOID, _plane_row(KIND_ELLIPSOID)),
    (KIND_CYLINDER, KIND_ELLIPSOID, _convex_row(KIND_CYLINDER, KIND_ELLIPSOID)),
    (KIND_HULL, KIND_ELLIPSOID, _convex_row(KIND_HULL, KIND_ELLIPSOID)),
    (KIND_ELLIPSOID, KIND_ELLIPSOID, _convex_row(KIND_ELLIPSOID, KIND_ELLIPSOID)),
    (KIND_SPHERE, KIND_TERRAIN, _terrain_row(KIND_SPHERE)),
    (KIND_CAPSULE, KIND_TERRAIN, _terrain_row(KIND_CAPSULE)),
    (KIND_BOX, KIND_TERRAIN, _terrain_row(KIND_BOX)),
    (KIND_CYLINDER, KIND_TERRAIN, _terrain_row(KIND_CYLINDER)),
    (KIND_HULL, KIND_TERRAIN, _terrain_row(KIND_HULL)),
    (KIND_ELLIPSOID, KIND_TERRAIN, _terrain_row(KIND_ELLIPSOID)),
)
PAIR_KINDS = tuple((low, high) for low, high, _ in PAIR_TESTS)
PAIR_BIT = {pair: 1 << i for i, pair in enumerate(PAIR_KINDS)}
PAIRS_ALL = (1 << len(PAIR_KINDS)) - 1


def _check_table() -> None:
    """Each row a pair of known kinds, lower rank first, met once."""
    for low, high, test in PAIR_TESTS:
        if not 0 <= low <= high < len(shapes.KINDS) or PAIR_KINDS.count((low, high)) != 1:
            raise ImportError(f'narrow_kernels.PAIR_TESTS: the row of {test.__name__} must '
                              'be a pair of shapes.KINDS numbers, lower first, met once')


_check_table()


def _dispatch_source() -> str:
    """``_pair_dispatch``: for the pair (low, high) the gated test of its row, else -1."""
    args = ('tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b, rot_b, pool, margin, '
            'point, normal, depth, feature, start')
    lines = [f'def _pair_dispatch(low, high, {args}):',
             '    """The contacts of a pair of kinds (low, high) by its row of PAIR_TESTS, or -1',
             '    (no row, or a test outside ``tests``). Written from the table."""']
    for i, (low, high, _) in enumerate(PAIR_TESTS):
        lines += [f'    if low == {low} and high == {high}:',
                  f'        return _gated_{i}({args})']
    lines.append('    return -1')
    return '\n'.join(lines) + '\n'


for _i, (_low, _high, _test) in enumerate(PAIR_TESTS):
    globals()[f'_gated_{_i}'] = literal_gate(1 << _i, -1)(_test)
_pair_dispatch = generated_kernel(globals(), '_pair_dispatch', _dispatch_source())


@inline_kernel
def collide_pair_of(tests, kind_a, geom_a, centre_a, rot_a, kind_b, geom_b, centre_b, rot_b,
                    pool, margin, point, normal, depth, feature, start):
    """``collide_pair`` with the contact tests of the set ``tests`` alone (``PAIR_BIT``; a
    constant: see ``jit.literal_gate``); a pair outside it is a ValueError, as two planes
    are. Compiled into its callers (each with its own constant), never on its own."""
    rows = start + MAX_CONTACTS_PER_PAIR
    if (start < 0 or point.shape[0] < rows or normal.shape[0] < rows or depth.shape[0] < rows
            or feature.shape[0] < rows or point.shape[1] < 3 or normal.shape[1] < 3):
        raise ValueError('collide_pair: the outputs need MAX_CONTACTS_PER_PAIR rows from start')
    if (geom_a.shape[0] < GEOM_WIDTH or geom_b.shape[0] < GEOM_WIDTH or centre_a.shape[0] < 3
            or centre_b.shape[0] < 3 or rot_a.shape[0] < 9 or rot_b.shape[0] < 9):
        raise ValueError('collide_pair: geom needs 5 values, centre 3 and rot 9')
    # B before A in rank: computed swapped (B's arrays where A's go), then the normals negated
    # (from B to A becomes from A to B). The arrays are passed on as they are, and each test
    # hands them to its function in the order it needs, never swapped into other variables:
    # numba counts references on array variables merged across branches, which costs more
    # than the sphere-sphere test itself.
    swap = kind_a > kind_b
    low = kind_b if swap else kind_a
    high = kind_a if swap else kind_b
    count = _pair_dispatch(low, high, tests, swap, geom_a, centre_a, rot_a, geom_b, centre_b,
                           rot_b, pool, margin, point, normal, depth, feature, start)
    if count < 0:
        raise ValueError('collide_pair: no contact test between these kinds (two planes are '
                         'both static, a kind is not one of KIND_*, or the pair is not in the '
                         'set its kernels were compiled for)')
    if swap:
        for row in range(start, start + count):
            normal[row, 0], normal[row, 1], normal[row, 2] = (
                -normal[row, 0], -normal[row, 1], -normal[row, 2])
    return count


@kernel
def collide_pair(kind_a, geom_a, centre_a, rot_a, kind_b, geom_b, centre_b, rot_b, pool, margin,
                 point, normal, depth, feature, start):
    """The contacts of shape A (kind_a, geom_a (5,), centre_a (3,), rot_a (9,), see the module
    doc) with shape B within ``margin`` (m), written to rows start, start + 1, ... of point
    (K, 3), normal (K, 3) (from A to B), depth (K,), feature (K,) int64, world frame; returns
    their number (0 to MAX_CONTACTS_PER_PAIR). ValueError if the outputs have fewer than
    start + MAX_CONTACTS_PER_PAIR rows, an input array is too short, or both are planes."""
    return collide_pair_of(PAIRS_ALL, kind_a, geom_a, centre_a, rot_a, kind_b, geom_b,
                           centre_b, rot_b, pool, margin, point, normal, depth, feature, start)


def _collide_pairs_for(tests, name):
    """``collide_pairs`` (below) with the contact tests ``tests``, a constant in it; ``name``,
    its name and the name of its cache entry."""

    def collide_pairs(pair_a, pair_b, kinds, geoms, pool, centres, rotations, margins,
                      point, normal, depth, feature, source):
        """The contacts of P candidate pairs of colliders, pair k being colliders pair_a[k] and
        pair_b[k] (int64, indices into kinds (C,) int64, geoms (C, 5), centres (C, 3), rotations
        (C, 9), as in the module doc) within margins[k] (m): written pair after pair to the rows of
        point (K, 3), normal (K, 3) (from pair_a's collider to pair_b's), depth (K,), feature (K,)
        int64 and source (K,) int64 (= k), K >= P * MAX_CONTACTS_PER_PAIR; returns their number.
        ValueError (before anything is written) for an index out of range or arrays too small.
        Only the contact tests ``tests`` are compiled in (another pair: ValueError)."""
        n_pairs = pair_a.shape[0]
        colliders = kinds.shape[0]
        rows = n_pairs * MAX_CONTACTS_PER_PAIR
        if (pair_b.shape[0] < n_pairs or margins.shape[0] < n_pairs or geoms.shape[0] < colliders
                or centres.shape[0] < colliders or rotations.shape[0] < colliders
                or geoms.shape[1] < GEOM_WIDTH or centres.shape[1] < 3 or rotations.shape[1] < 9):
            raise ValueError('collide_pairs: per-pair or per-collider arrays too short')
        if (point.shape[0] < rows or normal.shape[0] < rows or depth.shape[0] < rows
                or feature.shape[0] < rows or source.shape[0] < rows):
            raise ValueError('collide_pairs: the outputs need P * MAX_CONTACTS_PER_PAIR rows')
        for k in range(n_pairs):
            i, j = int(pair_a[k]), int(pair_b[k])
            if i < 0 or i >= colliders or j < 0 or j >= colliders:
                raise ValueError('collide_pairs: a collider index out of range')
        # The two colliders' rows are copied into views of one array on the stack
        # (jit.stack_empty): a pair's test then counts no reference of them (a row view of
        # an owned array, geoms[i], would cost two atomic counts at each call).
        rows_of = stack_empty(ROW_COPIES, 0, np.float64)
        geom_a, geom_b = rows_of[:GEOM_WIDTH], rows_of[GEOM_WIDTH:2 * GEOM_WIDTH]
        at = 2 * GEOM_WIDTH
        centre_a, centre_b = rows_of[at:at + 3], rows_of[at + 3:at + 6]
        rot_a, rot_b = rows_of[at + 6:at + 15], rows_of[at + 15:at + 24]
        total = int(0)
        for k in range(n_pairs):
            i, j = int(pair_a[k]), int(pair_b[k])
            for q in range(GEOM_WIDTH):
                geom_a[q], geom_b[q] = geoms[i, q], geoms[j, q]
            for q in range(3):
                centre_a[q], centre_b[q] = centres[i, q], centres[j, q]
            for q in range(9):
                rot_a[q], rot_b[q] = rotations[i, q], rotations[j, q]
            count = collide_pair_of(tests, int(kinds[i]), geom_a, centre_a, rot_a, int(kinds[j]),
                                    geom_b, centre_b, rot_b, pool, float(margins[k]), point,
                                    normal, depth, feature, total)
            for row in range(total, total + count):
                source[row] = k
            total += count
        return total

    collide_pairs.__name__ = collide_pairs.__qualname__ = name
    return kernel(collide_pairs)


def pairs_kernel(tests: int):
    """``collide_pairs`` with the contact tests ``tests`` (``PAIR_BIT``): a kernel of its own
    for each set, made the first time it is asked for (``jit.made_global``)."""
    checked_tests(tests)
    name = 'collide_pairs' if tests == PAIRS_ALL else f'collide_pairs_{tests}'
    return made_global(globals(), name, lambda: _collide_pairs_for(tests, name))


@literal_entry(pairs_kernel)
def collide_pairs_of(tests, pair_a, pair_b, kinds, geoms, pool, centres, rotations, margins,
                     point, normal, depth, feature, source):
    """``collide_pairs`` with the contact tests ``tests`` alone (``PAIR_BIT``; a constant
    where a kernel calls it, which then calls ``pairs_kernel(tests)``); a pair outside them is
    a ValueError."""


# every contact test (a kernel named collide_pairs)
collide_pairs = pairs_kernel(PAIRS_ALL)


@kernel
def sphere_batch(kind_b, centres_a, radii_a, centres_b, geoms_b, margins, keep,
                 point, normal, depth):
    """Balls against balls (kind_b KIND_SPHERE) or against planes (KIND_PLANE), M pairs: ball
    k of centre centres_a[k] (m) and radius radii_a[k] with the shape B of centres_b[k] and
    geoms_b[k] (M, 5) (as ``collide_pairs``), within margins[k]. keep[k] (bool) says whether
    pair k touches; the kept pairs' contacts (feature 0) fill the first rows of point (M, 3),
    normal (M, 3), depth (M,), in order; returns their number. The same arithmetic as
    ``collide_pair``, without its per-pair dispatch, for large scenes."""
    pairs = radii_a.shape[0]
    if (centres_a.shape[0] < pairs or centres_b.shape[0] < pairs or geoms_b.shape[0] < pairs
            or margins.shape[0] < pairs or keep.shape[0] < pairs or point.shape[0] < pairs
            or normal.shape[0] < pairs or depth.shape[0] < pairs or centres_a.shape[1] < 3
            or centres_b.shape[1] < 3 or geoms_b.shape[1] < GEOM_WIDTH):
        raise ValueError('sphere_batch: arrays too short for the pairs')
    if kind_b != KIND_SPHERE and kind_b != KIND_PLANE:
        raise ValueError('sphere_batch: B must be spheres or planes')
    feature = np.empty(pairs, dtype=np.int64)     # every feature is 0: not returned
    total = int(0)
    for k in range(pairs):
        ax, ay, az = float(centres_a[k, 0]), float(centres_a[k, 1]), float(centres_a[k, 2])
        bx, by, bz = float(centres_b[k, 0]), float(centres_b[k, 1]), float(centres_b[k, 2])
        if kind_b == KIND_SPHERE:
            found = _sphere_sphere(ax, ay, az, float(radii_a[k]), bx, by, bz,
                                   float(geoms_b[k, RADIUS]), float(margins[k]), int(0),
                                   0.0, 0.0, 1.0, point, normal, depth, feature, total)
        else:
            found = _sphere_plane(ax, ay, az, float(radii_a[k]), bx, by, bz,
                                  float(geoms_b[k, NORMAL]), float(geoms_b[k, NORMAL + 1]),
                                  float(geoms_b[k, NORMAL + 2]), float(margins[k]), int(0),
                                  point, normal, depth, feature, total)
        keep[k] = found > 0
        total += found
    return total
