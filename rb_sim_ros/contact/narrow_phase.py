# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Narrow phase: the contacts between two placed shapes, for every pair of kinds.

Conventions (every function, every pair; all vectors world frame, SI):

* ``normal`` is a unit vector from shape A towards shape B: B separates by moving along
  +normal, A along -normal. For a pair with a plane, the plane is B and normal = -plane normal.
* ``depth`` is the penetration along the normal (m): > 0 overlapping, < 0 a gap. A function
  given ``margin`` >= 0 also returns contacts with a gap up to ``margin`` (speculative contacts,
  see docs/collisions.md); with margin 0 only touching or overlapping ones.
* ``point`` is midway between the two surfaces: with pA the point of A deepest into B (or
  nearest to it) and pB that of B, point = (pA + pB) / 2 and depth = (pA - pB) . normal.
* ``feature`` is a small int naming the pair of features in touch (a box vertex, a clipped
  edge, a capsule end); it stays the same from step to step while they do, so that the solver
  can carry impulses over (warm start). Its values mean nothing else.

``collide(shape_a, pose_a, shape_b, pose_b, margin)`` dispatches on the kinds (in
collision_shapes.RANK order, swapping and negating the normals when needed); poses are the
shapes' own world (centre, rotation) from ``collision_shapes.world_pose``. Box-box is the
separating axis test over the 15 axes (3 + 3 face normals, 9 edge-edge cross products), with
a face contact clipped to the reference face (Sutherland-Hodgman, at most 4 points kept) and
an edge-edge contact at the closest points of the two edges. ``sphere_sphere_batch`` and
``sphere_plane_batch`` are the same tests on arrays of pairs, for large scenes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rb_sim_ros.contact.collision_shapes import RANK, Shape

# Two directions whose cross product is shorter than this are parallel (no edge-edge axis).
PARALLEL_EPS = 1e-6
# A face axis is kept over a better edge axis unless the edge one separates by more than
# EDGE_RELATIVE * face + EDGE_ABSOLUTE (m): an edge contact on a resting face is the classic
# source of jitter; the same tolerance prefers A's face over B's.
EDGE_RELATIVE = 0.95
EDGE_ABSOLUTE = 1e-5
# Contacts of a capsule lying on a box face: candidates whose normal is within this cosine of
# the deepest one's count as the same face (two ends of a resting capsule).
SAME_FACE_COS = 0.999
UP = np.array([0.0, 0.0, 1.0])


class Contact(NamedTuple):
    """One contact point: ``point`` (m), ``normal`` (unit, from A to B), ``depth`` (m, > 0
    overlapping), world frame; ``feature`` names the features in touch (see module doc)."""

    point: np.ndarray
    normal: np.ndarray
    depth: float
    feature: int


def _contact(pa: np.ndarray, pb: np.ndarray, normal: np.ndarray, feature: int) -> Contact:
    return Contact(0.5 * (pa + pb), normal, float((pa - pb) @ normal), feature)


def _unit(v: np.ndarray, fallback: np.ndarray = UP) -> np.ndarray:
    n = math.sqrt(float(v @ v))
    return v / n if n > 1e-300 else fallback


# -- sphere ------------------------------------------------------------------------------------
def sphere_sphere(ca, ra: float, cb, rb: float, margin: float = 0.0,
                  feature: int = 0, fallback: np.ndarray = UP) -> list[Contact]:
    """Balls of radii ra, rb (m) at centres ca, cb (m). Coincident centres: normal = fallback."""
    d = cb - ca
    dist = math.sqrt(float(d @ d))
    if ra + rb - dist < -margin:
        return []
    n = d / dist if dist > 1e-300 else fallback
    return [_contact(ca + ra * n, cb - rb * n, n, feature)]


