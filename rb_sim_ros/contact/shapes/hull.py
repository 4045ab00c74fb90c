# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The convex hull: the smallest convex solid holding a set of points (a convex mesh, a
part of a convex decomposition). Its row: the offset of its data in the pool, its vertex
and face counts; its data (``pack``): its vertices (x, y, z each), then each face as its unit
outward normal, its corner count m and its m corner indices in order round the face
(counter-clockwise seen from outside).

The points are hulled once (``Hull`` is a value: validated and hulled when made, by qhull
through scipy). More than MAX_VERTICES vertices are thinned to MAX_VERTICES before the hull
is made (farthest-point sampling from the vertex farthest along +x: the kept ones spread over
the hull, corners first), so the hull used is inside the one given (``simplified`` says how
many vertices there were). Coplanar triangles are merged into the polygons of the solid's
faces, and a point on an edge or inside a face is not a vertex.

Its contacts are those of the convex narrow phase (``convex_kernels``): its core is itself,
``core_point`` its vertex farthest along a direction, ``core_face`` the face holding that
vertex most square to the direction (at most ``FACE_CAPACITY`` of its corners: a face of more
gives that many, spread round it, the farthest vertex among them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Any

import numpy as np

from rb_sim_ros.contact.shapes.base import (FACE_CAPACITY, IDENTITY_XYZW, material,
                                            MAX_LENGTH, MIN_LENGTH, ORIGIN, placement, Pool)
from rb_sim_ros.core.jit import inline_kernel
from rb_sim_ros.core.rigid_body import short

NAME = 'hull'
KIND = 5
FIELDS = ('points',)
PLACED = True
STATIC_ONLY = False

# The most vertices of a hull (a face tag is a vertex index: < 64 as the narrow phase's
# incident tags must be); the most points given (a mesh of more is decimated before it is
# given: hulling a million points alone takes a second).
MAX_VERTICES = 64
MAX_POINTS = 200_000
# Triangles whose normals are within COPLANAR_ANGLE (rad) and whose planes are within
# COPLANAR_RELATIVE of the hull's size are one face (a mesh's flat face split in triangles,
# its vertices rounded to float32: 1e-7 of the size).
COPLANAR_ANGLE = 1e-5
COPLANAR_RELATIVE = 1e-6
# A face within TILTED (rad) of a direction gives the same corners whatever its farthest
# vertex (as the cylinder's cap): a nearly level face does not move its contacts each step.
TILTED = 1e-3
_LEVEL = math.cos(TILTED)
# Slots of its row.
OFFSET, VERTICES, FACES = 0, 1, 2


@dataclass(frozen=True)
class Hull:
    """The convex hull of ``points`` ((x, y, z) in m, at least 4, not all in a plane) in its
    own axes, placed at ``position`` (m, body frame) with axes turned by
    ``orientation_xyzw``. After hulling, ``points`` are the hull's vertices only; ``faces``
    their polygons (indices, counter-clockwise from outside), ``normals`` the faces' unit
    outward normals; ``simplified`` the vertex count of the hull given when it had more than
    MAX_VERTICES (else 0)."""

    points: Any  # N x 3 numbers; once hulled, its vertices as a tuple of (x, y, z)
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)
    faces: tuple = field(init=False, repr=False, compare=False)
    normals: np.ndarray = field(init=False, repr=False, compare=False)
    simplified: int = field(init=False, repr=False, compare=False)

    kind = NAME

    def __post_init__(self) -> None:
        given = _points(self.points)
        vertices, faces, normals, simplified = hull_of(given)
        object.__setattr__(self, 'points', tuple(tuple(float(c) for c in v) for v in vertices))
        vertices.flags.writeable = False
        normals.flags.writeable = False
        object.__setattr__(self, 'faces', faces)
        object.__setattr__(self, 'normals', normals)
        object.__setattr__(self, 'simplified', simplified)
        placement(self)
        material(self)

    @property
    def vertices(self) -> np.ndarray:
        """Its vertices (V, 3), its axes (m)."""
        return np.array(self.points)

    @property
    def bounding_radius(self) -> float:
        """Its farthest vertex from its origin (m)."""
        return float(np.sqrt((self.vertices ** 2).sum(axis=1)).max())

    def triangles(self) -> np.ndarray:
        """Its surface as triangles (T, 3) of vertex indices, counter-clockwise from outside
        (each face fanned from its first corner)."""
        return np.array([(f[0], f[k], f[k + 1]) for f in self.faces
                         for k in range(1, len(f) - 1)], dtype=np.int64)

    def mass_properties(self, density: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass (kg), centre of mass (m, its axes), inertia tensor about the centre of mass
        (kg m^2, its axes)) of the solid of uniform ``density`` (kg/m^3): its volume
        integrals summed over the tetrahedra of its surface triangles with its origin."""
        return mass_properties(self.vertices, self.triangles(), density)


VALUE = Hull


def _points(value) -> np.ndarray:
    """The given points as an (N, 3) float array, each coordinate finite and at most
    MAX_LENGTH in size; ValueError naming what is wrong."""
    if isinstance(value, np.ndarray):
        array = value
    else:
        if isinstance(value, (str, bytes)) or not hasattr(value, '__len__'):
            raise ValueError(f'points must be a list of [x, y, z] (m), got {short(value)}')
        if len(value) > MAX_POINTS:
            raise ValueError(f'points: at most MAX_POINTS = {MAX_POINTS} points, got '
                             f'{len(value)} (decimate the mesh first)')
        for i, p in enumerate(value):
            if (not isinstance(p, (list, tuple, np.ndarray)) or len(p) != 3
                    or not all(isinstance(c, (int, float)) and not isinstance(c, bool)
                               for c in p)):
                raise ValueError(f'points[{i}] must be 3 numbers [x, y, z] (m), got '
                                 f'{short(p)}')
        try:
            array = np.array(value, dtype=np.float64)
        except OverflowError:
            raise ValueError('points: a coordinate does not fit a float') from None
    if array.ndim != 2 or array.shape[1] != 3 or array.dtype.kind not in 'fiu':
        raise ValueError(f'points must be N x 3 numbers (m), got an array of shape '
                         f'{array.shape}')
    if len(array) > MAX_POINTS:
        raise ValueError(f'points: at most MAX_POINTS = {MAX_POINTS} points, got '
                         f'{len(array)} (decimate the mesh first)')
    array = np.array(array, dtype=np.float64)
    if not np.all(np.isfinite(array)):
        bad = int(np.flatnonzero(~np.isfinite(array).all(axis=1))[0])
        raise ValueError(f'points[{bad}] is not finite: {array[bad].tolist()}')
    if np.any(np.abs(array) > MAX_LENGTH):
        raise ValueError(f'points: a coordinate is beyond MAX_LENGTH = {MAX_LENGTH:g} m')
    if len(array) < 4:
        raise ValueError(f'points: a hull needs at least 4 points not in one plane, got '
                         f'{len(array)}')
    return array


def _qhull(points: np.ndarray):
    from scipy.spatial import ConvexHull, QhullError  # only to make a hull
    try:
        return ConvexHull(points)
    except (QhullError, ValueError):
        raise ValueError('points: they span no volume (all in one plane, on a line or at '
                         'one point): a hull needs a solid') from None


def hull_of(points: np.ndarray) -> tuple[np.ndarray, tuple, np.ndarray, int]:
    """(vertices (V, 3), faces (polygons of vertex indices, counter-clockwise from outside),
    normals (F, 3), simplified) of the convex hull of ``points`` (N, 3): see the module doc."""
    hull = _qhull(points)
    vertices = points[np.sort(hull.vertices)]
    simplified = 0
    if len(vertices) > MAX_VERTICES:
        simplified = len(vertices)
        vertices = vertices[_spread(vertices, MAX_VERTICES)]
        hull = _qhull(vertices)
        vertices = vertices[np.sort(hull.vertices)]
    size = float(np.ptp(vertices, axis=0).max())
    if not size >= MIN_LENGTH or _qhull(vertices).volume <= (MIN_LENGTH * size) * size * size:
        raise ValueError(f'points: they span no volume (a hull of size {size:g} m and no '
                         'thickness)')
    for _ in range(2):  # a point on an edge or inside a face is dropped, and the hull remade
        faces, normals = _faces(vertices, _qhull(vertices), size)
        used = sorted({i for f in faces for i in f})
        if len(used) == len(vertices):
            return vertices, faces, normals, simplified
        vertices = vertices[used]
    raise ValueError('points: their hull could not be made into faces (rounding)')


def _spread(points: np.ndarray, count: int) -> np.ndarray:
    """Indices of ``count`` of ``points`` by farthest-point sampling, from the one farthest
    along +x (the first on a tie)."""
    chosen = [int(np.argmax(points[:, 0]))]
    distance = np.sum((points - points[chosen[0]]) ** 2, axis=1)
    while len(chosen) < count:
        k = int(np.argmax(distance))
        chosen.append(k)
        distance = np.minimum(distance, np.sum((points - points[k]) ** 2, axis=1))
    return np.sort(np.array(chosen))


def _faces(vertices: np.ndarray, hull, size: float) -> tuple[tuple, np.ndarray]:
    """The hull's triangles (indices into ``vertices``, which are its vertices) merged into
    faces: polygons whose corners turn (collinear points dropped), counter-clockwise from
    outside, with their unit outward normals (the mean of their triangles')."""
    index = {tuple(v): i for i, v in enumerate(vertices.tolist())}
    tri = np.array([[index[tuple(hull.points[j].tolist())] for j in s] for s in hull.simplices])
    normal = hull.equations[:, :3] / np.linalg.norm(hull.equations[:, :3], axis=1)[:, None]
    offset = np.einsum('ij,ij->i', normal, vertices[tri[:, 0]])
    cos_tol, off_tol = math.cos(COPLANAR_ANGLE), COPLANAR_RELATIVE * size
    group = -np.ones(len(tri), dtype=np.int64)
    faces, normals = [], []
    for t in range(len(tri)):
        if group[t] >= 0:
            continue
        members = np.flatnonzero((group < 0) & (normal @ normal[t] >= cos_tol)
                                 & (np.abs(offset - offset[t]) <= off_tol))
        group[members] = len(faces)
        n = normal[members].sum(axis=0)
        n /= np.linalg.norm(n)
        corners = sorted({int(i) for i in tri[members].ravel()})
        polygon = _ordered(vertices, corners, n, size)
        faces.append(tuple(polygon))
        normals.append(n)
    return tuple(faces), np.array(normals)


def _ordered(vertices: np.ndarray, corners: list[int], n: np.ndarray, size: float) -> list[int]:
    """``corners`` (indices of points of a face of unit normal n) in order round the face,
    counter-clockwise seen from outside, without the points on its edges."""
    p = vertices[corners]
    centre = p.mean(axis=0)
    u = p[int(np.argmax(((p - centre) ** 2).sum(axis=1)))] - centre  # never the centre
    u -= (u @ n) * n
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    angle = np.arctan2((p - centre) @ v, (p - centre) @ u)
    ring = [corners[k] for k in np.argsort(angle, kind='stable')]
    kept = []
    for k, i in enumerate(ring):  # a corner turns: its edges are not in line
        a, b = vertices[ring[k - 1]], vertices[ring[(k + 1) % len(ring)]]
        turn = np.cross(vertices[i] - a, b - vertices[i]) @ n
        if turn > 1e-9 * size * size:
            kept.append(i)
    if len(kept) < 3:
        raise ValueError('points: their hull has a face of fewer than 3 corners (rounding: '
                         'give points that are not nearly in one plane)')
    return kept


def mass_properties(vertices: np.ndarray, triangles: np.ndarray,
                    density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) of the solid bounded by the closed surface
    ``triangles`` (T, 3) (counter-clockwise from outside) over ``vertices`` (V, 3), of uniform
    ``density``: each triangle and the origin make a tetrahedron of signed volume
    det / 6 = a . (b x c) / 6 and second moment det (A C A^T), A = [a b c], C = (1 + I) / 120
    (the unit tetrahedron's)."""
    origin = vertices.mean(axis=0)  # (tetrahedra from a point among them: no cancelling)
    a, b, c = (vertices[triangles[:, k]] - origin for k in range(3))
    det = np.einsum('ij,ij->i', a, np.cross(b, c))
    volume = det.sum() / 6.0
    if not volume > 0.0:
        raise ValueError(f'the surface encloses no volume (signed volume {volume!r} m^3)')
    centre = (det[:, None] * (a + b + c)).sum(axis=0) / (24.0 * volume)
    s = a + b + c
    second = (np.einsum('t,ti,tj->ij', det, a, a) + np.einsum('t,ti,tj->ij', det, b, b)
              + np.einsum('t,ti,tj->ij', det, c, c) + np.einsum('t,ti,tj->ij', det, s, s))
    second /= 120.0  # integral of x x^T over the solid
    second -= volume * np.outer(centre, centre)
    inertia = density * (np.trace(second) * np.eye(3) - second)
    return density * volume, centre + origin, 0.5 * (inertia + inertia.T)


def pack(shape: Hull, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Its vertices and faces into ``pool`` (see the module doc), their offset and counts into
    its row."""
    data = [np.asarray(shape.points, dtype=np.float64).reshape(-1)]
    for face, n in zip(shape.faces, shape.normals):
        data.append(np.concatenate([n, [float(len(face))], np.array(face, dtype=np.float64)]))
    geom[OFFSET] = pool.add(np.concatenate(data))
    geom[VERTICES] = len(shape.points)
    geom[FACES] = len(shape.faces)


def draw(shape: Hull) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one mesh, (its vertices, its triangles)."""
    return [('mesh', (shape.vertices, shape.triangles()), np.array(shape.position),
             np.array(shape.rotation))]


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the hull of row ``c`` reaches from its origin along (l0, l1, l2) (its axes,
    unit): its farthest vertex's distance along it (negative if it lies behind)."""
    start, count = int(geoms[c, OFFSET]), int(geoms[c, VERTICES])
    best = -math.inf
    for i in range(count):
        k = start + 3 * i
        s = float(pool[k]) * l0 + float(pool[k + 1]) * l1 + float(pool[k + 2]) * l2
        if s > best:
            best = s
    return best


@inline_kernel
def core_radius(geom):
    """No rounding: the hull is its own core."""
    return 0.0


@inline_kernel
def _farthest(geom, pool, l0, l1, l2):
    """The index of its vertex farthest along (l0, l1, l2) (the first on a tie)."""
    start, count = int(geom[OFFSET]), int(geom[VERTICES])
    best, at = -math.inf, 0
    for i in range(count):
        k = start + 3 * i
        s = float(pool[k]) * l0 + float(pool[k + 1]) * l1 + float(pool[k + 2]) * l2
        if s > best:
            best, at = s, i
    return at


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its vertex farthest along (l0, l1, l2) (any length)."""
    k = int(geom[OFFSET]) + 3 * _farthest(geom, pool, l0, l1, l2)
    return float(pool[k]), float(pool[k + 1]), float(pool[k + 2])


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """The face holding its vertex farthest along (l0, l1, l2) (unit) whose normal is most
    along it: its corners in order into out[:n], tags their vertex indices (at most
    FACE_CAPACITY of them, spread round a face of more, the farthest vertex among them
    unless the face is within TILTED of the direction); returns n."""
    start, count = int(geom[OFFSET]), int(geom[VERTICES])
    top = _farthest(geom, pool, l0, l1, l2)
    at = start + 3 * count
    best, best_at = -math.inf, -1
    for _ in range(int(geom[FACES])):
        m = int(pool[at + 3])
        for j in range(m):
            if int(pool[at + 4 + j]) == top:
                s = float(pool[at]) * l0 + float(pool[at + 1]) * l1 + float(pool[at + 2]) * l2
                if s > best:
                    best, best_at = s, at
                break
        at += 4 + m
    if best_at < 0:  # (no face holds it: a hull is always made with one)
        x, y, z = core_point(geom, pool, l0, l1, l2)
        out[0, 0], out[0, 1], out[0, 2] = x, y, z
        tags[0] = top
        return 1
    m = int(pool[best_at + 3])
    first = 0
    if m > FACE_CAPACITY and best < _LEVEL:
        for j in range(m):
            if int(pool[best_at + 4 + j]) == top:
                first = j
    n = m if m <= FACE_CAPACITY else FACE_CAPACITY
    for q in range(n):
        j = (first + (q * m) // n) % m
        i = int(pool[best_at + 4 + j])
        k = start + 3 * i
        out[q, 0], out[q, 1], out[q, 2] = float(pool[k]), float(pool[k + 1]), float(pool[k + 2])
        tags[q] = i
    return n
