# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The one table of output kinds (ros/output_kinds.py) is what the ports publish, the recorder
records and replay compares: each kind is filled by OutputMessages, and its quantities are the
state it was filled from (world frame for the pose, the body frame for odom's twist)."""

import math

from rb_sim_ros.ros import body_ports, node_recorder, output_kinds
from rb_sim_ros.ros.ros_messages import OutputMessages

HALF = math.sqrt(0.5)


def test_every_kind_is_published_recorded_and_filled():
    assert node_recorder.OUTPUTS == {k.name: k.msg_type for k in output_kinds.KINDS}
    published = {t: m for t, m, _ in body_ports.PUBLISHED}
    for kind in output_kinds.KINDS:
        assert published[kind.name] is kind.msg_type
        assert isinstance(getattr(OutputMessages('world', 'body', 'world'), kind.name),
                          kind.msg_type)
    assert set(node_recorder.REQUIRED_OUTPUTS) == {'pose', 'twist', 'odom'}
    assert set(body_ports.MOVING_ONLY) == {'imu', 'accel'} == set(output_kinds.MOTION)
    assert not output_kinds.needs_motion('tf') and output_kinds.needs_motion('imu')


def test_the_quantities_are_the_state_a_message_was_filled_from():
    """A body at (1, 2, 3) turned 90 degrees about z, moving at (1, 0, 0) m/s and turning at
    (0, 0, 2) rad/s: in its own frame it moves along -y (odom's twist is the body frame's)."""
    out = OutputMessages('world', 'body', 'world')
    q = (0.0, 0.0, HALF, HALF)
    assert out.fill(5_000_000, (1.0, 2.0, 3.0), q, (1.0, 0.0, 0.0), (0.0, 0.0, 2.0))
    assert out.fill_motion(5_000_000, q, (0.0, 0.0, 2.0), (0.0, 0.0, -9.81), (0.5, 0.0, 0.0),
                           (0.0, 0.0, -9.81))
    got = {k.name: k.quantities(getattr(out, k.name)) for k in output_kinds.KINDS}
    assert got['pose'] == {'position': (1.0, 2.0, 3.0), 'orientation': q}
    assert got['twist'] == {'linear_velocity': (1.0, 0.0, 0.0),
                            'angular_velocity': (0.0, 0.0, 2.0)}
    odom = got['odom']
    assert odom['position'] == (1.0, 2.0, 3.0) and odom['orientation'] == q
    assert all(math.isclose(a, b, abs_tol=1e-15)
               for a, b in zip(odom['linear_velocity'], (0.0, -1.0, 0.0)))
    assert odom['angular_velocity'] == (0.0, 0.0, 2.0)
    # free fall: the accelerometer reads no specific force
    assert got['imu']['linear_acceleration'] == (0.0, 0.0, 0.0)
    assert got['accel'] == {'linear_acceleration': (0.0, 0.0, -9.81),
                            'angular_acceleration': (0.5, 0.0, 0.0)}
