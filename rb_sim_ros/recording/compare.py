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
from typing import Any

from rb_sim_ros.recording.reader import RecordingReader


def message_values(msg) -> Any:
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


def difference(a: str, b: str, metadata_view=None, message_view=None) -> str:
    """'' if recordings ``a`` and ``b`` hold the same, else the first difference, one line.

    ``metadata_view(path, name, record)`` and ``message_view(path, topic, message)``, when
    given, say what of a metadata record (a dict) and of a message is compared (e.g. without
    the file's own name): what they return is compared instead (a metadata record whose
    view is None is left out)."""
    ra, rb = RecordingReader(a), RecordingReader(b)
    if ra.library != rb.library:
        return f'writer {ra.library!r} != {rb.library!r}'
    ma, mb = ra.metadata, rb.metadata
    if metadata_view is not None:
        ma = {n: v for n, r in ma.items() if (v := metadata_view(a, n, dict(r))) is not None}
        mb = {n: v for n, r in mb.items() if (v := metadata_view(b, n, dict(r))) is not None}
    if ma != mb:
        names = sorted(n for n in set(ma) | set(mb) if ma.get(n) != mb.get(n))
        return f'metadata {names} differs'
    if ra.topics != rb.topics:
        return f'topics differ: {sorted(set(ra.topics) ^ set(rb.topics)) or "their info"}'
    for k, (x, y) in enumerate(itertools.zip_longest(ra.messages(), rb.messages())):
        if x is None or y is None:
            return f'message {k}: only one of them has it'
        if (x.topic, x.log_time_ns, x.publish_time_ns, x.sequence) != \
                (y.topic, y.log_time_ns, y.publish_time_ns, y.sequence):
            return f'message {k}: {x.topic} at {x.log_time_ns} != {y.topic} at {y.log_time_ns}'
        vx, vy = x.message, y.message
        if message_view is not None:
            vx, vy = message_view(a, x.topic, vx), message_view(b, y.topic, vy)
        if message_values(vx) != message_values(vy):
            return f'message {k} on {x.topic} at {x.log_time_ns} ns: the fields differ'
    return ''
