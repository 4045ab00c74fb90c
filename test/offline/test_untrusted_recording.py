# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
"""replay treats everything in a file as untrusted: a bad recording is one line and exit 2.

No ROS graph: recordings are the regression fixture with its metadata rewritten (by the mcap
library, not by our writer), or runs recorded offline as the node records them (Simulation,
OutputMessages and NodeRecorder, period by period). rosbags is the independent reader.
"""

import contextlib
import io
import json
import math
from pathlib import Path
import tracemalloc
from unittest import mock

from hypothesis import given, HealthCheck, settings, strategies as st
from mcap.writer import Writer
import pytest
from rosbags.highlevel import AnyReader

from oracles.node_recording import record_offline
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.offline import replay
from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.node_recorder import NodeRecorder, OUTPUTS
from rb_sim_ros.ros.ros_messages import fill_tf, OutputMessages, tf_message
from rb_sim_ros.sim.simulation import (BodySpec, Config, Delete, SetWrench, Simulation,
                                       Spawn)
from support.recordings import disk_full_after, mcap_parts, rewrite, topic_parts

FIXTURE = Path(__file__).resolve().parents[1] / 'fixtures' / 'regression.mcap'
OUTPUT_KINDS = ('pose', 'twist', 'odom')  # what the runs recorded offline here publish
RECORDED_KINDS = tuple(OUTPUTS)  # what the node records of a body (the fixture)


PARTS = mcap_parts(FIXTURE)
META = PARTS[4]['rb_sim_ros']


def _rewrite(path, meta):
    """The fixture with its 'rb_sim_ros' metadata replaced by ``meta`` (str -> str)."""
    header, schemas, channels, messages, _ = PARTS
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile=header.profile, library=header.library)
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                      dict(c.metadata)) for i, c in channels.items()}
        for m in messages:
            w.add_message(cids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)
        w.add_metadata('rb_sim_ros', meta)
        w.finish()
    return path


MAX_TEST_STEPS = 100_000  # far more than any recording here needs


class _CountingSimulation(Simulation):
    """A Simulation that fails the test, instead of hanging it, past MAX_TEST_STEPS steps."""

    def run(self, n):
        assert self.step_count + n <= MAX_TEST_STEPS, f'replay asked for {n} more steps'
        super().run(n)


