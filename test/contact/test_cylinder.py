# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mujoco
"""The cylinder collider and the convex narrow phase it uses (GJK, EPA, face clipping),
against oracles: the closed forms of a rolling cylinder and of the nearest point of a
cylinder, the exact pair tests the project already has (a box's and a capsule's SAT and
segment tests give the same depth and normal as GJK/EPA on the same shapes), MuJoCo's mass
properties, and a cylinder at rest (standing, lying) that neither sinks nor rocks."""

import math

import mujoco
import numpy as np
import pytest

from rb_sim_ros.contact import convex_kernels as ck, narrow_kernels as nk, narrow_phase as nph
from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Cylinder, Plane, Sphere
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import load_scene, mass_and_inertia
from rb_sim_ros.sim.simulation import BodySpec, ContactSettings

G = 9.81
I3 = np.eye(3)


def _xyzw(rotation) -> tuple:
    return tuple(float(c) for c in so3.quaternion_xyzw_from_matrix(rotation))


def _can(r, length, position, rotation=I3, **kwargs) -> BodySpec:
    m, moments = mass_and_inertia('cylinder', 1000.0, {'radius': r, 'length': length})
    return BodySpec('can', m, moments, initial_position=tuple(position),
                    initial_orientation_xyzw=_xyzw(rotation),
                    colliders=(Cylinder(r, length),), **kwargs)


def test_a_cylinders_mass_properties_are_mujocos():
    """Mass and principal moments of a solid cylinder from a density, as MuJoCo's compiler
    computes them for the same geom."""
    r, length, density = 0.13, 0.7, 800.0
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><worldbody><body><freejoint/><geom type="cylinder" size="{r} {length / 2}" '
        f'density="{density}"/></body></worldbody></mujoco>')
    m, moments = mass_and_inertia('cylinder', density, {'radius': r, 'length': length})
    assert m == pytest.approx(model.body_mass[1], rel=1e-12)
    np.testing.assert_allclose(moments, model.body_inertia[1], rtol=1e-12)


@pytest.mark.parametrize('theta', [0.2, 0.45])
def test_a_cylinder_rolls_down_an_incline_at_two_thirds_g_sin_theta(theta):
    """Rolling without slipping: a = g sin(theta) / (1 + I / (m r^2)) = (2/3) g sin(theta);
    after T it has gone a T^2 / 2, its spin is its speed over r, and it stays on the plane."""
    r, length, dt, steps = 0.1, 0.3, 1e-3, 1000
    tilt = so3.exp((0.0, theta, 0.0))
    normal, downhill = tilt @ (0.0, 0.0, 1.0), tilt @ (1.0, 0.0, 0.0)
    lying = so3.exp((math.pi / 2, 0.0, 0.0))  # its axis along y, across the slope
    world = collision_world([_can(r, length, r * normal, lying)], dt, (0.0, 0.0, -G),
                            planes=(Plane(normal=tuple(normal)),),
                            contact=ContactSettings(friction=1.0, sleep_time=0.0))
    world.step(steps)
    st = world.state('can')
    a = 2.0 / 3.0 * G * math.sin(theta)
    t = steps * dt
    travel = (np.array(st.position) - r * normal) @ downhill
    assert travel == pytest.approx(0.5 * a * t * t, rel=5e-3)
    speed = np.array(st.linear_velocity) @ downhill
    assert speed == pytest.approx(a * t, rel=5e-3)
    assert abs(st.angular_velocity[1]) == pytest.approx(speed / r, rel=5e-3)
    assert abs(np.array(st.position) @ normal - r) < 5e-4


@pytest.mark.parametrize('how', ['standing', 'lying', 'tipped'])
def test_a_cylinder_comes_to_rest_on_a_cap_or_its_side_without_rocking(how):
    """Dropped 2 cm onto the ground (tipped: 0.2 rad off upright, it falls back onto its
    cap): at rest at the height of its half length or of its radius, within the contact
    slop; and still: over the last half second its height does not move and it does not
    turn, as a box resting on a face does not."""
    r, length, dt = 0.1, 0.3, 1e-3
    rotation = {'standing': I3, 'lying': so3.exp((math.pi / 2, 0.0, 0.0)),
                'tipped': so3.exp((0.2, 0.1, 0.0))}[how]
    rest = r if how == 'lying' else length / 2
    world = collision_world([_can(r, length, (0.0, 0.0, rest + 0.02), rotation)], dt,
                            (0.0, 0.0, -G), planes=(Plane(),),
                            contact=ContactSettings(friction=0.8, sleep_time=0.0))
    world.step(2500)
    heights, spins = [], []
    for _ in range(500):
        world.step(1)
        st = world.state('can')
        heights.append(st.position[2])
        spins.append(float(np.abs(st.angular_velocity).max()))
    assert abs(heights[-1] - rest) < 3e-4
    assert max(heights) - min(heights) < 1e-9
    assert max(spins) < 1e-9


