# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
"""The MCAP recording layer through tmp_path, checked against rosbags as an independent reader.

No ROS graph: only message classes and rclpy's serialisation. rosbags opens a bare .mcap file
(``AnyReader([path])``) and a bag directory (after ``write_rosbag2_metadata``); on a directory
it also checks every recorded ``type_description_hash`` against its own RIHS01 computation.
"""

import os
from pathlib import Path
import selectors
import signal
import subprocess
import sys
import time

from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Metadata
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from nav_msgs.msg import Odometry
import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag2 import Reader as Rosbag2Reader
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
import yaml

from rb_sim_ros.recording import (ReaderError, RecordingReader, RecordingWriter, recover,
                                  schema_text, type_hash, write_rosbag2_metadata, WriterError)
from rb_sim_ros.recording.compare import difference
from rb_sim_ros.recording.schemas import interface_file
from support.recordings import disk_full_after

ROOT = Path(__file__).resolve().parents[2]
TOPICS = [('/pose', PoseStamped), ('/twist', Twist), ('/odom', Odometry),
          ('/rb_sim/input/body/wrench', WrenchStamped)]
QOS = {'/twist': QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
       '/odom': {'depth': 5, 'durability': 'transient_local', 'deadline_ns': 1_500_000_000},
       '/rb_sim/input/body/wrench': {'history': 'keep_all'}}
META = {'config': '{"dt": 0.001, "bodies": ["body"]}', 'version': '0.1.0'}
QOS_KEYS = ['history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
            'liveliness', 'liveliness_lease_duration', 'avoid_ros_namespace_conventions']


def _message(i):
    """Message i of a recording: the four types in turn, every one with distinct values."""
    kind = i % 4
    if kind == 0:
        m = PoseStamped()
        m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id = i, 999_999_999 - i, 'w'
        p = m.pose.position
        p.x, p.y, p.z = 0.1 * i, -1e-300, 1e300
        m.pose.orientation.x, m.pose.orientation.w = 0.6, 0.8
    elif kind == 1:
        m = Twist()
        m.linear.x, m.linear.y, m.angular.z = float(i), -float(i), 1.0 / 3.0
    elif kind == 2:
        m = Odometry()
        m.header.frame_id, m.child_frame_id = 'odom', f'base_link_{i}'
        m.pose.covariance[i % 36] = i + 0.25
        m.twist.twist.angular.z = -2.0 ** -i
    else:
        m = WrenchStamped()
        m.header.frame_id = 'body'
        m.wrench.force.z, m.wrench.torque.x = 9.81 * i, 1e-3 * i
    return TOPICS[kind][0], m


