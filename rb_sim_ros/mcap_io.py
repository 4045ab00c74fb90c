# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""MCAP files that ROS 2 tools read: a non-blocking writer, a reader, and recovery.

The files follow the ``ros2`` profile as rosbag2's MCAP storage on Jazzy writes it: message
encoding ``cdr`` (rclpy's own serialisation), schema encoding ``ros2msg`` with the full
dependency text taken from the installed .msg files, and ``offered_qos_profiles`` channel
metadata in Jazzy's YAML form. A bare .mcap of this form opens in ``ros2 bag info/play``,
Foxglove and the ``rosbags`` library.

Durability: the file is chunked (zstd) and indexed; chunks are small and every finished chunk is
flushed to the OS, so a process killed with SIGKILL leaves a file readable up to its last
complete chunk, which ``recover`` turns into a finalised copy.

Timestamps are integer nanoseconds, always passed in; nothing reads the wall clock.
"""

from __future__ import annotations

import importlib
import io
import os
from pathlib import Path
import queue
import re
import sys
import threading
from typing import Any, Iterator

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rclpy.serialization import deserialize_message, serialize_message

PROFILE = 'ros2'
CHUNK_SIZE = 64 * 1024
SEPARATOR = '=' * 80
PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
              'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'}
# rclpy's defaults for the infinite durations, as rosbag2 writes them.
_INFINITE = {'sec': 9223372036, 'nsec': 854775807}


class WriterError(Exception):
    """A recording could not be written; the message says what and where."""


class ReaderError(Exception):
    """A file is not a readable recording; the message says what and where."""


# -- schemas --------------------------------------------------------------------------------
def _share_dirs() -> list[Path]:
    dirs = [Path(p) / 'share' for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
            if p]
    dirs.append(Path(sys.prefix) / 'share')
    return dirs


def msg_file(type_name: str) -> Path:
    """The installed .msg file of 'pkg/msg/Type' (or 'pkg/Type')."""
    pkg, _, name = type_name.replace('/msg/', '/').partition('/')
    for share in _share_dirs():
        path = share / pkg / 'msg' / f'{name}.msg'
        if path.is_file():
            return path
    raise WriterError(f'no installed .msg file for {type_name} (searched the share/ folders of '
                      'AMENT_PREFIX_PATH and of this Python)')


def _dependencies(pkg: str, text: str) -> list[str]:
    """The non-primitive field types of a .msg text, as 'pkg/Type', in order."""
    deps = []
    for line in text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        base = re.sub(r'(\[.*\]|<=\d+)$', '', line.split()[0])  # arrays, bounded strings
        if base in PRIMITIVES:  # constants ('uint8 OK=0') are always primitive
            continue
        deps.append((base if '/' in base else f'{pkg}/{base}').replace('/msg/', '/'))
    return deps


def schema_text(type_name: str) -> str:
    """The ros2msg schema of 'pkg/msg/Type': its .msg text and, after separators, that of every
    type it uses, depth first, each once (as rosbag2 writes it)."""
    main = type_name.replace('/msg/', '/')
    parts, seen, todo = [], {main}, []
    text = msg_file(main).read_text()
    parts.append(text.rstrip('\n'))
    todo.extend(_dependencies(main.split('/')[0], text))
    while todo:
        dep = todo.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        dep_text = msg_file(dep).read_text()
        parts.append(f'{SEPARATOR}\nMSG: {dep}\n{dep_text.rstrip(chr(10))}')
        todo = _dependencies(dep.split('/')[0], dep_text) + todo
    return '\n'.join(parts) + '\n'


def type_name_of(msg_type) -> str:
    """'pkg/msg/Type' of an rclpy message class."""
    module = msg_type.__module__.split('.')
    return f'{module[0]}/msg/{msg_type.__name__}'


def message_class(type_name: str):
    """The rclpy message class of 'pkg/msg/Type'; ReaderError if it is not installed."""
    pkg, _, name = type_name.partition('/msg/')
    try:
        return getattr(importlib.import_module(f'{pkg}.msg'), name)
    except (ImportError, AttributeError):
        raise ReaderError(f'message type {type_name} is not installed here') from None


def qos_yaml(depth: int = 10, reliable: bool = True, transient_local: bool = False) -> str:
    """offered_qos_profiles as rosbag2 writes it on Jazzy (a YAML list of one profile)."""
    def duration(name):
        return f'  {name}:\n    sec: {_INFINITE["sec"]}\n    nsec: {_INFINITE["nsec"]}\n'
    return ('- history: keep_last\n'
            f'  depth: {depth}\n'
            f'  reliability: {"reliable" if reliable else "best_effort"}\n'
            f'  durability: {"transient_local" if transient_local else "volatile"}\n'
            + duration('deadline') + duration('lifespan')
            + '  liveliness: automatic\n' + duration('liveliness_lease_duration')
            + '  avoid_ros_namespace_conventions: false\n')


# -- writing --------------------------------------------------------------------------------
class RecordingWriter:
    """Writes a ros2-profile MCAP file; a context manager with an idempotent ``finish()``.

    ``write`` serialises on the caller's thread (microseconds, C) and queues the bytes; a
    background thread compresses and writes, so the caller never waits on the disk. Refuses to
    overwrite an existing file unless ``overwrite``.
    """

    def __init__(self, path: str, overwrite: bool = False, chunk_size: int = CHUNK_SIZE,
                 library: str = 'rb_sim_ros') -> None:
        self.path = str(path)
        try:
            raw = open(self.path, 'wb' if overwrite else 'xb', buffering=0)
        except FileExistsError:
            raise WriterError(f'{self.path}: exists; refusing to overwrite it '
                              '(record_overwrite:=true to replace it)') from None
        except OSError as e:
            raise WriterError(f'{self.path}: cannot create: {e.strerror}') from None
        # mcap's Writer hands each finished chunk to its stream in one write; with a one-byte
        # buffer that write goes straight to the OS, so a finished chunk survives SIGKILL.
        self._file = io.BufferedWriter(raw, buffer_size=1)
        self._writer = Writer(self._file, chunk_size=chunk_size,
                              compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library=library)
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._error: Exception | None = None
        self._finished = False
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._drain, name='mcap_writer', daemon=True)
        self._thread.start()

    def register_topic(self, topic: str, msg_type, qos: str | None = None) -> None:
        """Declare ``topic`` carrying rclpy messages of class ``msg_type``."""
        self._check_open()
        if topic in self._channels:
            raise WriterError(f'{self.path}: topic {topic} is already registered')
        name = type_name_of(msg_type)
        if name not in self._schemas:
            self._schemas[name] = self._writer.register_schema(
                name=name, encoding='ros2msg', data=schema_text(name).encode())
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding='cdr', schema_id=self._schemas[name],
            metadata={'offered_qos_profiles': qos or qos_yaml()})

    def write(self, topic: str, msg, log_time_ns: int, publish_time_ns: int | None = None,
              sequence: int = 0) -> None:
        """Queue ``msg`` on ``topic`` at ``log_time_ns`` (integer ns); returns at once."""
        self._check_open()
        try:
            channel = self._channels[topic]
        except KeyError:
            raise WriterError(f'{self.path}: topic {topic} was not registered') from None
        self._queue.put((channel, int(log_time_ns), serialize_message(msg),
                         int(log_time_ns if publish_time_ns is None else publish_time_ns),
                         int(sequence) & 0xFFFFFFFF))

    def write_metadata(self, name: str, data: dict[str, str]) -> None:
        """An MCAP metadata record (string keys and values)."""
        self._check_open()
        self._queue.put(('metadata', name, {str(k): str(v) for k, v in data.items()}))

    def _drain(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            try:
                if item[0] == 'metadata':
                    self._writer.add_metadata(item[1], item[2])
                else:
                    channel, log_time, data, publish_time, sequence = item
                    self._writer.add_message(channel, log_time, data, publish_time, sequence)
            except Exception as e:  # kept, and raised to the caller at finish()
                self._error = self._error or e

    def _check_open(self) -> None:
        if self._finished:
            raise WriterError(f'{self.path}: already finished')

    def finish(self) -> None:
        """Write everything queued, the summary and the footer; close. Idempotent."""
        with self._lock:
            if self._finished:
                return
            self._finished = True
            self._queue.put(None)
            self._thread.join()
            try:
                self._writer.finish()
            finally:
                self._file.close()
        if self._error is not None:
            raise WriterError(f'{self.path}: writing failed: {self._error!r}')

    def __enter__(self) -> 'RecordingWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.finish()


# -- reading --------------------------------------------------------------------------------
class RecordingReader:
    """Reads a ros2-profile MCAP file, complete or cut short (killed while writing).

    ``metadata`` maps each metadata record's name to its dict; ``channels`` maps topics to
    'pkg/msg/Type'; ``messages()`` yields (topic, message, log_time_ns, publish_time_ns,
    sequence) in log-time order; ``truncated`` says the file had no valid end and was read as
    a stream up to its last complete record.
    """

    def __init__(self, path: str) -> None:
        self.path = str(path)
        try:
            with open(self.path, 'rb') as f:
                data = f.read()
        except OSError as e:
            raise ReaderError(f'{self.path}: cannot read: {e.strerror}') from None
        if not data.startswith(b'\x89MCAP0\r\n'):
            raise ReaderError(f'{self.path}: not an MCAP file (no MCAP magic at its start)')
        self.truncated = False
        self._records = self._read_all(data)
        header = self._records['header']
        if header is not None and header.profile != PROFILE:
            raise ReaderError(f"{self.path}: MCAP profile '{header.profile}', not '{PROFILE}'")
        self.metadata = {m.name: dict(m.metadata) for m in self._records['metadata']}
        self.channels = {}
        for ch in self._records['channels'].values():
            schema = self._records['schemas'].get(ch.schema_id)
            if ch.message_encoding != 'cdr' or schema is None or schema.encoding != 'ros2msg':
                raise ReaderError(f'{self.path}: channel {ch.topic} is not cdr/ros2msg '
                                  f'({ch.message_encoding})')
            self.channels[ch.topic] = schema.name

    def _read_all(self, data: bytes) -> dict:
        out = {'header': None, 'schemas': {}, 'channels': {}, 'messages': [], 'metadata': []}
        try:
            reader = make_reader(io.BytesIO(data))
            out['header'] = reader.get_header()
            summary = reader.get_summary()
            if summary is None:
                raise McapError('no summary')
            out['schemas'] = dict(summary.schemas)
            out['channels'] = dict(summary.channels)
            out['messages'] = [m for _s, _c, m in reader.iter_messages(log_time_order=True)]
            out['metadata'] = list(reader.iter_metadata())
            return out
        except (McapError, ValueError, EOFError, OSError, KeyError, AssertionError):
            pass
        except Exception:  # the mcap library raises bare errors on some corruptions
            pass
        # No usable footer/summary: read as a stream, keeping every complete record.
        self.truncated = True
        out = {'header': None, 'schemas': {}, 'channels': {}, 'messages': [], 'metadata': []}
        try:
            for record in StreamReader(io.BytesIO(data)).records:
                if isinstance(record, Schema):
                    out['schemas'][record.id] = record
                elif isinstance(record, Channel):
                    out['channels'][record.id] = record
                elif isinstance(record, Message):
                    out['messages'].append(record)
                elif isinstance(record, Metadata):
                    out['metadata'].append(record)
                elif type(record).__name__ == 'Header':
                    out['header'] = record
        except Exception:  # cut inside a record or chunk: keep what came before
            pass
        if out['header'] is None:
            raise ReaderError(f'{self.path}: corrupt MCAP: not even its header is readable')
        out['messages'].sort(key=lambda m: m.log_time)
        return out

    def messages(self) -> Iterator[tuple[str, Any, int, int, int]]:
        by_id = {ch.id: ch for ch in self._records['channels'].values()}
        classes = {topic: message_class(name) for topic, name in self.channels.items()}
        for m in self._records['messages']:
            ch = by_id.get(m.channel_id)
            if ch is None:
                raise ReaderError(f'{self.path}: message on unknown channel {m.channel_id}')
            try:
                msg = deserialize_message(m.data, classes[ch.topic])
            except Exception as e:
                raise ReaderError(f'{self.path}: cannot decode a message on {ch.topic} at '
                                  f'{m.log_time} ns: {e}') from None
            yield ch.topic, msg, m.log_time, m.publish_time, m.sequence


def recover(src: str, dst: str, overwrite: bool = False) -> dict[str, int]:
    """Write a finalised copy of ``src`` (killed while recording) holding every complete
    message, schema, channel and metadata record; returns counts."""
    reader = RecordingReader(src)
    try:
        f = open(dst, 'wb' if overwrite else 'xb')
    except FileExistsError:
        raise WriterError(f'{dst}: exists; refusing to overwrite it') from None
    recs = reader._records
    with f:
        w = Writer(f, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        w.start(profile=PROFILE, library=(recs['header'].library if recs['header'] else ''))
        schema_ids = {sid: w.register_schema(s.name, s.encoding, s.data)
                      for sid, s in sorted(recs['schemas'].items())}
        channel_ids = {cid: w.register_channel(c.topic, c.message_encoding,
                                               schema_ids[c.schema_id], dict(c.metadata))
                       for cid, c in sorted(recs['channels'].items())}
        for m in recs['metadata']:
            w.add_metadata(m.name, dict(m.metadata))
        for m in recs['messages']:
            w.add_message(channel_ids[m.channel_id], m.log_time, m.data, m.publish_time,
                          m.sequence)
        w.finish()
    return {'messages': len(recs['messages']), 'channels': len(recs['channels']),
            'metadata': len(recs['metadata'])}
