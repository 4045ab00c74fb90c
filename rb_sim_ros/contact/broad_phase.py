# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Broad phase: which pairs of colliders may touch, without testing all N^2 of them.

Sort and sweep on axis-aligned boxes (AABBs, world frame, m): sort the boxes by their lower
bound on one axis (the axis along which the lower bounds spread most, unless given), and for
each box walk the sorted list while the next lower bound is within its upper bound, keeping
the pairs whose boxes also overlap on the other two axes. The cost is O(N log N + C) for C
pairs overlapping on the sweep axis, instead of N^2 / 2 tests. Infinite planes are not boxes:
``plane_candidates`` tests each collider's exact support distance against each plane.

The result is deterministic: pairs (i, j) with i < j, sorted lexicographically, whatever the
input order of equal bounds. Compiled kernels (``core.jit``), plain float comparisons and
arithmetic: compiled and interpreted give the same pairs.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.core.jit import inline_kernel, kernel

# The most pairs of colliders the broad phase finds in one step, and the most box tests its
# sweep makes (each overlap on the sweep axis is one). Past either it stops and returns
# ``OVERFLOW`` (the world step refuses the step with the reason): colliders piled up in one
# place (MAX_BODIES bodies of MAX_COLLIDERS each would make 8e11 pairs, more memory than any
# machine has). A dense pile of 20,000 single-collider bodies makes about 120,000 pairs; the
# narrow phase's buffers for MAX_PAIRS are some 170 MB.
MAX_PAIRS = 1 << 18
MAX_SWEEP = 64 * MAX_PAIRS
# What sweep_and_prune returns past its bounds: one pair (-1, -1).
OVERFLOW = -1


# The sorts of the world's step, as kernels of their own: numba compiles a sort (its
# specialisation for the array's type) into every kernel that calls np.sort or np.argsort,
# seconds each inside world_steps; a kernel is compiled once, cached, and compiled beside
# world_steps (world_step.compile_leaves). numpy's own are the interpreted tier.


@kernel
def stable_order(keys):
    """The indices that sort ``keys`` (1-D), equal keys in their order (a stable sort)."""
    return np.argsort(keys, kind='mergesort')


@kernel
def sorted_copy(values):
    """``values`` (1-D int64) sorted, as a new array."""
    return np.sort(values)


@inline_kernel
def sweep_and_prune(lower, upper, group, static, axis):
    """Pairs (P, 2) of indices i < j whose boxes [lower, upper] (each (N, 3), m) overlap on all
    three axes (closed intervals: touching counts), but for pairs of one ``group`` (N,) (the
    colliders of one body) and pairs of two ``static`` (N,) colliders; sorted by (i, j). Sort
    and sweep on ``axis``, or where it is -1 on the axis of the largest spread of the lower
    bounds (any axis gives the same pairs; the spread only makes it fast). Past MAX_PAIRS
    pairs or MAX_SWEEP box tests: the one pair (OVERFLOW, OVERFLOW) instead."""
    count = lower.shape[0]
    if count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    if axis < 0:
        axis, best = 0, -1.0
        for a in range(3):
            lo_min, lo_max = math.inf, -math.inf
            for i in range(count):
                value = float(lower[i, a])
                lo_min = min(lo_min, value)
                lo_max = max(lo_max, value)
            if lo_max - lo_min > best:
                axis, best = a, lo_max - lo_min
    keys = np.empty(count)
    for i in range(count):
        keys[i] = lower[i, axis]
    order = stable_order(keys)
    found = 0
    tested = 0
    capacity = 4 * count
    pairs = np.empty(capacity, dtype=np.int64)
    for p in range(count):
        i = order[p]
        hi = float(upper[i, axis])
        for s in range(p + 1, count):
            j = order[s]
            if float(lower[j, axis]) > hi:
                break
            tested += 1
            if tested > MAX_SWEEP:
                return np.full((1, 2), OVERFLOW, dtype=np.int64)
            if group[i] == group[j] or (static[i] and static[j]):
                continue
            overlap = True
            for a in range(3):
                if a != axis and (float(lower[i, a]) > float(upper[j, a])
                                  or float(lower[j, a]) > float(upper[i, a])):
                    overlap = False
            if not overlap:
                continue
            if found == capacity:
                bigger = np.empty(2 * capacity, dtype=np.int64)
                bigger[:capacity] = pairs
                pairs, capacity = bigger, 2 * capacity
            pairs[found] = min(i, j) * count + max(i, j)
            found += 1
            if found > MAX_PAIRS:
                return np.full((1, 2), OVERFLOW, dtype=np.int64)
    keys_found = sorted_copy(pairs[:found])
    out = np.empty((found, 2), dtype=np.int64)
    for k in range(found):
        out[k, 0] = keys_found[k] // count
        out[k, 1] = keys_found[k] % count
    return out


@inline_kernel
def plane_candidates(colliders, body, rotations, kinds, geoms, pool, centres, plane_normals,
                     plane_points, margin):
    """Pairs (P, 2) of (collider, plane), sorted, where collider ``colliders[k]`` comes within
    its body's margin of plane p: n . c - support <= n . p0 + margin, support the collider's
    extent towards the plane (its kind's, ``shapes.support_of``, along -n in its axes)."""
    count, planes = colliders.shape[0], plane_normals.shape[0]
    out = np.empty((count * planes, 2), dtype=np.int64)
    found = 0
    for k in range(count):
        c = colliders[k]
        kind = int(kinds[c])
        for p in range(planes):
            nx, ny, nz = (float(plane_normals[p, 0]), float(plane_normals[p, 1]),
                          float(plane_normals[p, 2]))
            # -n in the collider's axes: -R^T n, towards the plane
            l0 = (nx * float(rotations[c, 0]) + ny * float(rotations[c, 3])
                  + nz * float(rotations[c, 6]))
            l1 = (nx * float(rotations[c, 1]) + ny * float(rotations[c, 4])
                  + nz * float(rotations[c, 7]))
            l2 = (nx * float(rotations[c, 2]) + ny * float(rotations[c, 5])
                  + nz * float(rotations[c, 8]))
            support = shapes.support_of(kind, geoms, pool, c, -l0, -l1, -l2)
            height = (nx * float(centres[c, 0]) + ny * float(centres[c, 1])
                      + nz * float(centres[c, 2])) - (
                nx * float(plane_points[p, 0]) + ny * float(plane_points[p, 1])
                + nz * float(plane_points[p, 2]))
            if height - support <= float(margin[body[c]]):
                out[found, 0], out[found, 1] = c, p
                found += 1
    return out[:found]


def brute_force_pairs(lower: np.ndarray, upper: np.ndarray, group: np.ndarray | None = None,
                      static: np.ndarray | None = None) -> np.ndarray:
    """The same pairs as ``sweep_and_prune`` by testing all of them: the reference for tests."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    count = len(lower)
    i, j = np.triu_indices(count, k=1)
    keep = np.all((lower[i] <= upper[j]) & (lower[j] <= upper[i]), axis=1)
    if group is not None:
        keep &= np.asarray(group)[i] != np.asarray(group)[j]
    if static is not None:
        static = np.asarray(static, dtype=bool)
        keep &= ~(static[i] & static[j])
    return np.stack([i[keep], j[keep]], axis=1).astype(np.int64)