def test_cylinders_stand_on_a_box_and_on_each_other():
    """A crate on the ground, a cylinder standing on it, another standing on that one and one
    lying on the crate: every one rests at the height of what is under it plus its own half
    height, within the slop of each contact below it."""
    dt, r, length = 1e-3, 0.1, 0.3
    crate = BodySpec('crate', 10.0, (0.1, 0.1, 0.1), initial_position=(0.0, 0.0, 0.1),
                     colliders=(Box((1.0, 1.0, 0.2)),))
    m, moments = mass_and_inertia('cylinder', 1000.0, {'radius': r, 'length': length})
    lying = so3.exp((math.pi / 2, 0.0, 0.0))
    cans = [BodySpec(name, m, moments, initial_position=at, initial_orientation_xyzw=_xyzw(rot),
                     colliders=(Cylinder(r, length),))
            for name, at, rot in (('low', (0.0, 0.0, 0.36), I3), ('high', (0.02, 0.0, 0.67), I3),
                                  ('side', (0.3, 0.0, 0.31), lying))]
    world = collision_world([crate, *cans], dt, (0.0, 0.0, -G), planes=(Plane(),),
                            contact=ContactSettings(friction=0.8, sleep_time=0.0))
    world.step(3000)
    z = {name: world.state(name).position[2] for name in ('crate', 'low', 'high', 'side')}
    assert abs(z['crate'] - 0.1) < 3e-4
    assert abs(z['low'] - (0.2 + length / 2)) < 6e-4
    assert abs(z['high'] - (0.2 + 1.5 * length)) < 9e-4
    assert abs(z['side'] - (0.2 + r)) < 6e-4


def _cylinder_point_distance(r, h, p) -> float:
    """The signed distance of p (the cylinder's frame) from the surface of the solid cylinder
    of radius r, half length h about z: outside, the distance to the nearest point of the
    clamped disc stack; inside, minus the distance to the nearest of side and caps."""
    rho, z = math.hypot(p[0], p[1]), abs(p[2])
    out_r, out_z = max(rho - r, 0.0), max(z - h, 0.0)
    if out_r > 0.0 or out_z > 0.0:
        return math.hypot(out_r, out_z)
    return -min(r - rho, h - z)


def test_a_ball_against_a_cylinder_has_the_depth_of_the_nearest_point():
    """A ball whose centre is outside the cylinder (every ball a step meets: its centre
    would have to sink a radius deep first): GJK gives the depth the nearest point of the
    cylinder says, radius minus distance, and the normal along it. A centre inside: EPA, on
    the polytope of a curved core, to a micrometre."""
    rng = np.random.default_rng(11)
    r, length = 0.3, 0.8
    outside = inside = 0
    for _ in range(400):
        rotation = so3.exp(rng.normal(size=3))
        centre = rng.normal(size=3) * 0.3
        local = rng.uniform(-0.6, 0.6, size=3)
        ball = float(rng.uniform(0.05, 0.3))
        distance = _cylinder_point_distance(r, length / 2, local)
        contacts = nph.collide(Sphere(ball), (centre + rotation @ local, I3),
                               Cylinder(r, length), (centre, rotation), margin=0.05)
        if ball - distance < -0.05:
            assert contacts == []
            continue
        assert len(contacts) == 1
        c = contacts[0]
        assert abs(np.linalg.norm(c.normal) - 1.0) < 1e-12
        # the nearest surface point of the cylinder, along the normal from the centre
        nearest = local + (ball - c.depth) * (rotation.T @ c.normal)
        if distance > 0.0:
            assert c.depth == pytest.approx(ball - distance, abs=1e-9)
            assert abs(_cylinder_point_distance(r, length / 2, nearest)) < 1e-9
            outside += 1
        else:  # EPA on the curved side: measured 6e-8 m and 8e-4 rad at worst
            assert c.depth == pytest.approx(ball - distance, abs=1e-6)
            assert abs(_cylinder_point_distance(r, length / 2, nearest)) < 1e-6
            inside += 1
    assert outside > 100 and inside > 20


def _deepest(contacts):
    return max(contacts, key=lambda c: c.depth) if contacts else None


