# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node on an MJCF scene_file: its free bodies get their topics and fall onto its floor;
a model that is not rigid bodies exits 2 with one line naming the file."""

from nav_msgs.msg import Odometry
import pytest

pytest.importorskip('mujoco')  # (PyPI only: package.xml names no key for it)

BALL = ('<mujoco><option gravity="0 0 -9.81"/><worldbody>'
        '<geom name="floor" type="plane" size="5 5 .1"/>'
        '<body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/>'
        '</body></worldbody></mujoco>')


def test_an_mjcf_scene_falls_onto_its_floor(start_sim, probe, tmp_path):
    model = tmp_path / 'drop.xml'
    model.write_text(BALL)
    sim = start_sim('-p', f'scene_file:={model}')
    odom = probe.collect(Odometry, 'ball/odom')
    # 1 m falls in 0.45 s: wait until it rests on the floor at its radius
    probe.wait_for(lambda: odom and odom[-1].header.stamp.sec >= 2, what='2 s of ball/odom')
    z = [m.pose.pose.position.z for m in odom]
    assert max(z) <= 1.0 and abs(z[-1] - 0.1) < 2e-3, z[-1]
    assert odom[-1].header.frame_id == 'world' and odom[-1].child_frame_id == 'ball'
    sim.stop()


def test_an_articulated_model_exits_2_with_one_line_naming_the_file(start_sim, tmp_path):
    model = tmp_path / 'arm.xml'
    model.write_text('<mujoco><worldbody><body name="arm"><joint name="elbow" type="hinge"/>'
                     '<geom size="0.1"/></body></worldbody></mujoco>')
    sim = start_sim('-p', f'scene_file:={model}')
    assert sim.proc.wait(120) == 2
    out = sim.output()
    assert 'Traceback' not in out, out
    lines = [line for line in out.splitlines() if str(model) in line]
    assert len(lines) == 1 and "joint 'elbow' is a hinge joint" in lines[0], out


def test_spawn_entity_takes_a_urdf_and_refuses_an_articulated_mjcf(start_sim, probe):
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import GetEntities, SpawnEntity
    start_sim('-p', 'start_paused:=true')
    urdf = ('<robot name="r"><link name="hull"><inertial><mass value="2"/><inertia ixx="0.1" '
            'iyy="0.1" izz="0.1"/></inertial><collision><geometry><box size="1 1 1"/>'
            '</geometry></collision></link></robot>')
    reply = probe.call(SpawnEntity, 'spawn_entity', SpawnEntity.Request(resource_string=urdf))
    assert (reply.result.result, reply.entity_name) == (Result.RESULT_OK, 'hull')
    names = probe.call(GetEntities, 'get_entities', GetEntities.Request()).entities
    assert 'hull' in list(names)
    arm = ('<mujoco><worldbody><body name="arm"><joint name="elbow" type="hinge"/>'
           '<geom size="0.1"/></body></worldbody></mujoco>')
    reply = probe.call(SpawnEntity, 'spawn_entity',
                       SpawnEntity.Request(name='arm', resource_string=arm))
    assert reply.result.result == SpawnEntity.Response.RESOURCE_PARSE_ERROR
    assert "joint 'elbow' is a hinge joint" in reply.result.error_message