def sphere_plane(c, r: float, plane_point, plane_normal, margin: float = 0.0,
                 feature: int = 0) -> list[Contact]:
    """A ball against the half-space (plane_point, plane_normal out of the solid)."""
    s = float((c - plane_point) @ plane_normal)
    if r - s < -margin:
        return []
    return [_contact(c - r * plane_normal, c - s * plane_normal, -plane_normal, feature)]


def sphere_box(c, r: float, cb, rb, half, margin: float = 0.0) -> list[Contact]:
    """A ball (centre c, radius r) against a box (centre cb, axes rb, half extents half).

    Outside the box the normal joins the nearest box point to the centre; a centre inside the
    box leaves through the nearest face (the first axis on a tie)."""
    local = rb.T @ (c - cb)
    q = np.clip(local, -half, half)
    delta = local - q
    dist2 = float(delta @ delta)
    if dist2 > 0.0:
        dist = math.sqrt(dist2)
        if r - dist < -margin:
            return []
        n_local = delta / dist
        qb = q
    else:
        faces = half - np.abs(local)
        i = int(np.argmin(faces))
        n_local = np.zeros(3)
        n_local[i] = 1.0 if local[i] >= 0.0 else -1.0
        qb = local.copy()
        qb[i] = n_local[i] * half[i]
    pa = local - r * n_local
    return [_contact(cb + rb @ pa, cb + rb @ qb, -(rb @ n_local), 0)]


def _segment_point(c, axis, half_length: float, p) -> np.ndarray:
    t = float((p - c) @ axis)
    return c + max(-half_length, min(half_length, t)) * axis


def sphere_capsule(c, r: float, cb, rotb, rb: float, hb: float,
                   margin: float = 0.0) -> list[Contact]:
    """A ball against a capsule (centre cb, axes rotb, radius rb, half segment length hb)."""
    axis = rotb[:, 2]
    s = _segment_point(cb, axis, hb, c)
    fallback = _unit(np.cross(axis, UP)) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return sphere_sphere(c, r, s, rb, margin, 0, fallback)


# -- capsule -----------------------------------------------------------------------------------
def capsule_plane(c, rot, r: float, h: float, plane_point, plane_normal,
                  margin: float = 0.0) -> list[Contact]:
    """A capsule against a half-space: a contact at each end ball that touches (features 0,
    1; one only for a zero-length capsule)."""
    axis = rot[:, 2]
    ends = (c - h * axis, c + h * axis) if h > 0.0 else (c,)
    out = []
    for k, e in enumerate(ends):
        out += sphere_plane(e, r, plane_point, plane_normal, margin, k)
    return out


def closest_segment_parameters(p1, d1, p2, d2) -> tuple[float, float, bool]:
    """(s, t, parallel): the points p1 + s d1 and p2 + t d2, s and t in [0, 1], closest to each
    other (Ericson, Real-Time Collision Detection, 5.1.9); parallel is True when the segments
    are (then s, t is one of the closest pairs)."""
    r = p1 - p2
    a = float(d1 @ d1)
    e = float(d2 @ d2)
    f = float(d2 @ r)
    tiny = 1e-30
    if a <= tiny and e <= tiny:
        return 0.0, 0.0, True
    if a <= tiny:
        return 0.0, min(1.0, max(0.0, f / e)), True
    c = float(d1 @ r)
    if e <= tiny:
        return min(1.0, max(0.0, -c / a)), 0.0, True
    b = float(d1 @ d2)
    denom = a * e - b * b
    parallel = denom <= PARALLEL_EPS * PARALLEL_EPS * a * e
    s = 0.0 if parallel else min(1.0, max(0.0, (b * f - c * e) / denom))
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, min(1.0, max(0.0, -c / a))
    elif t > 1.0:
        t, s = 1.0, min(1.0, max(0.0, (b - c) / a))
    return s, t, parallel


