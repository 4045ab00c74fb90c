# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
"""A controller called in-process in lockstep (offline/closed_loop) makes the run the simulator
node makes with the same controller as a ROS node over DDS: the same recording, field by
field. The oracles: the node's own recording of the DDS run (node_recorder.same_run),
replay --verify, and the controller's law applied to the recorded states (each wrench is the
law of the state the protocol says)."""

import math

import pytest
from rosbags.highlevel import AnyReader

from rb_sim_ros.offline import closed_loop, replay
from rb_sim_ros.recording.reader import RecordingReader
from rb_sim_ros.ros import node_recorder
from support.attitude_law import ctl, loop, wrenches_follow_the_law

CONTROLLER = str(loop.HERE / 'attitude_controller.py')
GAINS = {'target_rpy': loop.TARGET_RPY, 'inertia': loop.INERTIA,
         'natural_frequency': loop.WN, 'damping_ratio': loop.ZETA}
# What examples/closed_loop_ci.py sets on the simulator (record and its overwrite are
# RUN_NEUTRAL: they may differ).
SIM = {'lockstep_timeout': 60.0, 'record_overwrite': True, 'inertia': loop.INERTIA}


def test_in_process_and_over_dds_the_same_controller_makes_the_same_run(
        installed, ros_env, tmp_path):
    """The noisy IMU as the controller's state, and a delay of two periods: what both ways
    must reproduce (the noise drawn at the same publishes, the answers taking effect at the
    same steps)."""
    sim = {'imu_gyro_noise': 0.01, 'imu_seed': 7, 'lockstep_delay': 2,
           'real_time_factor': 0.0}
    dds = loop.closed_loop(tmp_path / 'dds.mcap', env=ros_env, stop_after=2.0,
                           sim_args=[a for k, v in sim.items()
                                     for a in ('-p', f'{k}:={v}')],
                           controller_args=['-p', 'source:=imu'])
    law = closed_loop.load_controller(CONTROLLER, dict(GAINS, source='imu'))
    ours = tmp_path / 'ours.mcap'
    result = closed_loop.run(dict(SIM, stop_after=2.0, **sim), {'body': law}, str(ours))
    assert (result.error, result.steps, result.refused) == ('', 2000, 0)
    assert node_recorder.same_run(str(dds), str(ours)) == ''
    assert replay.verify(str(ours)).identical
    assert wrenches_follow_the_law(ours, '', 'imu', delay=2) > 150


def _wrench_steps(path):
    return [m.sequence for m in RecordingReader(str(path)).messages(
        topics=['/rb_sim/input/body/wrench'])]


def test_the_loop_settles_the_body_and_answers_each_state_once_where_the_protocol_says(
        tmp_path):
    """In-process alone (no ROS graph): the body reaches its target within the time its
    gains promise, and each wrench is the law of the state before it."""
    law = closed_loop.load_controller(CONTROLLER, GAINS)
    path = tmp_path / 'run.mcap'
    result = closed_loop.run(dict(SIM, stop_after=4.0), {'body': law}, str(path))
    assert result.answered == 400 and result.error == ''
    assert wrenches_follow_the_law(path, '', 'odom', delay=0) > 300
    t, angle = loop.attitude_errors(path)
    assert t[-1] == 4.0 and angle[-1] < 0.005 < 1.0 < angle[0]
    settled_at = t[[k for k in range(len(t)) if angle[k] > 0.02 * angle[0]][-1] + 1]
    assert settled_at < 1.5 * 4.0 / (loop.ZETA * loop.WN)


class _Law:
    """A law that answers as told: its wrench per call number, raising where it is an
    exception."""

    def __init__(self, answers) -> None:
        self.answers, self.calls = answers, 0

    def __call__(self, state):
        answer = self.answers(self.calls)
        self.calls += 1
        if isinstance(answer, Exception):
            raise answer
        return answer


