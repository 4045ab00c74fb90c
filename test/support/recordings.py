# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Recordings for the tests that read them: the parts of an MCAP file read by the mcap library
itself (to be rewritten), and a writer's disk that fills up. A run recorded offline as the node
records it is oracles/node_recording.py's (the replay benchmark records with it too). Needs
mcap."""

import errno
import json
import os

from mcap.reader import make_reader
from mcap.writer import Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from rb_sim_ros.ros.node_recorder import RUN_DEFINITION


def mcap_parts(path):
    """(header, schemas, channels, messages, metadata) of the MCAP file ``path``, read by the
    mcap library itself."""
    with open(path, 'rb') as f:
        reader = make_reader(f)
        header, summary = reader.get_header(), reader.get_summary()
        messages = [m for _s, _c, m in reader.iter_messages(log_time_order=False)]
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    return header, summary.schemas, summary.channels, messages, metadata


def topic_parts(path):
    """(schemas, channels, [(topic, message record)], rb_sim_ros metadata), read by mcap."""
    with open(path, 'rb') as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        messages = [(c.topic, m) for _s, c, m in reader.iter_messages()]
        meta = next(dict(m.metadata) for m in reader.iter_metadata() if m.name == 'rb_sim_ros')
    return summary.schemas, summary.channels, messages, meta


def rewrite(path, schemas, channels, messages, meta):
    """Write ``path`` from parts (``topic_parts``, edited): the run definition message says
    what the metadata ``meta`` says, as the node writes them."""
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile='ros2', library='test')
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {c.topic: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                            dict(c.metadata)) for c in channels.values()}
        for topic, m in messages:
            data = m.data
            if topic == RUN_DEFINITION:
                data = serialize_message(String(data=json.dumps(meta, sort_keys=True)))
            w.add_message(cids[topic], m.log_time, data, m.publish_time, m.sequence)
        w.add_metadata('rb_sim_ros', meta)
        w.finish()
    return path


def disk_full_after(w, budget):
    """Make writer ``w``'s file take ``budget`` more bytes, the last write only in part, then
    fail with ENOSPC, as a full disk does."""
    left = [budget]

    def write(data):
        n = min(len(data), left[0])
        if n:
            os.write(w._sink.fd, bytes(data[:n]))
            left[0] -= n
        if n < len(data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        w._sink.position += n
        return n

    w._sink.write = write
