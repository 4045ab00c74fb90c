# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The terrain: a triangle mesh, open or closed, convex or not (a landing site, a bin), on
static bodies only. Each triangle is one-sided: its normal (counter-clockwise corners seen from
the side bodies rest on) is the way it pushes.

Its row: the offset of its data in the pool, ``TRIANGLE`` (-1: the whole mesh; a triangle's
index in the row the terrain's contact test makes of one of its triangles, which ``core_point``
and ``core_face`` then read as that triangle, a flat convex core), its vertex, triangle and node
counts. Its data (``pack``): its vertices (x, y, z each); each triangle as its 3 corner indices,
its unit normal and one flag for each of its edges (corner k to k + 1), 1 where the edge is
*active*: an edge of the surface's border, or a convex fold sharper than FLAT_ANGLE; then its
bounding-volume hierarchy (BVH) over the triangles, each node its box (lower, upper) in its axes
and (first, count) of its triangles in the order that follows (count 0: an inner node, whose
children are nodes first and first + 1); then that order.

Contacts (``terrain_kernels.terrain_pair``): the triangles whose boxes meet the other shape's
box (the hierarchy walked), each one against the shape by the convex narrow phase; a contact
whose point lies inside its triangle, or on an edge or corner no active edge meets (a tiled
floor's inner edge, the inside of a fold), takes the triangle's normal, so that a body sliding
or rolling across a flat tiled floor meets no edge (no snag, no bump).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Any

import numpy as np

from rb_sim_ros.contact.shapes.base import (IDENTITY_XYZW, material, MAX_LENGTH, MIN_LENGTH,
                                            ORIGIN, placement, Pool)
from rb_sim_ros.core.jit import inline_kernel
from rb_sim_ros.core.rigid_body import short

NAME = 'terrain'
KIND = 7
FIELDS = ('vertices', 'triangles')
PLACED = True
STATIC_ONLY = True

# The most triangles and vertices of a terrain (its data: about 100 bytes a triangle).
MAX_TRIANGLES = 500_000
MAX_VERTICES = 500_000
# A triangle of area below this fraction of the square of the terrain's size is dropped
# (``dropped`` counts them): it has no normal to push along.
SLIVER_RELATIVE = 1e-14
# Two triangles sharing an edge whose normals differ by less than this (rad) are one flat
# surface there: the edge is inactive (no contact takes its normal).
FLAT_ANGLE = 1e-3
# The most triangles in a leaf of the hierarchy.
LEAF_SIZE = 4
# Slots of its row.
OFFSET, TRIANGLE, VERTICES, TRIANGLES, NODES = 0, 1, 2, 3, 4
# Floats per triangle (3 corners, normal, 3 edge flags) and per node of its data.
TRIANGLE_WIDTH = 9
NODE_WIDTH = 8


@dataclass(frozen=True)
class Terrain:
    """The triangle mesh of ``vertices`` ((x, y, z) in m, its own axes) and ``triangles``
    (3 vertex indices each, counter-clockwise seen from the side it pushes towards), placed at
    ``position`` (m, body frame) with axes turned by ``orientation_xyzw``. Triangles of no
    area are dropped (``dropped`` counts them). ``active`` (T, 3): whether each edge is active
    (the module doc)."""

    vertices: Any
    triangles: Any
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)
    normals: np.ndarray = field(init=False, repr=False, compare=False)
    active: np.ndarray = field(init=False, repr=False, compare=False)
    dropped: int = field(init=False, repr=False, compare=False)

    kind = NAME

    def __post_init__(self) -> None:
        vertices = _vertices(self.vertices)
        triangles = _triangles(self.triangles, len(vertices))
        size = float(np.ptp(vertices, axis=0).max())
        if not size >= MIN_LENGTH:
            raise ValueError(f'vertices: they span {size:g} m, less than MIN_LENGTH = '
                             f'{MIN_LENGTH:g} m')
        cross = np.cross(vertices[triangles[:, 1]] - vertices[triangles[:, 0]],
                         vertices[triangles[:, 2]] - vertices[triangles[:, 0]])
        length = np.sqrt((cross * cross).sum(axis=1))
        kept = length > 2.0 * SLIVER_RELATIVE * size * size
        if not kept.any():
            raise ValueError('triangles: every one has no area (its corners in a line)')
        triangles, normals = triangles[kept], cross[kept] / length[kept, None]
        for name, value in (('vertices', vertices), ('triangles', triangles)):
            value.flags.writeable = False
            object.__setattr__(self, name, tuple(tuple(v) for v in value.tolist()))
        normals.flags.writeable = False
        active = _active_edges(vertices, triangles, normals)
        active.flags.writeable = False
        object.__setattr__(self, 'normals', normals)
        object.__setattr__(self, 'active', active)
        object.__setattr__(self, 'dropped', int((~kept).sum()))
        placement(self)
        material(self)

    @property
    def bounding_radius(self) -> float:
        """Its farthest vertex from its origin (m)."""
        return float(np.sqrt((np.array(self.vertices) ** 2).sum(axis=1)).max())


