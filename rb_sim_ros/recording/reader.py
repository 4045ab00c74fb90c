# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""RecordingReader: a ROS 2 MCAP recording, complete or cut short, read back as rclpy messages.

A complete file is read through its summary and indexes. A file without a valid footer and
summary (the writer was killed, or the disk filled) is read as a stream, without seeking, from
its start up to its last complete record: every message of every finished chunk, nothing of
the unfinished one; ``truncated`` and ``truncation`` say so. Chunks are checked against their
CRC; read as a stream, a corrupt chunk is skipped (listed in ``damaged``) and reading goes on.
Messages come in log-time order (a stream whose log times go backwards is sorted in memory).
Anything that is not such a recording raises ReaderError with the file and the reason; errors
of the mcap library never escape as they are.
"""

from __future__ import annotations

import importlib
import io
import os
from typing import Any, Iterable, Iterator, NamedTuple

from mcap.exceptions import EndOfFile, RecordLengthLimitExceeded
from mcap.reader import SeekingReader
from mcap.records import (Channel, Chunk, Footer, Header, McapRecord, Message, Metadata,
                          Schema)
from mcap.stream_reader import breakup_chunk, CRCValidationError, StreamReader
from rclpy.serialization import deserialize_message

from rb_sim_ros.recording.errors import interrupt_in, ReaderError
from rb_sim_ros.recording.schemas import split_type_name

MAGIC = b'\x89MCAP0\r\n'
PROFILE = 'ros2'
MESSAGE_ENCODING = 'cdr'
SCHEMA_ENCODINGS = ('ros2msg', 'ros2idl')


class TopicInfo(NamedTuple):
    """A recorded topic: its type 'pkg/msg/Type', message count and channel metadata."""

    type_name: str
    message_count: int
    offered_qos_profiles: str  # YAML text, '' if the channel has none
    type_hash: str | None  # 'RIHS01_<hex>' (channel metadata topic_type_hash), if recorded
    message_encoding: str
    schema_encoding: str


class RecordedMessage(NamedTuple):
    """One message read back; unpacks as (topic, message, log_time_ns, publish_time_ns, seq)."""

    topic: str
    message: Any  # an instance of the topic's rclpy message class
    log_time_ns: int
    publish_time_ns: int
    sequence: int


class RawMessage(NamedTuple):
    """One message as recorded: its CDR bytes (to republish serialised, or copy)."""

    topic: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int
    sequence: int


def message_class(type_name: str) -> type:
    """The rclpy message class of 'pkg/msg/Type'; ReaderError if it is not installed here."""
    try:
        package, name = split_type_name(type_name)
        cls = getattr(importlib.import_module(f'{package}.msg'), name)
    except (ValueError, ImportError, AttributeError):
        raise ReaderError(f'message type {type_name} is not installed here (no Python module '
                          f'{type_name.split("/")[0]}.msg with that class)') from None
    return cls


def _describe(error: Exception, offset: int) -> str:
    if isinstance(error, EndOfFile):
        return f'the file ends inside the record at byte {offset} (cut short while writing)'
    if isinstance(error, RecordLengthLimitExceeded):
        return (f'the record at byte {offset} claims more bytes than the file holds (cut short '
                'while writing, or corrupt)')
    if isinstance(error, CRCValidationError):
        return f'the chunk at byte {offset} fails its CRC check (corrupt)'
    return f'the record at byte {offset} is unreadable ({type(error).__name__}: {error})'


class RecordStream:
    """The records of a file in order, up to the first incomplete one; corrupt chunks (CRC or
    compression errors) are skipped and listed in ``damaged``. For this package's use."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.good_end = 0  # byte offset after the last complete record
        self.footer = False
        self.problem = ''
        self.damaged: list[str] = []

    def records(self) -> Iterator[McapRecord]:
        try:
            f = open(self.path, 'rb')
        except OSError as e:
            raise ReaderError(f'{self.path}: cannot open: {e.strerror}') from None
        with f:
            size = os.fstat(f.fileno()).st_size
            records = StreamReader(f, emit_chunks=True, validate_crcs=True,
                                   record_size_limit=max(size, 1)).records
            self.good_end = len(MAGIC)
            while True:
                start = self.good_end
                try:
                    record = next(records)
                except StopIteration:
                    self.good_end = f.tell()  # after the closing magic
                    return
                except Exception as e:  # the file is not readable past this point
                    self.problem = _describe(e, start)
                    return
                self.good_end = f.tell()
                if isinstance(record, Chunk):
                    try:
                        inner = breakup_chunk(record, validate_crc=True)
                    except Exception as e:  # its length was sound: skip it, read on
                        self.damaged.append(_describe(e, start))
                        continue
                    yield from inner
                    continue
                if isinstance(record, Footer):
                    self.footer = True
                yield record


