# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scenes from MJCF files, against MuJoCo's own compiler and simulator: the masses, centres
and inertias it computes, a welded body's against the same geoms in one body, a drop that
lands where MuJoCo's lands; every refusal one line naming the file and the element."""

import os

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, Sphere
from rb_sim_ros.contact.shapes import Ellipsoid
from rb_sim_ros.core import so3
from rb_sim_ros.sim import scene as scenes
from rb_sim_ros.sim.mjcf import ModelError, ros_name, WORLD_BODY
from rb_sim_ros.sim.scene import load_scene, SceneError
from rb_sim_ros.sim.simulation import Config, Simulation
from support import entity_bomb

mujoco = pytest.importorskip('mujoco')  # (PyPI only: package.xml names no key for it)


def load_mjcf(path, max_bytes=scenes.MAX_BYTES):
    """The Scene of an MJCF file, as load_scene reads it, with a bound of our choosing."""
    from rb_sim_ros.sim import mjcf
    gravity, bodies = mjcf.load_mjcf(path, max_bytes, scenes.MAX_BODIES)
    return scenes.Scene(gravity, bodies, scenes.ContactSettings())


def _write(tmp_path, text, name='model.xml'):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _mjcf(world, gravity='0 0 -9.81'):
    return (f'<mujoco><option gravity="{gravity}"/><worldbody>{world}</worldbody>'
            '</mujoco>')


FREE = _mjcf(
    '<geom name="floor" type="plane" size="5 5 .1" friction="0.7"/>'
    '<body name="crate-1" pos="0.3 -0.2 1.0" quat="0.9 0.1 0.3 0.2"><freejoint/>'
    '  <geom type="box" size="0.2 0.15 0.1" pos="0.05 0 0" density="700"/></body>'
    '<body name="ball" pos="-1 0 2"><freejoint/>'
    '  <geom type="sphere" size="0.1" mass="2.5"/>'
    '  <geom type="capsule" size="0.03 0.2" pos="0 0 0.2" quat="1 1 0 0" mass="0.4"/></body>'
    '<body name="post" pos="2 0 0.5"><geom type="box" size="0.1 0.1 0.5"/></body>')