def capsule_capsule(ca, rota, ra: float, ha: float, cb, rotb, rb: float, hb: float,
                    margin: float = 0.0) -> list[Contact]:
    """Two capsules: the closest points of their segments, as two balls. Parallel segments
    that overlap along their length touch at both ends of the overlap (features 1, 2)."""
    ua, ub = rota[:, 2], rotb[:, 2]
    p1, d1 = ca - ha * ua, 2.0 * ha * ua
    p2, d2 = cb - hb * ub, 2.0 * hb * ub
    s, t, parallel = closest_segment_parameters(p1, d1, p2, d2)
    side = cb - ca
    fallback = _unit(np.cross(ua, ub), _unit(side - (side @ ua) * ua))
    if fallback @ side < 0.0:
        fallback = -fallback
    if parallel and ha > 0.0 and hb > 0.0:
        a = float(d1 @ d1)
        s0 = float((p2 - p1) @ d1) / a
        s1 = float((p2 + d2 - p1) @ d1) / a
        lo, hi = max(0.0, min(s0, s1)), min(1.0, max(s0, s1))
        if hi - lo > 1e-9:
            out = []
            for k, sk in enumerate((lo, hi)):
                pa = p1 + sk * d1
                out += sphere_sphere(pa, ra, _segment_point(cb, ub, hb, pa), rb, margin,
                                     k + 1, fallback)
            return out
    return sphere_sphere(p1 + s * d1, ra, p2 + t * d2, rb, margin, 0, fallback)


def _segment_box_distance(p0, d, half) -> tuple[float, float]:
    """(t, distance^2): the point p0 + t d, t in [0, 1], nearest the box |x_i| <= half_i
    (box-local coordinates, plain floats), and its squared distance. The squared distance is
    convex and piecewise quadratic in t, with breaks where a coordinate crosses a face plane:
    each piece is minimised exactly; the first best t wins ties."""
    breaks = [0.0, 1.0]
    for i in range(3):
        if d[i] != 0.0:
            for bound in (-half[i], half[i]):
                t = (bound - p0[i]) / d[i]
                if 0.0 < t < 1.0:
                    breaks.append(t)
    breaks.sort()
    best_t, best = 0.0, math.inf
    for t0, t1 in zip(breaks[:-1], breaks[1:]):
        if t1 <= t0:
            continue
        tm = 0.5 * (t0 + t1)
        qa = qb = 0.0
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
        t = t0 if qa <= 0.0 else min(t1, max(t0, -qb / qa))
        dist2 = 0.0
        for i in range(3):
            x = p0[i] + t * d[i]
            excess = max(0.0, abs(x) - half[i])
            dist2 += excess * excess
        if dist2 < best:
            best_t, best = t, dist2
    return best_t, best


