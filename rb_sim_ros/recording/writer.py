# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""RecordingWriter: a ROS 2 (rosbag2-compatible) MCAP file, written without stalling the caller.

The caller's thread only checks arguments and serialises (``cdr``'s serialiser of the type,
or rclpy's for a type it does not handle: microseconds);
the bytes go through a queue to a background thread that builds chunks, compresses them and
writes them. Each finished chunk goes to the OS in one ``os.write`` (no user-space buffer), so a
process killed with SIGKILL leaves a file readable up to its last finished chunk; a chunk is
finished when it reaches ``chunk_size`` bytes or, when messages are few, ``max_chunk_age_s``
seconds after its first message.

A write that fails on the background thread (disk full, I/O error, file size limit) stops the
recording there and never raises on the caller's thread: ``failed`` says why, later writes are
cheap no-ops, and the file keeps every record written before the failure (``recover`` finalises
it). Only ``finish`` raises it, once, for a caller that wants to know at the end.
"""

from __future__ import annotations

import atexit
import dataclasses
import errno
import io
import operator
import os
import queue
import struct
import threading
import time
from typing import Any, Mapping
import weakref

from mcap.writer import CompressionType, LIBRARY_IDENTIFIER, Writer
from rclpy.serialization import serialize_message

from rb_sim_ros.recording.bag_info import (bag_information, dump, METADATA_KEY, METADATA_NAME,
                                           TopicSummary)
from rb_sim_ros.recording.cdr import encoder
from rb_sim_ros.recording.errors import WriterError
from rb_sim_ros.recording.qos import offered_qos_profiles
from rb_sim_ros.recording.schemas import schema_text, type_hash, type_name_of

PROFILE = 'ros2'
MESSAGE_ENCODING = 'cdr'
SCHEMA_ENCODING = 'ros2msg'
CHUNK_SIZE = 64 * 1024
# The writer's name in the file's header: the caller hands its own (the node recorder says
# rb_sim_ros and its version); this package's layers below ros import nothing above them.
LIBRARY = LIBRARY_IDENTIFIER
COMPRESSION = {'zstd': CompressionType.ZSTD, 'lz4': CompressionType.LZ4,
               'none': CompressionType.NONE}
_U64 = 2**64
try:  # mcap 1.x's internals, for _Writer's fast path (without them: mcap's own add_message)
    from mcap._chunk_builder import ChunkBuilder
    from mcap.data_stream import RecordBuilder
    from mcap.records import MessageIndex
    _FAST_MCAP = True
except ImportError:  # pragma: no cover - another mcap
    _FAST_MCAP = False
_MESSAGE_OPCODE = 0x05  # MCAP's Message record
# Queue items: tuples whose first element says what they are.
_MESSAGE, _SCHEMA, _CHANNEL, _METADATA, _FLUSH, _FINISH = range(6)
_YIELD_EVERY = 16  # messages written in a row (~70 us) before the writer thread lets others run

_open_writers: weakref.WeakSet = weakref.WeakSet()


@atexit.register
def _finish_open_writers() -> None:
    """Finalise recordings still open at interpreter exit (not after SIGKILL, obviously)."""
    for writer in list(_open_writers):
        try:
            writer.finish()
        except WriterError:
            pass


class _Sink:
    """The file as mcap's Writer sees it: every write goes to the OS at once, in full."""

    def __init__(self, fd: int, fsync: bool) -> None:
        self.fd = fd
        self.position = 0
        self.synced = 0
        self._fsync = fsync

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view):]
        self.position += len(data)
        return len(data)

    def tell(self) -> int:
        return self.position

    def flush(self) -> None:
        if self._fsync and self.synced != self.position:
            os.fsync(self.fd)
            self.synced = self.position