def _record(path, n=400, **kwargs):
    """Write n messages (log time 1000 i ns, publish time +7, sequence i // 4) and metadata."""
    sent = []
    with RecordingWriter(path, **kwargs) as w:
        for topic, cls in TOPICS:
            w.register_topic(topic, cls, QOS.get(topic))
        w.write_metadata('rb_sim_ros', META)
        for i in range(n):
            topic, msg = _message(i)
            w.write(topic, msg, 1000 * i, 1000 * i + 7, i // 4)
            sent.append((topic, msg, 1000 * i, 1000 * i + 7, i // 4))
    return sent


def _rosbags(path):
    """(topic, log time, message) as rosbags decodes them with the file's own schemas."""
    with AnyReader([Path(path)]) as reader:
        return [(c.topic, t, reader.deserialize(raw, c.msgtype))
                for c, t, raw in reader.messages()]


def _assert_same(mine, theirs, where='msg'):
    """Every field of rclpy message ``mine`` equals the same field of rosbags' ``theirs``."""
    fields = getattr(mine, 'get_fields_and_field_types', None)
    if fields is not None:
        for name in fields():
            _assert_same(getattr(mine, name), getattr(theirs, name), f'{where}.{name}')
    elif isinstance(mine, (str, bool, int, float)):
        assert mine == theirs, where
    else:
        assert list(mine) == list(theirs), where


def _summary(path):
    with open(path, 'rb') as f:
        reader = make_reader(f)
        return reader.get_header(), reader.get_summary()


# -- round trips --------------------------------------------------------------------------------
def test_round_trip_reads_back_every_message_and_the_metadata(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _record(f)
    r = RecordingReader(f)
    assert not r.truncated and r.truncation == ''
    assert r.metadata['rb_sim_ros'] == META
    assert r.channels == {topic: f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'
                          for topic, cls in TOPICS}
    assert r.message_count == len(sent) and (r.start_time_ns, r.end_time_ns) == (0, 399_000)
    assert all(info.message_count == 100 for info in r.topics.values())
    assert [tuple(m) for m in r.messages()] == sent
    assert [m.message for m in r.messages('/odom')] == [m for t, m, *_ in sent if t == '/odom']
    assert [m.data for m in r.raw_messages(['/twist'])] == [
        serialize_message(m) for t, m, *_ in sent if t == '/twist']
    with pytest.raises(ReaderError, match=r"no topics \['/nope'\]"):
        list(r.messages('/nope'))


def test_rosbags_decodes_every_message_with_equal_fields(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _record(f)
    theirs = _rosbags(f)
    assert len(theirs) == len(sent)
    for (topic, mine, log, *_), (their_topic, their_log, their) in zip(sent, theirs):
        assert (their_topic, their_log) == (topic, log)
        _assert_same(mine, their, topic)


def test_a_bag_directory_for_rosbag2_readers_with_checked_type_hashes(tmp_path):
    bag = tmp_path / 'bag'
    bag.mkdir()
    sent = _record(bag / 'run.mcap')
    assert write_rosbag2_metadata(bag / 'run.mcap') == bag / 'metadata.yaml'
    with Rosbag2Reader(bag) as reader:  # rosbags' strict metadata.yaml (version 9) parser
        assert reader.message_count == len(sent)
        assert {c.topic: c.msgcount for c in reader.connections} == {t: 100 for t, _ in TOPICS}
    with AnyReader([bag]) as reader:  # checks each type_description_hash against its own
        assert all(c.digest.startswith('RIHS01_') for c in reader.connections)
        assert sum(1 for _ in reader.messages()) == len(sent)
    with pytest.raises(WriterError, match='metadata.yaml: exists; refusing to overwrite'):
        write_rosbag2_metadata(bag / 'run.mcap')
    write_rosbag2_metadata(bag / 'run.mcap', overwrite=True)


# -- what the file holds ------------------------------------------------------------------------
def test_file_is_ros2_profile_cdr_ros2msg_zstd_chunked_and_indexed(tmp_path):
    f = tmp_path / 'run.mcap'
    _record(f, chunk_size=4096)
    header, summary = _summary(f)
    assert header.profile == 'ros2'
    assert {c.message_encoding for c in summary.channels.values()} == {'cdr'}
    assert {s.encoding for s in summary.schemas.values()} == {'ros2msg'}
    for schema in summary.schemas.values():
        assert schema.data.decode() == schema_text(schema.name)
    assert len(summary.chunk_indexes) > 5
    assert all(c.compression == 'zstd' and c.message_index_offsets
               for c in summary.chunk_indexes)
    assert summary.statistics.message_count == 400


def test_schema_text_is_rosbag2s_full_dependency_text():
    text = schema_text('geometry_msgs/msg/PoseStamped')
    sep = '\n' + '=' * 80 + '\nMSG: '
    main, *sections = text.split(sep)
    assert main == interface_file('geometry_msgs/msg/PoseStamped').read_text()
    names = [s.split('\n', 1)[0] for s in sections]
    # rosbag2: the types each file uses in sorted order, depth first, each once.
    assert names == ['geometry_msgs/Pose', 'geometry_msgs/Point', 'geometry_msgs/Quaternion',
                     'std_msgs/Header', 'builtin_interfaces/Time']
    for section in sections:
        name, body = section.split('\n', 1)
        assert body == interface_file(name).read_text()
    odom = schema_text('nav_msgs/msg/Odometry')
    for nested in ('geometry_msgs/PoseWithCovariance', 'geometry_msgs/TwistWithCovariance',
                   'geometry_msgs/Vector3', 'std_msgs/Header', 'builtin_interfaces/Time'):
        assert odom.count(f'{sep}{nested}\n') == 1


def test_interface_files_are_found_first_on_ament_prefix_path_then_beside_the_module(
        tmp_path, monkeypatch):
    caches = (interface_file, schema_text, type_hash)
    fake = tmp_path / 'share' / 'geometry_msgs' / 'msg'
    fake.mkdir(parents=True)
    (fake / 'Vector3.msg').write_text('float64 x\nfloat64 y\nfloat64 z\n')
    monkeypatch.setenv('AMENT_PREFIX_PATH', os.pathsep.join([str(tmp_path), '/nonexistent']))
    try:
        for cache in caches:
            cache.cache_clear()
        assert schema_text('geometry_msgs/msg/Vector3') == 'float64 x\nfloat64 y\nfloat64 z\n'
        assert interface_file('geometry_msgs/msg/Twist').read_text().count('Vector3') == 2
        assert type_hash('geometry_msgs/msg/Vector3') is None  # no Vector3.json there
        with pytest.raises(WriterError, match=r'no installed Thing.msg for nobody_msgs/msg/'
                                              r'Thing \(looked in .*AMENT_PREFIX_PATH'):
            schema_text('nobody_msgs/msg/Thing')
    finally:
        for cache in caches:
            cache.cache_clear()


def test_type_hashes_match_an_independent_computation_from_the_schemas(tmp_path):
    f = tmp_path / 'run.mcap'
    _record(f, n=4)
    _, summary = _summary(f)
    for channel in summary.channels.values():
        name = summary.schemas[channel.schema_id].name
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(schema_text(name), name))
        assert channel.metadata['topic_type_hash'] == store.hash_rihs01(name)


def test_channels_offer_qos_as_rosbag2_jazzy_writes_it(tmp_path):
    f = tmp_path / 'run.mcap'
    _record(f, n=4)
    _, summary = _summary(f)
    qos = {c.topic: yaml.safe_load(c.metadata['offered_qos_profiles'])
           for c in summary.channels.values()}
    for (profile,) in qos.values():
        assert list(profile) == QOS_KEYS
        assert profile['liveliness'] == 'automatic'
        assert profile['lifespan'] == {'sec': 9223372036, 'nsec': 854775807}  # infinite
    assert qos['/pose'][0]['history'] == 'keep_last' and qos['/pose'][0]['depth'] == 10
    assert (qos['/twist'][0]['reliability'], qos['/twist'][0]['depth']) == ('best_effort', 1)
    assert qos['/odom'][0]['durability'] == 'transient_local'
    assert qos['/odom'][0]['deadline'] == {'sec': 1, 'nsec': 500_000_000}
    assert qos['/rb_sim/input/body/wrench'][0]['history'] == 'keep_all'
    with AnyReader([f]) as reader:  # rosbags' own QoS parser agrees
        by_topic = {c.topic: c.ext.offered_qos_profiles[0] for c in reader.connections}
    assert by_topic['/twist'].reliability.name == 'BEST_EFFORT'
    assert by_topic['/odom'].durability.name == 'TRANSIENT_LOCAL'


def test_file_ends_with_rosbag2s_bag_information(tmp_path):
    f = tmp_path / 'run.mcap'
    _record(f, n=8)
    info = yaml.safe_load(RecordingReader(f).metadata['rosbag2']['serialized_metadata'])
    assert (info['version'], info['storage_identifier'], info['message_count']) == (9, 'mcap', 8)
    assert info['relative_file_paths'] == ['run.mcap']
    assert info['duration'] == {'nanoseconds': 7000}
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert topics['/odom']['message_count'] == 2
    assert topics['/odom']['topic_metadata']['type_description_hash'].startswith('RIHS01_')
    assert list(topics['/odom']['topic_metadata']['offered_qos_profiles'][0]) == QOS_KEYS


# -- the writer's refusals ----------------------------------------------------------------------
def test_refuses_to_overwrite_unless_told(tmp_path):
    f = tmp_path / 'run.mcap'
    f.write_bytes(b'precious')
    with pytest.raises(WriterError, match=f'{f}: exists; refusing to overwrite'):
        RecordingWriter(f)
    assert f.read_bytes() == b'precious'
    _record(f, n=8, overwrite=True)
    assert RecordingReader(f).message_count == 8
    with pytest.raises(WriterError, match='cannot create: No such file or directory'):
        RecordingWriter(tmp_path / 'missing' / 'run.mcap')


@pytest.mark.parametrize('misuse, why', [
    (lambda w: w.register_topic('/twist', Twist), '/twist.* is already registered'),
    (lambda w: w.register_topic('pose', PoseStamped), 'not a fully qualified topic name'),
    (lambda w: w.register_topic('/x', dict), 'is not an rclpy message class'),
    (lambda w: w.register_topic('/x', Twist, {'depth': 1, 'deepness': 2}),
     r"unknown QoS keys \['deepness'\]"),
    (lambda w: w.register_topic('/x', Twist, {'reliability': 'sometimes'}),
     "QoS reliability 'sometimes' is not one of"),
    (lambda w: w.write('/nope', Twist(), 0), "topic '/nope' was not registered"),
    (lambda w: w.write('/twist', PoseStamped(), 0), 'carries Twist, not PoseStamped'),
    (lambda w: w.write('/twist', Twist(), 1.5), 'log_time_ns 1.5 is not an integer'),
    (lambda w: w.write('/twist', Twist(), -1), r'log_time_ns -1 is outside \[0, 2\*\*64\)'),
    (lambda w: w.write('/twist', Twist(), 0, publish_time_ns=2**64), 'publish_time_ns'),
    (lambda w: w.write('/twist', Twist(), 0, sequence='7'), "sequence '7' is not an integer"),
    (lambda w: w.write_metadata('rb_sim_ros', {'dt': 0.001}), 'not a string key and string'),
    (lambda w: w.write_metadata('rosbag2', {}), "'rosbag2' is rosbag2's own"),
])
def test_writer_refuses_misuse_and_names_the_file(tmp_path, misuse, why):
    f = tmp_path / 'run.mcap'
    with RecordingWriter(f) as w:
        w.register_topic('/twist', Twist)
        with pytest.raises(WriterError, match=why) as info:
            misuse(w)
        assert str(f) in str(info.value) or 'rclpy message class' in str(info.value)
        w.write('/twist', Twist(), 5)  # still usable after a refusal
    assert RecordingReader(f).message_count == 1


def test_finish_is_idempotent_and_writing_after_it_is_refused(tmp_path):
    w = RecordingWriter(tmp_path / 'run.mcap')
    w.register_topic('/twist', Twist)
    w.write('/twist', Twist(), 0)
    w.finish()
    w.finish()
    assert w.finished
    for late in (lambda: w.write('/twist', Twist(), 1), lambda: w.flush(),
                 lambda: w.register_topic('/pose', PoseStamped),
                 lambda: w.write_metadata('x', {})):
        with pytest.raises(WriterError, match='finished; nothing more can be written'):
            late()
    assert RecordingReader(tmp_path / 'run.mcap').message_count == 1


def _sent_prefix_of(read, sent):
    """``read`` (topic, log time, message) is the first len(read) of ``sent``."""
    return [(t, log) for t, log, _m in read] == [(t, log) for t, _m, log, *_ in
                                                 sent[:len(read)]] and all(
        m.linear.x == s[1].linear.x for (_t, _l, m), s in zip(read, sent) if _t == '/twist')


def test_a_full_disk_stops_the_recording_quietly_and_leaves_a_recoverable_file(tmp_path):
    f = tmp_path / 'run.mcap'
    w = RecordingWriter(f, chunk_size=1024, max_chunk_age_s=None)
    for topic, cls in TOPICS:
        w.register_topic(topic, cls)
    w.write_metadata('rb_sim_ros', META)
    w.flush(wait=True)
    disk_full_after(w, 3000)
    sent = []
    for i in range(2000):  # never raises on this thread
        topic, msg = _message(i)
        w.write(topic, msg, 1000 * i, sequence=i)
        sent.append((topic, msg, 1000 * i, i))
        if i % 50 == 49:
            w.flush(wait=True)
    assert w.failed is not None and w.failed.startswith(f'{f}: writing failed: ')
    assert 'No space left on device (ENOSPC)' in w.failed and '\n' not in w.failed
    assert isinstance(w.error, WriterError) and str(w.error) == w.failed
    queued = w.pending
    for i in range(1000):  # cheap no-ops: nothing is queued any more
        w.write('/twist', Twist(), i)
    w.flush(wait=True)
    w.register_topic('/late', Twist)
    w.write_metadata('late', {})
    assert w.pending <= queued
    with pytest.raises(WriterError, match='No space left on device'):
        w.finish()  # told once, at the end
    w.finish()
    assert os.path.getsize(f) <= f.stat().st_size
    r = RecordingReader(f)
    assert r.truncated
    out = tmp_path / 'recovered.mcap'
    counts = recover(f, out)
    theirs = _rosbags(out)  # the independent reader opens the recovered file
    assert 0 < len(theirs) == counts['messages'] < len(sent)
    assert _sent_prefix_of(theirs, sent)


FILE_SIZE_LIMITED_WRITER = """
import resource, signal, sys
from geometry_msgs.msg import Twist
from rb_sim_ros.recording import RecordingWriter, WriterError
limit = int(sys.argv[2])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # then write() fails with EFBIG instead
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
w = RecordingWriter(sys.argv[1], chunk_size=2048, max_chunk_age_s=None)
w.register_topic('/twist', Twist)
k = 0
while w.failed is None and k < 10 ** 6:
    t = Twist()
    t.linear.x = float(k)
    w.write('/twist', t, k, sequence=k)
    k += 1
    if k % 100 == 0:
        w.flush(wait=True)
print(k, flush=True)
print(w.failed, flush=True)
try:
    w.finish()
except WriterError as e:
    print('finish:', e, flush=True)
"""


def test_a_file_size_limit_stops_the_recording_quietly_and_recover_repairs_it(tmp_path):
    """A real failing write(2): the kernel refuses to grow the file past RLIMIT_FSIZE."""
    f = tmp_path / 'limited.mcap'
    limit = 30_000
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get('PYTHONPATH')])])}
    done = subprocess.run([sys.executable, '-c', FILE_SIZE_LIMITED_WRITER, str(f), str(limit)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    written, failed, finish = done.stdout.splitlines()
    assert failed.startswith(f'{f}: writing failed: File too large (EFBIG)')
    assert finish == f'finish: {failed}'
    assert 'Traceback' not in done.stderr
    assert f.stat().st_size <= limit
    out = tmp_path / 'recovered.mcap'
    recover(f, out)
    xs = [m.linear.x for _t, _log, m in _rosbags(out)]
    assert 0 < len(xs) < int(written)
    assert xs == [float(k) for k in range(len(xs))]


def test_a_killed_file_has_rosbag2s_bag_information_from_its_start(tmp_path):
    """rosbag2 writes its 'rosbag2' metadata record when a file opens and again at its end."""
    f = tmp_path / 'run.mcap'
    w = RecordingWriter(f, max_chunk_age_s=None)
    w.register_topic('/twist', Twist)
    w.write('/twist', Twist(), 5)
    killed = tmp_path / 'killed.mcap'
    killed.write_bytes(f.read_bytes())  # what SIGKILL would leave now
    w.finish()

    def bag_infos(path):
        """Every 'rosbag2' record, read with the mcap library up to where the file ends."""
        found = []
        with open(path, 'rb') as fh:
            try:
                for r in StreamReader(fh, skip_magic=False).records:
                    if isinstance(r, Metadata) and r.name == 'rosbag2':
                        found.append(yaml.safe_load(r.metadata['serialized_metadata']))
            except EndOfFile:  # a killed file ends inside a record
                pass
        return found

    first, = bag_infos(killed)
    assert (first['version'], first['message_count'], first['files'][0]['path']) == (
        9, 0, 'run.mcap')
    opened, closed = bag_infos(f)
    assert opened == first
    assert closed['message_count'] == 1
    assert closed['topics_with_message_count'][0]['topic_metadata']['name'] == '/twist'
    assert yaml.safe_load(RecordingReader(f).metadata['rosbag2']['serialized_metadata']) == (
        closed)  # the last one wins
    assert _rosbags(f)[0][:2] == ('/twist', 5)


def test_a_bad_path_is_one_writer_error_naming_it_and_why(tmp_path):
    (tmp_path / 'file').write_text('x')
    cases = {tmp_path / 'missing' / 'run.mcap': 'cannot create: No such file or directory',
             tmp_path / 'file': 'exists; refusing to overwrite',
             tmp_path / 'file' / 'run.mcap': 'cannot create: Not a directory',
             Path('/proc/rb_sim_ros.mcap'): 'cannot create: ',
             Path('/dev/full'): 'cannot write: No space left on device'}
    for path, why in cases.items():
        with pytest.raises(WriterError) as info:
            RecordingWriter(path, overwrite=path.name == 'full')
        assert isinstance(info.value, ValueError)  # what a program refusing bad input catches
        assert str(info.value).startswith(f'{path}: {why}'), str(info.value)
    assert (tmp_path / 'file').read_text() == 'x'


# -- cut short: truncated files, SIGKILL, recovery ---------------------------------------------
def test_flushed_messages_are_readable_while_recording_in_log_time_order(tmp_path):
    f = tmp_path / 'live.mcap'
    with RecordingWriter(f, max_chunk_age_s=None) as w:
        w.register_topic('/twist', Twist)
        for t in (50, 30, 40, 10, 20):
            msg = Twist()
            msg.linear.x = float(t)
            w.write('/twist', msg, t)
        w.flush(wait=True)
        live = RecordingReader(f)
        assert live.truncated and 'no valid footer' in live.truncation
        assert [m.log_time_ns for m in live.messages()] == [10, 20, 30, 40, 50]
        assert [m.message.linear.x for m in live.messages()] == [10.0, 20.0, 30.0, 40.0, 50.0]


@pytest.mark.parametrize('chunk', [1, 7, -1])
def test_a_truncated_copy_reads_its_complete_chunks_and_recovers(tmp_path, chunk):
    f = tmp_path / 'run.mcap'
    sent = _record(f, n=2000, chunk_size=4096)
    chunks = _summary(f)[1].chunk_indexes
    index = chunk % len(chunks)
    cut = chunks[index].chunk_start_offset + chunks[index].chunk_length // 2
    kept = [s for s in sent if s[2] <= chunks[index - 1].message_end_time]
    assert 0 < len(kept) < len(sent)
    short = tmp_path / 'short.mcap'
    short.write_bytes(f.read_bytes()[:cut])
    with pytest.raises(AnyReaderError, match='magic'):
        _rosbags(short)  # rosbags refuses a file without its footer
    r = RecordingReader(short)
    assert r.truncated and f'read up to byte {chunks[index].chunk_start_offset}' in r.truncation
    assert 'the file ends inside the record' in r.truncation
    assert [tuple(m) for m in r.messages()] == kept
    assert r.metadata['rb_sim_ros'] == META and 'rosbag2' in r.metadata
    out = tmp_path / 'recovered.mcap'
    counts = recover(short, out)
    assert counts == {'messages': len(kept), 'schemas': 4, 'channels': 4, 'metadata': 1,
                      'attachments': 0, 'truncated': True, 'damaged_chunks': 0,
                      'dropped_bytes': cut - chunks[index].chunk_start_offset}
    done = RecordingReader(out)
    assert not done.truncated and [tuple(m) for m in done.messages()] == kept
    theirs = _rosbags(out)
    assert len(theirs) == len(kept)
    for (topic, mine, log, *_), (their_topic, their_log, their) in zip(kept, theirs):
        assert (their_topic, their_log) == (topic, log)
        _assert_same(mine, their, topic)


KILLED_WRITER = """
import sys
from geometry_msgs.msg import Twist
from rb_sim_ros.recording import RecordingWriter
w = RecordingWriter(sys.argv[1], chunk_size=2048, max_chunk_age_s=None)
w.register_topic('/twist', Twist)
w.write_metadata('rb_sim_ros', {'run': 'killed'})
k = 0
while True:
    t = Twist()
    t.linear.x = float(k)
    w.write('/twist', t, k, sequence=k)
    k += 1
    if k == 5000:
        w.flush(wait=True)
        print('flushed', k, flush=True)
"""


def _read_line(stream, timeout: float) -> str:
    """One line from a child's pipe, or what came before EOF; fails after ``timeout`` s of
    waiting, where a bare readline() would hang the suite on a child that never writes."""
    data = b''
    end = time.monotonic() + timeout
    with selectors.DefaultSelector() as sel:
        sel.register(stream, selectors.EVENT_READ)
        while not data.endswith(b'\n'):
            left = end - time.monotonic()
            if left <= 0 or not sel.select(left):
                pytest.fail(f'no line from the child after {timeout} s (got {data!r})')
            chunk = os.read(stream.fileno(), 1)  # byte by byte: nothing read past the line
            if not chunk:
                break
            data += chunk
    return data.decode()


def test_sigkill_leaves_every_finished_chunk_and_recover_finalises_it(tmp_path):
    f = tmp_path / 'killed.mcap'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get('PYTHONPATH')])])}
    proc = subprocess.Popen([sys.executable, '-c', KILLED_WRITER, str(f)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = _read_line(proc.stdout, timeout=300.0)
    finally:
        proc.send_signal(signal.SIGKILL)
        _, err = proc.communicate()
    assert line == 'flushed 5000\n', err
    assert proc.returncode == -signal.SIGKILL
    r = RecordingReader(f)
    xs = [m.message.linear.x for m in r.messages()]
    assert r.truncated and len(xs) >= 5000  # all flushed ones, and maybe more chunks
    assert xs == [float(k) for k in range(len(xs))]
    assert r.metadata['rb_sim_ros'] == {'run': 'killed'}
    out = tmp_path / 'recovered.mcap'
    assert recover(f, out)['messages'] == len(xs)
    assert [m.linear.x for _t, _log, m in _rosbags(out)] == xs


def test_recover_copies_a_complete_file_and_refuses_to_overwrite(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _record(f, n=40)
    out = tmp_path / 'copy.mcap'
    counts = recover(f, out)
    assert counts['messages'] == 40 and not counts['truncated'] and counts['dropped_bytes'] == 0
    assert [tuple(m) for m in RecordingReader(out).messages()] == sent
    with pytest.raises(WriterError, match='copy.mcap: exists; refusing to overwrite'):
        recover(f, out)
    with pytest.raises(WriterError, match='is the recording being recovered'):
        recover(f, f, overwrite=True)
    assert RecordingReader(f).message_count == 40
    short = tmp_path / 'short.mcap'
    short.write_bytes(f.read_bytes()[:-100])
    with pytest.raises(WriterError, match=r'truncated .*recover\(\) it'):
        write_rosbag2_metadata(short)


# -- foreign and corrupt files ------------------------------------------------------------------
@pytest.mark.parametrize('content, why', [
    (b'', r'empty file \(0 bytes\), not an MCAP recording'),
    (b'hello, world\n', "not an MCAP file \\(it starts with b'hello, w'"),
    (b'\x89PNG\r\n\x1a\n' + bytes(64), r"not an MCAP file \(it starts with b'\\x89PNG"),
    (b'SQLite format 3\x00' + bytes(64), 'not an MCAP file'),
    (b'\x89MCAP0\r\n' + b'\x01' + bytes(3), 'corrupt MCAP file: no readable header'),
])
def test_foreign_files_are_refused_clearly(tmp_path, content, why):
    f = tmp_path / 'bad.mcap'
    f.write_bytes(content)
    with pytest.raises(ReaderError, match=why) as info:
        RecordingReader(f)
    assert str(info.value).startswith(f'{f}: ')
    with pytest.raises(ReaderError, match=why):
        recover(f, tmp_path / 'out.mcap')
    assert not (tmp_path / 'out.mcap').exists()


def test_missing_files_and_directories_are_refused(tmp_path):
    with pytest.raises(ReaderError, match='missing.mcap: cannot open: No such file'):
        RecordingReader(tmp_path / 'missing.mcap')
    with pytest.raises(ReaderError, match='cannot open: Is a directory'):
        RecordingReader(tmp_path)


def _raw_mcap(path, profile='ros2', encoding='cdr', schema=('geometry_msgs/msg/Twist',
                                                            'ros2msg'), data=b''):
    with open(path, 'wb') as fh:
        w = Writer(fh)
        w.start(profile=profile, library='test')
        sid = w.register_schema(schema[0], schema[1], b'')
        cid = w.register_channel('/x', encoding, sid)
        w.add_message(cid, 1, data, 1)
        w.finish()


def test_other_profiles_encodings_and_undecodable_messages_are_refused(tmp_path):
    f = tmp_path / 'x.mcap'
    _raw_mcap(f, profile='')
    with pytest.raises(ReaderError, match="profile '', not 'ros2': not a ROS 2 recording"):
        RecordingReader(f)
    f.unlink()
    _raw_mcap(f, encoding='json', schema=('Twist', 'jsonschema'))
    with pytest.raises(ReaderError, match="channel /x has message encoding 'json' and schema "
                                          "encoding 'jsonschema'"):
        RecordingReader(f)
    f.unlink()
    _raw_mcap(f, data=b'\x00\x01\x00\x00garbage')
    with pytest.raises(ReaderError, match='message on /x at 1 ns does not deserialise as '
                                          'geometry_msgs/msg/Twist'):
        list(RecordingReader(f).messages())
    f.unlink()
    _raw_mcap(f, schema=('nobody_msgs/msg/Thing', 'ros2msg'))
    assert RecordingReader(f).channels == {'/x': 'nobody_msgs/msg/Thing'}
    with pytest.raises(ReaderError, match='nobody_msgs/msg/Thing is not installed here'):
        list(RecordingReader(f).messages())


def test_ctrl_c_while_rclpy_converts_a_message_is_an_interrupt_not_a_bad_file(tmp_path):
    """A signal handled while rclpy's C++ builds the Python message surfaces as pybind11's
    TypeError raised from the KeyboardInterrupt; the reader must re-raise the interrupt (a
    replay stopped by Ctrl-C once said the recording was corrupt). A real timer, real rclpy:
    every interrupt of many must come out as KeyboardInterrupt."""
    f = tmp_path / 'x.mcap'
    _raw_mcap(f, schema=('nav_msgs/msg/Odometry', 'ros2msg'),
              data=serialize_message(Odometry()))
    reader = RecordingReader(f)
    raw = next(reader.raw_messages())
    armed = [False]

    def interrupt(_signum, _frame):
        if armed[0]:
            armed[0] = False
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 3e-5, 3e-5)
    interrupts = 0
    try:
        # Armed only inside the try. Bounded: an interrupt Python swallows (raised in a
        # finaliser: "Exception ignored") is armed again by the next call, and a round that
        # meets none ends after its calls.
        for _ in range(2000):
            if interrupts == 200:
                break
            try:
                for _ in range(2000):
                    armed[0] = True
                    reader.deserialize(raw)
                armed[0] = False
            except KeyboardInterrupt:
                interrupts += 1
    finally:
        armed[0] = False
        signal.setitimer(signal.ITIMER_REAL, 0, 0)
        signal.signal(signal.SIGALRM, previous)
    assert interrupts == 200
    assert reader.deserialize(raw).message == Odometry()


def test_a_corrupt_chunk_is_a_reader_error_and_recover_skips_it(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _record(f, n=400, chunk_size=4096)
    chunks = _summary(f)[1].chunk_indexes
    chunk = chunks[3]
    data = bytearray(f.read_bytes())
    middle = chunk.chunk_start_offset + chunk.chunk_length // 2
    data[middle:middle + 8] = bytes(b ^ 0x5A for b in data[middle:middle + 8])
    f.write_bytes(bytes(data))
    r = RecordingReader(f)
    assert not r.truncated
    with pytest.raises(ReaderError, match=r'run.mcap: corrupt data inside the file .*recover'):
        list(r.messages())
    kept = [s for s in sent if not chunk.message_start_time <= s[2] <= chunk.message_end_time]
    out = tmp_path / 'fixed.mcap'
    counts = recover(f, out)
    assert (counts['damaged_chunks'], counts['messages']) == (1, len(kept))
    assert [tuple(m) for m in RecordingReader(out).messages()] == kept
    short = tmp_path / 'short.mcap'  # the same damage in a file cut short: skipped, read on
    short.write_bytes(bytes(data[:chunks[-1].chunk_start_offset + 10]))
    r = RecordingReader(short)
    assert r.truncated and len(r.damaged) == 1
    assert f'chunk at byte {chunk.chunk_start_offset} fails its CRC check' in r.damaged[0]
    assert [tuple(m) for m in r.messages()] == [
        s for s in kept if s[2] < chunks[-1].message_start_time]


def test_an_inline_writer_writes_the_same_recording(tmp_path):
    """background=False (a sweep worker's: no thread) gives a file that reads back the same
    as the threaded writer's, whose chunks close by size only there too."""
    paths = []
    for background in (True, False):
        (tmp_path / str(background)).mkdir()
        path = tmp_path / str(background) / 'run.mcap'  # (the name is in the bag info)
        with RecordingWriter(path, chunk_size=4096, max_chunk_age_s=None,
                             background=background) as w:
            w.register_topic('/pose', PoseStamped)
            for k in range(500):
                msg = PoseStamped()
                msg.header.frame_id = 'world'
                msg.pose.position.x = k * 0.1
                w.write('/pose', msg, k * 1000)
            assert w.pending == 0 or background
        paths.append(str(path))
    assert difference(*paths) == ''
    assert RecordingReader(paths[1]).message_count == 500