def capsule_box(c, rot, r: float, h: float, cb, rotb, half,
                margin: float = 0.0) -> list[Contact]:
    """A capsule (A) against a box (B).

    Separated segment: the nearest points of segment and box (exact, ``_segment_box_distance``),
    plus the ends and face crossings that touch the same face (a capsule lying on a face
    touches at both ends of its span). Segment inside the box (deep, a failure of position
    correction): the axis of least penetration of segment and box (3 face normals, 3 cross
    products), with the deeper segment end(s) as contact points."""
    axis = rot[:, 2]
    p0 = rotb.T @ (c - h * axis - cb)
    p1 = rotb.T @ (c + h * axis - cb)
    d = p1 - p0
    hl = half.tolist()
    t_best, dist2 = _segment_box_distance(p0.tolist(), d.tolist(), hl)
    if dist2 > 1e-24:
        if r - math.sqrt(dist2) < -margin:
            return []
        candidates = [(0.0, 0), (1.0, 1)] if h > 0.0 else [(0.0, 0)]
        for i in range(3):
            if d[i] != 0.0:
                for side, bound in enumerate((-half[i], half[i])):
                    t = (bound - p0[i]) / d[i]
                    if 0.0 < t < 1.0:
                        candidates.append((float(t), 2 + 2 * i + side))
        best = _capsule_box_at(p0 + t_best * d, r, half, rotb, cb, margin, 10)
        out = [best]
        for t, feature in candidates:
            if abs(t - t_best) <= 1e-9:
                continue
            ct = _capsule_box_at(p0 + t * d, r, half, rotb, cb, margin, feature)
            if ct is not None and ct.normal @ best.normal >= SAME_FACE_COS:
                out.append(ct)
        return out
    # Deep: the segment meets the box.
    u = _unit(d)
    mid = 0.5 * (p0 + p1)
    axes = [np.eye(3)[i] for i in range(3)]
    for i in range(3):
        cr = np.cross(u, np.eye(3)[i])
        if cr @ cr > PARALLEL_EPS * PARALLEL_EPS:
            axes.append(cr / math.sqrt(float(cr @ cr)))
    best_sep, best_axis = -math.inf, axes[0]
    for ax in axes:
        sep = abs(float(mid @ ax)) - float(half @ np.abs(ax)) - 0.5 * abs(float(d @ ax))
        if sep > best_sep:
            best_sep, best_axis = sep, ax
    lax = best_axis if mid @ best_axis >= 0.0 else -best_axis
    support = float(half @ np.abs(lax))
    n_world = -(rotb @ lax)
    out = []
    ends = [(p0, 0), (p1, 1)] if h > 0.0 else [(p0, 0)]
    deepest = min(float(p @ lax) for p, _ in ends)
    for p, feature in ends:
        s = float(p @ lax) - support
        if r - s < -margin and float(p @ lax) > deepest:
            continue
        pa, pb = p - r * lax, p - s * lax
        out.append(_contact(cb + rotb @ pa, cb + rotb @ pb, n_world, 20 + feature))
    return out


def _capsule_box_at(p, r, half, rotb, cb, margin, feature):
    """Contact of the ball of radius r at box-local p (outside the box) with the box."""
    q = np.clip(p, -half, half)
    delta = p - q
    dist = math.sqrt(float(delta @ delta))
    if dist <= 1e-12 or r - dist < -margin:
        return None
    n_local = delta / dist
    return _contact(cb + rotb @ (p - r * n_local), cb + rotb @ q, -(rotb @ n_local), feature)


# -- box ---------------------------------------------------------------------------------------
_SIGNS = np.array([[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)
                   for sz in (-1.0, 1.0)])


def box_plane(c, rot, half, plane_point, plane_normal, margin: float = 0.0) -> list[Contact]:
    """A box against a half-space: every vertex within ``margin`` of the plane (feature =
    vertex index, 0-7)."""
    vertices = c + (_SIGNS * half) @ rot.T
    s = (vertices - plane_point) @ plane_normal
    out = []
    for k in np.flatnonzero(-s >= -margin):
        v = vertices[k]
        out.append(Contact(v - 0.5 * s[k] * plane_normal, -plane_normal, float(-s[k]), int(k)))
    return out


_EDGE_INDEX = tuple(np.array(v) for v in (
    [i for i in range(3) for _ in range(3)], [j for _ in range(3) for j in range(3)],
    [(i + 1) % 3 for i in range(3) for _ in range(3)],
    [(i + 2) % 3 for i in range(3) for _ in range(3)],
    [(j + 1) % 3 for _ in range(3) for j in range(3)],
    [(j + 2) % 3 for _ in range(3) for j in range(3)]))