def _box_overlap(a, pose_a, b, pose_b) -> tuple[float, np.ndarray]:
    """The least overlap of two boxes over the 15 axes that can separate them (3 + 3 face
    normals, 9 edge crossings) and its axis from A to B: their minimum translation, when
    they overlap."""
    (ca, ra), (cb, rb) = pose_a, pose_b
    ha, hb = np.array(a.size) / 2, np.array(b.size) / 2
    axes = [ra[:, i] for i in range(3)] + [rb[:, j] for j in range(3)]
    for i in range(3):
        for j in range(3):
            c = np.cross(ra[:, i], rb[:, j])
            if np.linalg.norm(c) > 1e-9:
                axes.append(c / np.linalg.norm(c))
    best, along = math.inf, None
    for u in axes:
        overlap = np.abs(ra.T @ u) @ ha + np.abs(rb.T @ u) @ hb - abs((cb - ca) @ u)
        if overlap < best:
            best, along = overlap, u if (cb - ca) @ u >= 0.0 else -u
    return best, along


def _convex(a, pose_a, b, pose_b, margin):
    rows = nk.MAX_CONTACTS_PER_PAIR
    out = (np.zeros((rows, 3)), np.zeros((rows, 3)), np.zeros(rows), np.zeros(rows, np.int64))
    pool = shapes.Pool()
    arrays = nph.shape_arrays(a, *pose_a, pool) + nph.shape_arrays(b, *pose_b, pool)
    count = ck.convex_pair(*arrays, pool.array(), margin, *out, 0)
    return count, out


def test_epa_finds_the_minimum_translation_of_two_overlapping_boxes():
    """GJK + EPA on two overlapping boxes (polytopes: EPA ends on a face of A - B): the
    deepest contact is the least overlap over the separating axes, along its axis."""
    rng = np.random.default_rng(5)
    compared = 0
    for _ in range(300):
        a, b = Box(tuple(rng.uniform(0.1, 0.8, 3))), Box(tuple(rng.uniform(0.1, 0.8, 3)))
        pose_a = (rng.normal(size=3) * 0.05, so3.exp(rng.normal(size=3)))
        pose_b = (rng.normal(size=3) * 0.4, so3.exp(rng.normal(size=3)))
        overlap, axis = _box_overlap(a, pose_a, b, pose_b)
        if overlap <= 0.0:
            continue
        count, (point, normal, depth, feature) = _convex(a, pose_a, b, pose_b, 0.0)
        k = int(np.argmax(depth[:count]))
        assert depth[k] == pytest.approx(overlap, abs=1e-12)
        assert float(normal[k] @ axis) > 1.0 - 1e-9
        compared += 1
    assert compared > 100


@pytest.mark.parametrize('pair', ['capsule-box', 'sphere-box', 'capsule-capsule'])
def test_gjk_and_epa_give_the_depth_and_normal_of_the_exact_tests(pair):
    """The convex narrow phase run on pairs that have exact tests of their own (a ball's or
    a segment's nearest points to a box or a segment): the deepest contact has their depth,
    overlapping or apart within the margin, and their normal."""
    rng = np.random.default_rng(5)
    kinds = pair.split('-')
    make = {'box': lambda: Box(tuple(rng.uniform(0.1, 0.8, 3))),
            'capsule': lambda: Capsule(float(rng.uniform(0.05, 0.2)),
                                       float(rng.uniform(0.1, 0.6))),
            'sphere': lambda: Sphere(float(rng.uniform(0.05, 0.3)))}
    compared = 0
    for _ in range(300):
        a, b = make[kinds[0]](), make[kinds[1]]()
        pose_a = (rng.normal(size=3) * 0.05, so3.exp(rng.normal(size=3)))
        pose_b = (rng.normal(size=3) * 0.4, so3.exp(rng.normal(size=3)))
        exact = _deepest(nph.collide(a, pose_a, b, pose_b, margin=0.05))
        count, (point, normal, depth, feature) = _convex(a, pose_a, b, pose_b, 0.05)
        if exact is None:
            assert count == 0
            continue
        assert count > 0
        k = int(np.argmax(depth[:count]))
        assert depth[k] == pytest.approx(exact.depth, abs=1e-9)
        assert float(normal[k] @ exact.normal) > 1.0 - 1e-9
        compared += 1
    assert compared > 40


