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

``collide(shape_a, pose_a, shape_b, pose_b, margin)`` gives them as ``Contact`` values; poses
are the shapes' own world (centre, rotation) from ``collision_shapes.world_pose``. The work is
done by the compiled float kernels of ``narrow_kernels`` (``collide_pair``, and
``collide_pairs`` for many pairs at once, from arrays: the form a compiled world step calls),
where the methods are: the kinds in collision_shapes.RANK order (swapping and negating the
normals when needed); box-box by the separating axis test over the 15 axes (3 + 3 face normals,
9 edge-edge cross products), with a face contact clipped to the reference face
(Sutherland-Hodgman, at most 4 points kept) and an edge-edge contact at the closest points of
the two edges. ``sphere_sphere_batch`` and ``sphere_plane_batch`` are the same tests on arrays
of pairs, for large scenes (``narrow_kernels.sphere_batch``), with the same bits as
``collide``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.collision_shapes import Shape
from rb_sim_ros.contact.narrow_kernels import (collide_pair, GEOM_WIDTH, KIND_PLANE,
                                               KIND_SPHERE, MAX_CONTACTS_PER_PAIR, NORMAL,
                                               PAIR_BIT, RADIUS, sphere_batch)

# The kernels' kind of each shape kind (shapes.RANK).
KIND = dict(shapes.RANK)


class Contact(NamedTuple):
    """One contact point: ``point`` (m), ``normal`` (unit, from A to B), ``depth`` (m, > 0
    overlapping), world frame; ``feature`` names the features in touch (see module doc)."""

    point: np.ndarray
    normal: np.ndarray
    depth: float
    feature: int


def shape_arrays(shape: Shape, centre, rotation,
                 pool: shapes.Pool) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(kind, geom (5,), centre (3,), rot (9,)) of ``shape`` placed at the world ``centre``
    (m) with the world ``rotation`` of its axes (from ``collision_shapes.world_pose``), as the
    kernels take them (see narrow_kernels): new float64 arrays, C order, writeable, what
    its kind keeps beyond its row added to ``pool``. A plane's geom[2:5] is its normal turned
    into the world frame, R n written out."""
    rot = np.array(rotation, dtype=np.float64, order='C').reshape(9)
    return (shapes.kind_of(shape), shapes.packed(shape, rot, pool),
            np.array(centre, dtype=np.float64).reshape(3), rot)


def collide(a: Shape, pose_a, b: Shape, pose_b, margin: float = 0.0) -> list[Contact]:
    """Contacts of shape ``a`` at ``pose_a`` with ``b`` at ``pose_b`` (each a world (centre,
    rotation) pair), normals from a to b; [] when they are further apart than ``margin``."""
    low, high = sorted((shapes.kind_of(a), shapes.kind_of(b)))
    if (low, high) not in PAIR_BIT:
        raise ValueError(f'no contact test between a {a.kind} and a {b.kind} (both static: '
                         'they never meet)')
    point, normal = np.empty((MAX_CONTACTS_PER_PAIR, 3)), np.empty((MAX_CONTACTS_PER_PAIR, 3))
    depth, feature = np.empty(MAX_CONTACTS_PER_PAIR), np.empty(MAX_CONTACTS_PER_PAIR, np.int64)
    pool = shapes.Pool()
    arrays = shape_arrays(a, *pose_a, pool) + shape_arrays(b, *pose_b, pool)
    count = collide_pair(*arrays, pool.array(), float(margin), point, normal, depth, feature,
                         int(0))
    return [Contact(point[k], normal[k], float(depth[k]), int(feature[k]))
            for k in range(count)]


# -- batches (large scenes) --------------------------------------------------------------------
def _batch(kind_b, ca, ra, cb, geoms_b, margin):
    ra = np.array(ra, dtype=np.float64, order='C').reshape(-1)
    m = len(ra)
    margins = np.array(np.broadcast_to(np.asarray(margin, dtype=np.float64), (m,)), order='C')
    keep = np.zeros(m, dtype=bool)
    point, normal, depth = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
    count = sphere_batch(kind_b, np.array(ca, dtype=np.float64, order='C').reshape(m, 3), ra,
                         np.array(cb, dtype=np.float64, order='C').reshape(m, 3), geoms_b,
                         margins, keep, point, normal, depth)
    return keep, point[:count], normal[:count], depth[:count]


def sphere_sphere_batch(ca, ra, cb, rb, margin):
    """Sphere-sphere ``collide`` on M pairs at once, with the same bits: centres (M, 3) and
    radii (M,) of A and B, margin (M,) or a float (m). Returns (keep (M,) bool, point (K, 3),
    normal (K, 3), depth (K,)) for the K kept pairs, in order."""
    geoms = np.zeros((len(ra), GEOM_WIDTH))
    geoms[:, RADIUS] = rb
    return _batch(KIND_SPHERE, ca, ra, cb, geoms, margin)


def sphere_plane_batch(c, r, plane_point, plane_normal, margin):
    """Sphere-plane ``collide`` on M pairs: (M, 3) centres, (M,) radii, (M, 3) plane points and
    unit normals (world frame), margin (M,) or a float. Returns (keep, point, normal, depth) as
    ``sphere_sphere_batch``."""
    geoms = np.zeros((len(r), GEOM_WIDTH))
    geoms[:, NORMAL:NORMAL + 3] = plane_normal
    return _batch(KIND_PLANE, c, r, plane_point, geoms, margin)
