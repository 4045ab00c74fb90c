# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The convex hull collider (contact/shapes/hull.py): its mass properties against the closed
forms and trimesh's, its contacts against exact geometry, and in a world it rests, slides,
stacks and tips as the box collider of the same corners does; bad points are refused."""

import math

import numpy as np
import pytest
import trimesh

from rb_sim_ros.contact import narrow_phase as nph
from rb_sim_ros.contact.collision_shapes import Box, Hull, Plane, Sphere
from rb_sim_ros.contact.shapes import hull
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec, ContactSettings

G = 9.81
I3 = np.eye(3)
SIZE = np.array([0.4, 0.3, 0.2])
CORNERS = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]) * SIZE / 2
MASS = 12.0
MOMENTS = tuple(MASS / 12.0 * np.array([SIZE[1] ** 2 + SIZE[2] ** 2,
                                        SIZE[0] ** 2 + SIZE[2] ** 2,
                                        SIZE[0] ** 2 + SIZE[1] ** 2]))


def _xyzw(rotation) -> tuple:
    return tuple(float(c) for c in so3.quaternion_xyzw_from_matrix(rotation))


def _rotation(state) -> np.ndarray:
    return np.array(state.rotation)


def test_mass_properties_are_the_closed_forms_and_trimeshs():
    """A box's hull: m = rho abc, I = m (b^2 + c^2) / 12 ...; the unit corner tetrahedron:
    V = 1/6, centre (1/4, 1/4, 1/4), I_xx = 3 m / 40, I_xy = m / 80 about its centre; a random
    cloud's hull: trimesh's volume, centre of mass and inertia tensor (its own integrals)."""
    m, centre, inertia = Hull(CORNERS.tolist()).mass_properties(500.0)
    assert m == pytest.approx(500.0 * SIZE.prod(), rel=1e-13)
    np.testing.assert_allclose(centre, 0.0, atol=1e-15)
    np.testing.assert_allclose(inertia, np.diag(MOMENTS) * m / MASS, rtol=1e-13, atol=1e-15)
    m, centre, inertia = Hull([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]).mass_properties()
    assert m == pytest.approx(1.0 / 6.0, rel=1e-14)
    np.testing.assert_allclose(centre, 0.25, rtol=1e-14)
    expected = np.full((3, 3), m / 80.0) + np.eye(3) * (3.0 * m / 40.0 - m / 80.0)
    np.testing.assert_allclose(inertia, expected, rtol=1e-13)
    rng = np.random.default_rng(4)
    for _ in range(5):
        points = rng.normal(size=(40, 3)) * rng.uniform(0.1, 2.0, 3) + rng.normal(size=3)
        mine = Hull(points.tolist())
        m, centre, inertia = mine.mass_properties(700.0)
        theirs = trimesh.convex.convex_hull(points)
        theirs.density = 700.0
        assert m == pytest.approx(theirs.mass, rel=1e-12)
        np.testing.assert_allclose(centre, theirs.center_mass, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(inertia, theirs.moment_inertia, rtol=1e-10,
                                   atol=1e-12 * np.abs(inertia).max())
        assert len(mine.points) == len(theirs.vertices)


def test_faces_are_the_solids_polygons():
    """Coplanar triangles are one face: a box's hull has 6 faces of 4 corners, each
    counter-clockwise about its outward normal, and no vertex but its corners (points on
    its edges and faces given too are not vertices)."""
    extra = [[0.0, 0.0, 0.1], [0.2, 0.0, 0.0], [0.1, 0.15, 0.1]]  # on a face, an edge, a face
    box = Hull(CORNERS.tolist() + extra)
    assert len(box.points) == 8 and len(box.faces) == 6
    v = box.vertices
    for face, n in zip(box.faces, box.normals):
        assert len(face) == 4
        p = v[list(face)]
        assert np.allclose((p - p.mean(axis=0)) @ n, 0.0, atol=1e-15)
        assert np.allclose(np.abs(n).max(), 1.0)
        for k in range(4):  # each turn is to the left, seen from outside
            turn = np.cross(p[k] - p[k - 1], p[(k + 1) % 4] - p[k]) @ n
            assert turn > 0.0
        assert (v @ n).max() == pytest.approx(p[0] @ n, abs=1e-15)  # outward


def test_many_points_are_thinned_to_max_vertices_inside_the_hull_given():
    """2,000 points on a sphere: the hull used has MAX_VERTICES of them (says how many it
    had), is inside the full hull and holds most of its volume."""
    rng = np.random.default_rng(1)
    points = rng.normal(size=(2000, 3))
    points /= np.linalg.norm(points, axis=1)[:, None]
    thin = Hull(points.tolist())
    assert len(thin.points) == hull.MAX_VERTICES and thin.simplified == 2000
    given = {tuple(p) for p in points.tolist()}
    assert all(p in given for p in thin.points)
    full = trimesh.convex.convex_hull(points)
    assert 0.85 * full.volume < thin.mass_properties()[0] < full.volume
    assert Hull(CORNERS.tolist()).simplified == 0


@pytest.mark.parametrize('points, reason', [
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], 'no volume'),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], 'at least 4 points'),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, math.nan]], r'points\[3\] is not finite'),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1e300]], 'MAX_LENGTH'),
    ([[0, 0, 0], [1, 0, 0], [0, 1], [0, 0, 1]], r'points\[2\] must be 3 numbers'),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 'x'], [0, 0, 1]], r'points\[2\] must be 3 numbers'),
    ([[0, 0, 0], [1, 0, 0], [0, 1, True], [0, 0, 1]], r'points\[2\] must be 3 numbers'),
    ('points', 'a list of'),
    ([[0, 0, 0]] * 4, 'no volume'),
    ([[0, 0, 0], [1e-12, 0, 0], [0, 1e-12, 0], [0, 0, 1e-12]], 'no volume'),
])
def test_bad_points_are_refused_with_the_reason(points, reason):
    with pytest.raises(ValueError, match=reason):
        Hull(points)


def test_millions_of_points_are_refused_before_any_work():
    with pytest.raises(ValueError, match='MAX_POINTS'):
        Hull(np.zeros((hull.MAX_POINTS + 1, 3)))


def test_a_ball_on_a_hulls_face_and_edge_touches_where_geometry_says():
    """A ball over the top face of a turned box hull: one contact, the face's normal, depth
    r - distance; over an edge: the normal from the edge's nearest point to the centre."""
    turn = so3.exp((0.3, -0.2, 0.5))
    box_hull = Hull(CORNERS.tolist())
    centre = np.array([0.1, -0.2, 0.3])
    r = 0.1
    for local, depth in (((0.05, 0.02, 0.1 + 0.09), 0.01), ((0.2 + 0.06, 0.0, 0.1 + 0.06), None)):
        ball_at = centre + turn @ np.array(local)
        contacts = nph.collide(box_hull, (centre, turn), Sphere(r), (ball_at, I3), 0.0)
        assert len(contacts) == 1
        c = contacts[0]
        if depth is not None:
            np.testing.assert_allclose(c.normal, turn[:, 2], atol=1e-12)
            assert c.depth == pytest.approx(depth, abs=1e-12)
        else:
            edge_point = centre + turn @ np.array([0.2, 0.0, 0.1])
            gap = ball_at - edge_point
            np.testing.assert_allclose(c.normal, gap / np.linalg.norm(gap), atol=1e-9)
            assert c.depth == pytest.approx(r - np.linalg.norm(gap), abs=1e-9)


