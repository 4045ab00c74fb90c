# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""MCAP files through tmp_path, read back by this module and by rosbags (independent)."""

from pathlib import Path
import signal
import subprocess
import sys

from geometry_msgs.msg import PoseStamped, Twist, WrenchStamped
from nav_msgs.msg import Odometry
import pytest
from rosbags.highlevel import AnyReader
import yaml

from rb_sim_ros.mcap_io import (ReaderError, RecordingReader, RecordingWriter, recover,
                                schema_text, WriterError)


def _messages(n):
    out = []
    for i in range(n):
        p = PoseStamped()
        p.header.stamp.sec, p.header.frame_id = i, 'odom'
        p.pose.position.x, p.pose.orientation.w = 0.5 * i, 1.0
        t = Twist()
        t.angular.z = -0.25 * i
        o = Odometry()
        o.child_frame_id = 'base_link'
        o.twist.twist.linear.y = 1e-3 * i
        w = WrenchStamped()
        w.header.frame_id = 'body'
        w.wrench.torque.x = float(i)
        out += [('/pose', p), ('/twist', t), ('/odom', o), ('/in', w)]
    return out


def _write(path, n=50, **kwargs):
    with RecordingWriter(str(path), **kwargs) as w:
        for topic, cls in (('/pose', PoseStamped), ('/twist', Twist), ('/odom', Odometry),
                           ('/in', WrenchStamped)):
            w.register_topic(topic, cls)
        w.write_metadata('rb_sim_ros', {'config': '{"dt": 0.001}'})
        for k, (topic, msg) in enumerate(_messages(n)):
            w.write(topic, msg, 1000 * (k // 4), sequence=k // 4)
    return _messages(n)


def _rosbags(path):
    with AnyReader([Path(path)]) as reader:
        return [(c.topic, reader.deserialize(raw, c.msgtype))
                for c, _t, raw in reader.messages()]


def test_round_trip_and_an_independent_reader(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _write(f)
    r = RecordingReader(str(f))
    assert not r.truncated
    assert r.metadata == {'rb_sim_ros': {'config': '{"dt": 0.001}'}}
    assert r.channels['/odom'] == 'nav_msgs/msg/Odometry'
    got = list(r.messages())
    assert [(t, m) for t, m, *_ in got] == sent
    assert [seq for *_, seq in got][::4] == list(range(50))
    theirs = _rosbags(f)
    assert len(theirs) == len(sent)
    for (topic, mine), (their_topic, their) in zip(sent, theirs):
        assert topic == their_topic
        if topic == '/pose':
            assert (their.pose.position.x, their.header.frame_id) == (mine.pose.position.x,
                                                                      'odom')
        elif topic == '/odom':
            assert their.twist.twist.linear.y == mine.twist.twist.linear.y
        elif topic == '/in':
            assert their.wrench.torque.x == mine.wrench.torque.x


def test_schema_carries_every_dependency():
    text = schema_text('geometry_msgs/msg/PoseStamped')
    sections = [line for line in text.splitlines() if line.startswith('MSG: ')]
    assert sections == ['MSG: std_msgs/Header', 'MSG: builtin_interfaces/Time',
                        'MSG: geometry_msgs/Pose', 'MSG: geometry_msgs/Point',
                        'MSG: geometry_msgs/Quaternion']
    assert text.count('=' * 80) == 5


def test_channels_offer_qos_as_rosbag2_writes_it(tmp_path):
    f = tmp_path / 'run.mcap'
    _write(f, n=1)
    from mcap.reader import make_reader
    with open(f, 'rb') as fh:
        reader = make_reader(fh)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
    for ch in summary.channels.values():
        assert ch.message_encoding == 'cdr'
        assert summary.schemas[ch.schema_id].encoding == 'ros2msg'
        (qos,) = yaml.safe_load(ch.metadata['offered_qos_profiles'])
        assert qos['history'] == 'keep_last' and qos['reliability'] == 'reliable'
        assert set(qos) >= {'depth', 'durability', 'deadline', 'lifespan', 'liveliness',
                            'liveliness_lease_duration', 'avoid_ros_namespace_conventions'}


def test_refuses_to_overwrite_unless_told(tmp_path):
    f = tmp_path / 'run.mcap'
    f.write_bytes(b'precious')
    with pytest.raises(WriterError, match='refusing to overwrite'):
        RecordingWriter(str(f))
    assert f.read_bytes() == b'precious'
    _write(f, n=2, overwrite=True)
    assert len(list(RecordingReader(str(f)).messages())) == 8


def test_finish_is_idempotent_and_writing_after_it_is_refused(tmp_path):
    w = RecordingWriter(str(tmp_path / 'run.mcap'))
    w.register_topic('/twist', Twist)
    w.finish()
    w.finish()
    with pytest.raises(WriterError, match='already finished'):
        w.write('/twist', Twist(), 0)
    with pytest.raises(WriterError, match='not registered'):
        RecordingWriter(str(tmp_path / 'b.mcap')).write('/nope', Twist(), 0)


def test_truncated_file_reads_to_its_last_chunk_and_recovers(tmp_path):
    f = tmp_path / 'run.mcap'
    sent = _write(f, n=3000, chunk_size=8 * 1024)
    data = f.read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:len(data) * 2 // 3])
    with pytest.raises(Exception):
        _rosbags(cut)  # rosbags refuses a file without its footer
    r = RecordingReader(str(cut))
    got = list(r.messages())
    assert r.truncated and 0 < len(got) < len(sent)
    assert [(t, m) for t, m, *_ in got] == sent[:len(got)]  # a prefix, nothing invented
    out = tmp_path / 'recovered.mcap'
    counts = recover(str(cut), str(out))
    assert counts['messages'] == len(got) and counts['metadata'] == 1
    assert len(_rosbags(out)) == len(got)
    assert not RecordingReader(str(out)).truncated


WRITER = """
import sys
from geometry_msgs.msg import Twist
from rb_sim_ros.mcap_io import RecordingWriter
w = RecordingWriter(sys.argv[1], chunk_size=2048)
w.register_topic('/twist', Twist)
k, told = 0, False
while True:
    t = Twist()
    t.linear.x = float(k)
    w.write('/twist', t, k, sequence=k)
    k += 1
    if not told and k % 1000 == 0 and len(open(sys.argv[1], 'rb').read()) > 20000:
        print('chunks on disk', flush=True)
        told = True
"""


def test_sigkill_leaves_a_readable_prefix(tmp_path):
    f = tmp_path / 'killed.mcap'
    proc = subprocess.Popen([sys.executable, '-c', WRITER, str(f)], stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline().strip() == 'chunks on disk'
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    r = RecordingReader(str(f))
    xs = [m.linear.x for _t, m, *_ in r.messages()]
    assert r.truncated and len(xs) > 100
    assert xs == [float(k) for k in range(len(xs))]
    out = tmp_path / 'recovered.mcap'
    recover(str(f), str(out))
    assert [m.linear.x for _t, m in _rosbags(out)] == xs


@pytest.mark.parametrize('content, why', [
    (b'', 'not an MCAP file'), (b'hello, world\n', 'not an MCAP file'),
    (b'\x89PNG\r\n\x1a\n' + bytes(100), 'not an MCAP file'),
    (b'\x89MCAP0\r\n' + bytes(3), 'corrupt MCAP'),
])
def test_foreign_and_corrupt_files_are_refused_clearly(tmp_path, content, why):
    f = tmp_path / 'bad.mcap'
    f.write_bytes(content)
    with pytest.raises(ReaderError, match=why):
        RecordingReader(str(f))


def test_other_profiles_are_refused(tmp_path):
    from mcap.writer import Writer
    f = tmp_path / 'json.mcap'
    with open(f, 'wb') as fh:
        w = Writer(fh)
        w.start(profile='', library='test')
        w.finish()
    with pytest.raises(ReaderError, match="profile '', not 'ros2'"):
        RecordingReader(str(f))
    with pytest.raises(ReaderError, match='cannot read'):
        RecordingReader(str(tmp_path / 'missing.mcap'))
