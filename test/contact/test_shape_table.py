# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The table of shape kinds (contact/shapes) and the table of their contact tests
(narrow_kernels.PAIR_TESTS): every kind's module keeps the protocol, every row of the pair
table is reached in both orders, a support is the farthest point of its shape, and nothing
outside the kinds' modules tells kinds apart by name."""

import math
from pathlib import Path
import re

import numpy as np
import pytest

from rb_sim_ros.contact import broad_phase, narrow_kernels as nk, narrow_phase as nph, shapes
from rb_sim_ros.contact import world_kernels as wk
from rb_sim_ros.contact.shapes import base
from rb_sim_ros.core import so3

PACKAGE = Path(__file__).resolve().parents[2] / 'rb_sim_ros'
# One shape of each kind as a scene file gives it; a new kind without one fails here.
EXAMPLES = {
    'sphere': {'type': 'sphere', 'radius': 0.3, 'position': [0.1, 0.0, 0.0]},
    'capsule': {'type': 'capsule', 'radius': 0.1, 'length': 0.4,
                'orientation': [0.0, 0.3826834323650898, 0.0, 0.9238795325112867]},
    'box': {'type': 'box', 'size': [0.4, 0.2, 0.6], 'friction': 0.7},
    'plane': {'type': 'plane', 'normal': [0.0, 0.0, 1.0], 'offset': -0.5},
    'cylinder': {'type': 'cylinder', 'radius': 0.2, 'length': 0.5, 'position': [0.0, 0.1, 0.0],
                 'orientation': [0.3826834323650898, 0.0, 0.0, 0.9238795325112867]},
    # not symmetric about its origin
    'hull': {'type': 'hull', 'points': [[-0.2, -0.1, -0.1], [0.3, -0.1, -0.1],
                                        [-0.2, 0.25, -0.1], [-0.1, 0.0, 0.4],
                                        [0.2, 0.2, 0.2]],
             'orientation': [0.0, 0.0, 0.3826834323650898, 0.9238795325112867]},
    'ellipsoid': {'type': 'ellipsoid', 'radii': [0.3, 0.2, 0.15], 'position': [0.0, 0.0, 0.1],
                  'orientation': [0.0, 0.3826834323650898, 0.0, 0.9238795325112867]},
    # a square roof facing down (its triangles clockwise seen from above), turned and placed
    'terrain': {'type': 'terrain', 'vertices': [[-0.5, -0.4, 0.0], [0.5, -0.4, 0.0],
                                                [0.5, 0.4, 0.0], [-0.5, 0.4, 0.0]],
                'triangles': [[0, 2, 1], [0, 3, 2]], 'position': [0.0, 0.0, 0.05],
                'orientation': [0.0, 0.0, 0.3826834323650898, 0.9238795325112867]},
}
SOLIDS = ('sphere', 'capsule', 'box', 'cylinder', 'hull', 'ellipsoid')
Z_UP = np.array([0.0, 0.0, 1.0])


def test_every_kind_keeps_the_protocol_and_reads_back_as_written():
    assert set(EXAMPLES) == set(shapes.NAMES)
    for number, module in enumerate(shapes.KINDS):
        assert module.KIND == number and module.VALUE.kind == module.NAME
        assert shapes.RANK[module.NAME] == number and shapes.BY_NAME[module.NAME] is module
        assert isinstance(module.FIELDS, tuple) and module.FIELDS
        assert isinstance(module.PLACED, bool) and isinstance(module.STATIC_ONLY, bool)
        shape = shapes.shape_from_dict(EXAMPLES[module.NAME])
        assert isinstance(shape, module.VALUE) and shapes.kind_of(shape) == number
        assert shapes.shape_to_dict(shape) == EXAMPLES[module.NAME]
        row = shapes.packed(shape, np.eye(3), shapes.Pool())
        assert row.shape == (nk.GEOM_WIDTH,) and np.all(np.isfinite(row))
    # the ranks of the recordings: a new kind comes last
    assert shapes.NAMES == ('sphere', 'capsule', 'box', 'plane', 'cylinder', 'hull', 'ellipsoid',
                            'terrain')


