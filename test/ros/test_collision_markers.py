# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""RViz markers of colliders: placed where the shapes are, by hand-worked poses."""

import math

import numpy as np
import pytest
from visualization_msgs.msg import Marker

from rb_sim_ros.contact.collision_shapes import Box, Capsule, Cylinder, Hull, Plane, Sphere
from rb_sim_ros.contact.collision_world import WorldContact
from rb_sim_ros.contact.shapes import base
from rb_sim_ros.core import so3
from rb_sim_ros.ros.collision_markers import CollisionMarkers, MARKERS, PLANE_THICKNESS
from rb_sim_ros.sim.simulation import BodySpec, Config

S = math.sqrt(0.5)
Z90 = (0.0, 0.0, S, S)   # 90 degrees about z: x -> y, y -> -x
X90 = (S, 0.0, 0.0, S)   # 90 degrees about x: z -> -y


def _config():
    return Config(bodies=(
        BodySpec('a', colliders=(Sphere(0.05, position=(0.1, 0.0, 0.0)),
                                 Box((0.2, 0.4, 0.6), orientation_xyzw=Z90))),
        BodySpec('rod', colliders=(Capsule(0.03, 0.5),)),
        BodySpec('wall', static=True, colliders=(Plane((2.0, 0.0, 0.0), 2.0),))))


def _position(m):
    return np.array([m.pose.position.x, m.pose.position.y, m.pose.position.z])


def _rotation(m):
    o = m.pose.orientation
    return so3.matrix_from_quaternion_xyzw((o.x, o.y, o.z, o.w))