VALUE = Terrain


def _vertices(value) -> np.ndarray:
    """(V, 3) finite floats of at most MAX_LENGTH in size; ValueError naming what is wrong."""
    if isinstance(value, (str, bytes)) or not hasattr(value, '__len__'):
        raise ValueError(f'vertices must be a list of [x, y, z] (m), got {short(value)}')
    if len(value) > MAX_VERTICES:
        raise ValueError(f'vertices: at most MAX_VERTICES = {MAX_VERTICES}, got {len(value)}')
    try:
        array = np.array(value)
    except (ValueError, TypeError, OverflowError):
        raise ValueError(f'vertices must be N x 3 numbers (m), got {short(value)}') from None
    if array.dtype.kind not in 'fiu' or (not isinstance(value, np.ndarray) and _has_bool(value)):
        raise ValueError(f'vertices must be N x 3 numbers (m), got {short(value)}')
    try:
        array = array.astype(np.float64)
    except OverflowError:
        raise ValueError('vertices: a coordinate does not fit a float') from None
    if array.ndim != 2 or array.shape[1] != 3 or len(array) < 3:
        raise ValueError(f'vertices must be at least 3 of [x, y, z] (m), got an array of '
                         f'shape {array.shape}')
    if not np.all(np.isfinite(array)):
        bad = int(np.flatnonzero(~np.isfinite(array).all(axis=1))[0])
        raise ValueError(f'vertices[{bad}] is not finite: {array[bad].tolist()}')
    if np.any(np.abs(array) > MAX_LENGTH):
        raise ValueError(f'vertices: a coordinate is beyond MAX_LENGTH = {MAX_LENGTH:g} m')
    return array


def _triangles(value, count: int) -> np.ndarray:
    """(T, 3) int64 vertex indices in [0, count), at most MAX_TRIANGLES."""
    if isinstance(value, (str, bytes)) or not hasattr(value, '__len__') or len(value) == 0:
        raise ValueError(f'triangles must be a non-empty list of [i, j, k] (vertex indices), '
                         f'got {short(value)}')
    if len(value) > MAX_TRIANGLES:
        raise ValueError(f'triangles: at most MAX_TRIANGLES = {MAX_TRIANGLES}, got '
                         f'{len(value)}')
    try:
        array = np.array(value)
    except (ValueError, TypeError, OverflowError):
        raise ValueError(f'triangles must be T x 3 vertex indices, got {short(value)}') from None
    if (array.ndim != 2 or array.shape[1] != 3 or array.dtype.kind not in 'iu'
            or (not isinstance(value, np.ndarray) and _has_bool(value))):
        raise ValueError(f'triangles must be T x 3 integer vertex indices, got '
                         f'{short(value)}')
    bad = np.flatnonzero(((array < 0) | (array >= count)).any(axis=1))
    if bad.size:
        raise ValueError(f'triangles[{int(bad[0])}] = {array[bad[0]].tolist()} names a vertex '
                         f'it does not have ({count} vertices)')
    array = array.astype(np.int64)
    same = np.flatnonzero((array[:, 0] == array[:, 1]) | (array[:, 1] == array[:, 2])
                          | (array[:, 0] == array[:, 2]))
    if same.size:
        raise ValueError(f'triangles[{int(same[0])}] = {array[same[0]].tolist()} repeats a '
                         'vertex')
    return array