def box_box(ca, rota, ha, cb, rotb, hb, margin: float = 0.0) -> list[Contact]:
    """Two boxes (centres, axes as columns of the rotations, half extents), by separating axes.

    The axis of greatest separation (least penetration) among the 15 decides: if it separates
    by more than ``margin`` there is no contact; a face axis gives up to 4 points of the
    incident face clipped to the reference face, an edge axis one point between the edges."""
    d = cb - ca
    cmat = rota.T @ rotb                     # C_ij = a_i . b_j
    absc = np.abs(cmat)
    da = rota.T @ d                          # d in A's axes
    db = rotb.T @ d
    sep_a = np.abs(da) - ha - absc @ hb      # face axes of A
    sep_b = np.abs(db) - hb - absc.T @ ha    # face axes of B
    ia, ib = int(np.argmax(sep_a)), int(np.argmax(sep_b))
    face_a, face_b = float(sep_a[ia]), float(sep_b[ib])
    if face_a > margin or face_b > margin:
        return []
    # Edge axes a_i x b_j, in A's frame e_i x C[:, j], all 9 at once.
    i, j, i1, i2, j1, j2 = _EDGE_INDEX
    length = np.sqrt(cmat[i1, j] ** 2 + cmat[i2, j] ** 2)
    valid = length >= PARALLEL_EPS
    ra = ha[i1] * absc[i2, j] + ha[i2] * absc[i1, j]
    rb = hb[j1] * absc[i, j2] + hb[j2] * absc[i, j1]
    proj = da[i2] * cmat[i1, j] - da[i1] * cmat[i2, j]
    sep = np.where(valid, (np.abs(proj) - ra - rb) / np.where(valid, length, 1.0), -math.inf)
    if np.any(sep > margin):
        return []
    k = int(np.argmax(sep))
    edge_sep, edge = float(sep[k]), None
    if valid[k]:
        ax = np.zeros(3)
        ax[i1[k]] = -cmat[i2[k], j[k]]
        ax[i2[k]] = cmat[i1[k], j[k]]
        edge = (int(i[k]), int(j[k]), ax / length[k])
    face = face_a
    use_b = face_b > EDGE_RELATIVE * face_a + EDGE_ABSOLUTE
    if use_b:
        face = face_b
    if edge is not None and edge_sep > EDGE_RELATIVE * face + EDGE_ABSOLUTE:
        return _edge_contact(ca, rota, ha, cb, rotb, hb, d, edge, edge_sep)
    if use_b:
        contacts = _face_contacts(cb, rotb, hb, ib, ca, rota, ha, margin)
        return [Contact(p, -n, depth, 100 + f) for p, n, depth, f in contacts]
    return [Contact(p, n, depth, f)
            for p, n, depth, f in _face_contacts(ca, rota, ha, ia, cb, rotb, hb, margin)]


def _edge_contact(ca, rota, ha, cb, rotb, hb, d, edge, sep) -> list[Contact]:
    i, j, ax_local = edge
    n = rota @ ax_local
    if n @ d < 0.0:
        n = -n
    # A's edge along a_i through A's vertex furthest along n; B's along b_j, furthest along -n.
    ea = ca.copy()
    for k in range(3):
        if k != i:
            ea += (ha[k] if rota[:, k] @ n > 0.0 else -ha[k]) * rota[:, k]
    eb = cb.copy()
    for k in range(3):
        if k != j:
            eb += (-hb[k] if rotb[:, k] @ n > 0.0 else hb[k]) * rotb[:, k]
    ua, ub = rota[:, i], rotb[:, j]
    s, t, _ = closest_segment_parameters(ea - ha[i] * ua, 2.0 * ha[i] * ua,
                                         eb - hb[j] * ub, 2.0 * hb[j] * ub)
    pa = ea - ha[i] * ua + s * 2.0 * ha[i] * ua
    pb = eb - hb[j] * ub + t * 2.0 * hb[j] * ub
    return [Contact(0.5 * (pa + pb), n, -sep, 200 + 3 * i + j)]


