# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""recover: a finalised copy of a recording that was cut short, like ``mcap recover``.

A recording whose writer was killed has no summary or footer; rosbags and some ``ros2 bag``
versions refuse it. ``recover`` copies every complete record of it (header, schemas, channels,
messages of finished chunks, metadata, attachments), in file order, into a new file with
chunk and message indexes, statistics, rosbag2's bag information and a footer.
"""

from __future__ import annotations

import dataclasses
import os

from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.writer import Writer

from rb_sim_ros.recording.bag_info import (bag_information, dump, METADATA_KEY, METADATA_NAME,
                                           TopicSummary)
from rb_sim_ros.recording.errors import ReaderError, WriterError
from rb_sim_ros.recording.reader import RecordingReader, RecordStream
from rb_sim_ros.recording.writer import CHUNK_SIZE, COMPRESSION


def recover(src: str | os.PathLike, dst: str | os.PathLike, overwrite: bool = False,
            compression: str = 'zstd', chunk_size: int = CHUNK_SIZE) -> dict:
    """Copy the complete part of recording ``src`` into a new, finalised file ``dst``.

    Returns counts: {'messages', 'schemas', 'channels', 'metadata', 'attachments'}, and
    'truncated' (whether ``src`` was), 'dropped_bytes' (bytes of ``src`` after its last complete
    record, 0 for a complete file) and 'damaged_chunks' (corrupt chunks skipped). The copy's
    rosbag2 bag information is new (counts of what was recovered); ``src``'s own is not copied.
    Messages keep their file order; chunks are written anew (``compression``, ``chunk_size``).

    Raises ReaderError if ``src`` is not a readable ROS 2 recording. Refuses (WriterError) to
    overwrite ``dst`` unless ``overwrite``, to write over ``src`` itself, and an unknown
    ``compression``; a ``dst`` left half-written by a failure is removed.
    """
    src, dst = os.fspath(src), os.fspath(dst)
    if compression not in COMPRESSION:
        raise WriterError(f'{dst}: compression {compression!r} is not one of '
                          f'{", ".join(COMPRESSION)}')
    reader = RecordingReader(src)
    if os.path.exists(dst) and os.path.samefile(src, dst):
        raise WriterError(f'{dst}: is the recording being recovered; write the copy elsewhere')
    flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if overwrite else os.O_EXCL)
    try:
        fd = os.open(dst, flags, 0o644)
    except FileExistsError:
        raise WriterError(f'{dst}: exists; refusing to overwrite it (overwrite=True to '
                          'replace it)') from None
    except OSError as e:
        raise WriterError(f'{dst}: cannot create: {e.strerror}') from None
    stream = RecordStream(src)
    try:
        with os.fdopen(fd, 'wb') as f:
            counts = _copy(reader, stream, f, compression, chunk_size, os.path.basename(dst))
    except BaseException as e:
        os.unlink(dst)
        if isinstance(e, (ReaderError, WriterError)):
            raise
        if isinstance(e, OSError):
            raise WriterError(f'{dst}: writing failed: {e.strerror}') from None
        raise
    counts.update(truncated=not stream.footer, dropped_bytes=reader.size - stream.good_end,
                  damaged_chunks=len(stream.damaged))
    return counts


def _copy(reader: RecordingReader, stream: RecordStream, f, compression: str, chunk_size: int,
          name: str) -> dict:
    writer = Writer(f, chunk_size=chunk_size, compression=COMPRESSION[compression])
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    topics: dict[int, TopicSummary] = {}
    counts = dict.fromkeys(('messages', 'schemas', 'channels', 'metadata', 'attachments'), 0)
    per_channel: dict[int, int] = {}
    first: int | None = None
    last: int | None = None

    def schema(old: int) -> int:
        if old not in schema_ids and old in reader.mcap_schemas:
            s = reader.mcap_schemas[old]
            schema_ids[old] = writer.register_schema(s.name, s.encoding, s.data)
            counts['schemas'] += 1
        return schema_ids.get(old, 0)

    def channel(old: int) -> int | None:
        """The copy's id of channel ``old``, registered at first use (also when the chunk that
        declared it was damaged but the summary knows it)."""
        if old not in channel_ids and old in reader.mcap_channels:
            c = reader.mcap_channels[old]
            cid = channel_ids[old] = writer.register_channel(
                c.topic, c.message_encoding, schema(c.schema_id), dict(c.metadata))
            info = reader.topics[c.topic]
            topics[cid] = TopicSummary(c.topic, info.type_name, info.offered_qos_profiles,
                                       info.type_hash or '', 0, c.message_encoding)
            counts['channels'] += 1
        return channel_ids.get(old)

    for record in stream.records():
        if isinstance(record, Message):
            cid = channel(record.channel_id)
            if cid is None:
                raise ReaderError(f'{reader.path}: a message at {record.log_time} ns is on '
                                  f'channel {record.channel_id}, which no record declares')
            writer.add_message(cid, record.log_time, record.data, record.publish_time,
                               record.sequence)
            per_channel[cid] = per_channel.get(cid, 0) + 1
            counts['messages'] += 1
            t = record.log_time
            if first is None or last is None:
                first, last = t, t
            else:
                first, last = min(first, t), max(last, t)
        elif isinstance(record, Header):
            writer.start(profile=record.profile, library=record.library)
        elif isinstance(record, (Schema, Channel)):
            (schema if isinstance(record, Schema) else channel)(record.id)
        elif isinstance(record, Metadata):
            if record.name != METADATA_NAME:  # the copy gets its own, below
                writer.add_metadata(record.name, dict(record.metadata))
                counts['metadata'] += 1
        elif isinstance(record, Attachment):
            writer.add_attachment(record.create_time, record.log_time, record.name,
                                  record.media_type, record.data)
            counts['attachments'] += 1
    summaries = [dataclasses.replace(t, message_count=per_channel.get(cid, 0))
                 for cid, t in sorted(topics.items())]
    info = bag_information(name, summaries, first, last)
    writer.add_metadata(METADATA_NAME, {METADATA_KEY: dump(info)})
    writer.finish()
    return counts
