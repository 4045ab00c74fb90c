# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scenes from URDF files, against MuJoCo's own URDF parser: the links of a fixed-jointed
robot placed where MuJoCo places them, their inertias summed by the parallel-axis theorem
(written out here), the collisions where MuJoCo puts its geoms; a floating joint splits the
robot into bodies; every refusal one line naming the file and the element."""

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Cylinder
from rb_sim_ros.core import so3
from rb_sim_ros.sim import scene as scenes
from rb_sim_ros.sim.mjcf import ModelError
from rb_sim_ros.sim.scene import load_scene, SceneError
from rb_sim_ros.sim.urdf import load_urdf
from support import entity_bomb

mujoco = pytest.importorskip('mujoco')  # (PyPI only: the oracle)

ROBOT = """<robot name="rover">
  <link name="base">
    <inertial><origin xyz="0.1 -0.05 0.02" rpy="0.2 -0.1 0.4"/><mass value="3.0"/>
      <inertia ixx="0.11" ixy="0.01" ixz="-0.02" iyy="0.23" iyz="0.005" izz="0.31"/></inertial>
    <collision><origin xyz="0 0 0.05" rpy="0 0 0.3"/>
      <geometry><box size="0.4 0.3 0.1"/></geometry></collision>
  </link>
  <link name="mast">
    <inertial><origin xyz="0 0 0.2" rpy="0 0.5 0"/><mass value="0.5"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"/></inertial>
    <collision><origin xyz="0 0 0.25" rpy="0.2 0 0"/>
      <geometry><cylinder radius="0.05" length="0.5"/></geometry></collision>
  </link>
  <link name="camera">
    <inertial><mass value="0.2"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.003"/></inertial>
    <collision><origin xyz="0.02 0 0" rpy="0.1 0.2 0.3"/>
      <geometry><box size="0.05 0.08 0.04"/></geometry></collision>
  </link>
  <joint name="mount" type="fixed"><parent link="base"/><child link="mast"/>
    <origin xyz="0.15 0 0.1" rpy="0 0 0.7"/></joint>
  <joint name="head" type="fixed"><parent link="mast"/><child link="camera"/>
    <origin xyz="0 0.03 0.45" rpy="0.3 -0.2 0.1"/></joint>
  EXTRA
</robot>"""


def _write(tmp_path, text, name='robot.urdf'):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _load(path, max_bytes=scenes.MAX_BYTES):
    return load_urdf(path, max_bytes, scenes.MAX_BODIES)


def _mujoco(text):
    """MuJoCo's model of the URDF, each link a body of its own (not fused)."""
    model = mujoco.MjModel.from_xml_string(text.replace(
        'EXTRA', '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>'))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _sum_of(model, data, bodies):
    """Mass, centre and inertia (world axes) of MuJoCo's ``bodies`` welded: the
    parallel-axis theorem, written out."""
    mass = sum(float(model.body_mass[b]) for b in bodies)
    centre = sum(float(model.body_mass[b]) * data.xipos[b] for b in bodies) / mass
    inertia = np.zeros((3, 3))
    for b in bodies:
        r = data.ximat[b].reshape(3, 3)
        d = data.xipos[b] - centre
        inertia += r @ np.diag(model.body_inertia[b]) @ r.T
        inertia += float(model.body_mass[b]) * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, centre, inertia


def test_fixed_links_are_one_body_with_the_parallel_axis_sum_of_theirs(tmp_path):
    gravity, bodies = _load(_write(tmp_path, ROBOT.replace('EXTRA', '')))
    assert gravity == (0.0, 0.0, 0.0) and [b.name for b in bodies] == ['base']
    rover, = bodies
    model, data = _mujoco(ROBOT)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)]
    assert sorted(names[1:]) == ['base', 'camera', 'mast']
    mass, centre, inertia = _sum_of(model, data, range(1, model.nbody))
    rot = so3.matrix_from_quaternion_xyzw(rover.initial_orientation_xyzw)
    assert rover.mass == pytest.approx(mass, rel=1e-12) and mass == pytest.approx(3.7)
    np.testing.assert_allclose(rover.initial_position, centre, atol=1e-12)
    ours = rot @ np.array(rover.inertia).reshape(3, 3) @ rot.T
    np.testing.assert_allclose(ours, inertia, atol=1e-12)
    # the colliders where MuJoCo puts the geoms (world), with their sizes
    assert [type(c) for c in rover.colliders] == [Box, Cylinder, Box]
    for c, g in zip(rover.colliders, range(model.ngeom)):
        at = np.array(rover.initial_position) + rot @ np.array(c.position)
        np.testing.assert_allclose(at, data.geom_xpos[g], atol=1e-12)
        np.testing.assert_allclose(rot @ c.rotation, data.geom_xmat[g].reshape(3, 3),
                                   atol=1e-12)
    assert rover.colliders[0].size == (0.4, 0.3, 0.1)
    assert (rover.colliders[1].radius, rover.colliders[1].length) == (0.05, 0.5)