def _reach(shape, rotation, direction) -> float:
    """The oracle of a support: the largest p . d over the shape's extreme points (corners,
    the ends of a segment plus its radius), computed from the value, not its row."""
    d = np.asarray(direction, dtype=float)
    if shape.kind == 'sphere':
        return shape.radius
    if shape.kind == 'capsule':
        ends = [rotation @ np.array([0.0, 0.0, s * shape.half_length]) for s in (-1, 1)]
        return max(float(e @ d) for e in ends) + shape.radius
    if shape.kind == 'cylinder':  # the farther cap's disc: its centre, then r across the axis
        axis = rotation[:, 2]
        across = math.sqrt(max(1.0 - float(axis @ d) ** 2, 0.0))
        return abs(float(axis @ d)) * shape.half_length + shape.radius * across
    if shape.kind == 'hull':
        return max(float(rotation @ np.array(p) @ d) for p in shape.points)
    if shape.kind == 'ellipsoid':  # the point of (x/a)^2 + ... = 1 whose normal is d
        local = rotation.T @ d * np.array(shape.radii) ** 2
        point = rotation @ (local / math.sqrt(float(local @ (rotation.T @ d))))
        return float(point @ d)
    if shape.kind == 'terrain':  # the box of its vertices (its own axes): a bound of them
        v = np.array(shape.vertices)
        low, high = v.min(axis=0), v.max(axis=0)
        return max(float(rotation @ np.array([(low, high)[i][0], (low, high)[j][1],
                                              (low, high)[k][2]]) @ d)
                   for i in (0, 1) for j in (0, 1) for k in (0, 1))
    hx, hy, hz = shape.half_extents
    corners = [rotation @ np.array([sx * hx, sy * hy, sz * hz])
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return max(float(c @ d) for c in corners)


def test_a_support_is_the_farthest_point_and_bounds_hold_the_shape():
    rng = np.random.default_rng(7)
    solids = [shapes.shape_from_dict(EXAMPLES[n]) for n in SOLIDS + ('terrain',)]
    for _ in range(40):
        rotation = so3.exp(rng.normal(size=3))
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        for shape in solids:
            pool = shapes.Pool()
            geoms = shapes.packed(shape, rotation, pool).reshape(1, -1)
            pool = pool.array()
            local = rotation.T @ direction
            got = shapes.support_of(shapes.kind_of(shape), geoms, pool, 0, *local.tolist())
            assert got == pytest.approx(_reach(shape, rotation, direction), rel=1e-12,
                                        abs=1e-15), shape.kind
            # the bounds of the shape at that turn are its supports along the world axes
            lower, upper = np.zeros((1, 3)), np.zeros((1, 3))
            centre = rng.normal(size=(1, 3))
            wk.extents(0, rotation.reshape(1, 9), np.array([shapes.kind_of(shape)]), geoms,
                       pool, 0.0, centre, lower, upper)
            for a in range(3):
                axis = np.eye(3)[a]
                assert upper[0, a] - centre[0, a] == pytest.approx(
                    _reach(shape, rotation, axis), rel=1e-12, abs=1e-15)
                assert centre[0, a] - lower[0, a] == pytest.approx(
                    _reach(shape, rotation, -axis), rel=1e-12, abs=1e-15)
    plane = shapes.shape_from_dict(EXAMPLES['plane'])
    row = shapes.packed(plane, np.eye(3), shapes.Pool()).reshape(1, -1)
    assert shapes.support_of(shapes.plane.KIND, row, np.zeros(0), 0, 0.0, 0.0, 1.0) == math.inf
    assert math.isnan(shapes.support_of(len(shapes.KINDS), np.zeros((1, nk.GEOM_WIDTH)),
                                        np.zeros(0), 0, 0.0, 0.0, 1.0))


def _touching(low: str, high: str):
    """A shape of kind ``low`` at the origin and one of kind ``high`` overlapping it by 1 cm
    along z (a plane: its surface 1 cm into the first), with the world poses collide takes."""
    def upright(name):  # centred on its body's origin, its axes the body's
        return shapes.shape_from_dict({k: v for k, v in EXAMPLES[name].items()
                                       if k not in ('position', 'orientation')})
    a, b = upright(low), upright(high)
    if low == 'plane':  # (the cylinder's row: the plane is the lower kind) as below, swapped
        b_pose = shapes.world_pose(b, np.zeros(3), np.eye(3))
        down = _reach(b, b_pose[1], -Z_UP)
        return a, shapes.world_pose(a, (0.0, 0.0, 0.5 - down + 0.01), np.eye(3)), b, b_pose
    pose_a = shapes.world_pose(a, np.zeros(3), np.eye(3))
    down = _reach(a, pose_a[1], -Z_UP)
    if high == 'plane':
        return a, pose_a, b, shapes.world_pose(b, (0.0, 0.0, 0.5 - down + 0.01), np.eye(3))
    up = _reach(b, b.rotation, -Z_UP)
    return a, pose_a, b, shapes.world_pose(b, (0.0, 0.0, _reach(a, pose_a[1], Z_UP) + up
                                               - 0.01), np.eye(3))


def test_every_row_of_the_pair_table_is_reached_in_both_orders():
    """Each row's test gives the contacts of its pair whichever shape comes first: the same
    points, depths and features, the normals negated (bit for bit when the kinds differ: the
    pair is then computed swapped); a set of tests without the row's bit
    reaches none (-1), and a pair with no row is refused."""
    dispatch = getattr(nk._pair_dispatch, 'py_func', nk._pair_dispatch)
    assert nk.PAIR_KINDS == tuple((low, high) for low, high, _ in nk.PAIR_TESTS)
    assert len(set(nk.PAIR_KINDS)) == len(nk.PAIR_TESTS)
    for i, (low, high, _) in enumerate(nk.PAIR_TESTS):
        a, pose_a, b, pose_b = _touching(shapes.NAMES[low], shapes.NAMES[high])
        forward = nph.collide(a, pose_a, b, pose_b)
        backward = nph.collide(b, pose_b, a, pose_a)
        what = f'{a.kind}-{b.kind}'
        assert forward and len(forward) == len(backward), what
        if low == high:  # computed as given, each way: the same contacts, maybe reordered,
            # their features named from the other side
            def key(c):
                return tuple(c.point)
            forward, backward = sorted(forward, key=key), sorted(backward, key=key)
        # (a curved pair's normal is Newton's, each way, to within a few roundings)
        close = 1e-14 if shapes.CURVED[low] else 1e-15
        for f, g in zip(forward, backward):
            assert f.depth == pytest.approx(g.depth, abs=close) and f.depth > 0.0, what
            assert low == high or (f.depth == g.depth and f.feature == g.feature), what
            np.testing.assert_allclose(f.point, g.point, rtol=0, atol=close)
            np.testing.assert_allclose(f.normal, -g.normal, rtol=0, atol=close)
        pool = shapes.Pool()
        arrays_a = nph.shape_arrays(a, *pose_a, pool)
        arrays_b = nph.shape_arrays(b, *pose_b, pool)
        pool = pool.array()
        out = (np.empty((nk.MAX_CONTACTS_PER_PAIR, 3)), np.empty((nk.MAX_CONTACTS_PER_PAIR, 3)),
               np.empty(nk.MAX_CONTACTS_PER_PAIR), np.empty(nk.MAX_CONTACTS_PER_PAIR, np.int64))
        for tests, found in ((nk.PAIR_BIT[(low, high)], len(forward)),
                             (nk.PAIRS_ALL & ~nk.PAIR_BIT[(low, high)], -1)):
            assert dispatch(low, high, tests, False, *arrays_a[1:], *arrays_b[1:], pool, 0.0, *out,
                            0) == found, what
    plane = shapes.shape_from_dict(EXAMPLES['plane'])
    at = shapes.world_pose(plane, np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match='no contact test'):
        nph.collide(plane, at, plane, at)


def test_the_dispatch_is_written_from_the_table():
    """One branch for each row, in the table's order, and nothing else."""
    source = nk._dispatch_source()
    branches = re.findall(r'if low == (\d+) and high == (\d+):\n\s+return (_gated_\d+)\(',
                          source)
    assert [(int(a), int(b)) for a, b, _ in branches] == list(nk.PAIR_KINDS)
    assert [g for _, _, g in branches] == [f'_gated_{i}' for i in range(len(nk.PAIR_TESTS))]
    assert source.count('if ') == len(nk.PAIR_TESTS)


def test_plane_candidates_read_each_kind_by_its_support():
    """The broad phase's plane test keeps a collider exactly when its support towards the
    plane reaches it (within its body's margin), for every kind the table has."""
    rng = np.random.default_rng(3)
    solids = [shapes.shape_from_dict(EXAMPLES[n]) for n in SOLIDS]
    for _ in range(30):
        rotation = so3.exp(rng.normal(size=3))
        kinds = np.array([shapes.kind_of(s) for s in solids])
        pool = shapes.Pool()
        geoms = np.array([shapes.packed(s, rotation, pool) for s in solids])
        reach = np.array([_reach(s, rotation, -Z_UP) for s in solids])
        n = len(solids)
        heights = reach + rng.choice([-1e-3, 1e-3], size=n)
        centres = np.zeros((n, 3))
        centres[:, 2] = heights
        pairs = broad_phase.plane_candidates(
            np.arange(n), np.zeros(n, dtype=np.int64), np.tile(rotation.reshape(9), (n, 1)),
            kinds, geoms, pool.array(), centres, Z_UP.reshape(1, 3), np.zeros((1, 3)), np.zeros(1))
        assert pairs[:, 0].tolist() == np.flatnonzero(heights < reach).tolist()


BY_NAME = re.compile(r'\.kind\s*(==|!=|in)\s*[(\[\'"]')        # shape.kind == 'box'
BY_TYPE = re.compile(r'isinstance\([^)]*,\s*\(?(Sphere|Capsule|Box)\b')  # isinstance(s, Box)


def test_no_module_outside_the_kinds_tells_kinds_apart_by_name():
    """The package reads a kind through its module (shapes.BY_NAME, KIND, STATIC_ONLY, and
    its drawing pieces), so that a new kind is a module and rows: no ``.kind == 'box'``
    elsewhere, nor in the drawings (RViz markers, pictures), which draw pieces of
    ``base.PRIMITIVES``. (The plane alone is met by type: the world keeps half-spaces apart
    from the colliders that have bounds.)"""
    found = []
    for layer in ('contact', 'sim', 'ros', 'pictures', 'offline', 'recording'):
        for path in sorted((PACKAGE / layer).rglob('*.py')):
            if 'shapes' in path.relative_to(PACKAGE).parts:
                continue
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if re.search(BY_NAME, line) or re.search(BY_TYPE, line):
                    found.append(f'{path.relative_to(PACKAGE)}:{n}: {line.strip()}')
    assert found == []


def test_every_kind_draws_with_pieces_that_cover_it_exactly():
    """A kind's ``draw`` gives pieces of the primitives every drawing knows, and they are
    the shape: a solid's farthest piece point from its centre is its bounding radius (the
    shape's own reach, from its sizes), along its own axes; a plane's piece is its plane."""
    reach = {'sphere': lambda size: size[0],
             'box': lambda size: math.sqrt(sum(h * h for h in size)),
             'capsule': lambda size: size[0] + size[1],
             'cylinder': lambda size: math.hypot(size[0], size[1]),
             'mesh': lambda size: float(np.sqrt((size[0] ** 2).sum(axis=1)).max())}
    for module in shapes.KINDS:
        shape = shapes.shape_from_dict(EXAMPLES[module.NAME])
        pieces = shapes.pieces(shape)
        assert pieces and all(p[0] in base.PRIMITIVES for p in pieces), module.NAME
        for primitive, size, position, rotation in pieces:
            assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
            if primitive == 'plane':
                # z along the normal, through the point nearest the body origin
                assert np.allclose(rotation[:, 2], shape.normal, atol=1e-12)
                assert np.allclose(position, np.array(shape.normal) * shape.offset)
                continue
            assert reach[primitive](size) == pytest.approx(shape.bounding_radius, rel=1e-12)
            assert np.array_equal(position, shape.position)
            assert np.array_equal(rotation, shape.rotation)