def _block(shape, rotation=I3, position=(0.0, 0.0, 0.3), name='block', **kwargs):
    return BodySpec(name, MASS, MOMENTS, initial_position=tuple(position),
                    initial_orientation_xyzw=_xyzw(rotation), colliders=(shape,), **kwargs)


def _solid(name, hull, density, position, rotation):
    """A body of ``hull`` (its origin its centre of mass) of uniform ``density``."""
    m, _, inertia = hull.mass_properties(density)
    return BodySpec(name, m, tuple(inertia.ravel()), initial_position=position,
                    initial_orientation_xyzw=_xyzw(rotation), colliders=(hull,))


def _world(bodies, planes=(Plane(),), friction=0.8, dt=1e-3):
    return collision_world(bodies, dt, (0.0, 0.0, -G), planes=planes,
                           contact=ContactSettings(friction=friction))


@pytest.mark.parametrize('tilt', [(0.0, 0.0, 0.0), (0.5, 0.3, 0.0), (0.1, 1.2, 0.4)])
def test_a_box_hull_lands_and_rests_where_the_box_does(tilt):
    """Dropped tipped from 30 cm onto the ground: the hull of a box's corners comes to rest
    in the box collider's pose (to 1 mm and 1 mrad), on a face at its half height, still."""
    turn = so3.exp(tilt)
    poses = []
    for shape in (Box(tuple(SIZE)), Hull(CORNERS.tolist())):
        world = _world([_block(shape, turn)])
        world.step(1500)
        st = world.state('block')
        poses.append((np.array(st.position), _rotation(st)))
        assert np.linalg.norm(st.linear_velocity) < 1e-6
        assert np.linalg.norm(st.angular_velocity) < 1e-6
    (xb, rb), (xh, rh) = poses
    assert np.linalg.norm(xh - xb) < 1e-3
    assert np.linalg.norm(so3.log(rb.T @ rh)) < 1e-3
    assert min(abs(xh[2] - h / 2) for h in SIZE) < 2e-4   # on a face, within the slop


