# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""Lockstep over DDS: a closed loop repeats bit for bit on a loaded machine and at any pace,
each answer takes effect at the step the protocol says (recomputed from the recorded state
with the controller's own law), and a stalled, late or missing controller is said, timed out
as asked, and noted in the recording.

The oracles: a second run of the same closed loop (the recordings compared field by field,
recording/compare.py), replay --verify, and the controller's law applied to the recorded
states."""

import importlib
import json
from pathlib import Path
import subprocess
import sys

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from std_srvs.srv import SetBool, Trigger

from rb_sim_ros.offline import replay
from rb_sim_ros.recording.reader import RecordingReader
from rb_sim_ros.ros import node_recorder
from support.attitude_law import wrenches_follow_the_law
from support.ros_harness import stamp_ns

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'examples'))
ctl = importlib.import_module('attitude_controller')
loop = importlib.import_module('closed_loop_ci')

BURN = 'while True: pass'


def test_a_closed_loop_repeats_bit_for_bit_under_load_with_a_jittery_controller_at_any_pace(
        installed, ros_env, tmp_path):
    """Once as fast as possible on an idle machine; once in real time with both cores kept
    busy and a controller that waits a random time up to 5 ms before each answer. The
    controller reads the noisy IMU: waiting must not change the noise either."""
    noisy = ['-p', 'imu_gyro_noise:=0.01', '-p', 'imu_seed:=7']
    quick = loop.closed_loop(tmp_path / 'quick.mcap', env=ros_env, stop_after=4.0,
                             sim_args=[*noisy, '-p', 'real_time_factor:=0.0'],
                             controller_args=['-p', 'source:=imu'])
    burners = [subprocess.Popen([sys.executable, '-c', BURN]) for _ in range(2)]
    try:
        slow = loop.closed_loop(tmp_path / 'slow.mcap', env=ros_env, stop_after=4.0,
                                sim_args=[*noisy, '-p', 'real_time_factor:=1.0'],
                                controller_args=['-p', 'source:=imu',
                                                 '-p', 'answer_delay_max:=0.005'])
    finally:
        for b in burners:
            b.kill()
            b.wait()
    assert node_recorder.same_run(str(quick), str(slow)) == ''
    for run in (quick, slow):
        assert replay.verify(str(run)).identical
    for run in (quick, slow):
        assert wrenches_follow_the_law(run, '', 'imu', delay=0)
    # The loop closed: the body is on its target at the end.
    t, angle = loop.attitude_errors(quick)
    assert t[-1] == 4.0 and angle[-1] < 0.02 < 1.0 < angle[0]


def test_two_controllers_on_two_bodies_with_a_delay_repeat_and_answer_where_the_delay_says(
        installed, ros_env, tmp_path):
    scene = tmp_path / 'two.yaml'
    scene.write_text(
        'bodies:\n'
        f'  - {{name: a, mass: 1.0, inertia: {loop.INERTIA}}}\n'
        f'  - {{name: b, mass: 1.0, inertia: {loop.INERTIA}, '
        'orientation: [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]}\n')
    args = ['-p', f'scene_file:={scene}', '-p', 'lockstep_inputs:=[a, b]',
            '-p', 'lockstep_delay:=2', '-p', 'real_time_factor:=0.0']
    first = loop.closed_loop(tmp_path / 'first.mcap', env=ros_env, sim_args=args,
                             stop_after=2.0, controllers=[['-r', '__ns:=/a'],
                                                          ['-r', '__ns:=/b']])
    burners = [subprocess.Popen([sys.executable, '-c', BURN]) for _ in range(2)]
    try:
        second = loop.closed_loop(
            tmp_path / 'second.mcap', env=ros_env, sim_args=args, stop_after=2.0,
            controllers=[['-r', '__ns:=/a', '-p', 'answer_delay_max:=0.003'],
                         ['-r', '__ns:=/b']])
    finally:
        for b in burners:
            b.kill()
            b.wait()
    assert node_recorder.same_run(str(first), str(second)) == ''
    assert replay.verify(str(first)).identical
    for body in ('a/', 'b/'):
        assert wrenches_follow_the_law(first, body, 'odom', delay=2)


def _diagnostics(probe, got, key, wanted, what):
    def seen():
        for msg in got:
            for status in msg.status:
                values = {v.key: v.value for v in status.values}
                if wanted(values.get(key, ''), status):
                    return True
        return False
    probe.wait_for(seen, what=what)


def test_a_stalled_controller_is_said_and_the_services_work_in_lockstep(start_sim, probe):
    """The probe is the controller: it answers when the test says. /diagnostics names the
    input awaited and for how long; a wrong stamp is refused and counted; step refuses while
    an answer is missing and steps once it is in; a pause holds the run."""
    start_sim('-p', 'lockstep:=true', '-p', 'lockstep_inputs:=body')
    odom = probe.collect(Odometry, 'odom')

    def stamps():  # (a state not answered yet is sent again: the same stamp)
        return sorted({stamp_ns(o.header.stamp) for o in odom})
    diag = probe.collect(DiagnosticArray, '/diagnostics')
    pub = probe.publisher(WrenchStamped, 'wrench_stamped')
    probe.wait_for(lambda: odom, what='the state of t = 0')
    _diagnostics(probe, diag, 'lockstep_waiting_for',
                 lambda v, s: v == 'body' and s.level == DiagnosticStatus.WARN
                 and 'waiting' in s.message and 'for body' in s.message,
                 'a warning naming the input awaited')

    def answer(stamp, frame='body'):
        msg = WrenchStamped()
        msg.header.stamp, msg.header.frame_id = stamp, frame
        msg.wrench.torque.z = 0.01
        pub.publish(msg)

    wrong = Odometry().header.stamp
    wrong.nanosec = 5_000_000  # t = 5 ms: no state has it
    answer(wrong)
    _diagnostics(probe, diag, 'lockstep_refused_total', lambda v, s: v == '1',
                 'the refusal counted')
    assert stamps() == [0]  # nothing stepped
    for k in range(3):  # each answer steps one period, and only one
        answer(odom[-1].header.stamp)
        probe.wait_for(lambda: len(stamps()) == k + 2, what=f'period {k + 1}')
        assert stamps()[-1] == (k + 1) * 10_000_000 == stamp_ns(odom[-1].header.stamp)
    assert probe.call(SetBool, 'pause', SetBool.Request(data=True)).success
    r = probe.call(Trigger, 'step', Trigger.Request())
    assert not r.success and 'waiting' in r.message and 'body' in r.message
    answer(odom[-1].header.stamp, frame='hold')  # no change, and an answer
    probe.wait_for(lambda: probe.call(Trigger, 'step', Trigger.Request()).success,
                   what='a step once the answer is in')
    probe.wait_for(lambda: len(stamps()) == 5, what='the stepped period')
    assert stamps()[-1] == 40_000_000


def test_timeouts_and_a_controller_that_leaves_end_the_run_as_asked(start_sim, probe,
                                                                    tmp_path):
    """No controller: 'hold' goes on open loop after the timeout and ends at stop_after (exit
    0, the timeout noted in the recording); 'error' ends the run with exit 3 and the reason.
    A controller that leaves mid-run is not waited for any more, and said."""
    held = tmp_path / 'held.mcap'
    sim = start_sim('-p', 'lockstep:=true', '-p', 'lockstep_timeout:=0.5',
                    '-p', 'lockstep_on_timeout:=hold', '-p', 'stop_after:=0.3',
                    '-p', f'record:={held}')
    assert sim.proc.wait(300) == 0
    notes = [json.loads(m.message.data) for m in
             RecordingReader(str(held)).messages(topics=[node_recorder.LOCKSTEP])]
    assert notes and notes[0] == {'event': 'timeout', 'inputs': []}
    assert replay.verify(str(held)).identical
    failed = tmp_path / 'failed.mcap'
    sim = start_sim('-p', 'lockstep:=true', '-p', 'lockstep_timeout:=0.5',
                    '-p', 'stop_after:=0.3', '-p', f'record:={failed}')
    assert sim.proc.wait(300) == 3
    assert 'no answer from any controller' in sim.output()
    assert RecordingReader(str(failed)).topics  # finished: it reads
    # A controller that answers twice and leaves.
    left = tmp_path / 'left.mcap'
    sim = start_sim('-p', 'lockstep:=true', '-p', 'stop_after:=0.5', '-p', f'record:={left}')
    odom = probe.collect(Odometry, 'odom')
    pub = probe.publisher(WrenchStamped, 'wrench_stamped')
    for k in range(2):
        probe.wait_for(lambda: odom and stamp_ns(odom[-1].header.stamp) == k * 10_000_000,
                       what=f'state {k}')
        msg = WrenchStamped()
        msg.header.stamp, msg.header.frame_id = odom[-1].header.stamp, 'hold'
        pub.publish(msg)
    probe.wait_for(lambda: stamp_ns(odom[-1].header.stamp) == 20_000_000,
                   what='the third state')
    probe.node.destroy_publisher(pub)
    assert sim.proc.wait(300) == 0
    assert "'body' has no controller any more" in sim.output()
    notes = [json.loads(m.message.data) for m in
             RecordingReader(str(left)).messages(topics=[node_recorder.LOCKSTEP])]
    assert notes == [{'event': 'left', 'inputs': ['body']}]


def test_the_closed_loop_ci_example_of_the_readme_passes(installed, ros_env, tmp_path,
                                                         monkeypatch):
    """examples/closed_loop_ci.py as a user runs it (pytest examples/closed_loop_ci.py), on
    the suite's own ROS domain."""
    monkeypatch.setattr(loop, 'ros_environment', lambda: dict(ros_env))
    loop.test_the_attitude_controller_settles_as_its_gains_promise(tmp_path)
    assert (tmp_path / 'run.mcap').stat().st_size > 0