def _mujoco_inertia(model, body):
    """MuJoCo's body: mass, centre of mass (world) and inertia tensor (world axes)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rot = data.ximat[body].reshape(3, 3)
    return (float(model.body_mass[body]), data.xipos[body].copy(),
            rot @ np.diag(model.body_inertia[body]) @ rot.T)


def _ours(spec):
    """Our body: mass, centre of mass (world) and inertia tensor (world axes)."""
    rot = so3.matrix_from_quaternion_xyzw(spec.initial_orientation_xyzw)
    inertia = np.array(spec.inertia).reshape(3, 3)
    return spec.mass, np.array(spec.initial_position), rot @ inertia @ rot.T


def test_free_bodies_have_mujocos_masses_centres_and_inertias(tmp_path):
    scene = load_mjcf(_write(tmp_path, FREE))
    model = mujoco.MjModel.from_xml_string(FREE)
    by_name = {b.name: b for b in scene.bodies}
    assert sorted(by_name) == sorted(['ball', 'crate_1', 'post', WORLD_BODY])
    assert scene.gravity == (0.0, 0.0, -9.81)
    for ours, theirs in (('crate_1', 'crate-1'), ('ball', 'ball')):
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, theirs)
        mass, centre, inertia = _mujoco_inertia(model, body)
        m, c, i = _ours(by_name[ours])
        assert m == pytest.approx(mass, rel=1e-12)
        np.testing.assert_allclose(c, centre, rtol=0, atol=1e-12)
        np.testing.assert_allclose(i, inertia, rtol=0, atol=1e-9 * np.abs(inertia).max())
    assert by_name['post'].static and by_name[WORLD_BODY].static
    floor, = by_name[WORLD_BODY].colliders
    assert isinstance(floor, Plane) and floor.normal == (0.0, 0.0, 1.0) and floor.offset == 0.0
    assert floor.friction == 0.7
    crate, = by_name['crate_1'].colliders
    assert isinstance(crate, Box) and crate.size == pytest.approx((0.4, 0.3, 0.2))
    # the box's centre is the body's centre of mass: it has all the mass
    np.testing.assert_allclose(crate.position, (0.0, 0.0, 0.0), atol=1e-15)
    kinds = sorted(type(c).__name__ for c in by_name['ball'].colliders)
    assert kinds == ['Capsule', 'Sphere']
    capsule = next(c for c in by_name['ball'].colliders if isinstance(c, Capsule))
    assert capsule.radius == 0.03 and capsule.length == pytest.approx(0.4)


def test_a_welded_body_is_the_same_geoms_in_one_body(tmp_path):
    """A free body with two nested bodies without joints (welded, one turned) against MuJoCo
    computing the one body that holds the same geoms: the parallel-axis theorem's sum."""
    nested = _mjcf(
        '<body name="drone" pos="0 0 1" quat="0.96 0 0.28 0"><freejoint/>'
        '  <geom type="box" size="0.1 0.1 0.02" mass="1.0"/>'
        '  <body name="arm" pos="0.3 0 0" quat="0.7071068 0 0 0.7071068">'
        '    <geom type="capsule" size="0.01 0.1" pos="0 0.05 0" mass="0.2"/>'
        '    <body name="rotor" pos="0 0.2 0.05"><geom type="sphere" size="0.05" mass="0.1"/>'
        '    </body></body></body>')
    # the same geoms placed in the drone's frame by hand: (0.3, 0, 0) + Rz(90) (0, 0.05, 0)
    # = (0.25, 0, 0), the capsule's axis turned by Rz(90); the rotor at (0.3 - 0.2, 0, 0.05)
    flat = _mjcf(
        '<body name="drone" pos="0 0 1" quat="0.96 0 0.28 0"><freejoint/>'
        '  <geom type="box" size="0.1 0.1 0.02" mass="1.0"/>'
        '  <geom type="capsule" size="0.01 0.1" pos="0.25 0 0" quat="0.7071068 0 0 0.7071068"'
        '   mass="0.2"/>'
        '  <geom type="sphere" size="0.05" pos="0.1 0 0.05" mass="0.1"/></body>')
    drone, = load_mjcf(_write(tmp_path, nested)).bodies
    model = mujoco.MjModel.from_xml_string(flat)
    mass, centre, inertia = _mujoco_inertia(model, 1)
    m, c, i = _ours(drone)
    assert m == pytest.approx(1.3, rel=1e-12) and m == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(c, centre, atol=1e-6)  # (the quaternion's 7 digits)
    np.testing.assert_allclose(i, inertia, atol=1e-6 * np.abs(inertia).max())
    assert len(drone.colliders) == 3
    # and the welded one loaded by MuJoCo has the same total (its subtree mass)
    welded = mujoco.MjModel.from_xml_string(nested)
    assert float(welded.body_subtreemass[1]) == pytest.approx(m, rel=1e-12)


@pytest.mark.parametrize('geom, rest, near', [('type="box" size="0.2 0.2 0.1"', 0.1, 5e-3),
                                              ('type="cylinder" size="0.2 0.1"', 0.1, 1e-2)])
def test_a_dropped_body_lands_where_mujocos_lands(tmp_path, geom, rest, near):
    """A box (a cylinder) dropped on the floor, turned about x by 20 degrees: it falls, tips
    onto a face (its cap) and rests; MuJoCo's lands it flat at the same place, within its
    soft contact's sinking and the two frictions (``near``: the cylinder rolls on its rim as
    it tips, a point contact whose friction the two models bound differently; measured 5.3
    mm apart, the box 1 mm)."""
    text = _mjcf(
        '<geom type="plane" size="5 5 .1"/>'
        '<body name="box" pos="0 0 0.6" quat="0.9848078 0.1736482 0 0"><freejoint/>'
        f'  <geom {geom} mass="1"/></body>')
    scene = load_scene(_write(tmp_path, text))
    sim = Simulation(Config(dt=1e-3, gravity=scene.gravity, bodies=scene.bodies))
    sim.run(3000)
    position, quat, linear, _ = sim.pose_twist('box')
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 3000)
    assert np.linalg.norm(linear) < 1e-3 and np.linalg.norm(data.qvel[:3]) < 1e-2
    np.testing.assert_allclose(position, data.xipos[1], atol=near)
    ours_up = so3.matrix_from_quaternion_xyzw(quat)[:, 2]
    theirs_up = data.ximat[1].reshape(3, 3)[:, 2]
    assert abs(abs(ours_up @ theirs_up) - 1.0) < 1e-4  # the same face down
    assert position[2] == pytest.approx(rest, abs=1e-3)


