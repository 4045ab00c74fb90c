# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Shapes, the narrow phase against analytic cases, and the broad phase against brute force.

Convention checked throughout: the normal points from A to B, depth > 0 is overlap, and the
point is midway between the two surfaces (see narrow_phase's module doc). The array kernels
(narrow_kernels) give what ``collide`` gives, pair by pair, with the same bits compiled and
interpreted.
"""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from rb_sim_ros.contact import broad_phase, narrow_kernels as nk, narrow_phase as nph
from rb_sim_ros.contact.collision_shapes import (Box, Capsule, Cylinder, Hull, Plane, RANK,
                                                 shape_from_dict, shape_to_dict, Sphere,
                                                 world_pose)
from rb_sim_ros.contact.shapes import Pool
from rb_sim_ros.core import so3
from support import narrow_fingerprint

I3 = np.eye(3)
ORIGIN = np.zeros(3)


def pose(position=(0.0, 0.0, 0.0), rotation_vector=(0.0, 0.0, 0.0)):
    return np.array(position, dtype=float), so3.exp(rotation_vector)


def points(contacts):
    return sorted(tuple(np.round(c.point, 9)) for c in contacts)


# -- shapes ------------------------------------------------------------------------------------
@pytest.mark.parametrize('make, field', [
    (lambda: Sphere(0.0), 'radius'), (lambda: Sphere(-1.0), 'radius'),
    (lambda: Sphere(math.nan), 'radius'), (lambda: Sphere('x'), 'radius'),
    (lambda: Box((1.0, 0.0, 1.0)), r'size\[1\]'), (lambda: Box((1.0, 1.0)), 'size'),
    (lambda: Capsule(0.1, -1.0), 'length'), (lambda: Capsule(0.0, 1.0), 'radius'),
    (lambda: Sphere(0.1, position=(0.0, math.inf, 0.0)), 'position'),
    (lambda: Box((1, 1, 1), orientation_xyzw=(0, 0, 0, 0)), 'orientation_xyzw'),
    (lambda: Plane((0.0, 0.0, 0.0)), 'normal'), (lambda: Plane(offset=math.nan), 'offset'),
])
def test_shapes_refuse_bad_fields_naming_them(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_shape_values_and_dict_round_trip():
    box = Box((0.4, 0.3, 0.2), position=(0.0, 0.0, 0.1), orientation_xyzw=(0, 0, 1, 1))
    assert box.half_extents == (0.2, 0.15, 0.1)
    np.testing.assert_allclose(box.rotation, so3.exp((0.0, 0.0, math.pi / 2)), atol=1e-15)
    assert Plane((0.0, 0.0, 2.0)).normal == (0.0, 0.0, 1.0)
    for shape in (box, Sphere(0.1), Capsule(0.05, 0.3, position=(1.0, 2.0, 3.0)),
                  Plane((1.0, 0.0, 0.0), -2.5)):
        data = shape_to_dict(shape)
        assert shape_from_dict(data) == shape
    assert shape_to_dict(Sphere(0.1)) == {'type': 'sphere', 'radius': 0.1}
    with pytest.raises(ValueError, match='type'):
        shape_from_dict({'type': 'cone', 'radius': 1.0})
    with pytest.raises(ValueError, match='unknown keys'):
        shape_from_dict({'type': 'sphere', 'radius': 1.0, 'size': [1, 1, 1]})
    with pytest.raises(ValueError, match='radius missing'):
        shape_from_dict({'type': 'capsule', 'length': 1.0})


def test_world_pose_places_the_shape_in_the_body():
    body_rotation = so3.exp((0.0, 0.0, math.pi / 2))
    centre, rot = world_pose(Box((1, 1, 1), position=(1.0, 0.0, 0.0)), (0.0, 0.0, 5.0),
                             body_rotation)
    np.testing.assert_allclose(centre, (0.0, 1.0, 5.0), atol=1e-15)
    np.testing.assert_allclose(rot, body_rotation)


# -- sphere ------------------------------------------------------------------------------------
def test_sphere_sphere_depth_normal_point_and_margin():
    (c,) = nph.collide(Sphere(0.5), pose(), Sphere(0.3), pose((0.0, 0.6, 0.0)))
    assert c.depth == pytest.approx(0.2, abs=1e-15)
    np.testing.assert_allclose(c.normal, (0.0, 1.0, 0.0))
    np.testing.assert_allclose(c.point, (0.0, 0.4, 0.0), atol=1e-15)   # midway of 0.5, 0.3
    assert nph.collide(Sphere(0.5), pose(), Sphere(0.3), pose((0.0, 0.81, 0.0))) == []
    (s,) = nph.collide(Sphere(0.5), pose(), Sphere(0.3), pose((0.0, 0.81, 0.0)), margin=0.02)
    assert s.depth == pytest.approx(-0.01, abs=1e-15)                  # speculative: a gap


def test_sphere_plane_on_a_tilted_plane():
    n = np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)
    plane = Plane(tuple(n), 1.0)
    centre = 1.05 * n + np.array([2.0, 0.3, -0.3])          # 0.05 above it, moved along it
    (c,) = nph.collide(Sphere(0.1), (centre, I3), plane, world_pose(plane, ORIGIN, I3))
    assert c.depth == pytest.approx(0.05, abs=1e-15)
    np.testing.assert_allclose(c.normal, -n, atol=1e-15)               # sphere -> plane
    np.testing.assert_allclose(c.point, centre - 0.075 * n, atol=1e-15)


@pytest.mark.parametrize('centre, depth, normal', [
    ((0.0, 0.0, 0.55), 0.05, (0.0, 0.0, -1.0)),                       # face
    ((0.55, 0.0, 0.55), 0.1 - math.sqrt(0.005), (-1.0, 0.0, -1.0)),   # edge
    ((0.55, 0.55, 0.55), 0.1 - math.sqrt(0.0075), (-1.0, -1.0, -1.0)),  # vertex
    ((0.1, 0.2, 0.45), 0.15, (0.0, 0.0, -1.0)),                       # centre inside
])
def test_sphere_box_face_edge_vertex_inside(centre, depth, normal):
    (c,) = nph.collide(Sphere(0.1), pose(centre), Box((1.0, 1.0, 1.0)), pose())
    assert c.depth == pytest.approx(depth, abs=1e-14)
    np.testing.assert_allclose(c.normal, np.array(normal) / np.linalg.norm(normal), atol=1e-14)


def test_sphere_box_turned_box_and_swapped_order():
    rot = so3.exp((0.0, 0.0, math.pi / 4))
    box = Box((1.0, 1.0, 1.0))
    # The box's x axis now points along (1, 1, 0)/sqrt2: a face at distance 0.5 that way.
    u = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    (c,) = nph.collide(Sphere(0.2), (0.65 * u, I3), box, (ORIGIN, rot))
    assert c.depth == pytest.approx(0.05, abs=1e-14)
    np.testing.assert_allclose(c.normal, -u, atol=1e-14)
    (d,) = nph.collide(box, (ORIGIN, rot), Sphere(0.2), (0.65 * u, I3))
    np.testing.assert_allclose(d.normal, u, atol=1e-14)
    np.testing.assert_allclose(d.point, c.point, atol=1e-15)
    assert d.depth == c.depth


def test_sphere_capsule_side_and_cap():
    capsule = Capsule(0.1, 1.0)                    # segment z in [-0.5, 0.5]
    (side,) = nph.collide(Sphere(0.2), pose((0.25, 0.0, 0.3)), capsule, pose())
    assert side.depth == pytest.approx(0.05, abs=1e-14)
    np.testing.assert_allclose(side.normal, (-1.0, 0.0, 0.0), atol=1e-15)
    (cap,) = nph.collide(Sphere(0.2), pose((0.0, 0.0, 0.75)), capsule, pose())
    assert cap.depth == pytest.approx(0.05, abs=1e-14)
    np.testing.assert_allclose(cap.normal, (0.0, 0.0, -1.0), atol=1e-15)


# -- capsule -----------------------------------------------------------------------------------
def test_capsule_plane_lying_two_contacts_tilted_one():
    lying = pose((0.0, 0.0, 0.09), (0.0, math.pi / 2, 0.0))
    contacts = nph.collide(Capsule(0.1, 1.0), lying, Plane(), pose())
    assert [c.feature for c in contacts] == [0, 1]
    for c in contacts:
        assert c.depth == pytest.approx(0.01, abs=1e-15)
        np.testing.assert_allclose(c.normal, (0.0, 0.0, -1.0))
    assert points(contacts) == [(-0.5, 0.0, -0.005), (0.5, 0.0, -0.005)]
    tilted = pose((0.0, 0.0, 0.3), (0.0, 0.6, 0.0))
    (c,) = nph.collide(Capsule(0.1, 1.0), tilted, Plane(), pose())
    assert c.depth == pytest.approx(0.1 - (0.3 - 0.5 * math.cos(0.6)), abs=1e-14)


def test_capsule_capsule_crossed_and_parallel():
    crossed = nph.collide(Capsule(0.1, 1.0), pose(), Capsule(0.1, 1.0),
                          pose((0.19, 0.0, 0.3), (math.pi / 2, 0.0, 0.0)))
    assert len(crossed) == 1
    assert crossed[0].depth == pytest.approx(0.01, abs=1e-14)
    np.testing.assert_allclose(crossed[0].normal, (1.0, 0.0, 0.0), atol=1e-14)
    np.testing.assert_allclose(crossed[0].point, (0.095, 0.0, 0.3), atol=1e-14)
    parallel = nph.collide(Capsule(0.1, 1.0), pose(), Capsule(0.1, 1.0), pose((0.19, 0, 0.3)))
    assert points(parallel) == [(0.095, 0.0, -0.2), (0.095, 0.0, 0.5)]   # ends of the overlap
    assert all(c.depth == pytest.approx(0.01, abs=1e-14) for c in parallel)


def test_capsule_box_lying_on_a_face_across_an_edge_and_standing():
    box = Box((1.0, 1.0, 1.0))
    lying = nph.collide(Capsule(0.1, 2.0), pose((0.0, 0.0, 0.59), (0.0, math.pi / 2, 0.0)),
                        box, pose())
    assert points(lying) == [(-0.5, 0.0, 0.495), (0.5, 0.0, 0.495)]     # the span of the face
    for c in lying:
        assert c.depth == pytest.approx(0.01, abs=1e-14)
        np.testing.assert_allclose(c.normal, (0.0, 0.0, -1.0), atol=1e-15)
    # Along the top +x edge, touching it from the diagonal.
    off = 0.09 / math.sqrt(2.0)
    edge = nph.collide(Capsule(0.1, 2.0), pose((0.5 + off, 0.0, 0.5 + off), (math.pi / 2, 0, 0)),
                       box, pose())
    assert len(edge) == 2
    for c in edge:
        assert c.depth == pytest.approx(0.01, abs=1e-14)
        np.testing.assert_allclose(c.normal, (-math.sqrt(0.5), 0.0, -math.sqrt(0.5)),
                                   atol=1e-14)
    (stand,) = nph.collide(Capsule(0.1, 0.4), pose((0.2, 0.1, 0.79)), box, pose())
    assert stand.depth == pytest.approx(0.01, abs=1e-14)
    np.testing.assert_allclose(stand.point, (0.2, 0.1, 0.495), atol=1e-14)


def test_capsule_box_deep_uses_least_penetration_axis():
    contacts = nph.collide(Capsule(0.1, 1.0), pose((0.0, 0.0, 0.4), (0.0, math.pi / 2, 0.0)),
                           Box((1.0, 1.0, 1.0)), pose())
    assert contacts and all(c.depth == pytest.approx(0.2, abs=1e-14) for c in contacts)
    for c in contacts:
        np.testing.assert_allclose(c.normal, (0.0, 0.0, -1.0), atol=1e-15)


def test_segment_box_distance_is_the_minimum_over_the_segment():
    rng = np.random.default_rng(3)
    half = [0.5, 0.3, 0.2]
    for _ in range(200):
        p0, d = rng.normal(size=3) * 1.5, rng.normal(size=3)
        t, dist2 = nk.segment_box_distance(*p0.tolist(), *d.tolist(), *half)
        ts = np.linspace(0.0, 1.0, 4001)
        pts = p0 + ts[:, None] * d
        excess = np.maximum(np.abs(pts) - half, 0.0)
        sampled = (excess ** 2).sum(axis=1).min()
        assert dist2 <= sampled + 1e-12
        assert dist2 >= sampled - 1e-5 * (1.0 + sampled)


# -- box ---------------------------------------------------------------------------------------
def test_box_plane_resting_four_corners_and_a_corner_down():
    contacts = nph.collide(Box((0.4, 0.2, 0.1)), pose((0.0, 0.0, 0.049)), Plane(), pose())
    assert sorted(c.feature for c in contacts) == [0, 2, 4, 6]   # the z = -h vertices
    assert points(contacts) == [(-0.2, -0.1, -0.0005), (-0.2, 0.1, -0.0005),
                                (0.2, -0.1, -0.0005), (0.2, 0.1, -0.0005)]
    for c in contacts:
        assert c.depth == pytest.approx(0.001, abs=1e-15)
    # Corner down: the body diagonal (1, 1, 1) turned onto -z.
    axis = np.array([-1.0, 1.0, 0.0]) / math.sqrt(2.0)      # (1, 1, 1) x (0, 0, -1), unit
    rot = so3.exp(axis * math.acos(-1.0 / math.sqrt(3.0)))
    half_diagonal = math.sqrt(3.0) * 0.5
    (c,) = nph.collide(Box((1.0, 1.0, 1.0)), (np.array([0.0, 0.0, half_diagonal - 0.01]), rot),
                       Plane(), pose())
    assert c.depth == pytest.approx(0.01, abs=1e-12)
    np.testing.assert_allclose(c.point, (0.0, 0.0, -0.005), atol=1e-12)


def test_box_box_face_face_clipped_to_the_reference_face():
    contacts = nph.collide(Box((1.0, 1.0, 1.0)), pose(), Box((1.0, 1.0, 1.0)),
                           pose((0.2, 0.1, 0.99)))
    assert points(contacts) == [(-0.3, -0.4, 0.495), (-0.3, 0.5, 0.495), (0.5, -0.4, 0.495),
                                (0.5, 0.5, 0.495)]
    for c in contacts:
        assert c.depth == pytest.approx(0.01, abs=1e-14)
        np.testing.assert_allclose(c.normal, (0.0, 0.0, 1.0))
    # Swapped: the same points and depths, the normal negated.
    swapped = nph.collide(Box((1.0, 1.0, 1.0)), pose((0.2, 0.1, 0.99)), Box((1.0, 1.0, 1.0)),
                          pose())
    assert points(swapped) == points(contacts)
    for c in swapped:
        np.testing.assert_allclose(c.normal, (0.0, 0.0, -1.0))


def test_box_box_turned_about_the_normal_keeps_four_of_eight_points():
    contacts = nph.collide(Box((1.0, 1.0, 1.0)), pose(), Box((1.0, 1.0, 1.0)),
                           pose((0.0, 0.0, 0.99), (0.0, 0.0, math.pi / 4)))
    assert len(contacts) == 4                      # the octagon reduced to 4 points
    for c in contacts:
        assert c.depth == pytest.approx(0.01, abs=1e-14)
        assert abs(c.point[2] - 0.495) < 1e-14
        assert max(abs(c.point[0]), abs(c.point[1])) == pytest.approx(0.5, abs=1e-12)


def test_box_box_edge_edge():
    # A's top edge along x (A turned 45 deg about x), B's bottom edge along y (B about y).
    h = 0.5 * math.sqrt(2.0)
    (c,) = nph.collide(Box((1.0, 1.0, 1.0)), pose(ORIGIN, (math.pi / 4, 0.0, 0.0)),
                       Box((1.0, 1.0, 1.0)), pose((0.0, 0.0, 2 * h - 0.01), (0, math.pi / 4, 0)))
    assert c.depth == pytest.approx(0.01, abs=1e-12)
    np.testing.assert_allclose(c.normal, (0.0, 0.0, 1.0), atol=1e-12)
    np.testing.assert_allclose(c.point, (0.0, 0.0, h - 0.005), atol=1e-12)
    assert c.feature >= 200
    # Offset along both edges: the closest points move with them.
    (d,) = nph.collide(Box((1.0, 1.0, 1.0)), pose((0.1, 0.0, 0.0), (math.pi / 4, 0.0, 0.0)),
                       Box((1.0, 1.0, 1.0)), pose((0.0, 0.2, 2 * h - 0.01), (0, math.pi / 4, 0)))
    np.testing.assert_allclose(d.point, (0.0, 0.0, h - 0.005), atol=1e-12)
    assert d.depth == pytest.approx(0.01, abs=1e-12)


def test_box_box_separated_on_a_face_or_an_edge_axis():
    assert nph.collide(Box((1, 1, 1)), pose(), Box((1, 1, 1)), pose((0.0, 0.0, 1.01))) == []
    h = 0.5 * math.sqrt(2.0)
    apart = pose((0.0, 0.0, 2 * h + 0.01), (0.0, math.pi / 4, 0.0))
    a = pose(ORIGIN, (math.pi / 4, 0.0, 0.0))
    assert nph.collide(Box((1, 1, 1)), a, Box((1, 1, 1)), apart) == []
    (s,) = nph.collide(Box((1, 1, 1)), a, Box((1, 1, 1)), apart, margin=0.02)
    assert s.depth == pytest.approx(-0.01, abs=1e-12)


def test_every_pair_swaps_consistently():
    rng = np.random.default_rng(7)
    shapes = [Sphere(0.3), Capsule(0.2, 0.6), Box((0.5, 0.4, 0.3))]
    for _ in range(100):
        for a in shapes:
            for b in shapes:
                if isinstance(a, Box) and isinstance(b, Box):
                    continue                      # box-box may pick the other reference face
                pa = (rng.normal(size=3) * 0.3, so3.exp(rng.normal(size=3)))
                pb = (rng.normal(size=3) * 0.3, so3.exp(rng.normal(size=3)))
                ab, ba = nph.collide(a, pa, b, pb, 0.1), nph.collide(b, pb, a, pa, 0.1)
                assert len(ab) == len(ba)
                for c, d in zip(ab, ba):
                    np.testing.assert_allclose(c.normal, -d.normal, atol=1e-12)
                    np.testing.assert_allclose(c.point, d.point, atol=1e-12)
                    assert c.depth == pytest.approx(d.depth, abs=1e-12)
                    assert abs(np.linalg.norm(c.normal) - 1.0) < 1e-12


def test_batches_equal_collide_to_the_bit():
    rng = np.random.default_rng(1)
    m = 300
    ca, cb = rng.normal(size=(m, 3)), rng.normal(size=(m, 3))
    ra, rb = rng.uniform(0.1, 1.0, m), rng.uniform(0.1, 1.0, m)
    margin = np.where(rng.random(m) < 0.5, 0.0, 0.05)
    ca[7] = cb[7]                                        # coincident centres: the fallback
    keep, pt, nrm, depth = nph.sphere_sphere_batch(ca, ra, cb, rb, margin)
    assert 0 < keep.sum() < m and len(pt) == len(nrm) == len(depth) == keep.sum()
    k = 0
    for i in range(m):
        found = nph.collide(Sphere(ra[i]), (ca[i], I3), Sphere(rb[i]), (cb[i], I3), margin[i])
        assert len(found) == keep[i]
        if found:
            np.testing.assert_array_equal(pt[k], found[0].point)
            np.testing.assert_array_equal(nrm[k], found[0].normal)
            assert depth[k] == found[0].depth
            k += 1
    planes = [Plane(tuple(v)) for v in rng.normal(size=(m, 3))]
    n = np.array([p.normal for p in planes])
    p0 = rng.normal(size=(m, 3)) * 0.5
    keep, pt, nrm, depth = nph.sphere_plane_batch(ca, ra, p0, n, 0.0)
    assert 0 < keep.sum() < m
    k = 0
    for i in range(m):
        found = nph.collide(Sphere(ra[i]), (ca[i], I3), planes[i], (p0[i], I3), 0.0)
        assert len(found) == keep[i]
        if found:
            np.testing.assert_array_equal(pt[k], found[0].point)
            np.testing.assert_array_equal(nrm[k], found[0].normal)
            assert depth[k] == found[0].depth
            k += 1
    empty = nph.sphere_sphere_batch(np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)),
                                    np.zeros(0), 0.1)
    assert len(empty[0]) == len(empty[1]) == 0


# -- the array kernels ---------------------------------------------------------------------------
KINDS = ('sphere', 'capsule', 'box', 'plane', 'cylinder', 'hull')


def _random_shape(rng, kind):
    if kind == 'sphere':
        return Sphere(float(rng.uniform(0.05, 0.5)))
    if kind == 'capsule':
        length = 0.0 if rng.random() < 0.15 else float(rng.uniform(0.1, 1.0))
        return Capsule(float(rng.uniform(0.05, 0.3)), length)
    if kind == 'box':
        return Box(tuple(rng.uniform(0.1, 1.0, 3)))
    if kind == 'cylinder':
        return Cylinder(float(rng.uniform(0.05, 0.4)), float(rng.uniform(0.05, 1.0)))
    if kind == 'hull':  # a box's corners (faces on faces) or a cloud of points
        if rng.random() < 0.3:
            half = rng.uniform(0.05, 0.5, 3)
            return Hull([[sx * half[0], sy * half[1], sz * half[2]]
                         for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return Hull((rng.normal(size=(int(rng.integers(6, 40)), 3))
                     * rng.uniform(0.05, 0.4, 3)).tolist())
    return Plane(tuple(rng.normal(size=3)))


def _random_rotation(rng):
    mode = rng.integers(4)
    if mode == 0:
        return I3                                       # faces on faces, parallel capsules
    if mode == 1:
        return so3.exp((0.0, 0.0, float(rng.normal()) * 0.5))   # turned about z only
    if mode == 2:
        return so3.exp((0.0, math.pi / 2, 0.0))         # capsules lying along x
    return so3.exp(rng.normal(size=3))


def _half_height(shape, rot) -> float:
    """Half the extent of a placed sphere, capsule, box, cylinder or hull along the world z
    axis (m; a hull's farthest vertex from its origin)."""
    if shape.kind == 'cylinder':
        return (abs(rot[2, 2]) * shape.half_length
                + shape.radius * math.sqrt(max(1.0 - rot[2, 2] ** 2, 0.0)))
    if shape.kind == 'box':
        return float(np.abs(rot[2]) @ shape.half_extents)
    if shape.kind == 'hull':
        return float(np.abs(np.array(shape.points) @ rot[2]).max())
    if shape.kind == 'capsule':
        return abs(rot[2, 2]) * shape.half_length + shape.radius
    return shape.radius


def mixed_set(seed: int = 0, count: int = 700):
    """Random colliders in pairs of every two kinds (both orders, a plane as A too, never two
    planes), near each other: half of them B stacked on A along z (resting faces, capsules
    lying on boxes, parallel capsules, deep overlaps), margins 0 or up to 0.2 m; then a few
    pairs at non-finite poses. (shapes, poses, pair_a, pair_b, margins)."""
    rng = np.random.default_rng(seed)
    shapes, poses, pairs, margins = [], [], [], []
    while len(pairs) < count:
        ka, kb = (KINDS[k] for k in rng.integers(len(KINDS), size=2))
        if ka == kb == 'plane':
            continue
        for kind in (ka, kb):
            shape = _random_shape(rng, kind)
            if kind == 'plane':
                pose = (rng.normal(size=3) * 0.1 + (0.0, 0.0, -0.3), I3)
            else:
                pose = (rng.normal(size=3) * 0.35, _random_rotation(rng))
            shapes.append(shape)
            poses.append(pose)
        if ka != 'plane' and kb != 'plane' and rng.random() < 0.5:
            # B on top of A: its centre over A's by the sum of their half heights, give or take.
            lift = (_half_height(shapes[-2], poses[-2][1]) + _half_height(shapes[-1], poses[-1][1])
                    + float(rng.normal()) * 0.02)
            poses[-1] = (poses[-2][0] + (rng.normal() * 0.1, rng.normal() * 0.1, lift),
                         poses[-1][1])
        pairs.append((len(shapes) - 2, len(shapes) - 1))
        margins.append(0.0 if rng.random() < 0.4 else float(rng.uniform(0.0, 0.2)))
    bad = [(Sphere(0.1), (np.array([math.nan, 0.0, 0.0]), I3)),
           (Box((0.2, 0.2, 0.2)), (np.array([0.0, math.inf, 0.0]), I3)),
           (Capsule(0.1, 0.3), (ORIGIN, np.full((3, 3), math.nan))),
           (Box((0.2, 0.2, 0.2)), (ORIGIN, np.full((3, 3), math.inf))),
           (Capsule(0.1, 0.3), (np.array([0.0, 0.0, -math.inf]), I3))]
    for shape, pose in bad:
        for other in (Sphere(0.2), Capsule(0.1, 0.4), Box((0.3, 0.3, 0.3)), Plane(),
                      Cylinder(0.2, 0.3)):
            shapes += [shape, other]
            poses += [pose, (ORIGIN, I3)]
            pairs.append((len(shapes) - 2, len(shapes) - 1))
            margins.append(0.1)
    pair_a, pair_b = (np.array(c, dtype=np.int64) for c in zip(*pairs))
    return shapes, poses, pair_a, pair_b, np.array(margins)


def _arrays(shapes, poses, pair_a, pair_b, margins) -> dict:
    pool = Pool()
    packed = [nph.shape_arrays(s, *p, pool) for s, p in zip(shapes, poses)]
    return {'pair_a': pair_a, 'pair_b': pair_b,
            'kinds': np.array([p[0] for p in packed], dtype=np.int64),
            'geoms': np.array([p[1] for p in packed]), 'pool': pool.array(),
            'centres': np.array([p[2] for p in packed]),
            'rotations': np.array([p[3] for p in packed]), 'margins': margins}


def _collide_pairs(arrays: dict):
    rows = len(arrays['pair_a']) * nk.MAX_CONTACTS_PER_PAIR
    out = (np.zeros((rows, 3)), np.zeros((rows, 3)), np.zeros(rows),
           np.zeros(rows, dtype=np.int64), np.zeros(rows, dtype=np.int64))
    names = ('pair_a', 'pair_b', 'kinds', 'geoms', 'pool', 'centres', 'rotations', 'margins')
    count = nk.collide_pairs(*(arrays[k] for k in names), *out)
    return count, out


def test_kinds_are_the_narrow_phase_ranks():
    assert nph.KIND == RANK
    assert (nk.KIND_SPHERE, nk.KIND_CAPSULE, nk.KIND_BOX, nk.KIND_PLANE) == (0, 1, 2, 3)


def test_collide_pairs_agrees_with_collide_pair_by_pair():
    shapes, poses, pair_a, pair_b, margins = data = mixed_set()
    count, (point, normal, depth, feature, source) = _collide_pairs(_arrays(*data))
    row = 0
    per_pair = np.zeros(len(pair_a), dtype=int)
    for k, (i, j) in enumerate(zip(pair_a, pair_b)):
        for c in nph.collide(shapes[i], poses[i], shapes[j], poses[j], margins[k]):
            assert source[row] == k
            np.testing.assert_array_equal(point[row], c.point)      # nan == nan here
            np.testing.assert_array_equal(normal[row], c.normal)
            np.testing.assert_array_equal(depth[row], c.depth)
            assert feature[row] == c.feature
            row += 1
            per_pair[k] += 1
    assert row == count
    # The set reaches every pair of kinds and the cases with their own code.
    touching = per_pair > 0
    kind_pairs = {(shapes[i].kind, shapes[j].kind)
                  for i, j in zip(pair_a[touching], pair_b[touching])}
    assert kind_pairs == {(a, b) for a in KINDS for b in KINDS} - {('plane', 'plane')}
    kinds = [(shapes[pair_a[s]].kind, shapes[pair_b[s]].kind) for s in source[:count]]
    found = {(min(k, key=RANK.get), max(k, key=RANK.get), int(f))
             for k, f in zip(kinds, feature[:count])}
    for case in [('capsule', 'capsule', 1), ('capsule', 'capsule', 2),     # parallel overlap
                 ('capsule', 'plane', 1), ('capsule', 'box', 10), ('capsule', 'box', 1),
                 ('capsule', 'box', 20)]:                                  # near, ends, deep
        assert case in found, case
    assert {200 <= f < 209 for (a, b, f) in found if a == b == 'box'} == {False, True}
    # Face contacts on a face of A's and on one of B's (the normal along one of its axes).
    reference = set()
    for row in range(count):
        i, j = pair_a[source[row]], pair_b[source[row]]
        if shapes[i].kind == shapes[j].kind == 'box' and feature[row] >= 1000:
            along_a = np.abs(poses[i][1].T @ normal[row]).max() > 1.0 - 1e-12
            along_b = np.abs(poses[j][1].T @ normal[row]).max() > 1.0 - 1e-12
            reference.add('a' if along_a and not along_b else 'b' if along_b else 'both')
    assert {'a', 'b'} <= reference
    assert per_pair.max() >= 8                                            # a box on a plane
    assert np.isnan(depth[:count]).any()                                  # the bad poses


def test_compiled_and_interpreted_collide_pairs_give_the_same_bits(tmp_path):
    path = tmp_path / 'pairs.npz'
    np.savez(path, **_arrays(*mixed_set()))
    prints = []
    for disable in ('0', '1'):
        env = dict(os.environ, NUMBA_DISABLE_JIT=disable)
        out = subprocess.run([sys.executable, narrow_fingerprint.__file__, str(path)],
                             env=env, capture_output=True, text=True, timeout=900)
        assert out.returncode == 0, out.stderr[-3000:]
        prints.append(json.loads(out.stdout.strip().splitlines()[-1]))
    compiled, interpreted = prints
    assert compiled.pop('compiled') is True and interpreted.pop('compiled') is False
    assert compiled == interpreted and compiled['count'] > 500


def test_collide_pair_refuses_outputs_too_small_two_planes_and_bad_indices():
    pool = Pool()
    kind, geom, centre, rot = nph.shape_arrays(Sphere(0.5), ORIGIN, I3, pool)
    plane = nph.shape_arrays(Plane(), ORIGIN, I3, pool)
    pool = pool.array()
    rows = nk.MAX_CONTACTS_PER_PAIR
    out = (np.zeros((rows, 3)), np.zeros((rows, 3)), np.zeros(rows), np.zeros(rows, np.int64))
    assert nk.collide_pair(kind, geom, centre, rot, *plane, pool, 0.0, *out, 0) == 1
    with pytest.raises(ValueError, match='MAX_CONTACTS_PER_PAIR rows'):
        nk.collide_pair(kind, geom, centre, rot, *plane, pool, 0.0, *out, 1)
    with pytest.raises(ValueError, match='two planes'):
        nk.collide_pair(*plane, *plane, pool, 0.0, *out, 0)
    with pytest.raises(ValueError, match='between a plane and a plane .both static'):
        nph.collide(Plane(), (ORIGIN, I3), Plane(), (ORIGIN, I3))
    arrays = _arrays([Sphere(0.5), Plane()], [(ORIGIN, I3)] * 2, np.array([0]), np.array([1]),
                     np.zeros(1))
    count, out = _collide_pairs(arrays)
    assert count == 1 and out[4][0] == 0 and out[2][0] == 0.5
    arrays['pair_b'] = np.array([2])
    with pytest.raises(ValueError, match='out of range'):
        _collide_pairs(arrays)
    with pytest.raises(ValueError, match='P \\* MAX_CONTACTS_PER_PAIR'):
        nk.collide_pairs(np.array([0]), np.array([1]), arrays['kinds'], arrays['geoms'],
                         arrays['pool'], arrays['centres'], arrays['rotations'], np.zeros(1),
                         *(a[:rows - 1] for a in out))


# -- broad phase -------------------------------------------------------------------------------
def test_sweep_and_prune_finds_exactly_the_overlapping_pairs():
    rng = np.random.default_rng(5)
    for count in (0, 1, 2, 50, 400):
        lower = rng.uniform(0.0, 10.0, (count, 3))
        upper = lower + rng.uniform(0.0, 1.5, (count, 3))
        group = rng.integers(0, max(count // 2, 1), count)
        static = rng.random(count) < 0.3
        for axis in (-1, 0, 1, 2):
            got = broad_phase.sweep_and_prune(lower, upper, group, static, axis)
            want = broad_phase.brute_force_pairs(lower, upper, group, static)
            np.testing.assert_array_equal(got, want)
    # Touching boxes count; equal bounds in any order give the same sorted pairs.
    lower = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0]])
    pairs = broad_phase.sweep_and_prune(lower, lower + 1.0, np.arange(3), np.zeros(3, bool), -1)
    np.testing.assert_array_equal(pairs, [[0, 1], [0, 2], [1, 2]])


def test_sweep_and_prune_is_not_quadratic_when_few_touch():
    count = 20000                           # a row of boxes, each touching its neighbours only
    lower = np.zeros((count, 3))
    lower[:, 0] = np.arange(count) * 1.0
    pairs = broad_phase.sweep_and_prune(lower, lower + [1.0, 1.0, 1.0], np.arange(count),
                                        np.zeros(count, bool), -1)
    assert len(pairs) == count - 1


def test_plane_candidates_use_the_support_distance():
    normals = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])    # the ground, a wall at x = 5
    plane_points = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    centres = np.array([[0.0, 0.0, 0.5], [4.6, 0.0, 3.0], [0.0, 0.0, 2.0]])
    # Spheres of radius 0.5 (support 0.5 towards any plane), then the same as boxes of half
    # extents 0.5 turned by 45 degrees about y: support 0.5 sqrt(2) towards the ground and wall.
    rotations = np.tile(np.eye(3).reshape(9), (3, 1))
    spheres = np.full(3, nk.KIND_SPHERE)
    geoms = np.zeros((3, nk.GEOM_WIDTH))
    geoms[:, nk.RADIUS] = 0.5
    colliders, body, margin = np.arange(3), np.zeros(3, dtype=np.int64), np.zeros(1)
    pairs = broad_phase.plane_candidates(colliders, body, rotations, spheres, geoms,
                                         np.zeros(0), centres, normals, plane_points, margin)
    np.testing.assert_array_equal(pairs, [[0, 0], [1, 1]])
    turned = np.tile(so3.exp([0.0, math.pi / 4, 0.0]).reshape(9), (3, 1))
    centres = np.array([[0.0, 0.0, 0.7], [4.3, 0.0, 3.0], [0.0, 0.0, 0.8]])
    boxes = np.full(3, nk.KIND_BOX)
    geoms = np.zeros((3, nk.GEOM_WIDTH))
    geoms[:, nk.HX:nk.HZ + 1] = 0.5
    pairs = broad_phase.plane_candidates(colliders, body, turned, boxes, geoms,
                                         np.zeros(0), centres, normals, plane_points, margin)
    np.testing.assert_array_equal(pairs, [[0, 0], [1, 1]])  # 0.7 < 0.707 < 0.8
    margin[0] = 0.1                                           # within the margin: a candidate
    pairs = broad_phase.plane_candidates(colliders, body, turned, boxes, geoms,
                                         np.zeros(0), centres, normals, plane_points, margin)
    np.testing.assert_array_equal(pairs, [[0, 0], [1, 1], [2, 0]])