def _face_contacts(cr, rotr, hr, axis, ci, roti, hi, margin):
    """The incident box's face most opposed to the reference box's face ``axis`` (the one
    facing the incident box), clipped to the reference face: [(point, normal from reference
    to incident, depth, feature)]."""
    n = rotr[:, axis].copy()
    if n @ (ci - cr) < 0.0:
        n = -n
    # Incident face: the face of the other box whose outward normal is most against n.
    dots = roti.T @ n
    k = int(np.argmax(np.abs(dots)))
    sk = -1.0 if dots[k] > 0.0 else 1.0
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    centre = ci + sk * hi[k] * roti[:, k]
    e1, e2 = hi[k1] * roti[:, k1], hi[k2] * roti[:, k2]
    corners = np.array([centre + e1 + e2, centre - e1 + e2, centre - e1 - e2, centre + e1 - e2])
    polygon = list(zip(corners.tolist(), range(4)))
    # Clip by the 4 side planes of the reference face (plain floats: few points).
    a1, a2 = (axis + 1) % 3, (axis + 2) % 3
    u1, u2 = rotr[:, a1].tolist(), rotr[:, a2].tolist()
    o1, o2 = float(rotr[:, a1] @ cr), float(rotr[:, a2] @ cr)
    for plane_index, (u, limit) in enumerate((
            (u1, o1 + hr[a1]), ([-c for c in u1], hr[a1] - o1),
            (u2, o2 + hr[a2]), ([-c for c in u2], hr[a2] - o2))):
        polygon = _clip(polygon, u, float(limit), plane_index)
        if not polygon:
            return []
    face_offset = float(n @ cr) + hr[axis]
    nx, ny, nz = n.tolist()
    points = []
    for (px, py, pz), tag in polygon:
        s = nx * px + ny * py + nz * pz - face_offset       # > 0 above the reference face
        if -s >= -margin:
            h = 0.5 * s
            points.append((np.array([px - h * nx, py - h * ny, pz - h * nz]), -s, tag))
    if len(points) > 4:
        points = _reduce(points, n)
    feature_base = 1000 * (axis + 1) + (0 if sk > 0.0 else 500) + 10 * k
    return [(p, n, depth, feature_base + tag) for p, depth, tag in points]


def _clip(polygon, u, limit, plane_index):
    """Sutherland-Hodgman: the part of ``polygon`` ([(point as 3 floats, tag)]) with
    u . p <= limit. A vertex made on the edge from a vertex tagged t gets the tag
    4 + 4 * (t mod 32) + plane index: deterministic and stable while the same edges cross."""
    out = []
    count = len(polygon)
    ux, uy, uz = u
    for idx in range(count):
        p, tp = polygon[idx]
        q, tq = polygon[(idx + 1) % count]
        dp = ux * p[0] + uy * p[1] + uz * p[2] - limit
        dq = ux * q[0] + uy * q[1] + uz * q[2] - limit
        if dp <= 0.0:
            out.append((p, tp))
        if (dp < 0.0 < dq) or (dq < 0.0 < dp):
            t = dp / (dp - dq)
            out.append(([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]),
                         p[2] + t * (q[2] - p[2])], 4 + 4 * (min(tp, tq) % 32) + plane_index))
    return out


def _reduce(points, n):
    """Keep 4 of the clipped points: the deepest, the one furthest from it, then the two that
    span the largest area on either side of that line."""
    p = np.array([q for q, _, _ in points])
    first = max(range(len(points)), key=lambda i: (points[i][1], -i))
    far = int(np.argmax(((p - p[first]) ** 2).sum(axis=1)))
    d, q = p[far] - p[first], p - p[first]
    # (d x q) . n, written out: np.cross costs more than the rest of the reduction.
    area = np.stack([d[1] * q[:, 2] - d[2] * q[:, 1], d[2] * q[:, 0] - d[0] * q[:, 2],
                     d[0] * q[:, 1] - d[1] * q[:, 0]], axis=1) @ n
    keep = [first, far, int(np.argmax(area)), int(np.argmin(area))]
    seen = []
    for i in keep:
        if i not in seen:
            seen.append(i)
    return [points[i] for i in seen]


# -- dispatch ----------------------------------------------------------------------------------
def _plane(pose, shape):
    centre, rotation = pose
    return centre, rotation @ np.array(shape.normal)


