# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""replay FILE: one publisher per topic with the recorded QoS; bad topic names refused on load.

No ROS graph: ``_publish`` is given a fake node, and recordings are the regression fixture
rewritten by the mcap library (as test_untrusted_recording.py does), with a channel renamed
or its offered QoS changed.
"""

import json
from pathlib import Path

from mcap.writer import Writer
import pytest

from rb_sim_ros.offline import replay
from rb_sim_ros.recording import ReaderError
from support.recordings import mcap_parts

FIXTURE = Path(__file__).resolve().parents[1] / 'fixtures' / 'regression.mcap'
TRANSIENT_LOCAL = ('- history: keep_last\n  depth: 3\n  reliability: reliable\n'
                   '  durability: transient_local\n  deadline:\n    sec: 9223372036\n'
                   '    nsec: 854775807\n  liveliness: automatic\n'
                   '  avoid_ros_namespace_conventions: false')


# -- _publish with a fake node --------------------------------------------------------------
class _Pose:
    def __init__(self, i):
        self.i = i


class _Twist(_Pose):
    pass


class _Publisher:
    def __init__(self, msg_type, topic, qos):
        self.msg_type, self.topic, self.qos = msg_type, topic, qos
        self.published = []

    def publish(self, msg):
        self.published.append(msg)

    def get_subscription_count(self):
        return 0


class _Node:
    def __init__(self):
        self.publishers = []

    def create_publisher(self, msg_type, topic, qos):
        pub = _Publisher(msg_type, topic, qos)
        self.publishers.append(pub)
        return pub


class _Rclpy:
    @staticmethod
    def spin_once(node, timeout_sec=None):
        pass


def _outputs(n=6):
    """(topic, msg, log time) of n periods, a /pose and a /twist message each."""
    out = []
    for i in range(n):
        out.append(('/pose', _Pose(i), 1000 * i))
        out.append(('/twist', _Twist(i), 1000 * i))
    return out


def test_one_publisher_per_topic_publishes_every_message_in_order():
    node, outputs = _Node(), _outputs()
    replay._publish(_Rclpy, node, outputs, 0.0, 0.0, None, None)
    created = [(p.topic, p.msg_type) for p in node.publishers]
    assert created == [('/pose', _Pose), ('/twist', _Twist)]
    by_topic = {p.topic: p for p in node.publishers}
    for topic in ('/pose', '/twist'):
        assert by_topic[topic].published == [m for t, m, _ in outputs if t == topic]
    assert [m.i for m in by_topic['/pose'].published] == list(range(6))


def test_publishers_get_the_qos_given_per_topic_and_depth_10_without():
    node, marker = _Node(), object()
    replay._publish(_Rclpy, node, _outputs(2), 0.0, 0.0, None, None, {'/twist': marker})
    assert {p.topic: p.qos for p in node.publishers} == {'/pose': 10, '/twist': marker}


# -- recordings rewritten -------------------------------------------------------------------
def _rewrite(path, rename=None, channel_metadata=None):
    """The fixture with topics renamed (``rename``: old -> new, in the channels and in the
    metadata's output_topics) and channel metadata replaced (topic -> dict)."""
    rename, channel_metadata = rename or {}, channel_metadata or {}
    header, schemas, channels, messages, metadata = mcap_parts(FIXTURE)
    meta = dict(metadata['rb_sim_ros'])
    meta['output_topics'] = json.dumps({
        body: {kind: rename.get(topic, topic) for kind, topic in topics.items()}
        for body, topics in json.loads(meta['output_topics']).items()})
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile=header.profile, library=header.library)
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {i: w.register_channel(rename.get(c.topic, c.topic), c.message_encoding,
                                      sids[c.schema_id],
                                      channel_metadata.get(c.topic, dict(c.metadata)))
                for i, c in channels.items()}
        for m in messages:
            w.add_message(cids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)
        w.add_metadata('rb_sim_ros', meta)
        w.finish()
    return str(path)


