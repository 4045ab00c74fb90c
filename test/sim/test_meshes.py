# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Mesh files in scene files (sim/meshes.py): a body of ``shape: mesh`` takes the mass
properties of its file's solid (the closed forms, the parallel-axis theorem over its parts),
its colliders are the hulls of the parts, and a bad or out-of-bounds file is refused with the
reason, changing nothing."""

import math
import os

import numpy as np
import pytest
import trimesh

from rb_sim_ros.contact.collision_shapes import Hull
from rb_sim_ros.sim import meshes
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import body_entry, load_scene, SceneError
from rb_sim_ros.sim.simulation import ContactSettings

SIZE = (0.4, 0.3, 0.2)
# An STL holds float32 vertices: 1.2e-7 of a coordinate of 3 m is 6e-7 of an edge of 0.2 m.
FILE = 5e-6


def _box_mesh(size=SIZE, at=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=size)
    mesh.apply_translation(at)
    return mesh


def _scene(folder, body: str, name: str = 'scene.yaml') -> str:
    path = folder / name
    path.write_text('gravity: [0, 0, -9.81]\nbodies:\n' + body
                    + '  - {name: ground, static: true, colliders: [{type: plane}]}\n')
    return str(path)


def test_a_mesh_body_has_its_solids_mass_and_its_hull_as_collider(tmp_path):
    """A box mesh away from its file's origin: mass rho abc, inertia the box's about its
    centre of mass (the body's origin), one hull collider of its 8 corners about it; dropped,
    it rests on a face at its half height."""
    (tmp_path / 'meshes').mkdir()
    _box_mesh(at=(1.0, 2.0, 3.0)).export(tmp_path / 'meshes' / 'crate.stl')
    path = _scene(tmp_path, '  - {name: crate, shape: mesh, file: meshes/crate.stl, '
                            'density: 500, position: [0, 0, 0.3], colliders: shape}\n')
    crate = load_scene(path).bodies[0]
    a, b, c = SIZE
    m = 500.0 * a * b * c
    assert crate.mass == pytest.approx(m, rel=FILE)
    expected = np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12
    np.testing.assert_allclose(np.reshape(crate.inertia, (3, 3)), expected, rtol=2 * FILE,
                               atol=1e-12)
    (hull,) = crate.colliders
    assert isinstance(hull, Hull) and len(hull.points) == 8
    np.testing.assert_allclose(np.abs(hull.vertices), np.tile(SIZE, (8, 1)) / 2, atol=1e-6)
    world = collision_world(load_scene(path).bodies, 1e-3, (0.0, 0.0, -9.81),
                            contact=ContactSettings(friction=0.8))
    world.step(1000)
    assert world.state('crate').position[2] == pytest.approx(c / 2, abs=2e-4)


def test_the_parts_of_a_file_are_hulls_and_their_masses_add_by_parallel_axes(tmp_path):
    """A file of two disjoint boxes: two hull colliders; the body's mass, centre and inertia
    are the union's (trimesh's integrals over the whole surface); as a collider list entry
    ({type: mesh}) the same two hulls, placed as the entry says."""
    parts = trimesh.util.concatenate([_box_mesh((0.2, 0.2, 0.2), (-0.3, 0.0, 0.0)),
                                      _box_mesh((0.1, 0.4, 0.1), (0.25, 0.1, 0.05))])
    parts.export(tmp_path / 'parts.obj')
    path = _scene(tmp_path, '  - {name: toy, shape: mesh, file: parts.obj, density: 800, '
                            'colliders: shape}\n  - {name: rig, mass: 1, inertia: [1, 1, 1], '
                            'colliders: [{type: mesh, file: parts.obj, position: [0, 0, 1], '
                            'friction: 0.3}]}\n')
    toy, rig = load_scene(path).bodies[:2]
    parts.density = 800.0
    assert toy.mass == pytest.approx(parts.mass, rel=FILE)
    np.testing.assert_allclose(np.reshape(toy.inertia, (3, 3)), parts.moment_inertia,
                               rtol=2 * FILE, atol=1e-9)
    assert len(toy.colliders) == 2 and all(isinstance(h, Hull) for h in toy.colliders)
    # each hull is placed about the union's centre of mass
    lows = sorted(h.vertices.min(axis=0)[0] for h in toy.colliders)
    assert lows[0] == pytest.approx(-0.4 - parts.center_mass[0], abs=1e-6)
    assert len(rig.colliders) == 2
    assert all(h.position == (0.0, 0.0, 1.0) and h.friction == 0.3 for h in rig.colliders)


def _refused(tmp_path, body: str, reason: str) -> None:
    path = _scene(tmp_path, body)
    with pytest.raises(SceneError, match=reason):
        load_scene(path)


def test_bad_mesh_files_are_refused_with_the_reason(tmp_path, monkeypatch):
    folder = tmp_path / 'site'
    folder.mkdir()
    _box_mesh().export(tmp_path / 'outside.stl')
    _box_mesh().export(folder / 'box.stl')
    entry = '  - {{name: b, shape: mesh, file: {}, density: 500, colliders: shape}}\n'
    _refused(folder, entry.format('missing.stl'), 'missing.stl: no such file')
    _refused(folder, entry.format('../outside.stl'), 'outside the folders')
    _refused(folder, entry.format(str(tmp_path / 'outside.stl')), 'outside the folders')
    (folder / 'model.dae').write_text('<COLLADA/>')
    _refused(folder, entry.format('model.dae'), 'not a mesh format read here')
    (folder / 'nan.obj').write_text('v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 nan\nf 1 2 3\nf 1 2 4\n'
                                    'f 1 3 4\nf 2 3 4\n')
    _refused(folder, entry.format('nan.obj'), 'not finite')
    (folder / 'flat.obj').write_text('v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n')
    _refused(folder, entry.format('flat.obj'), 'no volume')
    (folder / 'junk.stl').write_bytes(os.urandom(300))
    _refused(folder, entry.format('junk.stl'), 'junk.stl')
    monkeypatch.setattr(meshes, 'MAX_VERTICES', 7)
    _refused(folder, entry.format('box.stl'), 'more than MAX_VERTICES = 7')
    monkeypatch.undo()
    _refused(folder, '  - {name: b, shape: mesh, file: box.stl, density: 500, scale: -1}\n',
             'scale must be finite and > 0')
    _refused(folder, '  - {name: b, shape: mesh, file: box.stl, mass: 2, density: 5}\n',
             'not both')
    _refused(folder, '  - {name: b, mass: 1, inertia: [1, 1, 1], file: box.stl}\n',
             'only with a shape')
    _refused(folder, '  - {name: b, mass: 1, inertia: [1, 1, 1], colliders: [{type: mesh, '
                     'file: box.stl, size: 2}]}\n', 'unknown keys')
    with pytest.raises(SceneError, match='relative to a scene file'):
        body_entry('{name: b, shape: mesh, file: box.stl, density: 5}', 'spawn')
    # the good file loads: nothing above was left half-done
    assert load_scene(_scene(folder, entry.format('box.stl'))).bodies[0].mass == \
        pytest.approx(500.0 * math.prod(SIZE), rel=FILE)


def _l_prism() -> trimesh.Trimesh:
    """An L-shaped slab 0.4 x 0.4 m, arms 0.1 m wide, 0.1 m thick (not convex)."""
    outline = np.array([[0, 0], [0.4, 0], [0.4, 0.1], [0.1, 0.1], [0.1, 0.4], [0, 0.4]])
    fan = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    return trimesh.creation.extrude_triangulation(outline, fan, 0.1)


def test_decompose_cuts_a_non_convex_mesh_into_hulls_a_ball_falls_between(tmp_path):
    """An L-shaped slab on the ground, static: as one hull it covers its inner corner, so a
    ball dropped over the corner rests on the hull's top (0.1 m up); with ``decompose: true``
    (coacd) its parts' hulls hold the L's volume (1%) and the ball falls past them to the
    ground, as onto the true L."""
    pytest.importorskip('coacd')
    _l_prism().export(tmp_path / 'ell.stl')
    heights = {}
    for decompose in ('false', 'true'):
        path = _scene(tmp_path, '  - {name: ell, static: true, colliders: [{type: mesh, '
                      f'file: ell.stl, decompose: {decompose}}}]}}\n'
                      '  - {name: ball, shape: sphere, radius: 0.03, density: 1000, '
                      'position: [0.25, 0.25, 0.3], colliders: shape}\n')
        ell = load_scene(path).bodies[0]
        volume = sum(h.mass_properties()[0] for h in ell.colliders)
        if decompose == 'true':
            assert len(ell.colliders) >= 2
            assert volume == pytest.approx(0.4 * 0.1 * 0.1 * 2 - 0.01 * 0.1, rel=0.01)
        else:
            assert len(ell.colliders) == 1
        world = collision_world(load_scene(path).bodies, 1e-3, (0.0, 0.0, -9.81),
                                contact=ContactSettings(friction=0.8))
        world.step(800)
        heights[decompose] = world.state('ball').position[2]
    assert heights['false'] > 0.1  # on the single hull's slanted top
    assert heights['true'] == pytest.approx(0.03, abs=2e-4)  # on the ground


def test_links_long_names_bad_indices_and_named_files_are_refused_or_not_read(tmp_path,
                                                                              monkeypatch):
    """A link out of the folder, a loop of links, a name too long, a face naming a vertex the
    file does not have: each refused in a line naming the file. An OBJ naming a material
    file: the mesh is read from its own bytes, and no other file is opened."""
    folder = tmp_path / 'site'
    folder.mkdir()
    _box_mesh().export(tmp_path / 'secret.stl')
    (folder / 'escape.stl').symlink_to(tmp_path / 'secret.stl')
    (folder / 'loop.stl').symlink_to(folder / 'loop.stl')
    entry = '  - {{name: b, shape: mesh, file: {}, density: 500, colliders: shape}}\n'
    _refused(folder, entry.format('escape.stl'), 'escape.stl: outside the folders')
    _refused(folder, entry.format('loop.stl'), 'loop.stl: cannot be read')
    _refused(folder, entry.format('x' * 4000 + '.stl'), r'x\.\.\.: cannot be read')
    with pytest.raises(meshes.MeshError, match='a string of 1 to 4096 characters'):
        meshes.mesh_parts('x' * 5000, [folder])
    (folder / 'bad.off').write_text('OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n'
                                    '3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 9\n')
    _refused(folder, entry.format('bad.off'), 'bad.off: ')
    import trimesh.resolvers
    opened = []
    for kind in (trimesh.resolvers.FilePathResolver, trimesh.resolvers.ZipResolver):
        monkeypatch.setattr(kind, 'get', lambda self, name: opened.append(name) or b'')
    (tmp_path / 'stolen.mtl').write_text('newmtl m\nmap_Kd ../../secret.png\n')
    cube = _box_mesh()
    lines = ['mtllib ../stolen.mtl', 'usemtl m'] + [f'v {x} {y} {z}' for x, y, z in cube.vertices]
    lines += [f'f {a + 1} {b + 1} {c + 1}' for a, b, c in cube.faces]
    (folder / 'dressed.obj').write_text('\n'.join(lines) + '\n')
    body = load_scene(_scene(folder, entry.format('dressed.obj'))).bodies[0]
    assert body.mass == pytest.approx(500.0 * math.prod(SIZE), rel=1e-12)
    assert opened == []