@pytest.mark.parametrize('theta, mu', [(0.4, 0.2), (0.3, 0.5)])
def test_a_box_hull_slides_down_an_incline_as_the_box_and_coulomb_say(theta, mu):
    """On an incline of theta with friction mu: a = g (sin theta - mu cos theta) when it
    slides (mu < tan theta), else it stays; the hull's travel is the box's and the law's."""
    normal = np.array([math.sin(theta), 0.0, math.cos(theta)])  # z turned by theta about y
    downhill = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    tilt = so3.exp((0.0, theta, 0.0))
    steps, dt = 800, 1e-3
    travel = []
    for shape in (Box(tuple(SIZE)), Hull(CORNERS.tolist())):
        start = normal * (SIZE[2] / 2)
        world = _world([_block(shape, tilt, start)], planes=(Plane(normal=tuple(normal)),),
                       friction=mu, dt=dt)
        world.step(steps)
        travel.append(float((np.array(world.state('block').position) - start) @ downhill))
    a = max(G * (math.sin(theta) - mu * math.cos(theta)), 0.0)
    t = steps * dt
    assert travel[1] == pytest.approx(travel[0], abs=2e-4)
    assert travel[1] == pytest.approx(0.5 * a * t * t, abs=2e-3)


def test_a_tall_box_hull_tips_over_when_the_box_does():
    """A tall block (0.1 x 0.1 x 0.5) stood on an edge past its balance angle falls onto its
    side, and the hull's fall takes the box's time (to 5 ms) and lands in the same place."""
    size = np.array([0.1, 0.1, 0.5])
    corners = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
    corners = corners * size / 2
    lean = so3.exp((0.0, 0.3, 0.0))  # balance at atan(0.1 / 0.5) = 0.197 rad
    low = (lean @ corners.T).T[:, 2].min()
    moments = tuple(2.0 / 12.0 * np.array([size[1] ** 2 + size[2] ** 2,
                                           size[0] ** 2 + size[2] ** 2,
                                           size[0] ** 2 + size[1] ** 2]))
    results = []
    for shape in (Box(tuple(size)), Hull(corners.tolist())):
        body = BodySpec('post', 2.0, moments, initial_position=(0.0, 0.0, -low),
                        initial_orientation_xyzw=_xyzw(lean), colliders=(shape,))
        world = _world([body])
        fallen = None
        for k in range(3000):
            world.step(1)
            if fallen is None and world.state('post').position[2] < 0.06:
                fallen = k
        results.append((fallen, np.array(world.state('post').position)))
    (tb, xb), (th, xh) = results
    assert tb is not None and th is not None and abs(th - tb) <= 5
    assert np.linalg.norm(xh - xb) < 2e-3 and xh[2] == pytest.approx(0.05, abs=2e-4)


def test_a_tetrahedron_comes_to_rest_on_a_face():
    """A regular-ish tetrahedron (the unit corner one about its centre of mass) dropped turned
    ends on a face: three vertices at the ground (within the slop), the fourth above, at
    rest."""
    corner = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float) * 0.3
    tet = Hull((corner - Hull(corner.tolist()).mass_properties()[1]).tolist())
    world = _world([_solid('tet', tet, 1000.0, (0.0, 0.0, 0.5), so3.exp((0.3, -0.4, 0.2)))])
    world.step(3000)
    st = world.state('tet')
    heights = np.sort((np.array(st.position) + tet.vertices @ _rotation(st).T)[:, 2])
    assert np.all(np.abs(heights[:3]) < 2e-4) and heights[3] > 0.1
    assert np.linalg.norm(st.linear_velocity) < 1e-6
    assert np.linalg.norm(st.angular_velocity) < 1e-6


