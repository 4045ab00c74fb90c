# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The recorder's wrench input packed from its numbers (a closed-loop run records one a
period) is the message's serialisation: rclpy reads it back as the WrenchStamped the generic
path records, byte for byte the generic serialiser's."""

from geometry_msgs.msg import WrenchStamped
from hypothesis import given, settings, strategies as st
import pytest
from rclpy.serialization import deserialize_message

from rb_sim_ros.core.rigid_body import Frame, Wrench
from rb_sim_ros.recording import RecordingWriter, WriterError
from rb_sim_ros.recording.cdr import encoder
from rb_sim_ros.ros.node_recorder import wrench_bytes, wrench_message
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
        writer.write_serialized('/x', data, 5)
    with pytest.raises(WriterError, match='must be bytes'):
        writer.write_serialized('/w', bytearray(data), 5)
    with pytest.raises(WriterError, match='log_time_ns'):
        writer.write_serialized('/w', data, -1)
    writer.write_serialized('/w', data, 5, sequence=7)
    writer.finish()
    from mcap.reader import make_reader
    with open(tmp_path / 'a.mcap', 'rb') as f:
        messages = [(m.log_time, m.sequence, m.data) for _, _, m in
                    make_reader(f).iter_messages()]
    assert messages == [(5, 7, data)]