class _Writer(Writer):
    """mcap's Writer, its ``add_message`` done in one struct call and one buffer write where
    its state is what this was written against (mcap 1.x: the chunk builder's record buffer,
    message indexes and times, the statistics): the same bytes, faster (a campaign's run
    writes thousands of small messages). Otherwise (``fast`` False: another mcap) mcap's own.
    (The class is named as mcap's so that ``self._Writer__x`` is mcap's private ``__x``.)"""

    _HEAD = struct.Struct('<BQHIQQ')  # opcode, record length, channel, sequence, times

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        builder = getattr(self, '_Writer__chunk_builder', None)
        stats = getattr(self, '_Writer__statistics', None)
        self.fast = (_FAST_MCAP and isinstance(builder, ChunkBuilder) and stats is not None and
                     isinstance(getattr(builder, 'record_writer', None), RecordBuilder) and
                     isinstance(getattr(builder.record_writer, '_buffer', None), io.BytesIO)
                     and isinstance(getattr(self, '_Writer__chunk_size', None), int)
                     and callable(getattr(self, '_Writer__finalize_chunk', None))
                     and all(hasattr(stats, a) for a in (
                         'message_count', 'message_start_time', 'message_end_time',
                         'channel_message_counts')))

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        if not self.fast:
            super().add_message(channel_id, log_time, data, publish_time, sequence)
            return
        stats = self._Writer__statistics  # type: ignore[attr-defined]
        if stats.message_count == 0 or log_time < stats.message_start_time:
            stats.message_start_time = log_time
        if log_time > stats.message_end_time:
            stats.message_end_time = log_time
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1
        builder = self._Writer__chunk_builder  # type: ignore[attr-defined]
        if builder.num_messages == 0 or log_time < builder.message_start_time:
            builder.message_start_time = log_time
        if log_time > builder.message_end_time:
            builder.message_end_time = log_time
        buffer = builder.record_writer._buffer
        index = builder.message_indices.get(channel_id)
        if index is None:
            index = builder.message_indices[channel_id] = MessageIndex(
                channel_id=channel_id, records=[])
        index.records.append((log_time, buffer.tell()))
        builder.num_messages += 1
        buffer.write(self._HEAD.pack(_MESSAGE_OPCODE, 22 + len(data), channel_id, sequence,
                                     log_time, publish_time))
        buffer.write(data)
        if buffer.tell() > self._Writer__chunk_size:  # type: ignore[attr-defined]
            self._Writer__finalize_chunk()  # type: ignore[attr-defined]


class _Inline:
    """The writer's queue without a thread: each item is written as it is put."""

    def __init__(self, consume) -> None:
        self._consume = consume

    def put(self, item) -> None:
        self._consume(item)

    def qsize(self) -> int:
        return 0


def _ns(value: Any, name: str, path: str, topic: str) -> int:
    try:
        ns = operator.index(value)
    except TypeError:
        raise WriterError(f'{path}: topic {topic}: {name} {value!r} is not an integer number '
                          'of nanoseconds') from None
    if not 0 <= ns < _U64:
        raise WriterError(f'{path}: topic {topic}: {name} {ns} is outside [0, 2**64) '
                          'nanoseconds')
    return ns


def _reason(e: BaseException) -> str:
    """'No space left on device (ENOSPC)' for an OSError, else the exception's repr."""
    if isinstance(e, OSError) and e.strerror:
        code = errno.errorcode.get(e.errno or 0)
        return f'{e.strerror} ({code})' if code else e.strerror
    return repr(e)


