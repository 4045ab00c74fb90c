# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Whether two recordings hold the same thing, bit for bit: what "identical files" can mean.

Two serialisations of one message by rclpy can differ in their bytes: its CDR leaves the
alignment padding after a string uninitialised (seen: the bytes after a header's frame_id), so
the compressed chunks differ too. ``difference`` therefore compares what a reader gets: the
writer's library, the metadata records, the channels (topic, type, QoS, type hash) and every
message (topic, log time, publish time, sequence, and every field, with floats compared by
their bits, so 0.0 differs from -0.0 and a NaN equals the same NaN).
"""

from __future__ import annotations

import itertools
import struct

from rb_sim_ros.recording.reader import RecordingReader


def message_values(msg) -> tuple:
    """Every field of a message as nested tuples; a float as its 8 bytes."""
    if hasattr(msg, 'get_fields_and_field_types'):
        return tuple((name, message_values(getattr(msg, name)))
                     for name in msg.get_fields_and_field_types())
    if isinstance(msg, float):
        return ('f', struct.pack('<d', msg))
    if isinstance(msg, (str, bytes, bool, int)) or msg is None:
        return msg
    try:  # sequences and arrays (numpy arrays among them)
        return tuple(message_values(item) for item in msg)
    except TypeError:
        return repr(msg)


def difference(a: str, b: str) -> str:
    """'' if recordings ``a`` and ``b`` hold the same, else the first difference, one line."""
    ra, rb = RecordingReader(a), RecordingReader(b)
    if ra.library != rb.library:
        return f'writer {ra.library!r} != {rb.library!r}'
    if ra.metadata != rb.metadata:
        names = sorted(n for n in set(ra.metadata) | set(rb.metadata)
                       if ra.metadata.get(n) != rb.metadata.get(n))
        return f'metadata {names} differs'
    if ra.topics != rb.topics:
        return f'topics differ: {sorted(set(ra.topics) ^ set(rb.topics)) or "their info"}'
    for k, (x, y) in enumerate(itertools.zip_longest(ra.messages(), rb.messages())):
        if x is None or y is None:
            return f'message {k}: only one of them has it'
        if (x.topic, x.log_time_ns, x.publish_time_ns, x.sequence) != \
                (y.topic, y.log_time_ns, y.publish_time_ns, y.sequence):
            return f'message {k}: {x.topic} at {x.log_time_ns} != {y.topic} at {y.log_time_ns}'
        if message_values(x.message) != message_values(y.message):
            return f'message {k} on {x.topic} at {x.log_time_ns} ns: the fields differ'
    return ''