def test_a_flat_face_on_a_cap_is_a_manifold_of_the_overlap():
    """A box standing on a cylinder's cap and a cylinder on a box: the contacts are points
    of the overlap of the two faces, at most 4, all of the same depth, on the plane between
    them, normal along the axis; a cylinder lying on a box touches along its side line (two
    ends); two lying side by side on each other, along their common line."""
    lying = so3.exp((math.pi / 2, 0.0, 0.0))
    cases = [(Box((0.2, 0.2, 0.2)), ((0.05, 0.0, 0.399), so3.exp((0.0, 0.0, 0.5))),
              Cylinder(0.3, 0.6), ((0.0, 0.0, 0.0), I3), 4),
             (Cylinder(0.3, 0.6), ((0.0, 0.0, 0.399), I3), Box((2.0, 2.0, 0.2)),
              ((0.0, 0.0, 0.0), I3), 4),
             (Cylinder(0.1, 0.6), ((0.0, 0.0, 0.199), lying), Box((2.0, 2.0, 0.2)),
              ((0.0, 0.0, 0.0), I3), 2),
             (Cylinder(0.1, 0.6), ((0.0, 0.0, 0.199), lying), Cylinder(0.1, 0.6),
              ((0.0, 0.0, 0.0), lying), 2)]
    for a, pose_a, b, pose_b, expected in cases:
        contacts = nph.collide(a, pose_a, b, pose_b, margin=0.01)
        assert len(contacts) == expected, (a, b)
        for c in contacts:  # (two curved sides: EPA to its tolerance, measured 6e-6 rad)
            assert c.depth == pytest.approx(0.001, abs=1e-9)
            np.testing.assert_allclose(c.normal, (0.0, 0.0, -1.0), atol=1e-5)  # A on top
        assert len({c.feature for c in contacts}) == len(contacts)  # warm starts tell apart


def _reach(shape, rotation, d) -> float:
    """How far ``shape`` (turned by ``rotation``) reaches from its centre along the unit d."""
    if isinstance(shape, Sphere):
        return shape.radius
    if isinstance(shape, Capsule):
        return abs(float(rotation[:, 2] @ d)) * shape.half_length + shape.radius
    if isinstance(shape, Box):
        return float(np.abs(rotation.T @ d) @ np.array(shape.half_extents))
    along = abs(float(rotation[:, 2] @ d))
    return along * shape.half_length + shape.radius * math.sqrt(max(1.0 - along ** 2, 0.0))


def test_every_contact_of_a_random_cylinder_lies_between_the_surfaces():
    """Random cylinders against each kind, placed as a step meets them: touching along a
    random direction, then moved up to 3 mm into each other or 1 cm apart. Every contact's
    normal is a unit vector, its depth at most the overlap along its normal that the shapes'
    supports allow, and its point less half its depth along the normal lies on A's surface
    (a point of a clipped face within tan(acos(FACE_COS)) of its depth: the face is measured
    along the normal)."""
    rng = np.random.default_rng(2)
    others = [lambda: Sphere(float(rng.uniform(0.05, 0.3))),
              lambda: Capsule(float(rng.uniform(0.05, 0.2)), float(rng.uniform(0.1, 0.6))),
              lambda: Box(tuple(rng.uniform(0.1, 0.8, 3))),
              lambda: Cylinder(float(rng.uniform(0.05, 0.4)), float(rng.uniform(0.1, 0.8)))]
    slack = math.tan(math.acos(ck.FACE_COS))
    found = 0
    for _ in range(400):
        can = Cylinder(float(rng.uniform(0.05, 0.4)), float(rng.uniform(0.1, 0.8)))
        other = others[int(rng.integers(len(others)))]()
        ra, rb = so3.exp(rng.normal(size=3)), so3.exp(rng.normal(size=3))
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        gap = float(rng.uniform(-0.003, 0.01))
        at = (_reach(can, ra, d) + _reach(other, rb, -d) + gap) * d
        for c in nph.collide(can, (np.zeros(3), ra), other, (at, rb), margin=0.02):
            n = c.normal
            assert abs(np.linalg.norm(n) - 1.0) < 1e-12
            assert c.depth <= _reach(can, ra, n) + _reach(other, rb, -n) - float(at @ n) + 1e-9
            on_a = ra.T @ (c.point + 0.5 * c.depth * n)
            error = _cylinder_point_distance(can.radius, can.half_length, on_a)
            assert abs(error) <= 1e-6 + slack * max(c.depth, 0.0)
            found += 1
    assert found > 100


