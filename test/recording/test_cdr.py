# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The generated CDR serialisers against rclpy's: random messages of every type a recording
holds and of types with every kind of field (sequences of strings and numbers, bytes, bools,
chars, nested sequences, an empty message) give rclpy's bytes, but for padding, which is
zeros here, and for the garbage rclpy's buffer may have after the data; rclpy reads them
back to the message, and so does rosbags (an independent reader). And the recording writer's
fast add_message against mcap's own: the same file."""

import random

from geometry_msgs.msg import AccelStamped, PoseStamped, Twist, TwistStamped, WrenchStamped
from hypothesis import given, settings, strategies as st
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import get_typestore, Stores
from rosidl_parser import definition as d
from sensor_msgs.msg import Image, Imu, JointState
from std_msgs.msg import Bool, ByteMultiArray, Char, Empty, Float32MultiArray, String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from rb_sim_ros.recording.cdr import encoder

RECORDED = (PoseStamped, Twist, Odometry, Imu, AccelStamped, TFMessage, WrenchStamped,
            TwistStamped, String)
OTHERS = (JointState, Image, ByteMultiArray, Float32MultiArray, Bool, Char, Empty, MarkerArray)
TEXTS = ('', 'a', 'ab', 'abc', 'world', 'body_1/imu', 'é', '日本', 'x' * 37)
_RANGES = {'int8': (-2**7, 2**7 - 1), 'uint8': (0, 2**8 - 1), 'int16': (-2**15, 2**15 - 1),
           'uint16': (0, 2**16 - 1), 'int32': (-2**31, 2**31 - 1), 'uint32': (0, 2**32 - 1),
           'int64': (-2**63, 2**63 - 1), 'uint64': (0, 2**64 - 1)}


def _value(rng: random.Random, t, depth: int):
    if isinstance(t, d.BasicType):
        name = t.typename
        if name == 'boolean':
            return rng.random() < 0.5
        if name in ('double', 'float'):
            x = rng.choice([0.0, -0.0, 1.5, rng.uniform(-1e6, 1e6), 1e-300, float('inf')])
            return float(np.float32(x)) if name == 'float' else x
        if name in ('octet', 'char'):
            return bytes([rng.randrange(256)]) if name == 'octet' else rng.randrange(256)
        lo, hi = _RANGES[name]
        return rng.choice([lo, hi, 0, rng.randint(lo, hi)])
    if isinstance(t, d.AbstractString):
        return rng.choice(TEXTS)
    if isinstance(t, d.NamespacedType):
        return _message(rng, _class(t), depth + 1)
    item = t.value_type
    n = t.size if isinstance(t, d.Array) else 0 if depth > 2 else rng.randrange(4)
    if isinstance(t, d.BoundedSequence):
        n = min(n, t.maximum_size)
    return [_value(rng, item, depth + 1) for _ in range(n)]


def _class(t) -> type:
    import importlib
    return getattr(importlib.import_module('.'.join(t.namespaces)), t.name)


def _message(rng: random.Random, msg_type: type, depth: int = 0):
    msg = msg_type()
    slots = [s for s in msg_type.__slots__ if s != '_check_fields']
    for slot, t in zip(slots, msg_type.SLOT_TYPES):
        setattr(msg, slot[1:], _value(rng, t, depth))
    return msg


def _equal_but_padding(ours: bytes, theirs: bytes, msg_type: type) -> bool:
    """rclpy's bytes, but where ours are zero (padding rclpy leaves as its buffer had it).
    rclpy's buffer has the length its size estimate gave, which for an empty sequence or a
    small message is more than the data (the rest left as it was): ours is the data. The
    types a recording holds are estimated exactly: the same length."""
    if msg_type in RECORDED and len(ours) != len(theirs) or len(ours) > len(theirs):
        return False
    return all(a == b or a == 0 for a, b in zip(ours, theirs))


