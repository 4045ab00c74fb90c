# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The recorder's wrench input packed from its numbers (a closed-loop run records one a
period) is the message's serialisation: rclpy reads it back as the WrenchStamped the generic
path records, byte for byte the generic serialiser's."""

from geometry_msgs.msg import WrenchStamped
from hypothesis import given, settings, strategies as st
from mcap.reader import make_reader
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.serialization import deserialize_message

from rb_sim_ros.core.rigid_body import Frame, Wrench
from rb_sim_ros.recording import RecordingWriter, WriterError
from rb_sim_ros.recording.cdr import encoder
from rb_sim_ros.ros.node_recorder import odom_bytes, wrench_bytes, wrench_message
from rb_sim_ros.ros.ros_messages import OutputMessages
from rb_sim_ros.sim.simulation import SetWrench

FINITE = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(force=st.tuples(FINITE, FINITE, FINITE), torque=st.tuples(FINITE, FINITE, FINITE),
       frame=st.sampled_from([Frame.WORLD, Frame.BODY]),
       time_ns=st.integers(0, 2**31 * 1_000_000_000 - 1))
def test_a_wrench_input_packed_is_its_message_serialised(force, torque, frame, time_ns):
    event = SetWrench(Wrench(force, torque, frame), 'body')
    data = wrench_bytes(event, time_ns)
    msg = wrench_message(event, time_ns, WrenchStamped())
    assert data == encoder(WrenchStamped)(msg)
    back = deserialize_message(data, WrenchStamped)
    assert back == msg
    assert (back.header.stamp.sec * 1_000_000_000 + back.header.stamp.nanosec) == time_ns
    assert back.header.frame_id == frame.value
    w = back.wrench
    assert (w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z) == \
        tuple(float(c) for c in (*force, *torque))


def test_serialised_writes_are_checked_as_messages_are(tmp_path):
    writer = RecordingWriter(str(tmp_path / 'a.mcap'), background=False)
    writer.register_topic('/w', WrenchStamped)
    data = wrench_bytes(SetWrench(Wrench((1.0, 2.0, 3.0)), 'b'), 5)
    with pytest.raises(WriterError, match="'/x' was not registered"):
        writer.write_serialized('/x', data, WrenchStamped, 5)
    with pytest.raises(WriterError, match='carries WrenchStamped, not Odometry'):
        writer.write_serialized('/w', data, Odometry, 5)
    with pytest.raises(WriterError, match='must be bytes'):
        writer.write_serialized('/w', bytearray(data), WrenchStamped, 5)
    with pytest.raises(WriterError, match='log_time_ns'):
        writer.write_serialized('/w', data, WrenchStamped, -1)
    writer.write_serialized('/w', data, WrenchStamped, 5, sequence=7)
    writer.finish()
    with open(tmp_path / 'a.mcap', 'rb') as f:
        messages = [(m.log_time, m.sequence, m.data) for _, _, m in
                    make_reader(f).iter_messages()]
    assert messages == [(5, 7, data)]


@settings(max_examples=150, deadline=None)
@given(state=st.tuples(*[st.tuples(*[FINITE] * 3)] * 3), quaternion=st.tuples(
           *[st.floats(-1.0, 1.0)] * 4), time_ns=st.integers(0, 2**31 * 1_000_000_000 - 1),
       frames=st.tuples(*[st.text(st.characters(blacklist_categories=('Cs',),
                                                blacklist_characters='\x00'), max_size=12)] * 2),
       twist_in_body=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_odom_packed_from_the_numbers_is_the_filled_message_serialised(
        state, quaternion, time_ns, frames, twist_in_body, seed):
    """Odometry not filled (a law that reads the IMU) is recorded from the fill's numbers:
    the bytes of the same Odometry filled and serialised, frame ids of any length (the
    padding after them) and covariances the node was given; rclpy reads it back as the filled
    message (frame ids without a NUL, which the wire cuts them at)."""
    position, linear, angular = state
    rng = np.random.default_rng(seed)
    covariances = rng.normal(size=36).tolist(), rng.normal(size=36).tolist()
    args = (frames[0], frames[1], 'body' if twist_in_body else 'world', *covariances)
    unfilled = OutputMessages(*args, kinds=['imu'])
    filled = OutputMessages(*args)
    ok = unfilled.fill(time_ns, position, quaternion, linear, angular)
    assert filled.fill(time_ns, position, quaternion, linear, angular) == ok
    stamp = unfilled.odom.header.stamp
    assert (stamp.sec, stamp.nanosec) == (0, 0)  # (never filled: frames and covariances)
    data = odom_bytes(unfilled)
    assert data == encoder(Odometry)(filled.odom)
    assert deserialize_message(data, Odometry) == filled.odom