def test_a_scene_cylinder_collides_as_its_own_shape(tmp_path):
    """``shape: cylinder`` with ``colliders: shape`` is one Cylinder collider of the body's
    radius and length, the body's mass and moments those of that solid."""
    path = tmp_path / 'scene.yaml'
    path.write_text('bodies: [{name: can, shape: cylinder, radius: 0.1, length: 0.3, '
                    'density: 1000, colliders: [{type: shape, friction: 0.3}]}]\n')
    can, = load_scene(str(path)).bodies
    assert can.colliders == (Cylinder(0.1, 0.3, friction=0.3),)
    m, moments = mass_and_inertia('cylinder', 1000.0, {'radius': 0.1, 'length': 0.3})
    assert can.mass == m and tuple(can.inertia) == moments


@pytest.mark.parametrize('a, pose_a, b, pose_b, normal', [
    # a can standing 10 um into a 1 km slab, 2 cm thick: GJK stalled on rounding and said
    # "apart", with a horizontal normal (review of 7c06965)
    (Cylinder(0.1, 0.3), ((0.0, 0.0, 0.16 - 1e-5), I3), Box((1e3, 1e3, 0.02)),
     ((0.0, 0.0, 0.0), I3), (0.0, 0.0, -1.0)),
    # two 100 m rods lying stacked along y, 0.1 mm into each other, 43 m apart along it
    (Cylinder(0.01, 100.0), ((0.0, 43.182, 0.03 - 1e-4), so3.exp((math.pi / 2, 0.0, 0.0))),
     Cylinder(0.01, 100.0), ((0.0, 0.0, 0.01), so3.exp((math.pi / 2, 0.0, 0.0))),
     (0.0, 0.0, -1.0))])
def test_long_and_flat_overlaps_are_overlaps_with_the_normal_across(a, pose_a, b, pose_b,
                                                                    normal):
    """Where a Minkowski difference is long and flat, GJK's last simplex is all rounding: it
    may call shapes apart only where a plane separates them; these overlap, so every contact
    is along the normal across the thin side (within a milliradian: EPA on the rods' curved
    sides, measured 2e-4 rad), with a positive depth."""
    pose_a = (np.array(pose_a[0]), pose_a[1])
    pose_b = (np.array(pose_b[0]), pose_b[1])
    contacts = nph.collide(a, pose_a, b, pose_b, margin=0.001)
    assert contacts
    for c in contacts:
        assert c.depth > 0.0
        np.testing.assert_allclose(c.normal, normal, atol=1e-3)


def test_side_lines_that_pass_aside_touch_once_where_they_cross():
    """Two cylinders lying on each other, one turned 0.14 rad about the vertical: their side
    lines are near parallel but pass aside of each other at the ends; the one contact is
    where they cross, on both surfaces."""
    lying = so3.exp((math.pi / 2, 0.0, 0.0))
    turned = so3.exp((0.0, 0.0, 0.14)) @ lying
    contacts = nph.collide(Cylinder(0.1, 0.6), ((0.0, 0.0, 0.199), turned), Cylinder(0.1, 0.6),
                           ((0.0, 0.0, 0.0), lying), margin=0.01)
    for c in contacts:
        on_a = turned.T @ (c.point + 0.5 * c.depth * c.normal - (0.0, 0.0, 0.199))
        assert abs(_cylinder_point_distance(0.1, 0.3, on_a)) < 1e-6
    assert len(contacts) == 1 and contacts[0].depth == pytest.approx(0.001, abs=1e-6)


def test_features_of_one_pair_are_distinct_and_a_tipped_cap_has_one_lowest_point():
    """Two caps clipped against each other give each contact its own feature (warm starts
    are looked up by it); a cylinder tipped either way about y over a plane touches at its
    one lowest rim point (the octant of 180 degrees was once counted twice)."""
    contacts = nph.collide(Cylinder(0.1, 0.2), ((0.0, 0.0, 0.0), I3), Cylinder(0.3, 0.2),
                           ((-0.30310889, -0.175, 0.2), so3.exp((0.02, 0.0, 0.0))), margin=0.02)
    assert contacts and len({c.feature for c in contacts}) == len(contacts)
    for tip in (0.3, -0.3):
        rotation = so3.exp((0.0, tip, 0.0))
        height = 0.1 * math.cos(0.3) + 0.1 * math.sin(0.3) - 1e-4  # 0.1 mm into the plane
        contacts = nph.collide(Cylinder(0.1, 0.2), ((0.0, 0.0, height), rotation), Plane(),
                               ((0.0, 0.0, 0.0), I3), margin=0.0)
        assert len(contacts) == 1 and contacts[0].depth == pytest.approx(1e-4, abs=1e-12)