@pytest.mark.parametrize('world, match', [
    ('<body name="arm"><joint name="elbow" type="hinge"/><geom size="0.1"/></body>',
     "body 'arm': joint 'elbow' is a hinge joint: only free joints"),
    ('<body name="slab" pos="0 0 1"><freejoint/><geom type="box" size="1 1 1" mass="1"/>'
     '<geom name="ground" type="plane" size="1 1 1"/></body>',
     'plane only allowed in static bodies'),  # (MuJoCo's compiler says it first)
    ('<body name="ghost"><freejoint/><geom size="0.1" contype="0" conaffinity="0" '
     'mass="0"/><inertial pos="0 0 0" mass="0" diaginertia="0 0 0"/></body>',
     "MuJoCo cannot compile it|body 'ghost': has no mass"),
    ('<body name="x"><freejoint/><geom size="0.1" bogus="1"/></body>',
     "MuJoCo cannot compile it: .*unrecognized attribute: 'bogus'"),
])
def test_what_cannot_be_one_rigid_body_is_refused_in_one_line(tmp_path, world, match):
    path = _write(tmp_path, _mjcf(world))
    with pytest.raises(SceneError, match=match) as e:
        load_scene(path)
    assert '\n' not in str(e.value) and str(e.value).startswith(path)


def test_an_ellipsoid_geom_is_an_ellipsoid_collider_where_mujoco_puts_it(tmp_path):
    """Its semi-axes MuJoCo's size, its friction, and its place and turn in the body MuJoCo's
    (read from the compiled model)."""
    text = _mjcf('<body name="egg" pos="0 0 1" quat="0.9 0.1 0.3 0.2"><freejoint/>'
                 '<geom name="shell" type="ellipsoid" size="0.1 0.2 0.3" pos="0.1 0 0" '
                 'euler="0.3 0 0" friction="0.7"/></body>')
    (egg,) = load_scene(_write(tmp_path, text)).bodies
    (shell,) = egg.colliders
    assert isinstance(shell, Ellipsoid) and shell.radii == (0.1, 0.2, 0.3)
    assert shell.friction == pytest.approx(0.7)
    model = mujoco.MjModel.from_xml_string(text)
    # where MuJoCo puts it in its body, in our body's frame (the centre of mass, the body's
    # axes: the geom is all the body, so its centre is the geom's)
    np.testing.assert_allclose(shell.position, model.geom_pos[0] - model.body_ipos[1],
                               atol=1e-12)
    ours = so3.matrix_from_quaternion_xyzw(shell.orientation_xyzw)
    theirs = np.zeros(9)
    mujoco.mju_quat2Mat(theirs, model.geom_quat[0])
    np.testing.assert_allclose(ours, theirs.reshape(3, 3), atol=1e-12)