def test_a_floating_joint_makes_a_body_of_its_own_where_the_joint_puts_it(tmp_path):
    extra = ('<link name="drone"><inertial><mass value="1.5"/><inertia ixx="0.02" ixy="0" '
             'ixz="0" iyy="0.02" iyz="0" izz="0.04"/></inertial></link>'
             '<joint name="release" type="floating"><parent link="camera"/>'
             '<child link="drone"/><origin xyz="0.5 0 1" rpy="0 0 1.2"/></joint>')
    text = ROBOT.replace('EXTRA', extra)
    _, bodies = _load(_write(tmp_path, text.replace('EXTRA', '')))
    assert [b.name for b in bodies] == ['base', 'drone']
    # MuJoCo takes free joints at the top level only: its placement of the same joint made
    # fixed is where the floating one starts
    welded = extra.replace('type="floating"', 'type="fixed"')
    model, data = _mujoco(ROBOT.replace('EXTRA', welded + 'EXTRA'))
    drone = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, 'drone')
    np.testing.assert_allclose(bodies[1].initial_position, data.xipos[drone], atol=1e-12)
    rot = so3.matrix_from_quaternion_xyzw(bodies[1].initial_orientation_xyzw)
    np.testing.assert_allclose(rot, data.xmat[drone].reshape(3, 3), atol=1e-12)
    # the rest is still the rover's
    assert bodies[0].mass == pytest.approx(3.7)


@pytest.mark.parametrize('extra, match', [
    ('<link name="wheel"/><joint name="axle" type="continuous"><parent link="base"/>'
     '<child link="wheel"/></joint>', "joint 'axle' is a continuous joint: only fixed"),
    ('<link name="can"><collision><geometry><capsule radius="0.1" length="0.2"/></geometry>'
     '</collision></link>', "link 'can' collision 0: capsule geometry: only box, sphere"),
    ('<link name="hull"><collision><geometry><mesh filename="package://rover/hull.stl"/>'
     '</geometry></collision></link>',
     "link 'hull' collision 0: mesh: package://rover/hull.stl: no ROS package 'rover'"),
    ('<link name="hull"><collision><geometry><mesh filename="../up.stl"/>'
     '</geometry></collision></link>', "link 'hull' collision 0: mesh: ../up.stl: outside"),
    ('<joint name="again" type="fixed"><parent link="base"/><child link="camera"/></joint>',
     "joint 'again': link 'camera' has two parents"),
    ('<joint name="ghost" type="fixed"><parent link="base"/><child link="nowhere"/></joint>',
     "joint 'ghost': no link named 'nowhere'"),
    ('<link name="dust"/>', "link 'dust': its body has no mass"),
    ('<link name="bad"><inertial><mass value="nan"/><inertia ixx="1"/></inertial></link>',
     "link 'bad' mass: not finite"),
    ('<link name="base"/>', "link 'base' is defined twice"),
])
def test_what_is_not_rigid_bodies_is_refused_in_one_line(tmp_path, extra, match):
    path = _write(tmp_path, ROBOT.replace('EXTRA', extra))
    with pytest.raises(SceneError, match=match) as e:
        load_scene(path)
    assert '\n' not in str(e.value) and str(e.value).startswith(path)


def test_loops_bad_files_and_bombs_are_refused(tmp_path):
    loop = ('<robot name="r"><link name="a"/><link name="b"/>'
            '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
            '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint></robot>')
    with pytest.raises(ModelError, match='loop'):
        _load(_write(tmp_path, loop))
    with pytest.raises(ModelError, match='cannot read'):
        _load(str(tmp_path / 'none.urdf'))
    with pytest.raises(ModelError, match='larger than 100 bytes'):
        _load(_write(tmp_path, ROBOT.replace('EXTRA', '')), max_bytes=100)
    with pytest.raises(ModelError, match='not a URDF'):
        _load(_write(tmp_path, '<mujoco/>'))
    with pytest.raises(ModelError, match='not XML'):
        _load(_write(tmp_path, entity_bomb('robot')))


def test_load_scene_reads_a_urdf_and_it_runs(tmp_path):
    from rb_sim_ros.core.rigid_body import Wrench
    from rb_sim_ros.sim.simulation import Config, SetWrench, Simulation
    scene = load_scene(_write(tmp_path, ROBOT.replace('EXTRA', '')))
    sim = Simulation(Config(dt=1e-3, gravity=scene.gravity, bodies=scene.bodies))
    sim.apply(SetWrench(Wrench(force=(3.7, 0.0, 0.0)), 'base'))
    sim.run(1000)
    # F = m a: 1 m/s^2 for 1 s from rest moves the centre of mass 0.5 m
    position = sim.pose_twist('base')[0]
    assert position[0] - scene.bodies[0].initial_position[0] == pytest.approx(0.5, rel=1e-9)