def _pair(a: Shape, pa, b: Shape, pb, margin: float) -> list[Contact]:
    (ca, ra), (cb, rb) = pa, pb
    kinds = (a.kind, b.kind)
    if kinds == ('sphere', 'sphere'):
        return sphere_sphere(ca, a.radius, cb, b.radius, margin)
    if kinds == ('sphere', 'capsule'):
        return sphere_capsule(ca, a.radius, cb, rb, b.radius, b.half_length, margin)
    if kinds == ('sphere', 'box'):
        return sphere_box(ca, a.radius, cb, rb, np.array(b.half_extents), margin)
    if kinds == ('sphere', 'plane'):
        return sphere_plane(ca, a.radius, *_plane(pb, b), margin)
    if kinds == ('capsule', 'capsule'):
        return capsule_capsule(ca, ra, a.radius, a.half_length, cb, rb, b.radius,
                               b.half_length, margin)
    if kinds == ('capsule', 'box'):
        return capsule_box(ca, ra, a.radius, a.half_length, cb, rb, np.array(b.half_extents),
                           margin)
    if kinds == ('capsule', 'plane'):
        return capsule_plane(ca, ra, a.radius, a.half_length, *_plane(pb, b), margin)
    if kinds == ('box', 'box'):
        return box_box(ca, ra, np.array(a.half_extents), cb, rb, np.array(b.half_extents),
                       margin)
    if kinds == ('box', 'plane'):
        return box_plane(ca, ra, np.array(a.half_extents), *_plane(pb, b), margin)
    raise ValueError(f'no contact test between a {a.kind} and a {b.kind} (two planes are '
                     'both static)')


def collide(a: Shape, pose_a, b: Shape, pose_b, margin: float = 0.0) -> list[Contact]:
    """Contacts of shape ``a`` at ``pose_a`` with ``b`` at ``pose_b`` (each a world (centre,
    rotation) pair), normals from a to b; [] when they are further apart than ``margin``."""
    if RANK[a.kind] <= RANK[b.kind]:
        return _pair(a, pose_a, b, pose_b, margin)
    return [Contact(c.point, -c.normal, c.depth, c.feature)
            for c in _pair(b, pose_b, a, pose_a, margin)]


# -- batches (large scenes) --------------------------------------------------------------------
def sphere_sphere_batch(ca, ra, cb, rb, margin):
    """``sphere_sphere`` on M pairs at once: arrays (M, 3), (M,), ..., margin (M,) or a float.
    Returns (keep (M,) bool, point (K, 3), normal (K, 3), depth (K,)) for the kept pairs."""
    d = cb - ca
    dist = np.sqrt(np.einsum('ij,ij->i', d, d))
    depth_all = ra + rb - dist
    keep = depth_all >= -np.asarray(margin)
    d, dist = d[keep], dist[keep]
    n = np.where(dist[:, None] > 1e-300, d / np.where(dist > 1e-300, dist, 1.0)[:, None], UP)
    pa = ca[keep] + ra[keep][:, None] * n
    pb = cb[keep] - rb[keep][:, None] * n
    return keep, 0.5 * (pa + pb), n, np.einsum('ij,ij->i', pa - pb, n)


def sphere_plane_batch(c, r, plane_point, plane_normal, margin):
    """``sphere_plane`` on M pairs: (M, 3) centres, (M,) radii, (M, 3) plane points and unit
    normals. Returns (keep, point, normal, depth) as ``sphere_sphere_batch``."""
    s = np.einsum('ij,ij->i', c - plane_point, plane_normal)
    keep = r - s >= -np.asarray(margin)
    c, r, s, n = c[keep], r[keep], s[keep], plane_normal[keep]
    pa = c - r[:, None] * n
    pb = c - s[:, None] * n
    return keep, 0.5 * (pa + pb), -n, np.einsum('ij,ij->i', pa - pb, -n)