def test_box_hulls_stack_as_boxes_do():
    """Three hulls of a box dropped into a stack come to rest on one another at the box
    stack's heights (each half the height above the last, within the slop)."""
    bodies = [_block(Hull(CORNERS.tolist()), position=(0.01 * k, 0.0, 0.1 + 0.205 * k),
                     name=f'b{k}') for k in range(3)]
    world = _world(bodies)
    world.step(2000)
    for k in range(3):
        st = world.state(f'b{k}')
        assert st.position[2] == pytest.approx(0.1 + 0.2 * k, abs=5e-4)
        assert np.linalg.norm(st.linear_velocity) < 1e-5


def _prism(sides: int, radius: float, height: float) -> Hull:
    turn = np.linspace(0.0, 2.0 * math.pi, sides, endpoint=False)
    ring = np.stack([radius * np.cos(turn), radius * np.sin(turn), np.zeros(sides)], axis=1)
    return Hull(np.concatenate([ring - (0, 0, height / 2), ring + (0, 0, height / 2)]).tolist())


def test_a_prism_of_many_corners_names_each_contact_apart():
    """A 20-sided prism (40 vertices: tags past 32, caps of more than FACE_CAPACITY corners)
    across a box's edge or tilted on its face, in many poses: every contact of a pair has its
    own feature (warm starts are keyed on them), and each lies on both surfaces (depth at
    most the overlap)."""
    prism = _prism(20, 0.1, 0.3)
    assert len(prism.points) == 40 and max(len(f) for f in prism.faces) == 20
    rng = np.random.default_rng(2)
    seen = 0
    for _ in range(300):
        turn = so3.exp(rng.normal(size=3) * 0.4) @ so3.exp((math.pi / 2, 0.0, 0.0))
        if rng.random() < 0.5:
            turn = so3.exp(rng.normal(size=3) * 0.05)
        at = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.2, 0.2), 0.0])
        at[2] = 0.5 - (prism.vertices @ turn.T)[:, 2].min() - rng.uniform(0.0, 0.004)
        contacts = nph.collide(Box((1.0, 1.0, 1.0)), (np.zeros(3), I3), prism, (at, turn),
                               0.002)
        features = [c.feature for c in contacts]
        assert len(set(features)) == len(features), features
        seen += len(contacts) > 1
    assert seen > 100


def test_a_prism_stands_on_its_cap_still():
    """The 20-sided prism standing on its cap (a face of 20 corners, 9 of them its contacts)
    comes to rest and stays still: no rocking, no creeping."""
    prism = _prism(20, 0.1, 0.3)
    world = _world([_solid('post', prism, 1000.0, (0.0, 0.0, 0.16),
                           so3.exp((0.05, -0.03, 0.0)))])
    world.step(1500)
    before = world.state('post')
    world.step(500)
    after = world.state('post')
    assert after.position[2] == pytest.approx(0.15, abs=2e-4)
    assert np.linalg.norm(np.array(after.position) - before.position) < 1e-7
    assert np.linalg.norm(after.angular_velocity) < 1e-6


@pytest.mark.parametrize('other', ['hull', 'sphere', 'box'])
def test_a_pair_within_the_margin_touches_and_one_beyond_does_not(other):
    """The convex narrow phase stops early for cores farther apart than the margin (a plane
    between them): a turned hull 1 mm above another shape gives a contact of depth -1 mm
    with a margin of 1.001 mm, and none with 0.999 mm."""
    pebble = Hull((np.random.default_rng(8).normal(size=(30, 3)) * 0.1).tolist())
    turn = so3.exp((0.4, -0.2, 0.3))
    shape = {'hull': Hull(CORNERS.tolist()), 'sphere': Sphere(0.1), 'box': Box(tuple(SIZE))}[other]
    top = {'hull': SIZE[2] / 2, 'sphere': 0.1, 'box': SIZE[2] / 2}[other]
    turned = pebble.vertices @ turn.T
    lowest = turned[np.argmin(turned[:, 2])]
    at = np.array([0.0, 0.0, top + 1e-3]) - lowest  # the lowest vertex over the top point
    for margin, found in ((1.001e-3, True), (0.999e-3, False)):
        contacts = nph.collide(shape, (np.zeros(3), I3), pebble, (at, turn), margin)
        assert bool(contacts) == found, (other, margin)
        if found:
            assert max(c.depth for c in contacts) == pytest.approx(-1e-3, abs=1e-9)