def _has_bool(rows) -> bool:
    """Whether a list of rows holds a bool (numpy would read it as 0 or 1)."""
    return any(isinstance(c, (bool, np.bool_)) for row in rows for c in row)


def _active_edges(vertices: np.ndarray, triangles: np.ndarray,
                  normals: np.ndarray) -> np.ndarray:
    """(T, 3) bool: edge k of each triangle (corner k to k + 1) is active when no other
    triangle shares it (the border), more than one does (not a surface there), or the one
    that does folds away from it (convex) by more than FLAT_ANGLE. ValueError when two that
    share an edge face opposite sides (they run it the same way, or lie on each other)."""
    count = len(triangles)
    ends = np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(ends, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    active = np.ones(3 * count, dtype=bool)
    cos_flat = math.cos(FLAT_ANGLE)
    start = 0
    while start < len(order):
        stop = start + 1
        while stop < len(order) and (key[order[stop]] == key[order[start]]).all():
            stop += 1
        if stop - start == 2:
            i, j = int(order[start]), int(order[start + 1])
            t, u = i // 3, j // 3
            n_t, n_u = normals[t], normals[u]
            if ends[i][0] == ends[j][0]:
                raise ValueError(f'triangles[{min(t, u)}] and triangles[{max(t, u)}] run the edge '
                                 f'{ends[i].tolist()} the same way: they face opposite sides '
                                 '(give every triangle counter-clockwise from the side it pushes '
                                 'towards)')
            if float(n_t @ n_u) <= -cos_flat:
                raise ValueError(f'triangles[{min(t, u)}] and triangles[{max(t, u)}] lie on each '
                                 'other facing away (a two-sided sheet: give the side it pushes '
                                 'towards)')
            # the corner of u off the edge, above or below t's plane
            off_u = int(triangles[u][(j % 3 + 2) % 3])
            fold = float((vertices[off_u] - vertices[int(triangles[t][i % 3])]) @ n_t)
            flat = float(n_t @ n_u) >= cos_flat
            convex = fold < 0.0 and not flat
            active[i] = active[j] = convex
        start = stop
    return active.reshape(count, 3)


def hierarchy(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(nodes (N, 8): lower, upper, first, count; order (T,)): the bounding-volume hierarchy
    of the triangles, split at the median of their centroids along the widest spread of them,
    LEAF_SIZE triangles a leaf at most; node 0 the root, an inner node's children are nodes
    first and first + 1 (count 0)."""
    corners = vertices[triangles]                       # (T, 3, 3)
    low, high = corners.min(axis=1), corners.max(axis=1)
    centroid = corners.mean(axis=1)
    order = np.arange(len(triangles))
    nodes: list[list[float]] = [[0.0] * NODE_WIDTH]
    work = [(0, 0, len(triangles))]                     # (node, first, stop) into order
    while work:
        node, first, stop = work.pop()
        span = order[first:stop]
        box = [*low[span].min(axis=0), *high[span].max(axis=0)]
        if stop - first <= LEAF_SIZE:
            nodes[node] = [*box, float(first), float(stop - first)]
            continue
        spread = np.ptp(centroid[span], axis=0)
        axis = int(np.argmax(spread))
        half = (stop - first) // 2
        part = np.argsort(centroid[span, axis], kind='stable')
        order[first:stop] = span[part]
        child = len(nodes)
        nodes.append([0.0] * NODE_WIDTH)
        nodes.append([0.0] * NODE_WIDTH)
        nodes[node] = [*box, float(child), 0.0]
        work.append((child + 1, first + half, stop))
        work.append((child, first, first + half))
    return np.array(nodes, dtype=np.float64), order


def pack(shape: Terrain, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Its vertices, triangles and hierarchy into ``pool`` (the module doc), their offset and
    counts into its row."""
    vertices = np.array(shape.vertices, dtype=np.float64)
    triangles = np.array(shape.triangles, dtype=np.int64)
    nodes, order = hierarchy(vertices, triangles)
    table = np.concatenate([triangles.astype(np.float64), shape.normals,
                            shape.active.astype(np.float64)], axis=1)
    geom[OFFSET] = pool.add(np.concatenate([vertices.ravel(), table.ravel(), nodes.ravel(),
                                            order.astype(np.float64)]))
    geom[TRIANGLE] = -1.0
    geom[VERTICES], geom[TRIANGLES], geom[NODES] = len(vertices), len(triangles), len(nodes)


def draw(shape: Terrain) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one mesh, (its vertices, its triangles)."""
    return [('mesh', (np.array(shape.vertices), np.array(shape.triangles, dtype=np.int64)),
             np.array(shape.position), np.array(shape.rotation))]


@inline_kernel
def nodes_at(geom):
    """Where its hierarchy's nodes start in the pool."""
    return int(geom[OFFSET]) + 3 * int(geom[VERTICES]) + TRIANGLE_WIDTH * int(geom[TRIANGLES])


@inline_kernel
def triangle_at(geom, t):
    """Where triangle t's row starts in the pool."""
    return int(geom[OFFSET]) + 3 * int(geom[VERTICES]) + TRIANGLE_WIDTH * t


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the terrain of row ``c`` reaches along (l0, l1, l2) (its axes, unit): that of
    its hierarchy's root box (its vertices' box: at least the reach of each vertex)."""
    at = nodes_at(geoms[c])
    reach = 0.0
    for a in range(3):
        la = l0 if a == 0 else (l1 if a == 1 else l2)
        low, high = float(pool[at + a]) * la, float(pool[at + 3 + a]) * la
        reach += low if low > high else high
    return reach


@inline_kernel
def core_radius(geom):
    """No rounding: a triangle is its own core."""
    return 0.0


@inline_kernel
def _corner(geom, pool, k):
    """Corner k (0, 1, 2) of the triangle of the row (its axes)."""
    i = int(pool[triangle_at(geom, int(geom[TRIANGLE])) + k])
    at = int(geom[OFFSET]) + 3 * i
    return float(pool[at]), float(pool[at + 1]), float(pool[at + 2])


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """The triangle's corner farthest along (l0, l1, l2) (the first on a tie)."""
    bx, by, bz = _corner(geom, pool, 0)
    best = bx * l0 + by * l1 + bz * l2
    for k in range(1, 3):
        x, y, z = _corner(geom, pool, k)
        s = x * l0 + y * l1 + z * l2
        if s > best:
            best, bx, by, bz = s, x, y, z
    return bx, by, bz


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """The triangle, its corners in order round it seen from (l0, l1, l2): counter-clockwise
    when the direction is along its normal, else the other way; tags the corner numbers."""
    at = triangle_at(geom, int(geom[TRIANGLE]))
    up = float(pool[at + 3]) * l0 + float(pool[at + 4]) * l1 + float(pool[at + 5]) * l2
    for q in range(3):
        k = q if up >= 0.0 else (3 - q) % 3
        x, y, z = _corner(geom, pool, k)
        out[q, 0], out[q, 1], out[q, 2] = x, y, z
        tags[q] = k
    return 3
