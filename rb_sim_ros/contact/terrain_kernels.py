# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A solid shape against a terrain (``shapes.terrain``: a triangle mesh on a static body).

``terrain_pair``: the shape's box in the terrain's axes (its core's reach along each of them,
the rounding and the margin added) walks the terrain's hierarchy; a triangle whose box misses
it, or whose plane the shape lies in front of by more than the margin, is passed by. A
triangle with no active edge (the terrain's ``active``: a border, a convex fold), the most of
a floor or a bin, meets the shape along its normal alone, as a plane does
(``convex_kernels.convex_plane``) within the triangle's sides: the shape's face along the
triangle's inward normal, clipped to the triangle's prism (``_inner_triangle``). Any other is
a flat convex core (the terrain's row with ``TRIANGLE`` set), met by the convex narrow phase
(``convex_kernels.convex_pair``), and then its inner edges: a contact whose point on the
triangle lies inside it, or on an edge or corner that no active edge meets, is turned to the
triangle's normal, its depth the shape's point's below the triangle's plane, its point
halfway there; one at an inner edge or corner whose normal the convex phase tilted from the
triangle's is dropped: the shape's deepest point lies inside a neighbour, which meets it
(kept, a point of the shape moving down, it would be a ghost contact that lifts a rolling
ball). So a body crossing a flat tiled floor is pushed along the floor's normal alone
wherever it is (no snag, no bump), and a one-sided triangle never pulls a body through it.
A contact met from two triangles (a point on the edge they share) is kept once. Of all the
triangles' contacts, at most ``narrow_kernels.MAX_CONTACTS_PER_PAIR`` (the deepest, then
each the farthest from those kept) are written, features their triangle's index mixed into
the tags (the warm start's keys).

Conventions as ``narrow_kernels``: normal from the shape (A) to the terrain (B), depth > 0
overlapping, point midway, world frame, rot row-major; the same bits compiled and
interpreted; a bad input gives a meaningless contact, never an exception.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.contact import convex_kernels, shapes
from rb_sim_ros.contact.contact_geometry import apply as _apply, apply_t as _apply_t
from rb_sim_ros.contact.shapes import terrain
from rb_sim_ros.contact.shapes.base import GEOM_WIDTH
from rb_sim_ros.core.jit import inline_kernel, kernel, stack_empty

KIND_TERRAIN = terrain.KIND
# The most contacts gathered from the triangles of one pair before the few are chosen (past
# it, a deeper one takes the place of the shallowest), and the hierarchy's deepest path.
GATHERED = 64
# When they fill it, they are thinned to this many, spread over them (``_thin``).
THINNED = 16
STACK_DEPTH = 64
# The most contacts a pair writes (narrow_kernels.MAX_CONTACTS_PER_PAIR: a global here,
# checked there).
WRITTEN = 9
# A point within this fraction of its triangle's size of an edge's line lies on that edge.
ON_EDGE = 1e-7
# Where a contact's point lies on its triangle (``_where``).
INSIDE, ON_INNER, ON_ACTIVE = 0, 1, 2
# A contact at an inner edge or corner is kept (along the triangle's normal) only when its
# normal is within about 1.4e-6 rad of the triangle's (cos above SQUARE): the shape's
# deepest point is then there, else it lies inside a neighbour, which meets it.
SQUARE = 1.0 - 1e-12
# Two contacts closer than this (m) with the same normal (as SQUARE) are one, met from two
# triangles sharing the edge or corner it lies on.
SAME_POINT = 1e-9
# The most points of a shape's face clipped to a triangle's prism (its face's, one more for
# each side cut), and the tag of a crossing of side k by the face's edge from its point m:
# CROSSING + 16 k + m.
CLIPPED = convex_kernels.CORE_FACE + 3
CROSSING = 3900
# A feature: the tag of the contact on its triangle and the triangle's index mixed into
# the warm start's 12 bits (world_step.FEATURE_BITS): tag * 97 + index * TRIANGLE_TAG, modulo
# FEATURES (distinct tags of one triangle stay distinct; two triangles' seldom meet).
FEATURES = 4096
TRIANGLE_TAG = 2654435761


@kernel
def _reach(kind, geom, rot, pool, dx, dy, dz):
    """How far the core of a shape (kind, geom, its rotation rot) reaches from its centre
    along the world direction d."""
    lx, ly, lz = _apply_t(rot, dx, dy, dz)
    px, py, pz = shapes.core_point_of(kind, geom, pool, lx, ly, lz)
    return px * lx + py * ly + pz * lz


@inline_kernel
def _where(gb, pool, tri, qx, qy, qz):
    """Where the point q (the terrain's axes, on or near the triangle whose row starts at
    ``tri``) lies: INSIDE it, ON_ACTIVE (on an active edge or a corner of one) or ON_INNER (on
    inner edges and corners only)."""
    corners = stack_empty(3, 3, np.float64)
    for k in range(3):
        at = int(gb[terrain.OFFSET]) + 3 * int(pool[tri + k])
        for a in range(3):
            corners[k, a] = float(pool[at + a])
    nx, ny, nz = float(pool[tri + 3]), float(pool[tri + 4]), float(pool[tri + 5])
    where = INSIDE
    for k in range(3):
        j = (k + 1) % 3
        ex = float(corners[j, 0]) - float(corners[k, 0])
        ey = float(corners[j, 1]) - float(corners[k, 1])
        ez = float(corners[j, 2]) - float(corners[k, 2])
        # the inward normal of edge k in the triangle's plane (n x e), as long as the edge
        ix, iy, iz = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex
        inward = ((qx - float(corners[k, 0])) * ix + (qy - float(corners[k, 1])) * iy
                  + (qz - float(corners[k, 2])) * iz)
        if inward <= ON_EDGE * (ex * ex + ey * ey + ez * ez):
            if float(pool[tri + 6 + k]) != 0.0:
                where = ON_ACTIVE
            elif where == INSIDE:
                where = ON_INNER
    return where


@kernel
def terrain_pair(kind, ga, ca, rota, gb, cb, rotb, pool, margin, point, normal, depth, feature,
                 row):
    """The contacts of a solid shape (kind, ga, ca, rota) with the terrain (gb, cb, rotb)
    within ``margin`` (the module doc), written from ``row``; their count (0 to WRITTEN)."""
    radius = shapes.core_radius_of(kind, ga)
    # the shape's box in the terrain's axes, about the terrain's origin
    rx, ry, rz = float(ca[0]) - float(cb[0]), float(ca[1]) - float(cb[1]), \
        float(ca[2]) - float(cb[2])
    ox, oy, oz = _apply_t(rotb, rx, ry, rz)
    low = stack_empty(3, 0, np.float64)
    high = stack_empty(3, 0, np.float64)
    for a in range(3):
        ax = float(rotb[a])
        ay = float(rotb[3 + a])
        az = float(rotb[6 + a])
        up = _reach(kind, ga, rota, pool, ax, ay, az) + radius + margin
        down = _reach(kind, ga, rota, pool, -ax, -ay, -az) + radius + margin
        at = ox if a == 0 else (oy if a == 1 else oz)
        low[a], high[a] = at - down, at + up
    tri_geom = stack_empty(GEOM_WIDTH, 0, np.float64)
    for s in range(GEOM_WIDTH):
        tri_geom[s] = float(gb[s])
    one_point = stack_empty(CLIPPED, 3, np.float64)
    one_normal = stack_empty(CLIPPED, 3, np.float64)
    one_depth = stack_empty(CLIPPED, 0, np.float64)
    one_feature = stack_empty(CLIPPED, 0, np.int64)
    got_point = stack_empty(GATHERED, 3, np.float64)
    got_normal = stack_empty(GATHERED, 3, np.float64)
    got_depth = stack_empty(GATHERED, 0, np.float64)
    got_feature = stack_empty(GATHERED, 0, np.int64)
    todo = stack_empty(STACK_DEPTH, 0, np.int64)
    nodes = terrain.nodes_at(gb)
    order = nodes + terrain.NODE_WIDTH * int(gb[terrain.NODES])
    got = 0
    todo[0] = 0
    waiting = 1
    while waiting > 0:
        waiting -= 1
        at = nodes + terrain.NODE_WIDTH * int(todo[waiting])
        apart = False
        for a in range(3):
            if float(pool[at + a]) > float(high[a]) or float(pool[at + 3 + a]) < float(low[a]):
                apart = True
        if apart:
            continue
        first, count = int(pool[at + 6]), int(pool[at + 7])
        if count == 0:
            if waiting + 2 <= STACK_DEPTH:  # (a hierarchy of half a million is 18 deep)
                todo[waiting], todo[waiting + 1] = first + 1, first
                waiting += 2
            continue
        for slot in range(first, first + count):
            t = int(pool[order + slot])
            tri = terrain.triangle_at(gb, t)
            if _apart(gb, pool, tri, low, high):
                continue
            fx, fy, fz = _apply(rotb, float(pool[tri + 3]), float(pool[tri + 4]),
                                float(pool[tri + 5]))
            # the shape wholly in front of the triangle's plane by more than the margin: none
            # (what the convex phase would find, at the cost of one support); wholly behind
            # it: none either (one-sided: a body beyond a thin wall is not pulled through it)
            sunk = _below(gb, pool, tri, rotb, cb, float(ca[0]), float(ca[1]), float(ca[2]),
                          fx, fy, fz)
            if (sunk + _reach(kind, ga, rota, pool, -fx, -fy, -fz) + radius < -margin
                    or -sunk + _reach(kind, ga, rota, pool, fx, fy, fz) + radius < -margin):
                continue
            inner = (float(pool[tri + 6]) == 0.0 and float(pool[tri + 7]) == 0.0
                     and float(pool[tri + 8]) == 0.0)
            if inner:  # no active edge: the contacts along its normal, as the plane's
                found = _inner_triangle(kind, ga, ca, rota, gb, cb, rotb, pool, tri, fx, fy, fz,
                                        radius, margin, one_point, one_normal, one_depth,
                                        one_feature)
            else:
                tri_geom[terrain.TRIANGLE] = float(t)
                # (plain ints: the kernel every row calls, not one more made for constants)
                found = convex_kernels.convex_pair(kind, ga, ca, rota, int(KIND_TERRAIN),
                                                   tri_geom, cb, rotb, pool, margin, one_point,
                                                   one_normal, one_depth, one_feature, int(0))
            for m in range(found):
                nx, ny, nz = (float(one_normal[m, 0]), float(one_normal[m, 1]),
                              float(one_normal[m, 2]))
                d = float(one_depth[m])
                px = float(one_point[m, 0])
                py = float(one_point[m, 1])
                pz = float(one_point[m, 2])
                # the triangle's point (B's) and the shape's (A's)
                bx, by, bz = px - 0.5 * d * nx, py - 0.5 * d * ny, pz - 0.5 * d * nz
                qx, qy, qz = _apply_t(rotb, bx - float(cb[0]), by - float(cb[1]),
                                      bz - float(cb[2]))
                where = INSIDE if inner else _where(gb, pool, tri, qx, qy, qz)
                along = -(nx * fx + ny * fy + nz * fz)
                if where == ON_INNER and along < SQUARE:
                    continue  # (a tilted contact at an inner edge: a snag)
                turn = not inner and along < 1.0 and (where != ON_ACTIVE or along < 0.0)
                if turn:  # along the triangle's normal: from the shape's point when the
                    # convex phase's normal was near it, else from its deepest point (the
                    # phase's way out, far off the normal, may be through the back)
                    if along >= convex_kernels.FACE_COS and where != ON_ACTIVE:
                        sx, sy, sz = px + 0.5 * d * nx, py + 0.5 * d * ny, pz + 0.5 * d * nz
                    else:
                        lx, ly, lz = _apply_t(rota, -fx, -fy, -fz)
                        cx, cy, cz = shapes.core_point_of(kind, ga, pool, lx, ly, lz)
                        wx, wy, wz = _apply(rota, cx, cy, cz)
                        sx = float(ca[0]) + wx - radius * fx
                        sy = float(ca[1]) + wy - radius * fy
                        sz = float(ca[2]) + wz - radius * fz
                    d = _below(gb, pool, tri, rotb, cb, sx, sy, sz, fx, fy, fz)
                    nx, ny, nz = -fx, -fy, -fz
                    px, py, pz = sx + 0.5 * d * fx, sy + 0.5 * d * fy, sz + 0.5 * d * fz
                if d < -margin:
                    continue
                tag = (int(one_feature[m]) * 97 + t * TRIANGLE_TAG) % FEATURES
                slot_at = got
                for k in range(got):  # met already, from a neighbour across an edge: once
                    ex = float(got_point[k, 0]) - px
                    ey = float(got_point[k, 1]) - py
                    ez = float(got_point[k, 2]) - pz
                    if (ex * ex + ey * ey + ez * ez <= SAME_POINT * SAME_POINT
                            and float(got_normal[k, 0]) * nx + float(got_normal[k, 1]) * ny
                            + float(got_normal[k, 2]) * nz >= SQUARE):
                        slot_at = k if d > float(got_depth[k]) else -1
                        break
                if slot_at < 0:
                    continue
                if slot_at == GATHERED:  # full: thinned to THINNED spread over them
                    got = _thin(got_point, got_normal, got_depth, got_feature, got, THINNED)
                    slot_at = got
                if slot_at == got:
                    got += 1
                got_point[slot_at, 0], got_point[slot_at, 1], got_point[slot_at, 2] = px, py, pz
                got_normal[slot_at, 0], got_normal[slot_at, 1] = nx, ny
                got_normal[slot_at, 2] = nz
                got_depth[slot_at] = d
                got_feature[slot_at] = tag
    return _written(got_point, got_normal, got_depth, got_feature, got, point, normal, depth,
                    feature, row)


@kernel
def _inner_triangle(kind, ga, ca, rota, gb, cb, rotb, pool, tri, fx, fy, fz, radius, margin,
                    point, normal, depth, feature):
    """The contacts of a shape with a triangle none of whose edges is active (world normal f):
    those the convex phase and the turn to its normal would give, found as a plane's
    (``convex_kernels.convex_plane``): the shape's face along -f (on its rounded surface),
    clipped to the triangle's prism (Sutherland-Hodgman on the planes through its edges,
    square to it), each point within the margin of its plane a contact halfway to it, normal
    -f; their count (at most CLIPPED)."""
    face = stack_empty(CLIPPED, 3, np.float64)
    tags = stack_empty(CLIPPED, 0, np.int64)
    cut = stack_empty(CLIPPED, 3, np.float64)
    cut_tags = stack_empty(CLIPPED, 0, np.int64)
    corners = stack_empty(3, 3, np.float64)
    for k in range(3):
        at = int(gb[terrain.OFFSET]) + 3 * int(pool[tri + k])
        wx, wy, wz = _apply(rotb, float(pool[at]), float(pool[at + 1]), float(pool[at + 2]))
        corners[k, 0] = float(cb[0]) + wx
        corners[k, 1] = float(cb[1]) + wy
        corners[k, 2] = float(cb[2]) + wz
    n = convex_kernels.world_face(kind, ga, ca, rota, pool, -fx, -fy, -fz, radius, face, tags)
    for k in range(3):
        j = (k + 1) % 3
        ex = float(corners[j, 0]) - float(corners[k, 0])
        ey = float(corners[j, 1]) - float(corners[k, 1])
        ez = float(corners[j, 2]) - float(corners[k, 2])
        ix, iy, iz = fy * ez - fz * ey, fz * ex - fx * ez, fx * ey - fy * ex  # f x e, inward
        kx, ky, kz = float(corners[k, 0]), float(corners[k, 1]), float(corners[k, 2])
        # (a side moved out by ON_EDGE of the edge: a point on an edge two triangles share
        # is kept by both, and met once, never lost to rounding by both)
        slack = ON_EDGE * (ex * ex + ey * ey + ez * ez)
        kept = 0
        for m in range(n):
            q = (m + 1) % n
            s0 = ((float(face[m, 0]) - kx) * ix + (float(face[m, 1]) - ky) * iy
                  + (float(face[m, 2]) - kz) * iz) + slack
            s1 = ((float(face[q, 0]) - kx) * ix + (float(face[q, 1]) - ky) * iy
                  + (float(face[q, 2]) - kz) * iz) + slack
            if s0 >= 0.0 and kept < CLIPPED:
                for a in range(3):
                    cut[kept, a] = face[m, a]
                cut_tags[kept] = tags[m]
                kept += 1
            if n > 1 and (q > m or n > 2) and (s0 >= 0.0) != (s1 >= 0.0) and kept < CLIPPED:
                w = s0 / (s0 - s1)
                for a in range(3):
                    cut[kept, a] = float(face[m, a]) + w * (float(face[q, a]) - float(face[m, a]))
                cut_tags[kept] = CROSSING + 16 * k + m
                kept += 1
        n = kept
        for m in range(n):
            for a in range(3):
                face[m, a] = cut[m, a]
            tags[m] = cut_tags[m]
    count = 0
    vx, vy, vz = float(corners[0, 0]), float(corners[0, 1]), float(corners[0, 2])
    for m in range(n):
        px, py, pz = float(face[m, 0]), float(face[m, 1]), float(face[m, 2])
        height = (px - vx) * fx + (py - vy) * fy + (pz - vz) * fz
        if -height >= -margin:
            h = 0.5 * height
            point[count, 0], point[count, 1], point[count, 2] = px - h * fx, py - h * fy, \
                pz - h * fz
            normal[count, 0], normal[count, 1], normal[count, 2] = -fx, -fy, -fz
            depth[count] = -height
            feature[count] = tags[m]
            count += 1
    return count


@inline_kernel
def _apart(gb, pool, tri, low, high):
    """Whether the box of the triangle whose row starts at ``tri`` misses the box [low, high]
    (the terrain's axes): it is then farther than the margin the box was widened by."""
    for a in range(3):
        lo, hi = math.inf, -math.inf
        for k in range(3):
            c = float(pool[int(gb[terrain.OFFSET]) + 3 * int(pool[tri + k]) + a])
            lo = c if c < lo else lo
            hi = c if c > hi else hi
        if lo > float(high[a]) or hi < float(low[a]):
            return True
    return False


@inline_kernel
def _below(gb, pool, tri, rotb, cb, sx, sy, sz, fx, fy, fz):
    """How far the world point s lies below the plane of triangle ``tri`` (its row's start;
    its world normal f)."""
    at = int(gb[terrain.OFFSET]) + 3 * int(pool[tri])
    vx, vy, vz = _apply(rotb, float(pool[at]), float(pool[at + 1]), float(pool[at + 2]))
    return ((float(cb[0]) + vx - sx) * fx + (float(cb[1]) + vy - sy) * fy
            + (float(cb[2]) + vz - sz) * fz)


@inline_kernel
def _thin(got_point, got_normal, got_depth, got_feature, got, keep):
    """The ``got`` contacts gathered cut to ``keep`` of them (``_chosen``), in their order, at
    the start; their count."""
    kept = stack_empty(GATHERED, 0, np.bool_)
    _chosen(got_point, got_depth, got, keep, kept)
    out = 0
    for k in range(got):
        if kept[k]:
            for a in range(3):
                got_point[out, a] = got_point[k, a]
                got_normal[out, a] = got_normal[k, a]
            got_depth[out] = got_depth[k]
            got_feature[out] = got_feature[k]
            out += 1
    return out


@inline_kernel
def _written(got_point, got_normal, got_depth, got_feature, got, point, normal, depth, feature,
             row):
    """At most WRITTEN of the ``got`` contacts gathered (``_chosen``), from ``row``; their
    count."""
    kept = stack_empty(GATHERED, 0, np.bool_)
    count = _chosen(got_point, got_depth, got, WRITTEN, kept)
    out = row
    for k in range(got):
        if kept[k]:
            for a in range(3):
                point[out, a] = got_point[k, a]
                normal[out, a] = got_normal[k, a]
            depth[out] = got_depth[k]
            feature[out] = got_feature[k]
            out += 1
    return count


@inline_kernel
def _chosen(got_point, got_depth, got, keep, kept):
    """Which of the ``got`` contacts to keep (kept[:got]), at most ``keep``: all when they fit,
    else the deepest (the first on a tie), then each the one farthest from those kept (its
    least distance to them the largest, the first on a tie); their count."""
    for k in range(got):
        kept[k] = got <= keep
    count = got if got <= keep else keep
    if got > keep:
        best = 0
        for k in range(1, got):
            if float(got_depth[k]) > float(got_depth[best]):
                best = k
        kept[best] = True
        near = stack_empty(GATHERED, 0, np.float64)
        for k in range(got):
            near[k] = math.inf
        last = best
        for _ in range(1, keep):
            far, far_at = -1.0, -1
            for k in range(got):
                if kept[k]:
                    continue
                dx = float(got_point[k, 0]) - float(got_point[last, 0])
                dy = float(got_point[k, 1]) - float(got_point[last, 1])
                dz = float(got_point[k, 2]) - float(got_point[last, 2])
                gap = dx * dx + dy * dy + dz * dz
                if gap < float(near[k]):
                    near[k] = gap
                if float(near[k]) > far:
                    far, far_at = float(near[k]), k
            kept[far_at] = True
            last = far_at
    return count