def test_load_keeps_the_recorded_qos_of_each_output_topic(tmp_path):
    qos = replay.load(_rewrite(tmp_path / 'same.mcap')).qos
    assert qos['/pose'] == {'history': 'keep_last', 'depth': 10, 'reliability': 'reliable',
                            'durability': 'volatile'}
    assert qos['/tf_static']['durability'] == 'transient_local'
    f = _rewrite(tmp_path / 'latched.mcap',
                 channel_metadata={'/odom': {'offered_qos_profiles': TRANSIENT_LOCAL}})
    assert replay.load(f).qos['/odom'] == {'history': 'keep_last', 'depth': 3,
                                           'reliability': 'reliable',
                                           'durability': 'transient_local'}


def test_recorded_qos_adapts_offers_as_ros2_bag_play_and_ignores_what_it_cannot_read():
    volatile = TRANSIENT_LOCAL.replace('transient_local', 'volatile')
    best_effort = TRANSIENT_LOCAL.replace('reliable', 'best_effort')
    assert replay.recorded_qos(TRANSIENT_LOCAL + '\n' + volatile)['durability'] == 'volatile'
    assert replay.recorded_qos(TRANSIENT_LOCAL + '\n' + best_effort)['reliability'] == \
        'best_effort'
    for text in ('', 'nonsense', TRANSIENT_LOCAL.replace('depth: 3', 'depth: -3'),
                 TRANSIENT_LOCAL.replace('reliable', 'very'), '- ' * 100_000, '- \n' * 30_000,
                 TRANSIENT_LOCAL.replace('depth: 3', 'depth: \u00b2'),
                 TRANSIENT_LOCAL.replace('depth: 3', 'depth: ' + '9' * 5000)):
        assert replay.recorded_qos(text) is None


@pytest.mark.parametrize('bad', ['/a b', '/1abc', '/a-b', '/a//b', '/a/', '/' + 'a' * 300])
def test_an_output_topic_that_is_no_ros_name_is_refused_on_load(tmp_path, bad):
    f = _rewrite(tmp_path / 'renamed.mcap', rename={'/pose': bad})
    with pytest.raises(ReaderError) as e:
        replay.load(f)
    message = str(e.value)
    assert '\n' not in message and message.startswith(f'{f}: ')
    assert repr(bad[:300]) in message and 'topic name' in message, message


@pytest.mark.parametrize('good', ['/pose', '/tf', '/_a/b_1', '/robot2/odom', '/a__b'])
def test_valid_topic_names_pass(good):
    assert replay.topic_name_problem(good) == ''


def test_topic_names_are_judged_as_rclpy_judges_them():
    validate = pytest.importorskip('rclpy.validate_full_topic_name').validate_full_topic_name
    for name in ('/a//b', '/a/', '/1abc', '/a__b', '/_a/b_1', '/a b', '/a-b', '/', '/a/1b',
                 '/a/_1', '/~a', '/{a}', 'a', '/' + 'a' * 246, '/' + 'a' * 247):
        try:
            validate(name)
            valid = True
        except Exception:  # rclpy's InvalidTopicNameException
            valid = False
        assert (replay.topic_name_problem(name) == '') == valid, name


class _Failing:
    """A publisher whose every publish fails as rclpy's does (an RCLError)."""

    def __init__(self):
        self.calls = 0

    def publish(self, msg):
        from rclpy._rclpy_pybind11 import RCLError
        self.calls += 1
        raise RCLError('failed to publish: some rmw error')


def test_a_publish_that_fails_on_a_topic_not_keep_all_is_one_line_at_once():
    """Only a keep_all topic waits for room (its full history fails the publish); anywhere
    else a failed publish is an error, said at once, not retried for a minute."""
    pub = _Failing()
    with pytest.raises(ValueError, match=r'^/a: publishing failed \(failed to publish'):
        replay._Sender(keep_all=['/b'])(pub, '/a', object())
    assert pub.calls == 1