def test_files_outside_the_models_folder_are_never_read(tmp_path):
    inside = tmp_path / 'model'
    (inside / 'sub').mkdir(parents=True)
    (tmp_path / 'secret.xml').write_text(
        '<mujoco><worldbody><body name="evil"><freejoint/><geom size="0.1"/></body>'
        '</worldbody></mujoco>')
    part = ('<mujoco><worldbody><body name="NAME"><freejoint/><geom size="0.1"/></body>'
            '</worldbody></mujoco>')
    (inside / 'part.xml').write_text(part.replace('NAME', 'b'))
    # an include in the folder is followed and loaded
    ok = _write(inside, '<mujoco><include file="part.xml"/></mujoco>')
    assert [b.name for b in load_mjcf(ok).bodies] == ['b']
    # MuJoCo reads an include in an included file from the model's folder, not the
    # including file's: so is it checked (a link there to the outside is refused), and a
    # model written that way loads
    (inside / 'sub' / 'inc.xml').write_text('<mujoco><include file="x.xml"/></mujoco>')
    (inside / 'sub' / 'x.xml').write_text(part.replace('NAME', 'harmless'))
    os.symlink(tmp_path / 'secret.xml', inside / 'x.xml')
    with pytest.raises(ModelError, match='outside the folder of the model'):
        load_mjcf(_write(inside, '<mujoco><include file="sub/inc.xml"/></mujoco>', 'bad.xml'))
    (inside / 'sub' / 'inc2.xml').write_text('<mujoco><include file="sub/y.xml"/></mujoco>')
    (inside / 'sub' / 'y.xml').write_text(part.replace('NAME', 'y'))
    both = _write(inside, '<mujoco><include file="part.xml"/><include file="sub/inc2.xml"/>'
                          '</mujoco>', 'both.xml')
    assert [b.name for b in load_mjcf(both).bodies] == ['b', 'y']
    for text, why in (
            ('<mujoco><include file="../secret.xml"/></mujoco>', 'outside the folder'),
            ('<mujoco><include file="link.xml"/></mujoco>', 'outside the folder'),
            ('<mujoco><asset><mesh name="m" file="/etc/passwd"/></asset></mujoco>',
             'outside the folders'),
            ('<mujoco><compiler meshdir="../up"/><asset><mesh name="m" file="a.stl"/>'
             '</asset></mujoco>', 'a folder of the model'),
            ('<mujoco><asset><texture name="t" type="2d" file="part.xml"/></asset>'
             '<compiler texturedir="sub"/></mujoco>', 'no file but an include or a mesh is read'),
            ('<mujoco><asset><texture name="t" type="cube" fileright="/etc/passwd"/>'
             '</asset></mujoco>', 'no file but an include or a mesh is read'),
            ('<mujoco><asset><texture name="t" type="2d" builtin="checker" width="8000" '
             'height="8000"/></asset></mujoco>', 'MAX_TEXTURE_PIXELS'),
            ('<mujoco><worldbody><replicate count="1000"><body><freejoint/><geom size="1"/>'
             '</body></replicate></worldbody></mujoco>', '<replicate> is not read here')):
        if not (inside / 'link.xml').exists():
            os.symlink(tmp_path / 'secret.xml', inside / 'link.xml')
        with pytest.raises(ModelError, match=why):
            load_mjcf(_write(inside, text, 'bad.xml'))
    # a model reached through a link is read from its own folder, with its includes there
    real = tmp_path / 'real'
    real.mkdir()
    (real / 'inc.xml').write_text(part.replace('NAME', 'own'))
    (real / 'model.xml').write_text('<mujoco><include file="inc.xml"/></mujoco>')
    share = tmp_path / 'share'
    share.mkdir()
    os.symlink(real / 'model.xml', share / 'model.xml')
    os.symlink(tmp_path / 'secret.xml', share / 'inc.xml')
    assert [b.name for b in load_mjcf(str(share / 'model.xml')).bodies] == ['own']


def test_a_model_sent_as_text_names_no_file_and_cannot_blow_up():
    from rb_sim_ros.sim import mjcf
    for text, why in (
            ('<mujoco><include file="x.xml"/></mujoco>', 'may name no file'),
            ('<mujoco><asset><texture name="t" type="cube" fileright="/dev/zero"/></asset>'
             '</mujoco>', 'no file but an include or a mesh is read'),
            ('<mujoco><asset><texture name="t" type="cube" builtin="flat" width="1000" '
             'height="1000"/></asset></mujoco>', 'MAX_TEXTURE_PIXELS'),
            ('<mujoco><worldbody><replicate count="99"><replicate count="99"><body><freejoint/>'
             '<geom size="1"/></body></replicate></replicate></worldbody></mujoco>',
             '<replicate> is not read here')):
        with pytest.raises(ModelError, match=why):
            mjcf.bodies_from_text(text, 'resource_string', 10)


