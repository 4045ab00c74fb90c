# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The small kernels every contact test uses: a rotation applied to a vector, a contact
written, a polygon clipped by a plane and reduced to four points. Conventions as
``narrow_kernels``' module doc (rot row-major, rot[3 i + j] = R_ij; the same bits compiled
and interpreted)."""

from __future__ import annotations

import math

from rb_sim_ros.core.jit import inline_kernel, kernel

# Below this length (m) a direction is undefined and a fallback is used.
TINY_LENGTH = 1e-300


@kernel
def clamp(x, lo, hi):
    """x clamped to [lo, hi]: min(hi, max(lo, x)) as Python evaluates it; lo for a nan x."""
    y = x if x > lo else lo
    return y if y < hi else hi


@kernel
def unit(x, y, z, fx, fy, fz):
    """(x, y, z) / |(x, y, z)|, or the fallback (fx, fy, fz) when shorter than TINY_LENGTH."""
    n = math.sqrt(x * x + y * y + z * z)
    if n > TINY_LENGTH:
        return x / n, y / n, z / n
    return fx, fy, fz


@kernel
def column(rot, j):
    """Local axis j of a shape in the world frame: column j of R (rot row-major, 9)."""
    return float(rot[j]), float(rot[3 + j]), float(rot[6 + j])


@kernel
def apply(rot, x, y, z):
    """R v: a vector of the shape's frame in the world frame."""
    return (float(rot[0]) * x + float(rot[1]) * y + float(rot[2]) * z,
            float(rot[3]) * x + float(rot[4]) * y + float(rot[5]) * z,
            float(rot[6]) * x + float(rot[7]) * y + float(rot[8]) * z)


@kernel
def apply_t(rot, x, y, z):
    """R^T v: a world vector in the shape's frame."""
    return (float(rot[0]) * x + float(rot[3]) * y + float(rot[6]) * z,
            float(rot[1]) * x + float(rot[4]) * y + float(rot[7]) * z,
            float(rot[2]) * x + float(rot[5]) * y + float(rot[8]) * z)


@kernel
def write(point, normal, depth, feature, row, px, py, pz, nx, ny, nz, d, tag):
    """Row ``row`` of the outputs: point p (m), normal n, depth d (m), feature tag."""
    point[row, 0], point[row, 1], point[row, 2] = px, py, pz
    normal[row, 0], normal[row, 1], normal[row, 2] = nx, ny, nz
    depth[row] = d
    feature[row] = tag


@kernel
def put(point, normal, depth, feature, row, pax, pay, paz, pbx, pby, pbz, nx, ny, nz, tag):
    """The contact between pA, the point of A deepest into B (or nearest it), and pB that of B,
    normal n (A to B), world frame: point (pA + pB) / 2, depth (pA - pB) . n."""
    point[row, 0], point[row, 1], point[row, 2] = (
        0.5 * (pax + pbx), 0.5 * (pay + pby), 0.5 * (paz + pbz))
    normal[row, 0], normal[row, 1], normal[row, 2] = nx, ny, nz
    depth[row] = (pax - pbx) * nx + (pay - pby) * ny + (paz - pbz) * nz
    feature[row] = tag


@kernel
def clip(src, src_tag, count, dst, dst_tag, ux, uy, uz, limit, plane):
    """Sutherland-Hodgman: the part of the polygon src[:count] (points, m) with u . p <= limit,
    into dst; returns its vertex count. A vertex made on the edge from a vertex tagged t to one
    tagged t' gets the tag 4 + 4 (min(t, t') mod 32) + plane: deterministic, and stable while
    the same edges cross."""
    out = 0
    for k in range(count):
        q = k + 1 if k + 1 < count else 0
        px, py, pz = float(src[k, 0]), float(src[k, 1]), float(src[k, 2])
        qx, qy, qz = float(src[q, 0]), float(src[q, 1]), float(src[q, 2])
        tp, tq = int(src_tag[k]), int(src_tag[q])
        dp = ux * px + uy * py + uz * pz - limit
        dq = ux * qx + uy * qy + uz * qz - limit
        if dp <= 0.0:
            dst[out, 0], dst[out, 1], dst[out, 2] = px, py, pz
            dst_tag[out] = tp
            out += 1
        if (dp < 0.0 and dq > 0.0) or (dq < 0.0 and dp > 0.0):
            t = dp / (dp - dq)     # dp and dq of strictly opposite signs: dp - dq != 0
            dst[out, 0] = px + t * (qx - px)
            dst[out, 1] = py + t * (qy - py)
            dst[out, 2] = pz + t * (qz - pz)
            dst_tag[out] = 4 + 4 * ((tp if tp < tq else tq) % 32) + plane
            out += 1
    return out


@kernel
def reduce_to_four(p, d, count, nx, ny, nz):
    """Of the clipped points p[:count] (depths d), the indices of 4 to keep: the deepest (the
    first on a tie), the one furthest from it, then the two that span the largest area on
    either side of that line, (p_far - p_first) x (p - p_first) . n largest and least."""
    first = 0
    for k in range(1, count):
        if float(d[k]) > float(d[first]):
            first = k
    fx, fy, fz = float(p[first, 0]), float(p[first, 1]), float(p[first, 2])
    far, far_d2 = 0, -1.0
    for k in range(count):
        qx, qy, qz = float(p[k, 0]) - fx, float(p[k, 1]) - fy, float(p[k, 2]) - fz
        d2 = qx * qx + qy * qy + qz * qz
        if k == 0 or d2 > far_d2:
            far, far_d2 = k, d2
    ex, ey, ez = float(p[far, 0]) - fx, float(p[far, 1]) - fy, float(p[far, 2]) - fz
    most, least = 0, 0
    most_area, least_area = 0.0, 0.0
    for k in range(count):
        qx, qy, qz = float(p[k, 0]) - fx, float(p[k, 1]) - fy, float(p[k, 2]) - fz
        area = ((ey * qz - ez * qy) * nx + (ez * qx - ex * qz) * ny
                + (ex * qy - ey * qx) * nz)
        if k == 0 or area > most_area:
            most, most_area = k, area
        if k == 0 or area < least_area:
            least, least_area = k, area
    return first, far, most, least


@inline_kernel
def write_at_most_four(p, d, tags, count, rx, ry, rz, sign, base,
                       point, normal, depth, feature, row):
    """The contacts p[:count] (depths d, features base + tags), normal sign * r, into the
    outputs from ``row``: all of them when they are at most 4, else the 4 of
    ``reduce_to_four`` about r (each once); returns how many."""
    if count <= 4:
        for m in range(count):
            write(point, normal, depth, feature, row + m, float(p[m, 0]), float(p[m, 1]),
                  float(p[m, 2]), sign * rx, sign * ry, sign * rz, float(d[m]),
                  base + int(tags[m]))
        return count
    keep = reduce_to_four(p, d, count, rx, ry, rz)
    written = 0
    for q in range(4):
        m = keep[q]
        seen = False
        for w in range(q):
            if keep[w] == m:
                seen = True
        if not seen:
            write(point, normal, depth, feature, row + written, float(p[m, 0]),
                  float(p[m, 1]), float(p[m, 2]), sign * rx, sign * ry, sign * rz,
                  float(d[m]), base + int(tags[m]))
            written += 1
    return written
