# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
"""A recording converted by bag tools still verifies: rosbags-convert to rosbag2 SQLite3 and
back to MCAP keeps every message and time stamp but drops the MCAP metadata records (and the
sequence numbers), so the run's definition is also a message at step 0 on a topic of its own.

No ROS graph: runs recorded offline as the node records them (oracles/node_recording.py),
converted by the rosbags-convert of this venv, read back by the mcap library and by rosbags.
"""

import contextlib
import io
import json
from pathlib import Path
import subprocess
import sys

from mcap.writer import Writer
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from std_msgs.msg import String

from oracles.node_recording import record_offline
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.offline import replay
from rb_sim_ros.recording import RecordingReader
from rb_sim_ros.ros.node_recorder import RUN_DEFINITION
from rb_sim_ros.sim.simulation import BodySpec, Config, SetWrench
from support.recordings import mcap_parts

FIXTURE = Path(__file__).resolve().parents[1] / 'fixtures' / 'regression.mcap'
CONVERT = Path(sys.executable).parent / 'rosbags-convert'


def _verify(path):
    """(exit status, stdout, stderr) of ``replay --verify path``, in this process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = replay.main(['replay', '--verify', str(path)])
    return code, out.getvalue(), err.getvalue()


def _convert(src, dst, storage):
    result = subprocess.run([str(CONVERT), '--src', str(src), '--dst', str(dst),
                             '--dst-storage', storage], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return dst


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    """(original, converted): two bodies under changing wrenches, recorded offline, and the
    same converted MCAP -> rosbag2 SQLite3 -> MCAP by rosbags-convert."""
    d = tmp_path_factory.mktemp('converted')
    a = BodySpec('a', 2.0, (0.2, 0.3, 0.4), initial_angular_velocity=(0.3, 1.0, -0.2))
    b = BodySpec('b', 1.0, (0.1, 0.1, 0.2), initial_angular_velocity=(0.0, 0.5, 2.0))
    config = Config(dt=1e-3, steps_per_publish=10, bodies=(a, b))
    original = d / 'run.mcap'
    record_offline(original, config, 40, events={
        5: [SetWrench(Wrench((1.0, 0.0, 0.0), (0.0, 0.0, 0.05)), 'a')],
        20: [SetWrench(Wrench((0.0, -2.0, 0.0)), 'b')]})
    sqlite = _convert(original, d / 'bag_sqlite3', 'sqlite3')
    assert list(sqlite.glob('*.db3'))
    back = _convert(sqlite, d / 'bag_mcap', 'mcap')
    return original, next(back.glob('*.mcap'))


def _rewrite(path, src, definition=None, drop=(), metadata=None, extra=(), late=None):
    """``src`` rewritten by the mcap library: the run definition message's text replaced
    (``definition``) or its log time (``late``), topics dropped, metadata records replaced
    (None: kept), messages added (``extra``: (log time, text) on the run definition's
    channel)."""
    header, schemas, channels, messages, meta = mcap_parts(src)
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile=header.profile, library=header.library)
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                      dict(c.metadata))
                for i, c in channels.items() if c.topic not in drop}
        by_topic = {c.topic: cids[i] for i, c in channels.items() if i in cids}
        for m in messages:
            if m.channel_id not in cids:
                continue
            data, log_time = m.data, m.log_time
            if channels[m.channel_id].topic == RUN_DEFINITION:
                if definition is not None:
                    data = serialize_message(String(data=definition))
                log_time = log_time if late is None else late
            w.add_message(cids[m.channel_id], log_time, data, log_time, m.sequence)
        for log_time, text in extra:
            w.add_message(by_topic[RUN_DEFINITION], log_time,
                          serialize_message(String(data=text)), log_time, 0)
        for name, record in (meta if metadata is None else metadata).items():
            w.add_metadata(name, record)
        w.finish()
    return path


def _definition(path):
    """The run definition message of ``path``, decoded (by the mcap library and rclpy)."""
    _h, _s, channels, messages, _m = mcap_parts(path)
    texts = [deserialize_message(m.data, String).data for m in messages
             if channels[m.channel_id].topic == RUN_DEFINITION]
    assert len(texts) == 1
    return json.loads(texts[0])


def test_the_definition_message_is_the_metadata_at_step_0_latched(run):
    original, _ = run
    _h, _s, channels, messages, metadata = mcap_parts(original)
    assert _definition(original) == metadata['rb_sim_ros']
    first = min(m.log_time for m in messages)
    ours = [m for m in messages if channels[m.channel_id].topic == RUN_DEFINITION]
    assert [(m.log_time, m.sequence) for m in ours] == [(first, 0)]
    with AnyReader([original]) as reader:  # an independent reader of the channel's QoS
        (connection,) = [c for c in reader.connections if c.topic == RUN_DEFINITION]
        assert connection.msgtype == 'std_msgs/msg/String'
        (qos,) = connection.ext.offered_qos_profiles
    assert (qos.durability.name, qos.reliability.name, qos.depth) == (
        'TRANSIENT_LOCAL', 'RELIABLE', 1)


def test_a_bag_converted_to_sqlite3_and_back_verifies_identical(run):
    original, converted = run
    _h, _s, channels, messages, metadata = mcap_parts(converted)
    assert 'rb_sim_ros' not in metadata  # what the conversion drops
    before = mcap_parts(original)
    # ... and what it keeps: every message's bytes and time stamps, on the same topics
    assert sorted((before[2][m.channel_id].topic, m.log_time, m.data) for m in before[3]) == \
        sorted((channels[m.channel_id].topic, m.log_time, m.data) for m in messages)
    assert {m.sequence for m in messages} == {0}
    code, out, err = _verify(converted)
    assert code == 0, out + err
    assert 'identical: every output message re-simulated bit for bit' in out
    n = sum(1 for m in messages if channels[m.channel_id].topic.rsplit('/', 1)[-1]
            in ('pose', 'twist', 'odom'))
    assert f'{n} of {n} recorded output messages compared' in out
    assert replay.recorded_qos(RecordingReader(str(converted)).topics[RUN_DEFINITION]
                               .offered_qos_profiles)['durability'] == 'transient_local'
    assert RUN_DEFINITION not in replay.load(str(converted)).recorded_per_topic  # not played


def _with(definition, key, change):
    d = dict(definition)
    d[key] = json.dumps(change(json.loads(d[key])))
    return d


def _set(d, key, value):
    d = dict(d)
    d[key] = value
    return d


def test_a_converted_bag_whose_definition_has_another_dt_does_not_verify(run, tmp_path):
    _, converted = run
    definition = _definition(converted)
    # Another dt, the parameters left: refused, one line naming the message.
    other = _with(definition, 'config', lambda c: _set(c, 'dt', 2e-3))
    f = _rewrite(tmp_path / 'dt.mcap', converted, json.dumps(other))
    code, out, err = _verify(f)
    assert code == 2 and err.count('\n') == 1, out + err
    assert err.startswith(f'replay: {f}: bad run definition on {RUN_DEFINITION}: '), err
    # Another dt and parameters that agree with it: a different run, not identical.
    other = _with(_with(definition, 'config', lambda c: _set(c, 'dt', 2e-3)), 'parameters',
                  lambda p: {**p, 'dt': 2e-3, 'publish_rate': p['publish_rate'] / 2})
    f = _rewrite(tmp_path / 'dt_params.mcap', converted, json.dumps(other))
    code, out, err = _verify(f)
    assert code in (1, 2) and 'identical:' not in out, out + err


def test_a_definition_message_that_differs_from_the_metadata_is_refused(run, tmp_path):
    original, _ = run
    definition = _definition(original)
    other = _with(definition, 'config', lambda c: _set(c, 'dt', 2e-3))
    f = _rewrite(tmp_path / 'both.mcap', original, json.dumps(other))
    code, out, err = _verify(f)
    assert code == 2 and out == '' and err.count('\n') == 1, out + err
    assert 'differ (in config)' in err and RUN_DEFINITION in err, err


@pytest.mark.parametrize('case', ['not json', 'nested', 'not strings', 'format', 'bad config',
                                  'bad topic', 'two messages', 'late', 'deep config'])
def test_a_bad_definition_message_is_one_line_and_exit_2(run, tmp_path, case):
    """The message is untrusted input as the metadata is: the same checks, one line."""
    _, converted = run
    d = _definition(converted)
    text, extra, late, words = None, (), None, 'bad run definition on /rb_sim/run_definition'
    if case == 'not json':
        text = '{"config": '
    elif case == 'nested':
        text = json.dumps({**d, 'config': json.loads(d['config'])})
    elif case == 'not strings':
        text = json.dumps({**d, 'format': 1})
    elif case == 'format':
        text, words = json.dumps({**d, 'format': '2'}), "format '2'"
    elif case == 'bad config':
        text = json.dumps(_with(d, 'config', lambda c: _set(c, 'dt', -1.0)))
    elif case == 'bad topic':
        text, words = json.dumps(_with(d, 'output_topics', lambda o: {
            **o, 'a': {**o['a'], 'pose': '/a b'}})), 'not a valid ROS topic name'
    elif case == 'two messages':
        extra, words = [(10_000_000, json.dumps(d))], 'holds 2 messages'
    elif case == 'late':
        late, words = 10_000_000, 'not at the first time stamp'
    elif case == 'deep config':
        text = json.dumps({**d, 'config': '[' * 50 + ']' * 50})
        words = 'nests 50 levels deep'
    f = _rewrite(tmp_path / 'bad.mcap', converted, text, extra=extra, late=late)
    code, out, err = _verify(f)
    assert code == 2 and out == '' and err.count('\n') == 1, out + err
    assert err.startswith(f'replay: {f}: ') and words in err, err


def test_an_old_recording_with_only_metadata_still_verifies(run, tmp_path):
    assert RUN_DEFINITION not in RecordingReader(str(FIXTURE)).topics  # made before it
    code, out, err = _verify(FIXTURE)
    assert code == 0 and 'identical' in out, out + err
    original, _ = run
    f = _rewrite(tmp_path / 'metadata_only.mcap', original, drop=(RUN_DEFINITION,))
    code, out, err = _verify(f)
    assert code == 0 and 'identical' in out, out + err
    # Neither the metadata nor the message: not a recording of the simulator.
    f = _rewrite(tmp_path / 'neither.mcap', original, drop=(RUN_DEFINITION,), metadata={})
    code, out, err = _verify(f)
    assert code == 2 and 'not a recording of the rb_sim_ros simulator' in err, err
