# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Broad phase: which pairs of colliders may touch, without testing all N^2 of them.

Sort and sweep on axis-aligned boxes (AABBs, world frame, m), vectorised with numpy: sort the
boxes by their lower bound on one axis (the axis along which the centres spread most, unless
given), find with one ``searchsorted`` how far each box's upper bound reaches into the sorted
list, expand those runs into candidate pairs, and keep the ones whose boxes also overlap on the
other two axes. The cost is O(N log N + C) for C pairs overlapping on the sweep axis, instead
of N^2 / 2 tests. Infinite planes are not boxes: ``plane_pairs`` tests each collider's exact
support distance against each plane.

The result is deterministic: pairs (i, j) with i < j, sorted lexicographically, whatever the
input order of equal bounds (stable sorts only).
"""

from __future__ import annotations

import numpy as np


def sweep_axis(lower: np.ndarray, upper: np.ndarray) -> int:
    """The axis (0, 1, 2) along which the box centres spread most (the first on a tie)."""
    centres = lower + upper
    return int(np.argmax(centres.var(axis=0))) if len(centres) else 0


def sweep_and_prune(lower: np.ndarray, upper: np.ndarray, group: np.ndarray | None = None,
                    static: np.ndarray | None = None, axis: int | None = None) -> np.ndarray:
    """Pairs (P, 2) of indices i < j whose boxes [lower, upper] (each (N, 3), m) overlap
    (closed intervals: touching counts). Pairs in the same ``group`` (N,) (colliders of one
    body) and pairs of two ``static`` (N,) colliders are left out."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    count = len(lower)
    if count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    if axis is None:
        axis = sweep_axis(lower, upper)
    order = np.argsort(lower[:, axis], kind='stable')
    lo = lower[order, axis]
    hi = upper[order, axis]
    # Box at sorted position p overlaps (on this axis) every later q with lo[q] <= hi[p].
    end = np.searchsorted(lo, hi, side='right')
    counts = np.maximum(end - np.arange(count) - 1, 0)
    total = int(counts.sum())
    if total == 0:
        return np.zeros((0, 2), dtype=np.int64)
    # Run p of the candidates is (p, p + 1), ..., (p, end[p] - 1), laid end to end.
    positions = np.arange(count)
    first = np.repeat(positions, counts)
    second = np.arange(total) - np.repeat(np.cumsum(counts) - counts - positions - 1, counts)
    i, j = order[first], order[second]
    # One contiguous array per axis: gathers from it are several times faster than from
    # columns of the (N, 3) arrays.
    lower_t, upper_t = np.ascontiguousarray(lower.T), np.ascontiguousarray(upper.T)
    keep = np.ones(total, dtype=bool)
    for k in range(3):
        if k != axis:
            lo_k, hi_k = lower_t[k], upper_t[k]
            keep &= (lo_k[i] <= hi_k[j]) & (lo_k[j] <= hi_k[i])
    i, j = i[keep], j[keep]
    keep = np.ones(len(i), dtype=bool)
    if group is not None:
        group = np.asarray(group)
        keep &= group[i] != group[j]
    if static is not None:
        static = np.asarray(static, dtype=bool)
        keep &= ~(static[i] & static[j])
    i, j = i[keep], j[keep]
    a, b = np.minimum(i, j), np.maximum(i, j)
    pairs = np.stack([a, b], axis=1).astype(np.int64)
    return pairs[np.lexsort((b, a))]


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


def plane_pairs(support: np.ndarray, plane_normals: np.ndarray, plane_points: np.ndarray,
                centres: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """Pairs (P, 2) of (collider, plane) indices, sorted, where the collider comes within
    ``margin`` (K,) of the plane: n . c - support <= n . p0 + margin. ``support`` (K, L) is
    each collider's extent towards each plane (m): for a box sum_i h_i |n . axis_i|, for a
    sphere its radius; centres (K, 3), plane normals and points (L, 3)."""
    if len(centres) == 0 or len(plane_normals) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    height = centres @ plane_normals.T - np.einsum('ij,ij->i', plane_points, plane_normals)
    hit = height - support <= np.asarray(margin)[:, None]
    k, p = np.nonzero(hit)      # row-major: sorted by collider, then plane
    return np.stack([k, p], axis=1).astype(np.int64)