def test_a_pipe_is_never_opened(tmp_path):
    """A named pipe would block the reader for ever: refused before it is opened."""
    os.mkfifo(tmp_path / 'pipe.xml')
    with pytest.raises(ModelError, match='not a regular file'):
        load_mjcf(_write(tmp_path, '<mujoco><include file="pipe.xml"/></mujoco>'))
    with pytest.raises(SceneError, match='not a regular file'):
        load_scene(str(tmp_path / 'pipe.xml'))


def test_missing_huge_and_malformed_files_are_refused(tmp_path):
    with pytest.raises(SceneError, match='cannot read'):
        load_scene(str(tmp_path / 'none.xml'))
    with pytest.raises(ModelError, match='more than 1000 bytes'):
        load_mjcf(_write(tmp_path, _mjcf('<geom size="1"/>' * 100)), max_bytes=1000)
    with pytest.raises(SceneError, match='is not XML'):
        load_scene(_write(tmp_path, '<mujoco><worldbody>'))
    # entities are not expanded into a billion laughs (expat refuses the amplification)
    with pytest.raises(SceneError, match='is not XML'):
        load_scene(_write(tmp_path, entity_bomb('mujoco')))


def test_names_become_ros_names():
    assert ros_name('crate-1', 3) == 'crate_1'
    assert ros_name('1st', 3) == 'b_1st'
    assert ros_name('', 7) == 'body7'
    assert ros_name('ünï', 2) == 'b__n_'
    assert len(ros_name('x' * 100, 1)) == 64


def test_repeated_and_unnamed_bodies_get_names_of_their_own(tmp_path):
    text = _mjcf('<body pos="0 0 1"><freejoint/><geom size="0.1"/></body>'
                 '<body name="a.b" pos="1 0 1"><freejoint/><geom size="0.1"/></body>'
                 '<body name="a_b" pos="2 0 1"><freejoint/><geom size="0.1"/></body>'
                 '<body name="a_b_2" pos="3 0 1"><freejoint/><geom size="0.1"/></body>'
                 f'<body name="{"x" * 70}" pos="4 0 1"><freejoint/><geom size="0.1"/></body>'
                 f'<body name="{"x" * 69}" pos="5 0 1"><freejoint/><geom size="0.1"/></body>')
    names = [b.name for b in load_mjcf(_write(tmp_path, text)).bodies]
    assert names == ['body1', 'a_b', 'a_b_2', 'a_b_2_2', 'x' * 64, 'x' * 62 + '_2']
    assert all(isinstance(c, Sphere) for b in load_mjcf(_write(tmp_path, text)).bodies
               for c in b.colliders)