def _verify(path):
    """(exit status, stdout, stderr) of ``replay --verify path``, in this process: any
    exception escaping main() fails the test (it would be a traceback)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            mock.patch.object(replay, 'Simulation', _CountingSimulation):
        code = replay.main(['replay', '--verify', str(path)])
    return code, out.getvalue(), err.getvalue()


def _assert_refused(path, *words):
    code, out, err = _verify(path)
    assert code == 2, out + err
    assert err.startswith(f'replay: {path}: ') and err.endswith('\n'), err
    assert err.count('\n') == 1, err
    for w in words:
        assert w in err, err
    return err


def _meta(**changes):
    """The fixture's metadata, its JSON fields changed by ``changes`` (key -> function of the
    decoded value returning the new one, or a str for the raw text)."""
    meta = dict(META)
    for key, change in changes.items():
        meta[key] = change if isinstance(change, str) else json.dumps(change(
            json.loads(META[key])))
    return meta


def _set(d, key, value):
    d = dict(d)
    d[key] = value
    return d


def _rosbags_outputs(path):
    """(topic, time) of every output message of a recording, read by rosbags: each body's
    outputs (node_recorder.OUTPUTS) and /tf."""
    with AnyReader([Path(path)]) as reader:
        return [(c.topic, t) for c, t, _raw in reader.messages()
                if c.topic.rsplit('/', 1)[-1] in RECORDED_KINDS or c.topic == '/tf']


# -- the fixture, untouched and rewritten ------------------------------------------------------
def test_the_rewritten_fixture_verifies_and_every_output_is_counted(tmp_path):
    f = _rewrite(tmp_path / 'same.mcap', META)
    code, out, err = _verify(f)
    assert code == 0 and err == '', out + err
    n = len(_rosbags_outputs(f))
    assert n > 0 and f'{n} of {n} recorded output messages compared' in out
    per_topic = {t: sum(1 for topic, _ in _rosbags_outputs(f) if topic == t)
                 for t in ('/pose', '/twist', '/odom', '/imu', '/accel', '/tf')}
    for topic, count in per_topic.items():
        assert f'{topic:<24} {count} of {count} compared' in out
    assert 'identical: every output message re-simulated bit for bit' in out


# -- what the issue found, one case each --------------------------------------------------------
CASES = {
    'twist frame': (_meta(parameters=lambda p: _set(p, 'twist_frame', 'sideways')),
                    'twist_frame'),
    'twist frame not a string': (_meta(parameters=lambda p: _set(p, 'twist_frame', [1])),
                                 'twist_frame'),
    'parameters a list': (_meta(parameters=lambda p: list(p)), 'parameters must be a mapping'),
    'parameters a string': (_meta(parameters=lambda p: 'odom'), 'parameters must be a mapping'),
    'renamed output topic': (_meta(output_topics=lambda o: {'body': _set(
        o['body'], 'pose', '/elsewhere')}), 'topic /pose is neither an output'),
    'swapped output topics': (_meta(output_topics=lambda o: {'body': {
        'pose': '/twist', 'twist': '/pose', 'odom': '/odom'}}), 'has type'),
    'renamed output kind': (_meta(output_topics=lambda o: {'body': {
        'posture': '/pose', 'twist': '/twist', 'odom': '/odom'}}), 'output_topics.body has'),
    'an output record_outputs does not name': (_meta(parameters=lambda p: _set(
        p, 'record_outputs', ['pose', 'twist', 'odom', 'imu'])), 'record_outputs names only'),
    'a required output record_outputs names missing': (_meta(
        parameters=lambda p: _set(p, 'record_outputs', ['pose', 'twist', 'odom', 'accel']),
        output_topics=lambda o: {'body': {'pose': '/pose', 'twist': '/twist'}}),
        "it needs ['pose', 'twist', 'odom']"),
    'record_outputs naming no output': (_meta(parameters=lambda p: _set(
        p, 'record_outputs', [])), 'record_outputs must name one or more'),
    'renamed body': (_meta(output_topics=lambda o: {'robot': o['body']}),
                     "bodies ['robot']"),
    'renamed body in config': (_meta(config=lambda c: _set(c, 'bodies', [
        _set(c['bodies'][0], 'name', 'robot')])), 'output_topics are for bodies'),
    'static body': (_meta(config=lambda c: _set(c, 'bodies', [
        _set(c['bodies'][0], 'static', True)])), 'moving bodies'),
    'deep json': (_meta(config='[' * 100_000 + ']' * 100_000), 'nests 100000 levels deep'),
    'deep parameters': (_meta(parameters='{"a": ' * 5000 + '1' + '}' * 5000), 'parameters'),
    # Log times still give the recorded sequence numbers (step mod 2**32), at 2**32 + 1 times
    # the steps: without the bound this runs for days.
    'hanging dt': (_meta(config=lambda c: _set(c, 'dt', 0.001 / (2 ** 32 + 1)),
                         parameters=lambda p: {k: v for k, v in p.items() if k != 'dt'}),
                   'refusing to simulate that long'),
    'imu noise nan': (_meta(parameters=lambda p: _set(p, 'imu_gyro_noise', math.nan)),
                      'not a finite number'),
    'imu seed negative': (_meta(parameters=lambda p: _set(p, 'imu_seed', -1)), 'imu_seed'),
    'frame prefix absolute': (_meta(parameters=lambda p: _set(p, 'frame_prefix', '/x/')),
                              'frame_prefix'),
    'tf topics unknown': (_set(META, 'tf_topics', '["/tf", "/elsewhere"]'), 'tf_topics'),
    'tf topics not a list': (_set(META, 'tf_topics', '{"/tf": 1}'), 'tf_topics'),
    'tf topics a body output': (_set(META, 'tf_topics', '["/pose"]'), 'tf_topics must list'),
    'tf topics twice': (_set(META, 'tf_topics', '["/tf", "/tf"]'), 'tf_topics must list'),
    'tf topics nested': (_set(META, 'tf_topics', '[["/tf"]]'), 'tf_topics must list'),
    'format 2': (_set(META, 'format', '2'), "format '2'"),
    'no format': ({k: v for k, v in META.items() if k != 'format'}, 'format None'),
    'config not json': (_meta(config='{"dt": '), 'config is not JSON'),
    'config nan': (_meta(config=lambda c: _set(c, 'dt', math.nan)), 'not a finite number'),
    'config huge int': (_meta(config=lambda c: _set(c, 'dt', 10 ** 400)), 'beyond 2**63'),
    'config list': (_meta(config=lambda c: [c]), 'config must be a mapping'),
    'bodies not a list': (_meta(config=lambda c: _set(c, 'bodies', 'body')), 'must be a list'),
    'colliders not mappings': (_meta(config=lambda c: _set(c, 'bodies', [
        _set(c['bodies'][0], 'colliders', [1])])), 'colliders[0] must be a mapping'),
    'mass nested': (_meta(config=lambda c: _set(c, 'bodies', [
        _set(c['bodies'][0], 'mass', [[1]])])), 'not nested'),
    'dt disagrees': (_meta(parameters=lambda p: _set(p, 'dt', 0.002)), 'parameters: dt'),
    'rate disagrees': (_meta(parameters=lambda p: _set(p, 'publish_rate', 100.0)),
                       'publish_rate'),
    'steps per output': (_meta(config=lambda c: _set(c, 'steps_per_publish', 10 ** 9)),
                         'steps_per_publish'),
    'no config': ({k: v for k, v in META.items() if k != 'config'}, "no 'config'"),
}


@pytest.mark.parametrize('case', sorted(CASES))
def test_malformed_metadata_is_one_line_and_exit_2(tmp_path, case):
    meta, words = CASES[case]
    _assert_refused(_rewrite(tmp_path / 'bad.mcap', meta), words)


# -- the property: any mutation of the metadata is refused in one line, or verifies ------------
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(
        st.text(max_size=8), children, max_size=4), max_leaves=8)


def _mutate(data, value, draw):
    """``value`` with one part (chosen by ``draw``) replaced, deleted or kept."""
    if isinstance(value, (dict, list)) and value and draw(st.booleans()):
        keys = list(value) if isinstance(value, dict) else list(range(len(value)))
        key = draw(st.sampled_from(keys))
        copy = dict(value) if isinstance(value, dict) else list(value)
        action = draw(st.sampled_from(['descend', 'delete', 'replace']))
        if action == 'descend':
            copy[key] = _mutate(data, copy[key], draw)
        elif action == 'delete':
            del copy[key]
        else:
            copy[key] = draw(JSON_VALUES)
        return copy
    if isinstance(value, float) and draw(st.booleans()):  # near misses of a good number
        return draw(st.sampled_from([value * (1 + 2 ** -40), value / (2 ** 32 + 1), -value,
                                     0.0, value * 1e300, value * 1e-300]))
    return draw(JSON_VALUES)


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_metadata_mutation_is_one_line_exit_2_or_a_verification(tmp_path, data):
    draw = data.draw
    meta = dict(META)
    key = draw(st.sampled_from(['config', 'parameters', 'output_topics', 'format', 'version']))
    how = draw(st.sampled_from(['json', 'text', 'delete']))
    if how == 'delete':
        del meta[key]
    elif how == 'text':
        meta[key] = draw(st.text(max_size=20))
    else:
        meta[key] = json.dumps(_mutate(data, json.loads(META[key]) if key not in (
            'format', 'version') else META[key], draw))
    f = _rewrite(tmp_path / 'mutated.mcap', meta)
    code, out, err = _verify(f)  # an exception here is a traceback: the test fails
    if code == 2:
        assert err.startswith(f'replay: {f}: ') and err.count('\n') == 1, err
    else:
        assert code in (0, 1) and err == '', (code, out, err)
        n = len(_rosbags_outputs(f))
        assert f'{n} of {n} recorded output messages compared' in out


def test_a_key_with_a_newline_is_named_on_one_line(tmp_path):
    """A key of the recording's config holding a newline (found by the test above): the
    refusal names it escaped, on one line."""
    meta = dict(META)
    meta['config'] = json.dumps({'\n': {}})
    f = _rewrite(tmp_path / 'mutated.mcap', meta)
    code, out, err = _verify(f)
    assert code == 2 and err.startswith(f'replay: {f}: ') and err.count('\n') == 1, err
    assert 'config.\\n ' in err


# -- runs recorded offline, period by period, as the node records them --------------------------
def _params(**changes):
    values = {p.name: p.default for p in node_params.PARAMS}
    values.update(dt=0.001, publish_rate=100.0, **changes)
    return values


def _record_offline(path, spec, periods, wrenches=None, spoil=None):
    """Record ``periods`` publish periods of one body as the node does (publish at step 0,
    then: inputs, step, publish; a non-finite run keeps its last finite state). ``wrenches``:
    period -> Wrench applied at its start. ``spoil(period, out)`` may alter the messages."""
    config = Config(dt=0.001, steps_per_publish=10, bodies=(spec,))
    params = _params()
    topics = {spec.name: {k: f'/{k}' for k in OUTPUT_KINDS}}
    sim = Simulation(config)
    out = OutputMessages(params['world_frame'], params['body_frame'], params['twist_frame'])
    rec = NodeRecorder(str(path), config, params, topics)
    went_non_finite = False

    def publish(period):
        out.fill(sim.time_ns, *sim.pose_twist(spec.name))
        if spoil is not None:
            spoil(period, out)
        rec.output(spec.name, sim.step_count, sim.time_ns, out)

    publish(0)
    for period in range(1, periods + 1):
        if wrenches and period in wrenches:
            event = SetWrench(wrenches[period], spec.name)
            sim.apply(event)
            rec.event(sim.step_count, sim.time_ns, event)
        try:
            sim.run(config.steps_per_publish)
        except IntegrationError:
            went_non_finite = True
        publish(period)
    rec.close()
    assert rec.failed is None
    return went_non_finite


def test_a_run_that_went_non_finite_compares_every_output(tmp_path):
    f = tmp_path / 'blowup.mcap'
    spec = BodySpec(inertia=(1.0, 2.0, 3.0), initial_angular_velocity=(1e150, 1e150, 1e150))
    assert _record_offline(f, spec, periods=6)  # the run does go non-finite
    n = len(_rosbags_outputs(f))
    assert n == 3 * 7
    code, out, err = _verify(f)
    assert code == 0 and err == '', out + err
    assert f'{n} of {n} recorded output messages compared' in out
    assert 'the run went non-finite, as the node did' in out


def test_non_finite_recorded_outputs_fail(tmp_path):
    def nan_at_the_end(period, out):
        if period >= 4:
            out.pose.pose.position.x = math.nan
            out.odom.twist.twist.angular.z = math.inf

    f = tmp_path / 'nan.mcap'
    _record_offline(f, BodySpec(initial_angular_velocity=(0.1, 0.2, 0.3)), periods=5,
                    wrenches={1: Wrench((1.0, 0, 0), (0, 0, 0.1))}, spoil=nan_at_the_end)
    n = len(_rosbags_outputs(f))
    code, out, err = _verify(f)
    assert code == 1, out + err
    assert f'{n} of {n} recorded output messages compared' in out
    assert '4 recorded output messages hold non-finite values' in out  # 2 periods x pose, odom
    assert 'identical' not in out


_parts, _write = topic_parts, rewrite


def test_an_offline_run_verifies_and_other_inputs_do_not(tmp_path):
    f, g = tmp_path / 'run.mcap', tmp_path / 'other.mcap'
    spec = BodySpec(mass=2.0, inertia=(0.2, 0.3, 0.4), initial_angular_velocity=(0.3, 1, -0.2))
    first = Wrench((1.0, 0, 0), (0, 0, 0.05))
    second = Wrench((0, -2.0, 0), (0.01, 0, 0))
    _record_offline(f, spec, periods=8, wrenches={2: first, 5: second})
    _record_offline(g, spec, periods=8, wrenches={2: first, 6: second})
    code, out, err = _verify(f)
    assert code == 0 and 'identical' in out, out + err
    # The outputs of the first run with the inputs of the second: found.
    schemas, channels, messages, meta = _parts(f)
    inputs = [(t, m) for t, m in _parts(g)[2] if t.startswith('/rb_sim/input/')]
    outputs = [(t, m) for t, m in messages if not t.startswith('/rb_sim/input/')]
    mixed = _write(tmp_path / 'mixed.mcap', schemas, channels, inputs + outputs, meta)
    code, out, err = _verify(mixed)
    assert code == 1 and 'MISMATCH' in out and 'first /' in out, out + err


def test_an_input_to_a_static_body_is_one_line(tmp_path):
    f = tmp_path / 'run.mcap'
    _record_offline(f, BodySpec(), periods=3, wrenches={1: Wrench((1.0, 0, 0))})
    schemas, channels, messages, meta = _parts(f)
    config = json.loads(meta['config'])
    config['bodies'][0]['static'] = True
    bad = _write(tmp_path / 'static.mcap', schemas, channels, messages,
                 {**meta, 'config': json.dumps(config)})
    _assert_refused(bad, 'moving bodies')


def test_an_input_that_cannot_apply_is_one_line(tmp_path):
    f = tmp_path / 'run.mcap'
    _record_offline(f, BodySpec(), periods=3, wrenches={2: Wrench((1.0, 0, 0))})  # step 10
    schemas, channels, messages, meta = _parts(f)
    # Its recorded input claims a step before the run reached it (log time and sequence).
    moved = []
    for topic, m in messages:
        if topic.startswith('/rb_sim/input/'):
            m = type(m)(channel_id=m.channel_id, sequence=m.sequence - 5,
                        log_time=m.log_time - 5_000_000, publish_time=m.publish_time,
                        data=m.data)
        moved.append((topic, m))
    moved.sort(key=lambda tm: tm[1].log_time)
    bad = _write(tmp_path / 'moved.mcap', schemas, channels, moved, meta)
    code, out, err = _verify(bad)
    assert code == 1 and 'MISMATCH' in out, out + err  # applied earlier: outputs differ
    # A wrench in a frame that does not exist.
    wrong = []
    for topic, m in messages:
        if topic.endswith('/wrench'):
            m = type(m)(channel_id=m.channel_id, sequence=m.sequence, log_time=m.log_time,
                        publish_time=m.publish_time,
                        data=m.data.replace(b'world', b'wurld'))
        wrong.append((topic, m))
    bad = _write(tmp_path / 'frame.mcap', schemas, channels, wrong, meta)
    _assert_refused(bad, '/rb_sim/input/body/wrench at step 10 is invalid', 'wurld')


# -- the command line: options ------------------------------------------------------------------
@pytest.mark.parametrize('option, value', [
    ('--rate', '1e-300'), ('--rate', '-1'), ('--rate', 'nan'), ('--rate', 'inf'),
    ('--rate', 'fast'), ('--wait', 'nan'), ('--wait', '-1'), ('--wait', 'inf'),
])
def test_bad_playback_options_are_one_line_and_exit_2(option, value):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as exit_info:
        replay.main(['replay', str(FIXTURE), option, value])
    assert exit_info.value.code == 2
    assert err.getvalue().startswith('replay: ') and err.getvalue().count('\n') == 1
    assert option in err.getvalue()


def test_the_json_depth_bound_ignores_brackets_in_strings():
    assert replay.json_depth('{"a": "[[[[{{{{", "b": [1, [2, {"c": "]]\\"]"}]]}') == 4
    assert replay.json_depth('1') == 0


def test_a_full_disk_stops_the_node_recorder_quietly_and_recover_repairs_the_file(tmp_path):
    f = tmp_path / 'run.mcap'
    spec = BodySpec(inertia=(0.2, 0.3, 0.4), initial_angular_velocity=(0.3, 1, -0.2))
    config = Config(dt=0.001, steps_per_publish=10, bodies=(spec,))
    params = _params()
    rec = NodeRecorder(str(f), config, params, {'body': {k: f'/{k}' for k in OUTPUT_KINDS}})
    writer = rec._writer
    writer.flush(wait=True)
    disk_full_after(writer, 20_000)
    sim = Simulation(config)
    out = OutputMessages()
    period = 0
    while rec.failed is None and period < 100_000:  # event() and output() never raise
        if period % 7 == 0:
            event = SetWrench(Wrench((0.1 * period, 0, 0), (0, 0, 0.01)), 'body')
            sim.apply(event)
            rec.event(sim.step_count, sim.time_ns, event)
        out.fill(sim.time_ns, *sim.pose_twist('body'))
        rec.output('body', sim.step_count, sim.time_ns, out)
        sim.run(config.steps_per_publish)
        period += 1
        if period % 20 == 0:
            writer.flush(wait=True)
    assert rec.failed.startswith(f'{f}: writing failed: No space left on device (ENOSPC)')
    assert '\n' not in rec.failed
    for _ in range(1000):  # no-ops now
        rec.output('body', sim.step_count, sim.time_ns, out)
    rec.close()  # does not raise
    rec.close()
    assert rec.failed.startswith(f'{f}: writing failed: No space left on device')
    repaired = tmp_path / 'repaired.mcap'
    with contextlib.redirect_stdout(io.StringIO()):
        assert replay.main(['replay', '--recover', str(f), str(repaired)]) == 0
    n = len(_rosbags_outputs(repaired))
    assert n > 0
    code, text, err = _verify(repaired)  # what was kept re-simulates bit for bit
    assert code == 0 and f'{n} of {n} recorded output messages compared' in text, text + err


# -- bodies spawned and deleted in a run -------------------------------------------------------
SPAWNED = BodySpec('b', 2.0, (0.1, 0.2, 0.3), initial_position=(1.0, 2.0, 3.0),
                   initial_angular_velocity=(0.0, 0.5, 1.0))


def _record_spawning(path, spawn_topics=None, params=None):
    """The single body 'body', with 'b' spawned at period 2 (outputs on /b/...), pushed at
    period 3 and deleted at period 6, recorded as the node records it (a spawned body's frame
    is its name)."""
    spec = BodySpec(initial_angular_velocity=(0.1, 0.2, 0.3))
    config = Config(dt=0.001, steps_per_publish=10, bodies=(spec,))
    params = params or _params()
    rec = NodeRecorder(str(path), config, params, {'body': {k: f'/{k}' for k in OUTPUT_KINDS}})
    sim = Simulation(config)
    outs = {'body': OutputMessages(params['world_frame'], params['body_frame'],
                                   params['twist_frame']),
            'b': OutputMessages(params['world_frame'], 'b', params['twist_frame'])}
    for period in range(9):
        if period == 2:
            sim.apply(Spawn(SPAWNED))
            rec.spawned(sim.step_count, sim.time_ns, Spawn(SPAWNED), spawn_topics or
                        {k: f'/b/{k}' for k in OUTPUT_KINDS})
        if period == 3:
            event = SetWrench(Wrench((0.0, 1.0, 0.0), (0.0, 0.0, 0.1)), 'b')
            sim.apply(event)
            rec.event(sim.step_count, sim.time_ns, event)
        if period == 6:
            sim.apply(Delete('b'))
            rec.deleted(sim.step_count, sim.time_ns, 'b')
        if period:
            sim.run(config.steps_per_publish)
        for name in [b.name for b in sim.config.bodies]:
            outs[name].fill(sim.time_ns, *sim.pose_twist(name))
            rec.output(name, sim.step_count, sim.time_ns, outs[name])
    rec.close()
    assert rec.failed is None


def test_record_outputs_holds_for_a_spawned_body_and_it_verifies(tmp_path):
    """record_outputs [odom]: the spawned body's outputs are its odom only, in the spawn's
    own record too, and replay verifies what is there."""
    f = tmp_path / 'spawn.mcap'
    _record_spawning(f, params=_params(record_outputs=['odom']))
    code, out, err = _verify(f)
    assert code == 0 and 'identical' in out, out + err
    with AnyReader([f]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections if c.msgcount}
        spawn = [json.loads(reader.deserialize(raw, c.msgtype).data)
                 for c, _, raw in reader.messages() if c.topic == '/rb_sim/input/b/spawn']
    assert {t for t in counts if not t.startswith('/rb_sim/')} == {'/odom', '/b/odom'}
    assert counts['/b/odom'] == 4 and counts['/odom'] == 9
    assert [s['output_topics'] for s in spawn] == [{'odom': '/b/odom'}]


def test_a_run_with_a_spawn_and_a_delete_verifies(tmp_path):
    f = tmp_path / 'spawn.mcap'
    _record_spawning(f)
    code, out, err = _verify(f)
    assert code == 0 and 'identical' in out, out + err
    with AnyReader([f]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert counts['/b/pose'] == 4 and counts['/pose'] == 9  # b published in periods 2..5
    assert counts['/rb_sim/input/b/spawn'] == counts['/rb_sim/input/b/delete'] == 1
    # Without its spawn the outputs of 'b' belong to nothing: one line.
    schemas, channels, messages, meta = _parts(f)
    kept = [(t, m) for t, m in messages if t != '/rb_sim/input/b/spawn']
    _assert_refused(_write(tmp_path / 'nospawn.mcap', schemas, channels, kept, meta),
                    'neither an output named in the metadata or a spawn')
    # Spawned later than its first output: found, one line.
    moved = []
    for topic, m in messages:
        if topic == '/rb_sim/input/b/spawn':
            m = type(m)(channel_id=m.channel_id, sequence=m.sequence + 10,
                        log_time=m.log_time + 10_000_000, publish_time=m.publish_time,
                        data=m.data)
        moved.append((topic, m))
    moved.sort(key=lambda tm: tm[1].log_time)
    _assert_refused(_write(tmp_path / 'late.mcap', schemas, channels, moved, meta),
                    "an output of 'b'", 'no such moving body')


@pytest.mark.parametrize('case', ['not json', 'not a body', 'other name', 'topic taken',
                                  'input topic', 'kinds'])
def test_a_bad_spawn_in_a_recording_is_one_line(tmp_path, case):
    f = tmp_path / 'spawn.mcap'
    topics = {k: f'/b/{k}' for k in OUTPUT_KINDS}
    if case == 'topic taken':
        topics = {**topics, 'pose': '/pose'}
    elif case == 'input topic':
        topics = {**topics, 'pose': '/rb_sim/input/b/pose'}
    elif case == 'kinds':
        topics = {k: v for k, v in topics.items() if k != 'odom'}
    _record_spawning(f, topics)
    schemas, channels, messages, meta = _parts(f)
    spoiled = []
    for topic, m in messages:
        if topic == '/rb_sim/input/b/spawn' and case in ('not json', 'not a body', 'other name'):
            n = int.from_bytes(m.data[4:8], 'little')  # after the CDR header; with the NUL
            text = m.data[8:8 + n - 1].decode('latin-1')
            text = {'not json': text.replace('{', '[', 1),
                    'not a body': text.replace('"mass": 2.0', '"mass": -2.0'),
                    'other name': text.replace('"name": "b"', '"name": "c"')}[case]
            m = type(m)(channel_id=m.channel_id, sequence=m.sequence, log_time=m.log_time,
                        publish_time=m.publish_time, data=_cdr_string(text))
        spoiled.append((topic, m))
    bad = _write(tmp_path / 'bad.mcap', schemas, channels, spoiled, meta)
    words = {'not json': 'not JSON', 'not a body': 'mass', 'other name': "spawns 'c'",
             'topic taken': 'not one of its own', 'input topic': 'not one of its own',
             'kinds': 'it needs'}[case]
    _assert_refused(bad, 'the input on /rb_sim/input/b/spawn at step 10 is invalid', words)


def _cdr_string(text):
    """A std_msgs/String as CDR (little endian): header, length with the NUL, bytes, NUL."""
    data = text.encode('latin-1')
    return b'\x00\x01\x00\x00' + (len(data) + 1).to_bytes(4, 'little') + data + b'\x00'


# -- recordings the node writes after every static or every moving body is deleted ------------
@pytest.mark.parametrize('deleted, tf_counts', [
    (['ground'], {'/tf': [2] * 13, '/tf_static': [1, 0]}),
    (['a', 'b'], {'/tf': [2] * 4 + [0] * 9, '/tf_static': [1]})])
def test_a_recording_after_every_static_or_every_moving_body_is_deleted_verifies(
        tmp_path, deleted, tf_counts):
    """Deleting the last static body makes the node send an empty /tf_static, deleting the
    last moving ones an empty /tf at every publish: a file the node writes verifies."""
    tf_message_type = pytest.importorskip('tf2_msgs.msg').TFMessage
    a = BodySpec('a', 1.0, (0.1, 0.2, 0.3), initial_angular_velocity=(0.3, 1.0, -0.2))
    b = BodySpec('b', 2.0, (0.2, 0.2, 0.4), initial_angular_velocity=(0.0, 0.4, 1.0))
    ground = BodySpec('ground', static=True)
    config = Config(dt=0.001, steps_per_publish=10, bodies=(a, b, ground))
    params = _params(scene_file='scene.yaml')
    world = params['world_frame']
    moving, static = ['a', 'b'], ['ground']
    topics = {n: {k: f'/{n}/{k}' for k in OUTPUT_KINDS} for n in moving}
    f = tmp_path / 'deleted.mcap'
    rec = NodeRecorder(str(f), config, params, topics, tf_topics=('/tf', '/tf_static'))
    sim = Simulation(config)
    outs = {n: OutputMessages(world, n, params['twist_frame']) for n in moving}

    def tf(names):  # as the node fills /tf and /tf_static (frames: the bodies' names)
        msg = tf_message(tf_message_type, world, [node_params.body_frame(params, n, False)
                                                  for n in names])
        fill_tf(msg, sim.time_ns, [sim.pose_twist(n)[:2] for n in names])
        return msg

    static_due = True
    for period in range(13):
        for name in deleted if period == 4 else []:
            sim.apply(Delete(name))
            rec.deleted(sim.step_count, sim.time_ns, name)
            (static if name in static else moving).remove(name)
            static_due = static_due or name == 'ground'
        if period:
            sim.run(config.steps_per_publish)
        for n in moving:
            outs[n].fill(sim.time_ns, *sim.pose_twist(n))
            rec.output(n, sim.step_count, sim.time_ns, outs[n])
        rec.tf('/tf', sim.step_count, sim.time_ns, tf(moving))
        if static_due:
            rec.tf('/tf_static', sim.step_count, sim.time_ns, tf(static))
            static_due = False
    rec.close()
    assert rec.failed is None
    # The file holds what the case is about, read by an independent reader.
    with AnyReader([f]) as reader:
        counts = {}
        for c, _t, raw in reader.messages():
            if c.topic in ('/tf', '/tf_static'):
                n = len(reader.deserialize(raw, c.msgtype).transforms)
                counts.setdefault(c.topic, []).append(n)
    assert counts == tf_counts
    code, out, err = _verify(f)
    assert code == 0 and 'identical' in out, out + err


# -- verify streams: memory does not grow with the length --------------------------------------
def _verify_peak(path):
    """(the verification, the peak of Python's allocations while verifying ``path``)."""
    tracemalloc.start()
    try:
        result = replay.verify(str(path))
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_verify_memory_is_bounded_whatever_the_length(tmp_path):
    spec = BodySpec(mass=2.0, inertia=(0.2, 0.3, 0.4), initial_angular_velocity=(0.3, 1, -0.2))
    config = Config(dt=0.001, steps_per_publish=1, bodies=(spec,))
    short, long = tmp_path / 'short.mcap', tmp_path / 'long.mcap'
    n = 800
    record_offline(short, config, n, events={n // 2: [SetWrench(Wrench((1.0, 0, 0)), 'body')]})
    record_offline(long, config, 4 * n,
                   events={n // 2: [SetWrench(Wrench((1.0, 0, 0)), 'body')]})
    replay.verify(str(short))  # once first: what is loaded once (modules, compiled kernels)
    (r_short, small), (r_long, big) = _verify_peak(short), _verify_peak(long)
    assert r_short.identical and r_long.identical
    assert (r_short.outputs, r_long.outputs) == (3 * (n + 1), 3 * (4 * n + 1))
    assert big < 1.5 * small, (small, big)  # bounded: 4 times the messages, not 4 times this