@pytest.mark.parametrize('msg_type', RECORDED + OTHERS, ids=lambda t: t.__name__)
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_bytes_are_rclpys_and_read_back_as_the_message(msg_type, seed):
    msg = _message(random.Random(seed), msg_type)
    encode = encoder(msg_type)
    assert encode is not None
    ours = encode(msg)
    assert ours[:4] == b'\x00\x01\x00\x00'
    assert _equal_but_padding(ours, serialize_message(msg), msg_type)
    assert deserialize_message(ours, msg_type) == msg
    assert encode(msg) == ours  # padding is zeros: the same message, the same bytes


def test_padding_is_zero_where_rclpy_pads():
    """A frame id of 2 characters leaves 7 bytes before the first double: all zeros."""
    msg = PoseStamped()
    msg.header.frame_id = 'ab'
    msg.pose.orientation.w = 1.0
    data = encoder(PoseStamped)(msg)
    #       header  sec nanosec  len 3   'ab\0' pad   (aligned to 8 from after the header)
    assert data[4:20] == bytes(8) + b'\x03\x00\x00\x00' + b'ab\x00' + b'\x00'
    assert len(data) == 4 + 16 + 7 * 8


def test_a_string_is_cut_at_its_nul_as_rclpy_cuts_it():
    msg = String(data='before\0after')
    assert encoder(String)(msg) == serialize_message(msg)
    assert deserialize_message(encoder(String)(msg), String).data == 'before'


def test_rosbags_reads_the_recorded_types():
    """An independent CDR reader: rosbags' typestore, on every type a recording holds."""
    store = get_typestore(Stores.ROS2_JAZZY)
    rng = random.Random(7)
    for msg_type in RECORDED:
        for _ in range(20):
            msg = _message(rng, msg_type)
            name = f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'
            theirs = store.deserialize_cdr(encoder(msg_type)(msg), name)
            ours = store.deserialize_cdr(serialize_message(msg), name)
            assert repr(theirs) == repr(ours), msg_type.__name__


def test_a_wide_string_type_is_left_to_rclpy():
    class WideText:  # (as rosidl makes a class: slots and their types)
        __slots__ = ['_text', '_check_fields']
        SLOT_TYPES = (d.UnboundedWString(),)
    assert encoder(WideText) is None


# -- the MCAP writer's fast add_message ------------------------------------------------------
@pytest.mark.parametrize('compression', ['zstd', 'none'])
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_fast_add_message_writes_mcaps_own_bytes(compression, seed):
    """The same messages (three channels, empty to large, times out of order, several
    chunks) through the fast add_message and through mcap's give the same file, byte for
    byte; mcap reads every message back."""
    import io as _io

    from mcap.reader import make_reader
    from mcap.writer import CompressionType

    from rb_sim_ros.recording import writer as recording_writer
    rng = random.Random(seed)
    messages = [(rng.randrange(1, 4), rng.randrange(0, 10**12), rng.randbytes(rng.choice(
        [0, 1, 7, 100, 3000])), rng.randrange(0, 10**12), rng.randrange(0, 2**32))
        for _ in range(rng.randrange(1, 300))]
    files = []
    for fast in (True, False):
        out = _io.BytesIO()
        w = recording_writer._Writer(out, chunk_size=4096, compression={
            'zstd': CompressionType.ZSTD, 'none': CompressionType.NONE}[compression])
        assert w.fast  # (mcap 1.x: what the fast path was written against)
        w.fast = fast
        w.start(profile='ros2', library='test')
        schema = w.register_schema('a/msg/B', 'ros2msg', b'int32 x')
        for topic in ('/a', '/b', '/c'):
            w.register_channel(topic, 'cdr', schema)
        for channel, log, data, pub, seq in messages:
            w.add_message(channel, log, data, pub, seq)
        w.finish()
        files.append(out.getvalue())
    assert files[0] == files[1]
    read = [(m.channel_id, m.log_time, m.data, m.publish_time, m.sequence)
            for _, _, m in make_reader(_io.BytesIO(files[0])).iter_messages(log_time_order=False)]
    assert sorted(read) == sorted(messages)