def test_markers_sit_on_the_shapes():
    markers = CollisionMarkers(_config(), 'odom')
    poses = {'a': ((1.0, 2.0, 3.0), Z90), 'rod': ((0.0, 0.0, 1.0), X90),
             'wall': ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))}
    contacts = [WorldContact('a', 'rod', np.array([0.5, 0.0, 0.0]), np.array([1.0, 0, 0]),
                             0.0, 2.0),
                WorldContact('a', 'wall', np.array([9.0, 0.0, 0.0]), np.array([1.0, 0, 0]),
                             -0.01, 0.0)]  # speculative, no impulse: not drawn
    array = markers.fill(1_500_000_000, poses, contacts)
    by_key = {(m.ns, m.id): m for m in array.markers}
    assert sorted(by_key) == [('a', 0), ('a', 3), ('contacts', 0), ('rod', 0), ('rod', 1),
                              ('rod', 2), ('wall', 0)]
    assert all(m.header.frame_id == 'odom' and m.header.stamp.sec == 1
               and m.header.stamp.nanosec == 500_000_000 for m in array.markers)
    sphere = by_key[('a', 0)]
    assert sphere.type == Marker.SPHERE and sphere.scale.x == pytest.approx(0.1)
    np.testing.assert_allclose(_position(sphere), (1.0, 2.1, 3.0), atol=1e-12)
    box = by_key[('a', 3)]
    assert (box.type, box.scale.x, box.scale.y, box.scale.z) == (Marker.CUBE, 0.2, 0.4, 0.6)
    # Two turns of 90 degrees about z: the box's x axis points along -x in the world.
    np.testing.assert_allclose(_rotation(box)[:, 0], (-1.0, 0.0, 0.0), atol=1e-12)
    cylinder, cap_up, cap_down = by_key[('rod', 0)], by_key[('rod', 1)], by_key[('rod', 2)]
    assert cylinder.type == Marker.CYLINDER and cylinder.scale.z == pytest.approx(0.5)
    np.testing.assert_allclose(_rotation(cylinder)[:, 2], (0.0, -1.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(_position(cap_up), (0.0, -0.25, 1.0), atol=1e-12)
    np.testing.assert_allclose(_position(cap_down), (0.0, 0.25, 1.0), atol=1e-12)
    wall = by_key[('wall', 0)]
    np.testing.assert_allclose(_position(wall), (2.0 - PLANE_THICKNESS / 2, 0.0, 0.0),
                               atol=1e-12)
    np.testing.assert_allclose(_rotation(wall)[:, 2], (1.0, 0.0, 0.0), atol=1e-12)
    points = by_key[('contacts', 0)].points
    assert [(p.x, p.y, p.z) for p in points] == [(0.5, 0.0, 0.0)]


@pytest.mark.parametrize('normal', [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.3, -0.4, 0.5)])
def test_a_plane_is_drawn_square_to_its_normal(normal):
    config = Config(bodies=(BodySpec('g', static=True, colliders=(Plane(normal, 0.5),)),))
    m = CollisionMarkers(config, 'odom').fill(0, {'g': ((0.0, 0.0, 0.0), (0, 0, 0, 1.0))})
    n = np.array(normal) / np.linalg.norm(normal)
    np.testing.assert_allclose(_rotation(m.markers[0])[:, 2], n, atol=1e-12)
    np.testing.assert_allclose(_position(m.markers[0]) @ n, 0.5 - PLANE_THICKNESS / 2,
                               atol=1e-12)


def test_a_cylinder_is_one_cylinder_marker_along_its_axis():
    """RViz's CYLINDER is the shape itself: diameter 2 r across, its length along its z,
    turned and placed as the collider in its body."""
    config = Config(bodies=(BodySpec('can', colliders=(
        Cylinder(0.1, 0.6, position=(0.0, 0.2, 0.0), orientation_xyzw=X90),)),))
    markers = CollisionMarkers(config, 'odom').fill(0, {'can': ((1.0, 0.0, 0.0), Z90)})
    m, = [m for m in markers.markers if m.ns == 'can']
    assert m.type == Marker.CYLINDER
    assert (m.scale.x, m.scale.y, m.scale.z) == pytest.approx((0.2, 0.2, 0.6))
    np.testing.assert_allclose(_position(m), (0.8, 0.0, 0.0), atol=1e-12)  # Z90 turns +y to -x
    np.testing.assert_allclose(_rotation(m)[:, 2], (1.0, 0.0, 0.0), atol=1e-12)


def test_every_drawing_primitive_has_markers():
    """The markers draw every primitive a kind may draw with (contact.shapes.base), so a new
    kind drawn with them needs nothing here."""
    assert set(MARKERS) == set(base.PRIMITIVES)


def test_a_hull_is_one_triangle_list_of_its_surface():
    """A hull's marker is a TRIANGLE_LIST of its faces' triangles in the hull's frame (placed
    as the collider in its body): three points a triangle, each a vertex, and the triangles'
    signed volumes about the centre sum to the hull's volume (a closed surface, outward)."""
    corners = [[x, y, z] for x in (-0.1, 0.3) for y in (-0.2, 0.2) for z in (0.0, 0.5)]
    hull = Hull(corners + [[0.1, 0.0, 0.7]], position=(0.0, 0.2, 0.0), orientation_xyzw=X90)
    config = Config(bodies=(BodySpec('rock', colliders=(hull,)),))
    markers = CollisionMarkers(config, 'odom').fill(0, {'rock': ((1.0, 0.0, 0.0), Z90)})
    m, = [m for m in markers.markers if m.ns == 'rock']
    assert m.type == Marker.TRIANGLE_LIST and (m.scale.x, m.scale.y, m.scale.z) == (1, 1, 1)
    points = np.array([(p.x, p.y, p.z) for p in m.points])
    assert len(points) % 3 == 0 and len(points) == 3 * len(hull.triangles())
    assert {tuple(p) for p in points} == {tuple(v) for v in hull.points}
    a, b, c = points[0::3], points[1::3], points[2::3]
    volume = np.einsum('ij,ij->i', a, np.cross(b, c)).sum() / 6.0
    assert volume == pytest.approx(hull.mass_properties()[0], rel=1e-12)
    np.testing.assert_allclose(_position(m), (0.8, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(_rotation(m), so3.matrix_from_quaternion_xyzw(Z90)
                               @ so3.matrix_from_quaternion_xyzw(X90), atol=1e-12)