class RecordingReader:
    """A ROS 2 recording (MCAP, profile ``ros2``, cdr messages), complete or cut short.

    Attributes: ``path``; ``library`` (the writer's, from the header); ``metadata``: metadata
    record name -> {key: value} (the last record of a name wins); ``channels``: topic ->
    'pkg/msg/Type'; ``topics``: topic -> TopicInfo; ``message_count``; ``start_time_ns`` and
    ``end_time_ns``: first and last log time (integer nanoseconds, None without messages);
    ``truncated``: True if the file has no valid end, ``truncation`` says what was read;
    ``size`` and ``readable_bytes``: bytes in the file and up to its last complete record;
    ``mcap_schemas``/``mcap_channels``: the MCAP Schema and Channel records by id;
    ``damaged``: corrupt chunks skipped when the file is read as a stream (a complete file
    with a corrupt chunk raises ReaderError when its messages are read; ``recover`` skips it).

    Refuses (ReaderError) a missing, empty or non-MCAP file, a file that is corrupt before its
    first record, another profile than ``ros2``, and channels that are not cdr messages with
    ros2msg/ros2idl schemas. Message types are looked up when messages are read.
    """

    mcap_schemas: dict[int, Schema]
    mcap_channels: dict[int, Channel]
    _metadata_records: list[Metadata]
    _counts: dict[int, int]

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        try:
            with open(self.path, 'rb') as f:
                head = f.read(len(MAGIC))
                size = os.fstat(f.fileno()).st_size
                indexed = self._read_indexed(f) if head == MAGIC else None
        except OSError as e:
            raise ReaderError(f'{self.path}: cannot open: {e.strerror}') from None
        if not head:
            raise ReaderError(f'{self.path}: empty file (0 bytes), not an MCAP recording')
        if head != MAGIC:
            raise ReaderError(f'{self.path}: not an MCAP file (it starts with {head!r}, not '
                              'the MCAP magic)')
        self.size = size
        self.truncated = False
        self.truncation = ''
        self.readable_bytes = size
        self.damaged: list[str] = []
        self._indexed = indexed is not None
        if indexed is None:
            self._scan()
        else:
            self._header, self.mcap_schemas, self.mcap_channels, records, stats = indexed
            self._counts = dict(stats.channel_message_counts)
            self.message_count = stats.message_count
            self._first, self._last = stats.message_start_time, stats.message_end_time
            self._in_order = True
            self._metadata_records = records
        self._check()

    # -- opening ----------------------------------------------------------------------------
    def _read_indexed(self, f: io.BufferedReader) -> tuple | None:
        """Header, schemas, channels, metadata and statistics from the summary, if usable."""
        try:
            f.seek(0)
            reader = SeekingReader(f, validate_crcs=True)
            header = reader.get_header()
            summary = reader.get_summary()
            if summary is None or summary.statistics is None:
                return None
            stats = summary.statistics
            if (len(summary.metadata_indexes) != stats.metadata_count
                    or len(summary.channels) != stats.channel_count
                    or len(summary.schemas) != stats.schema_count):
                return None  # a summary without everything: scan instead
            metadata = list(reader.iter_metadata())
        except Exception:  # no valid footer or summary: read as a stream instead
            return None
        return header, dict(summary.schemas), dict(summary.channels), metadata, stats

    def _scan(self) -> None:
        stream = RecordStream(self.path)
        self._header = None
        self.mcap_schemas = {}
        self.mcap_channels = {}
        self._metadata_records = []
        self._counts = {}
        self.message_count = 0
        self._first = self._last = None
        self._in_order = True
        for record in stream.records():
            if isinstance(record, Message):
                self.message_count += 1
                cid, t = record.channel_id, record.log_time
                self._counts[cid] = self._counts.get(cid, 0) + 1
                if self._first is None:
                    self._first = self._last = t
                else:
                    self._in_order = self._in_order and t >= self._last
                    self._first, self._last = min(self._first, t), max(self._last, t)
            elif isinstance(record, Schema):
                self.mcap_schemas.setdefault(record.id, record)
            elif isinstance(record, Channel):
                self.mcap_channels.setdefault(record.id, record)
            elif isinstance(record, Metadata):
                self._metadata_records.append(record)
            elif isinstance(record, Header):
                self._header = record
        if self._header is None:
            raise ReaderError(f'{self.path}: corrupt MCAP file: no readable header '
                              f'({stream.problem or "no records"})')
        self.readable_bytes = stream.good_end
        self.damaged = stream.damaged
        if not stream.footer:
            self.truncated = True
            self.truncation = (f'no valid footer: read up to byte {stream.good_end} of '
                               f'{self.size}; {stream.problem or "the file ends there"}')

    def _check(self) -> None:
        if self._header.profile != PROFILE:
            raise ReaderError(f"{self.path}: MCAP profile '{self._header.profile}', not "
                              f"'{PROFILE}': not a ROS 2 recording")
        self.library = self._header.library
        self.metadata = {m.name: dict(m.metadata) for m in self._metadata_records}
        self.topics: dict[str, TopicInfo] = {}
        self._topic_of: dict[int, str] = {}
        for cid, ch in sorted(self.mcap_channels.items()):
            schema = self.mcap_schemas.get(ch.schema_id)
            if (ch.message_encoding != MESSAGE_ENCODING or schema is None
                    or schema.encoding not in SCHEMA_ENCODINGS):
                found = 'no schema' if schema is None else f"schema encoding '{schema.encoding}'"
                raise ReaderError(f'{self.path}: channel {ch.topic} has message encoding '
                                  f"'{ch.message_encoding}' and {found}; a ROS 2 recording has "
                                  f"'{MESSAGE_ENCODING}' with {' or '.join(SCHEMA_ENCODINGS)}")
            count = self._counts.get(cid, 0)
            known = self.topics.get(ch.topic)
            if known is not None:
                if known.type_name != schema.name:
                    raise ReaderError(f'{self.path}: topic {ch.topic} is recorded with two '
                                      f'types, {known.type_name} and {schema.name}')
                count += known.message_count
            self.topics[ch.topic] = TopicInfo(
                schema.name, count, ch.metadata.get('offered_qos_profiles', ''),
                ch.metadata.get('topic_type_hash') or None, ch.message_encoding,
                schema.encoding)
            self._topic_of[cid] = ch.topic
        self.channels = {topic: info.type_name for topic, info in self.topics.items()}
        self.start_time_ns = self._first if self.message_count else None
        self.end_time_ns = self._last if self.message_count else None

    def schema(self, topic: str) -> str:
        """The schema text recorded for ``topic``; ReaderError if there is no such topic."""
        if topic not in self.topics:
            raise ReaderError(f'{self.path}: no topic {topic}')
        cid = next(c for c, t in self._topic_of.items() if t == topic)
        return self.mcap_schemas[self.mcap_channels[cid].schema_id].data.decode('utf-8', 'replace')

    # -- messages ---------------------------------------------------------------------------
    def _channel_ids(self, topics: Iterable[str] | str | None) -> set[int]:
        if topics is None:
            return set(self._topic_of)
        wanted = {topics} if isinstance(topics, str) else set(topics)
        unknown = wanted - set(self.topics)
        if unknown:
            raise ReaderError(f'{self.path}: no topics {sorted(unknown)} (it has '
                              f'{", ".join(sorted(self.topics)) or "none"})')
        return {cid for cid, topic in self._topic_of.items() if topic in wanted}

    def _raw(self, ids: set[int]) -> Iterator[Message]:
        """The Message records on channels ``ids``, in log-time order."""
        if self._indexed:
            yield from self._raw_indexed(ids)
            return
        messages = self._raw_streamed(ids)
        if not self._in_order:
            messages = iter(sorted(messages, key=lambda m: m.log_time))
        yield from messages

    def _raw_indexed(self, ids: set[int]) -> Iterator[Message]:
        topics = {self._topic_of[cid] for cid in ids}
        try:
            with open(self.path, 'rb') as f:
                reader = SeekingReader(f, validate_crcs=True)
                for _schema, channel, message in reader.iter_messages(topics=topics,
                                                                      log_time_order=True):
                    if channel.id in ids:
                        yield message
        except ReaderError:
            raise
        except OSError as e:
            raise ReaderError(f'{self.path}: cannot read: {e.strerror}') from None
        except Exception as e:  # the library's own errors, reported as ours
            raise ReaderError(f'{self.path}: corrupt data inside the file ({type(e).__name__}: '
                              f'{e}); recover() copies everything else') from None

    def _raw_streamed(self, ids: set[int]) -> Iterator[Message]:
        left = self.message_count  # the file may have grown since: stop where the scan did
        for record in RecordStream(self.path).records():
            if left == 0:
                return
            if isinstance(record, Message):
                left -= 1
                if record.channel_id in ids:
                    yield record

    def raw_messages(self, topics: Iterable[str] | str | None = None) -> Iterator[RawMessage]:
        """RawMessage (topic, CDR bytes, log_time_ns, publish_time_ns, sequence) in log-time
        order, of all topics or of ``topics``; ReaderError for an unknown topic or corrupt
        data."""
        topic_of = self._topic_of
        for m in self._raw(self._channel_ids(topics)):
            yield RawMessage(topic_of[m.channel_id], m.data, m.log_time, m.publish_time,
                             m.sequence)

    def messages(self, topics: Iterable[str] | str | None = None
                 ) -> Iterator[RecordedMessage]:
        """RecordedMessage (topic, rclpy message, log_time_ns, publish_time_ns, sequence) in
        log-time order, of all topics or of ``topics``.

        Raises ReaderError for an unknown topic, a type that is not installed here, corrupt
        data, or bytes that do not deserialise as the topic's type.
        """
        ids = self._channel_ids(topics)
        classes = {cid: message_class(self.topics[self._topic_of[cid]].type_name)
                   for cid in ids}
        topic_of = self._topic_of
        for m in self._raw(ids):
            topic = topic_of[m.channel_id]
            yield RecordedMessage(topic, self._decode(topic, m.data, m.log_time,
                                                      classes[m.channel_id]),
                                  m.log_time, m.publish_time, m.sequence)

    def deserialize(self, raw: RawMessage) -> RecordedMessage:
        """``raw`` (from ``raw_messages``) as ``messages`` gives it; ReaderError as there."""
        cls = message_class(self.topics[raw.topic].type_name)
        return RecordedMessage(raw.topic, self._decode(raw.topic, raw.data, raw.log_time_ns, cls),
                               raw.log_time_ns, raw.publish_time_ns, raw.sequence)

    def _decode(self, topic: str, data: bytes, log_time: int, cls: type) -> Any:
        try:
            return deserialize_message(data, cls)
        except Exception as e:  # rclpy raises several types for bad bytes
            stop = interrupt_in(e)
            if stop is not None:  # Ctrl-C during the conversion: not the file's fault
                raise stop from None
            raise ReaderError(f'{self.path}: the message on {topic} at {log_time} ns does not '
                              f'deserialise as {self.topics[topic].type_name}: {e}') from None

    def __repr__(self) -> str:
        state = f'truncated: {self.truncation}' if self.truncated else 'complete'
        return (f'RecordingReader({self.path!r}: {self.message_count} messages on '
                f'{len(self.topics)} topics, {state})')