class RecordingWriter:
    """Writes one MCAP file of the ``ros2`` profile that ``ros2 bag``, Foxglove and rosbags read.

    ``path``: the file to create; refused (WriterError) if it exists, unless ``overwrite``.
    ``chunk_size``: bytes of messages per chunk (before compression); small chunks reach the
    disk often. ``compression``: 'zstd' (default), 'lz4' or 'none'. ``max_chunk_age_s``:
    finish a chunk this long (seconds, wall time) after its first message even if it is not
    full, so a quiet recording still reaches the disk; None waits for full chunks.
    ``fsync``: also fsync after each chunk (survives power loss, not only SIGKILL; slower).
    ``bag_info``: write rosbag2's ``rosbag2`` metadata record (bag information) when the file
    opens and again, with the counts, at its end, as ``ros2 bag record`` does; so a file cut
    short still has one. Message timestamps are always passed in (integer nanoseconds); the
    writer never reads a clock for them. ``background`` False writes inline, on the caller's
    thread (no writer thread: for a process that does nothing else, such as a sweep's
    worker; chunks then close by size only, and only that one thread may write).

    Use as a context manager, or call ``finish()`` (idempotent); a writer still open when the
    interpreter exits is finished then. A file that cannot be created or started raises
    WriterError (a ValueError) naming the path and the reason. A failure of the background
    thread (disk full...) stops the recording: ``failed`` (poll it) holds its text, ``error``
    the WriterError; ``write``, ``register_topic``, ``write_metadata`` and ``flush`` then do
    nothing and raise nothing; ``finish`` closes the file without a footer (``recover`` it)
    and raises the error once. Any thread may call ``write``; the queue is unbounded
    (``pending`` tells its length), so a disk slower than the messages costs memory, never the
    caller's time.
    """

    def __init__(self, path: str | os.PathLike, overwrite: bool = False,
                 chunk_size: int = CHUNK_SIZE, compression: str = 'zstd',
                 library: str = LIBRARY, max_chunk_age_s: float | None = 1.0,
                 fsync: bool = False, bag_info: bool = True, background: bool = True) -> None:
        self.path = os.fspath(path)
        if compression not in COMPRESSION:
            raise WriterError(f'{self.path}: compression {compression!r} is not one of '
                              f'{", ".join(COMPRESSION)}')
        if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
            raise WriterError(f'{self.path}: chunk_size {chunk_size!r} is not a positive '
                              'number of bytes')
        if max_chunk_age_s is not None and not max_chunk_age_s > 0:
            raise WriterError(f'{self.path}: max_chunk_age_s {max_chunk_age_s!r} is not a '
                              'positive number of seconds (or None)')
        flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if overwrite else os.O_EXCL)
        try:
            fd = os.open(self.path, flags, 0o644)
        except FileExistsError:
            raise WriterError(f'{self.path}: exists; refusing to overwrite it (overwrite=True '
                              'to replace it)') from None
        except OSError as e:
            raise WriterError(f'{self.path}: cannot create: {_reason(e)}') from None
        self._sink = _Sink(fd, fsync)
        self._mcap = _Writer(self._sink,  # type: ignore[arg-type] # a file-like sink
                             chunk_size=chunk_size,
                             compression=COMPRESSION[compression])
        try:
            self._mcap.start(profile=PROFILE, library=library)
            if bag_info:  # as rosbag2 does when it opens a file: nothing recorded yet
                info = bag_information(os.path.basename(self.path), [], None, None)
                self._mcap.add_metadata(METADATA_NAME, {METADATA_KEY: dump(info)})
        except OSError as e:
            os.close(fd)
            if not overwrite:  # created here: leave nothing behind
                os.unlink(self.path)
            raise WriterError(f'{self.path}: cannot write: {_reason(e)}') from None
        self.compression = compression
        self._bag_info = bag_info
        self._max_age = max_chunk_age_s
        # topic -> (channel id, message type, its serialiser)
        self._topics: dict[str, tuple[int, type, Any]] = {}
        self._schemas: dict[str, int] = {}
        self._summaries: dict[int, TopicSummary] = {}
        self._counts: dict[int, int] = {}
        self._times: list[int] = []  # [first, last] log time written, once there is one
        self._error: WriterError | None = None
        # when the chunk in progress must be finished (monotonic)
        self._deadline: float | None = None
        self._in_a_row = 0
        self._closing = False
        self._finished = False
        self._lock = threading.Lock()
        self._register_lock = threading.Lock()
        if background:
            self._queue: Any = queue.SimpleQueue()
            self._thread: threading.Thread | None = threading.Thread(
                target=self._run, name=f'mcap writer {self.path}', daemon=True)
            self._thread.start()
        else:  # every call writes before it returns: no thread (a sweep's worker)
            self._queue = _Inline(self._consume)
            self._thread = None
        _open_writers.add(self)

    # -- the caller's side ------------------------------------------------------------------
    def register_topic(self, topic: str, msg_type: type, qos: Any = None) -> None:
        """Declare ``topic`` (fully qualified, '/name') carrying messages of ``msg_type``.

        ``msg_type``: an rclpy message class, e.g. ``geometry_msgs.msg.PoseStamped``. ``qos``:
        the publisher's offered QoS (rclpy ``QoSProfile``, a dict, see ``qos.py``, or None for
        keep_last 10 reliable volatile). Refuses (WriterError) a topic registered twice, a
        relative topic name, a non-message class, a type whose .msg files are not installed,
        and bad QoS.
        """
        self._check_open()
        if self._error is not None:
            return
        where = f'{self.path}: topic {topic!r}'
        if not isinstance(topic, str) or not topic.startswith('/') or len(topic) < 2:
            raise WriterError(f'{where} is not a fully qualified topic name like /pose')
        name = type_name_of(msg_type)
        qos_yaml = offered_qos_profiles(qos, where)
        text = schema_text(name)  # WriterError if not installed: nothing queued yet
        digest = type_hash(name)
        try:  # (made before anything is queued; rclpy's for a type it cannot make)
            encode = encoder(msg_type) or serialize_message
        except Exception:  # noqa: B902 - whatever a foreign message class does: rclpy's way
            encode = serialize_message
        metadata = {'offered_qos_profiles': qos_yaml}
        if digest is not None:
            metadata['topic_type_hash'] = digest
        with self._register_lock:  # ids are counted here and in the writer thread alike
            self._check_open()
            if topic in self._topics:
                raise WriterError(f'{where} is already registered')
            schema_id = self._schemas.get(name)
            if schema_id is None:
                schema_id = self._schemas[name] = len(self._schemas) + 1
                self._queue.put((_SCHEMA, schema_id, name, text.encode()))
            channel_id = len(self._topics) + 1
            self._summaries[channel_id] = TopicSummary(topic, name, qos_yaml, digest or '', 0)
            self._queue.put((_CHANNEL, channel_id, topic, schema_id, metadata))
            self._topics[topic] = (channel_id, msg_type, encode)

    def write(self, topic: str, msg: Any, log_time_ns: int, publish_time_ns: int | None = None,
              sequence: int = 0) -> None:
        """Queue ``msg`` on ``topic``; returns at once (serialisation only, on this thread).

        ``log_time_ns``/``publish_time_ns``: integer nanoseconds in [0, 2**64); publish time
        defaults to log time. ``sequence``: an integer, stored modulo 2**32 (MCAP's field is
        uint32). Refuses (WriterError) an unregistered topic, a message of another type than
        registered, non-integer or out-of-range times and writing after ``finish()``. Once
        writing the file has failed (``failed``), does nothing.
        """
        channel = self._channel(topic, type(msg))
        if channel is not None:
            self._put(topic, channel[0], channel[1](msg), log_time_ns, publish_time_ns,
                      sequence)

    def write_serialized(self, topic: str, data: bytes, msg_type: type, log_time_ns: int,
                         publish_time_ns: int | None = None, sequence: int = 0) -> None:
        """``write`` of a message of ``msg_type`` already serialised (``data``: its CDR bytes,
        encapsulation header first, as ``serialize_message`` gives them; the caller vouches
        that they are one). The same checks as ``write``."""
        channel = self._channel(topic, msg_type)
        if channel is None:
            return
        if type(data) is not bytes:
            raise WriterError(f'{self.path}: topic {topic}: serialised data must be bytes, '
                              f'not {type(data).__name__}')
        self._put(topic, channel[0], data, log_time_ns, publish_time_ns, sequence)

    def _channel(self, topic: str, msg_type: Any) -> tuple[int, Any] | None:
        """(channel id, serialiser) of registered ``topic`` for a message of ``msg_type``;
        None once writing has failed; WriterError after ``finish()``, for an unregistered
        topic or another type than registered."""
        if self._closing or self._error is not None:
            self._check_open()
            return None
        try:
            channel_id, registered, encode = self._topics[topic]
        except (KeyError, TypeError):
            raise WriterError(f'{self.path}: topic {topic!r} was not registered') from None
        if msg_type is not registered:
            raise WriterError(f'{self.path}: topic {topic} carries {registered.__name__}, not '
                              f'{getattr(msg_type, "__name__", msg_type)}')
        return channel_id, encode

    def _put(self, topic: str, channel_id: int, data: bytes, log_time_ns, publish_time_ns,
             sequence) -> None:
        log = log_time_ns
        if type(log) is not int or not 0 <= log < _U64:
            log = _ns(log_time_ns, 'log_time_ns', self.path, topic)
        pub = log
        if publish_time_ns is not None:
            pub = _ns(publish_time_ns, 'publish_time_ns', self.path, topic)
        if type(sequence) is not int:
            try:
                sequence = operator.index(sequence)
            except TypeError:
                raise WriterError(f'{self.path}: topic {topic}: sequence {sequence!r} is not '
                                  'an integer') from None
        self._queue.put((_MESSAGE, channel_id, log, pub, sequence & 0xFFFFFFFF, data))

    def write_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Queue an MCAP metadata record ``name`` with string keys and values.

        Refuses (WriterError) non-string keys or values, an empty name, and the name 'rosbag2'
        (rosbag2's bag information, written by ``finish`` when ``bag_info``).
        """
        self._check_open()
        if self._error is not None:
            return
        if not isinstance(name, str) or not name:
            raise WriterError(f'{self.path}: metadata name {name!r} is not a non-empty string')
        if name == METADATA_NAME and self._bag_info:
            raise WriterError(f"{self.path}: metadata name '{name}' is rosbag2's own; "
                              'choose another')
        for key, value in data.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise WriterError(f'{self.path}: metadata {name!r}: {key!r}: {value!r} is not '
                                  'a string key and string value (use JSON for structures)')
        self._queue.put((_METADATA, name, dict(data)))

    def flush(self, wait: bool = False) -> None:
        """Finish the chunk in progress and hand it to the OS; with ``wait``, block until done.

        Refuses (WriterError) after ``finish()``; does nothing once writing has failed.
        """
        self._check_open()
        if self._error is not None:
            return
        done = threading.Event() if wait else None
        self._queue.put((_FLUSH, done))
        if done is not None:
            done.wait()

    def finish(self) -> None:
        """Write all that is queued, the summary and the footer, and close the file.

        Blocks until done. Idempotent: later calls do nothing. Raises WriterError (once) if
        writing failed; the file then holds what was written before the failure.
        """
        with self._lock:
            if self._finished:
                return
            self._closing = True
            self._queue.put((_FINISH,))
            if self._thread is not None:
                self._thread.join()
            self._finished = True
            _open_writers.discard(self)
            try:
                os.close(self._sink.fd)
            except OSError as e:
                self._error = self._error or WriterError(f'{self.path}: closing failed: '
                                                         f'{_reason(e)}')
        if self._error is not None:
            raise WriterError(str(self._error))

    @property
    def finished(self) -> bool:
        """True once ``finish()`` has been called."""
        return self._closing

    @property
    def failed(self) -> str | None:
        """Why writing the file failed (path and reason), or None while it has not. Once set,
        the recording has stopped: the file holds what was written before."""
        error = self._error
        return None if error is None else str(error)

    @property
    def error(self) -> WriterError | None:
        """The failure as a WriterError, or None (see ``failed``)."""
        return self._error

    @property
    def pending(self) -> int:
        """Items queued and not yet written (approximate)."""
        return self._queue.qsize()

    def _check_open(self) -> None:
        if self._closing:
            raise WriterError(f'{self.path}: finished; nothing more can be written to it')

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.finish()

    # -- the writer thread ------------------------------------------------------------------
    def _run(self) -> None:
        get = self._queue.get
        while True:
            if self._deadline is None:
                item = get()
            else:
                try:
                    item = get(timeout=max(0.0, self._deadline - time.monotonic()))
                except queue.Empty:
                    item = (_FLUSH, None)
            if self._consume(item):
                return

    def _consume(self, item) -> bool:
        """Write one queued item (on the writer thread, or inline without one); True after
        the finish."""
        mcap = self._mcap
        sink = self._sink
        kind = item[0]
        if self._error is not None and kind not in (_FLUSH, _FINISH):
            return False  # broken: drop everything until finish()
        try:
            if kind == _MESSAGE:
                _, channel_id, log, pub, seq, data = item
                before = sink.position
                mcap.add_message(channel_id, log, data, pub, seq)
                counts, times = self._counts, self._times
                counts[channel_id] = counts.get(channel_id, 0) + 1
                if times:
                    times[0], times[1] = min(times[0], log), max(times[1], log)
                else:
                    times[:] = [log, log]
                if sink.position != before:  # a chunk was finished and written
                    sink.flush()
                    self._deadline = None
                elif self._deadline is None and self._max_age is not None and \
                        self._thread is not None:
                    self._deadline = time.monotonic() + self._max_age
                if self._thread is not None:
                    self._in_a_row += 1
                    if self._in_a_row >= _YIELD_EVERY:
                        self._in_a_row = 0
                        time.sleep(0)  # let the caller's threads take the GIL
                return False
            self._in_a_row = 0
            if kind == _SCHEMA:
                _, schema_id, name, text = item
                if mcap.register_schema(name, SCHEMA_ENCODING, text) != schema_id:
                    raise RuntimeError(f'schema id mismatch for {name}')
            elif kind == _CHANNEL:
                _, channel_id, topic, schema_id, metadata = item
                if mcap.register_channel(topic, MESSAGE_ENCODING, schema_id,
                                         metadata) != channel_id:
                    raise RuntimeError(f'channel id mismatch for {topic}')
            elif kind == _METADATA:
                mcap.add_metadata(item[1], item[2])
                sink.flush()
            elif kind == _FLUSH:
                if self._error is None:
                    mcap.flush()
                self._deadline = None
                if item[1] is not None:
                    item[1].set()
            elif kind == _FINISH:
                if self._error is None:
                    self._finish_file()
                return True
        except Exception as e:  # kept for ``failed``; never raised on the caller's thread
            self._error = WriterError(
                f'{self.path}: writing failed: {_reason(e)}; recording stopped, the file '
                'keeps what was written before (replay --recover finalises it)')
            if kind == _FLUSH and item[1] is not None:
                item[1].set()
            if kind == _FINISH:
                return True
        return False

    def _finish_file(self) -> None:
        self._mcap.flush()  # the last chunk first: bag information describes finished data
        if self._bag_info:
            topics = [dataclasses.replace(s, message_count=self._counts.get(cid, 0))
                      for cid, s in sorted(self._summaries.items())]
            first, last = self._times or (None, None)
            info = bag_information(os.path.basename(self.path), topics, first, last)
            self._mcap.add_metadata(METADATA_NAME, {METADATA_KEY: dump(info)})
        self._mcap.finish()
        self._sink.flush()