def test_a_law_that_raises_or_gives_a_bad_wrench_is_answered_with_no_change(tmp_path):
    """As ControlLoop and the node do: the wrench held stays (nothing recorded), the run goes
    on, and command_timeout does not fire (a HOLD is a command)."""
    def answers(k):
        if k < 3:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.1 * (k + 1))
        return [RuntimeError('boom'), ((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0)), None][k % 3]
    path = tmp_path / 'held.mcap'
    result = closed_loop.run({'stop_after': 2.0, 'command_timeout': 0.05},
                             {'body': _Law(answers)}, str(path))
    assert result.error == '' and result.refused == 132  # calls 3 to 199 but each third's None
    assert _wrench_steps(path) == [0, 10, 20]
    # the torque 0.3 N m about z held for the rest of the run: w_z = 0.6 + 0.3 (t - 0.02) / I
    w = [m.message.twist.twist.angular.z for m in RecordingReader(str(path)).messages(
        topics=['/odom'])][-1]
    assert w == pytest.approx((0.1 * 0.01 + 0.2 * 0.01 + 0.3 * 1.98) / 0.1, rel=1e-9)
    assert replay.verify(str(path)).identical


def test_an_answered_wrench_is_renewed_every_period_and_never_timed_out(tmp_path):
    """command_timeout shorter than the run but longer than a period: each answer is a
    command, so the force answered at every state acts for the whole run (v = F t / m)."""
    law = _Law(lambda k: ((1.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    values = closed_loop.node_values({'stop_after': 0.5, 'command_timeout': 0.05})
    run = closed_loop.ClosedLoop(values, {'body': law}, str(tmp_path / 'renewed.mcap'))
    assert run.start()
    periods = 1
    while run.period():
        periods += 1
    result = run.close()
    assert periods == 50 and result.answered == 50 and law.calls == 50
    assert _wrench_steps(tmp_path / 'renewed.mcap') == [0]  # the same wrench: recorded once
    v = run.sim.pose_twist('body')[2]
    assert v[0] == pytest.approx(0.5, rel=1e-12)


@pytest.mark.parametrize('where, params, said', [
    ('no_such_file.py', {}, 'cannot load it'),
    ('math', {}, 'no make_law'),
    (CONTROLLER, {'gain': 1.0}, "unknown parameter 'gain'"),
    (CONTROLLER, {'natural_frequency': -1.0}, 'must be > 0'),
    (CONTROLLER, {'inertia': [1.0, 'a', 1.0]}, 'inertia 3 moments'),
])
def test_a_bad_controller_is_refused_in_one_line(where, params, said):
    with pytest.raises(ValueError, match=said) as e:
        closed_loop.load_controller(where, params)
    assert '\n' not in str(e.value)


@pytest.mark.parametrize('params, said', [
    ({'stop_after': 1.0, 'dt': -1.0}, 'dt'),
    ({'stop_after': 1.0, 'no_such': 1}, "'no_such' is not a parameter"),
    ({}, 'stop_after'),
])
def test_bad_parameters_are_refused_in_one_line(params, said):
    with pytest.raises(ValueError, match=said):
        closed_loop.node_values(params)


def test_a_controller_for_a_body_without_topics_is_refused(tmp_path):
    with pytest.raises(ValueError, match="'ghost': not a moving body"):
        closed_loop.run({'stop_after': 1.0}, {'ghost': _Law(lambda k: None)},
                        str(tmp_path / 'x.mcap'))


def test_the_example_law_is_the_nodes_law():
    """make_law gives the torque pd_torque gives for the gains of the parameters."""
    law = ctl.make_law(GAINS)
    kp = [2.0 * i * loop.WN ** 2 for i in loop.INERTIA]
    kd = [2.0 * loop.ZETA * loop.WN * i for i in loop.INERTIA]
    from nav_msgs.msg import Odometry
    msg = Odometry()
    o = msg.pose.pose.orientation
    o.x, o.y, o.z, o.w = 0.1, 0.2, 0.3, math.sqrt(1 - 0.14)
    msg.twist.twist.angular.x = 0.5
    assert law(msg) == ((0.0, 0.0, 0.0), ctl.pd_torque(
        ctl.quaternion_from_rpy(*loop.TARGET_RPY), (o.x, o.y, o.z, o.w), (0.5, 0.0, 0.0),
        kp, kd, 10.0))


def test_two_bodies_of_a_scene_each_with_its_controller_and_a_delay(tmp_path):
    """Each body's answers take effect two periods after its state, on its own topics."""
    scene = tmp_path / 'two.yaml'
    scene.write_text(
        'bodies:\n'
        f'  - {{name: a, mass: 1.0, inertia: {loop.INERTIA}}}\n'
        f'  - {{name: b, mass: 1.0, inertia: {loop.INERTIA}, '
        'orientation: [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]}\n')
    path = tmp_path / 'two.mcap'
    laws = {b: closed_loop.load_controller(CONTROLLER, GAINS) for b in ('a', 'b')}
    result = closed_loop.run({'stop_after': 2.0, 'scene_file': str(scene),
                              'lockstep_delay': 2}, laws, str(path))
    assert result.error == '' and result.answered == 400
    for body in ('a/', 'b/'):
        assert wrenches_follow_the_law(path, body, 'odom', delay=2) > 150
    assert replay.verify(str(path)).identical


def test_a_scene_with_a_static_body_a_frame_prefix_and_two_controllers_over_dds_too(
        installed, ros_env, tmp_path):
    """What a scene adds to the node's recording: a static body's /tf_static, the bodies'
    own topics and frames (frame_prefix), two lockstep inputs, command_timeout, and fewer
    outputs recorded (record_outputs); the node over DDS with two controller nodes and the
    in-process loop record the same run."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text(
        'bodies:\n'
        f'  - {{name: a, mass: 1.0, inertia: {loop.INERTIA}}}\n'
        f'  - {{name: b, mass: 2.0, inertia: {loop.INERTIA}, '
        'orientation: [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]}\n'
        '  - name: ground\n'
        '    static: true\n'
        '    position: [0.0, 0.0, -5.0]\n'
        '    colliders: [{type: plane, normal: [0.0, 0.0, 1.0], offset: 0.0}]\n')
    sim = {'scene_file': str(scene), 'lockstep_inputs': ['a', 'b'], 'lockstep_delay': 1,
           'frame_prefix': 'sc/', 'command_timeout': 0.05, 'real_time_factor': 0.0,
           'record_outputs': ['odom', 'imu']}
    dds = loop.closed_loop(tmp_path / 'dds.mcap', env=ros_env, stop_after=1.0,
                           sim_args=[a for k, v in sim.items() for a in ('-p', f'{k}:={v}')],
                           controllers=[['-r', '__ns:=/a'], ['-r', '__ns:=/b']])
    laws = {b: closed_loop.load_controller(CONTROLLER, GAINS) for b in ('a', 'b')}
    ours = tmp_path / 'ours.mcap'
    result = closed_loop.run(dict(SIM, stop_after=1.0, **sim), laws, str(ours))
    assert result.error == '' and result.answered == 200
    assert node_recorder.same_run(str(dds), str(ours)) == ''
    recorded = {t for t, info in RecordingReader(str(dds)).topics.items()
                if info.message_count and not t.startswith('/rb_sim/')}
    assert recorded == {'/a/odom', '/a/imu', '/b/odom', '/b/imu', '/tf', '/tf_static'}
    statics = list(RecordingReader(str(ours)).messages(topics=['/tf_static']))
    assert [t.child_frame_id for t in statics[0].message.transforms] == ['sc/ground']


def test_in_process_parameters_it_cannot_honour_are_refused(tmp_path):
    law = closed_loop.load_controller(CONTROLLER, GAINS)
    with pytest.raises(ValueError, match='start_paused'):
        closed_loop.run({'stop_after': 1.0, 'start_paused': True}, {'body': law},
                        str(tmp_path / 'x.mcap'))
    with pytest.raises(ValueError, match='lockstep_inputs'):
        closed_loop.run({'stop_after': 1.0, 'lockstep_inputs': '[other]'}, {'body': law},
                        str(tmp_path / 'x.mcap'))


DATACLASS_LAW = """
from __future__ import annotations
from dataclasses import dataclass


@dataclass
class Gain:
    k: float = 1.0


def make_law(parameters):
    gain = Gain(**parameters)
    return lambda state: ((0.0, 0.0, 0.0), (0.0, 0.0, -gain.k * state.twist.twist.angular.z))
"""


def test_a_controller_file_loads_as_a_module_and_a_failing_one_is_one_line(tmp_path):
    (tmp_path / 'dc.py').write_text(DATACLASS_LAW)
    law = closed_loop.load_controller(str(tmp_path / 'dc.py'), {'k': 2.0})
    assert callable(law)
    (tmp_path / 'boom.py').write_text('raise RuntimeError("no")\n')
    with pytest.raises(ValueError, match='cannot load it: RuntimeError: no'):
        closed_loop.load_controller(str(tmp_path / 'boom.py'))
    with pytest.raises(ValueError, match='make_law: TypeError'):
        closed_loop.load_controller(str(tmp_path / 'dc.py'), {'nope': 1})


def test_record_outputs_keeps_those_outputs_bit_for_bit_and_replay_verifies_them(tmp_path):
    """A recording of odom and imu only, without /tf: those topics (as rosbags, an independent
    reader, lists them), each message the bytes of the full recording's, and replay verifies
    it (regenerating every output, comparing those recorded)."""
    law = closed_loop.load_controller(CONTROLLER, dict(GAINS, source='imu'))
    base = {'stop_after': 0.5, 'imu_gyro_noise': 0.01, 'imu_seed': 3}
    full, few = tmp_path / 'full.mcap', tmp_path / 'few.mcap'
    closed_loop.run(base, {'body': law}, str(full))
    closed_loop.run(dict(base, record_outputs=['odom', 'imu'], publish_tf=False),
                    {'body': law}, str(few))

    def outputs(path):
        with AnyReader([path]) as reader:
            return {c.topic: [raw for _, _, raw in reader.messages([c])]
                    for c in reader.connections
                    if c.msgcount and not c.topic.startswith('/rb_sim/')}
    every, kept = outputs(full), outputs(few)
    assert sorted(every) == ['/accel', '/imu', '/odom', '/pose', '/tf', '/twist']
    assert sorted(kept) == ['/imu', '/odom']
    assert all(kept[t] == every[t] and len(kept[t]) == 51 for t in kept)
    verified = replay.verify(str(few))
    assert verified.identical and verified.outputs == 2 * 51


@pytest.mark.parametrize('frame, expected', [
    # (the law's frame: what the node takes its answer as, and the wrench input recorded)
    ('world', ('world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.2))),
    ('/world', ('world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.2))),
    ('thruster', ('body', (1.0, 0.0, 0.0), (0.0, 0.0, 0.2 - 0.5))),  # t + r x f, r = (0, .5, 0)
    ('nowhere', None)])
def test_a_laws_frame_is_taken_as_the_node_takes_a_wrench_stamped(tmp_path, frame, expected):
    """A law answering in the world frame, or at an application point of the body (its force
    there, the moment r x f added about the centre of mass), as body_ports does for a
    wrench_stamped with that frame_id; an unknown frame is refused and held."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text('bodies:\n  - {name: body, mass: 2.0, inertia: [0.1, 0.1, 0.1], '
                     'points: {thruster: [0.0, 0.5, 0.0]}}\n')
    law = _Law(lambda k: ((1.0, 0.0, 0.0), (0.0, 0.0, 0.2)))
    law.frame = frame
    path = tmp_path / 'run.mcap'
    result = closed_loop.run({'scene_file': str(scene), 'stop_after': 0.1}, {'body': law},
                             str(path))
    assert result.error == '' and result.answered == 10
    recorded = [m.message for m in RecordingReader(str(path)).messages(
        topics=['/rb_sim/input/body/wrench'])]
    if expected is None:
        assert recorded == [] and result.refused == 10
        assert "frame_id 'nowhere'" in result.refusal
        return
    assert result.refused == 0 and len(recorded) == 1
    w = recorded[0]
    assert (w.header.frame_id, (w.wrench.force.x, w.wrench.force.y, w.wrench.force.z),
            (w.wrench.torque.x, w.wrench.torque.y, w.wrench.torque.z)) == expected
    assert replay.verify(str(path)).identical