def test_a_model_sent_as_text_is_one_body_named_by_the_request():
    """What a spawn's resource_string may hold besides a YAML entry (scene.body_entry)."""
    body = scenes.body_entry(ROBOT.replace('EXTRA', ''), 'rover2')
    assert body.name == 'rover2' and body.mass == pytest.approx(3.7)
    assert scenes.body_entry(ROBOT.replace('EXTRA', '')).name == 'base'
    ball = ('<mujoco><worldbody><body name="b" pos="0 0 1"><freejoint/>'
            '<geom size="0.1" mass="2"/></body></worldbody></mujoco>')
    assert scenes.body_entry(ball).mass == pytest.approx(2.0)
    two = ball.replace('</worldbody>', '<geom type="plane" size="1 1 1"/></worldbody>')
    with pytest.raises(SceneError, match=r'a spawn makes one body; this model makes 2 '
                                         r'\(mjcf_world, b\)'):
        scenes.body_entry(two)
    for text, match in (
            ('<mujoco><include file="x.xml"/></mujoco>', 'may name no file'),
            ('<mujoco><asset><mesh name="m" file="/x.stl"/></asset></mujoco>',
             'a model sent as text may name no file'),
            ('<sdf version="1.9"/>', 'neither a URDF'),
            ('<robot', 'not XML')):
        with pytest.raises(SceneError, match=match) as e:
            scenes.body_entry(text, where='resource_string')
        assert str(e.value).startswith('resource_string: ')


def test_a_link_called_world_is_the_world(tmp_path):
    """URDF's idiom: a robot fixed to a link 'world' stays put (a static body, named so as
    not to take the world frame's name); a floating joint from 'world' places a free body."""
    text = ('<robot name="cell"><link name="world"/>'
            '<link name="table"><collision><origin xyz="0 0 0.4"/><geometry>'
            '<box size="1 1 0.1"/></geometry></collision></link>'
            '<joint name="bolted" type="fixed"><parent link="world"/><child link="table"/>'
            '<origin xyz="2 0 0"/></joint>'
            '<link name="puck"><inertial><mass value="0.2"/><inertia ixx="1e-4" iyy="1e-4" '
            'izz="2e-4"/></inertial><collision><geometry><sphere radius="0.05"/></geometry>'
            '</collision></link>'
            '<joint name="free" type="floating"><parent link="world"/><child link="puck"/>'
            '<origin xyz="2 0 1"/></joint></robot>')
    _, (table, puck) = _load(_write(tmp_path, text))
    assert (table.name, table.static) == ('urdf_world', True)
    np.testing.assert_allclose(np.array(table.initial_position) + table.colliders[0].position,
                               (2.0, 0.0, 0.4), atol=1e-15)
    assert (puck.name, puck.static, puck.mass) == ('puck', False, 0.2)
    assert puck.initial_position == (2.0, 0.0, 1.0)


def test_a_mesh_collision_is_the_hull_of_its_file_found_as_ros_finds_it(tmp_path, monkeypatch):
    """A ``<mesh>`` by a path relative to the URDF (scaled) and one by ``package://`` (found
    through AMENT_PREFIX_PATH's share folders): each a hull whose vertices are the file's
    corners, scaled, turned and moved by the collision's origin and the body's centre of
    mass."""
    trimesh = pytest.importorskip('trimesh')
    (tmp_path / 'meshes').mkdir()
    trimesh.creation.box(extents=(0.2, 0.1, 0.05)).export(tmp_path / 'meshes' / 'plate.stl')
    prefix = tmp_path / 'install'
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'rover').write_text('')
    (prefix / 'share' / 'rover').mkdir()
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(prefix / 'share' / 'rover' / 'c.stl')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(prefix))
    text = """<robot name="r"><link name="base">
      <inertial><origin xyz="0.01 0.02 0.03"/><mass value="2.0"/>
        <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
      <collision><origin xyz="0.1 0 0" rpy="0 0 0.5"/>
        <geometry><mesh filename="meshes/plate.stl" scale="2 2 2"/></geometry></collision>
      <collision><origin xyz="0 0 0.3"/>
        <geometry><mesh filename="package://rover/c.stl"/></geometry></collision>
    </link></robot>"""
    _, (body,) = _load(_write(tmp_path, text))
    plate, cube = body.colliders
    turn = so3.exp((0.0, 0.0, 0.5))
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    expected = corners * (0.2, 0.1, 0.05) + (np.array([0.1, 0.0, 0.0]) - (0.01, 0.02, 0.03)
                                             ) @ turn  # in the hull's own axes: turned back
    got = plate.vertices + np.array(plate.position) @ np.array(plate.rotation)
    assert sorted(map(tuple, np.round(got, 6))) == sorted(map(tuple, np.round(expected, 6)))
    np.testing.assert_allclose(plate.rotation, turn, atol=1e-12)
    np.testing.assert_allclose(cube.position, (-0.01, -0.02, 0.27), atol=1e-12)
    np.testing.assert_allclose(np.abs(cube.vertices), 0.05, atol=1e-7)