def test_a_mesh_body_has_mujocos_mass_and_lands_where_mujocos_lands(tmp_path):
    """A wedge given as an inline mesh (its vertices): our body takes MuJoCo's mass, centre
    and inertia (its compiler's, from the mesh), its collider is the hull of the vertices
    where MuJoCo puts the geom; dropped turned onto the floor it rests on the same face, at
    the same place, as MuJoCo's (which collides meshes as their hulls too)."""
    wedge = '0 0 0  0.4 0 0  0 0.3 0  0.4 0.3 0  0 0 0.2  0 0.3 0.2'
    text = ('<mujoco><option gravity="0 0 -9.81"/><asset>'
            f'<mesh name="wedge" vertex="{wedge}"/></asset><worldbody>'
            '<geom type="plane" size="5 5 .1"/>'
            '<body name="wedge" pos="0 0 0.6" quat="0.9848078 0.1736482 0 0"><freejoint/>'
            '  <geom type="mesh" mesh="wedge" density="500"/></body></worldbody></mujoco>')
    scene = load_scene(_write(tmp_path, text))
    body = next(b for b in scene.bodies if b.name == 'wedge')
    model = mujoco.MjModel.from_xml_string(text)
    mass, centre, inertia = _mujoco_inertia(model, 1)
    m, c, i = _ours(body)
    assert m == pytest.approx(500.0 * 0.4 * 0.3 * 0.2 / 2, rel=1e-6)  # (float32 vertices)
    assert m == pytest.approx(mass, rel=1e-9)
    np.testing.assert_allclose(c, centre, atol=1e-9)
    np.testing.assert_allclose(i, inertia, atol=1e-9 * np.abs(inertia).max())
    (hull,) = body.colliders
    assert len(hull.points) == 6 and len(hull.faces) == 5
    sim = Simulation(Config(dt=1e-3, gravity=scene.gravity, bodies=scene.bodies))
    sim.run(3000)
    position, quat, linear, _ = sim.pose_twist('wedge')
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 3000)
    assert np.linalg.norm(linear) < 1e-3 and np.linalg.norm(data.qvel[:3]) < 1e-2
    # 12 mm apart along y (where it slides as it tips over its landing edge): both converged
    # in the step (ours 158.4 / 158.6 mm at dt = 1, 0.25 ms; MuJoCo's 146.3 / 145.9 at 2,
    # 0.1 ms), so the models' impacts differ (MuJoCo's soft contact acts over its 20 ms time
    # constant), not their errors
    np.testing.assert_allclose(position, data.xipos[1], atol=1.5e-2)
    # the same face down: the heights of the corners, each model's own placing of them
    turn = so3.matrix_from_quaternion_xyzw(quat)
    ours = position + (np.array(hull.position) + hull.vertices @ hull.rotation.T) @ turn.T
    g = int(np.flatnonzero(model.geom_bodyid == 1)[0])
    mesh = np.array(model.mesh_vert[:model.mesh_vertnum[0]], dtype=float)
    theirs = data.geom_xpos[g] + mesh @ data.geom_xmat[g].reshape(3, 3).T
    np.testing.assert_allclose(np.sort(ours[:, 2]), np.sort(theirs[:, 2]), atol=2e-3)


def test_a_mesh_file_in_the_models_folder_is_a_hull_where_mujoco_puts_it(tmp_path):
    """A mesh geom read from an STL under the model's meshdir: a hull of MuJoCo's vertices
    (its 8 corners, about MuJoCo's centre of the mesh), the body MuJoCo's mass; the same
    file through a link out of the folder is refused."""
    trimesh = pytest.importorskip('trimesh')
    (tmp_path / 'assets').mkdir()
    trimesh.creation.box(extents=(0.4, 0.2, 0.1)).export(tmp_path / 'assets' / 'slab.stl')
    text = ('<mujoco><compiler meshdir="assets"/><asset><mesh name="slab" file="slab.stl"/>'
            '</asset><worldbody><body name="slab" pos="0 0 1"><freejoint/>'
            '<geom type="mesh" mesh="slab" density="300"/></body></worldbody></mujoco>')
    path = _write(tmp_path, text)
    (slab,) = load_mjcf(path).bodies
    model = mujoco.MjModel.from_xml_path(path)
    assert slab.mass == pytest.approx(float(model.body_mass[1]), rel=1e-12)
    assert slab.mass == pytest.approx(300.0 * 0.4 * 0.2 * 0.1, rel=1e-6)
    (hull,) = slab.colliders
    assert len(hull.points) == 8 and len(hull.faces) == 6
    half = np.sort(np.abs(hull.vertices @ np.array(hull.rotation).T).max(axis=0))
    np.testing.assert_allclose(half, [0.05, 0.1, 0.2], atol=1e-6)
    outside = tmp_path / 'elsewhere'
    outside.mkdir()
    (tmp_path / 'assets' / 'slab.stl').rename(outside / 'slab.stl')
    (tmp_path / 'assets' / 'slab.stl').symlink_to(outside / 'slab.stl')
    with pytest.raises(SceneError, match='slab.stl.*outside the folders'):
        load_scene(_write(tmp_path / 'assets', text.replace('meshdir="assets"', ''),
                          'm.xml'))
