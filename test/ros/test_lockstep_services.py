# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
# built-msgs: simulation_interfaces
"""Lockstep with the services a user drives a run with: start paused, step, step_simulation,
simulate_steps, reset, spawn and delete, unpause, then stop_after. The probe is the
controller and answers when the test says.

The oracles: the protocol (a period steps only once its state is answered; an answer takes
effect at the next step), the IMU message sent again equal to the one recorded (a re-send
draws no noise), replay --verify of the run, and the recorded inputs (a non-finite answer is
"no change": no wrench)."""

from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from sensor_msgs.msg import Imu
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import Result
from simulation_interfaces.srv import DeleteEntity, SpawnEntity, StepSimulation
from std_srvs.srv import Empty, SetBool, Trigger

from rb_sim_ros.offline import replay
from rb_sim_ros.recording.reader import RecordingReader
from support.ros_harness import stamp_ns

OK = Result.RESULT_OK
MS = 1_000_000


def test_a_paused_lockstep_run_is_stepped_reset_and_changed_by_service_and_replays(
        start_sim, probe, tmp_path):
    scene = tmp_path / 'scene.yaml'
    scene.write_text('bodies:\n'
                     '  - {name: a, mass: 1.0, inertia: [0.1, 0.2, 0.3]}\n'
                     '  - {name: b, mass: 1.0, inertia: [0.1, 0.2, 0.3], '
                     'position: [2, 0, 0]}\n')
    run = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'lockstep:=true',
                    '-p', 'lockstep_inputs:=[a]', '-p', 'start_paused:=true',
                    '-p', 'imu_gyro_noise:=0.01', '-p', 'imu_seed:=3',
                    '-p', 'stop_after:=0.08', '-p', f'record:={run}')
    odom = probe.collect(Odometry, 'a/odom')
    imu = probe.collect(Imu, 'a/imu')
    pub = probe.publisher(WrenchStamped, 'a/wrench_stamped')

    def stamps():
        return sorted({stamp_ns(o.header.stamp) for o in odom})

    def answer(torque_z=0.01):
        msg = WrenchStamped()
        msg.header.stamp, msg.header.frame_id = odom[-1].header.stamp, 'a'
        msg.wrench.torque.z = torque_z
        pub.publish(msg)

    def step_simulation(steps):
        return probe.call(StepSimulation, 'step_simulation',
                          StepSimulation.Request(steps=steps)).result

    # Paused from the start, and not heard from: the state of t = 0 is sent again (the
    # same message: no noise drawn again) until the controller answers.
    probe.wait_for(lambda: len([m for m in imu if stamp_ns(m.header.stamp) == 0]) >= 2,
                   what='the state of t = 0 sent again while paused')
    first_imu = [m for m in imu if stamp_ns(m.header.stamp) == 0]
    assert all(m == first_imu[0] for m in first_imu)
    # A non-finite answer is refused and answers "no change": the run can step.
    answer(float('nan'))
    probe.wait_for(lambda: probe.call(Trigger, 'step', Trigger.Request()).success,
                   what='a step once t = 0 is answered')
    probe.wait_for(lambda: stamps()[-1] == 10 * MS, what='the state of t = 10 ms')
    # step_simulation holds the executor: without an answer it stops and says why ...
    failed = step_simulation(10)
    assert failed.result == Result.RESULT_OPERATION_FAILED
    assert 'lockstep' in failed.error_message and 'a to answer' in failed.error_message
    assert stamps()[-1] == 10 * MS
    # ... and with one it steps (one period: no second answer needed).
    answer(0.02)
    probe.wait_for(lambda: step_simulation(10).result == OK, what='step_simulation')
    probe.wait_for(lambda: stamps()[-1] == 20 * MS, what='the state of t = 20 ms')
    # simulate_steps waits for each answer between periods.
    client = ActionClient(probe.node, SimulateSteps, 'simulate_steps')
    probe.wait_for(client.server_is_ready, what='the simulate_steps action')
    goal = client.send_goal_async(SimulateSteps.Goal(steps=20))
    probe.wait_for(goal.done, what='the goal accepted')
    result = goal.result().get_result_async()
    answered = set()

    def answering_until_done():
        last = stamps()[-1]
        if last not in answered and last < 40 * MS:
            answered.add(last)
            answer(0.03)
        return result.done()
    probe.wait_for(answering_until_done, what='simulate_steps with answers', timeout=30)
    assert result.result().result.result.result == OK
    # (the state comes on its own topic: maybe after the result)
    probe.wait_for(lambda: stamps()[-1] == 40 * MS, what='the state of t = 40 ms')
    assert answered == {20 * MS, 30 * MS}
    # Spawn, delete and reset while paused, the answer to t = 40 ms in or not.
    req = SpawnEntity.Request(name='c', resource_string='{mass: 1.0, inertia: [1, 1, 1]}')
    assert probe.call(SpawnEntity, 'spawn_entity', req).result.result == OK
    assert probe.call(DeleteEntity, 'delete_entity',
                      DeleteEntity.Request(entity='b')).result.result == OK
    probe.call(Empty, 'reset', Empty.Request())
    # Run on: each state answered as it comes, to the end (stop_after: 80 ms).
    assert probe.call(SetBool, 'pause', SetBool.Request(data=False)).success

    def answer_each():
        last = stamps()[-1]
        if last not in answered:
            answered.add(last)
            answer(0.04)
        return sim.proc.poll() is not None
    probe.wait_for(answer_each, what='the run to its end')
    assert sim.proc.wait(300) == 0, sim.output()
    assert 'rejected wrench_stamped' in sim.output()

    assert replay.verify(str(run)).identical
    reader = RecordingReader(str(run))
    wrenches = [(m.sequence, m.message.wrench.torque.z) for m in
                reader.messages(topics=['/rb_sim/input/a/wrench'])]
    # Each answer at the step after the state it answered; t = 0's (NaN) changed nothing;
    # the answers 0.03 to t = 20 and 30 ms: one change; the reset at step 40 does not
    # clear a wrench, and 0.04 from the answer to t = 40 ms.
    assert wrenches == [(10, 0.02), (20, 0.03), (40, 0.04)], wrenches
    recorded_imu = next(m.message for m in reader.messages(topics=['/a/imu'])
                        if m.sequence == 0)
    assert recorded_imu == first_imu[0]


def test_a_lockstep_input_that_is_no_body_refuses_the_start_with_exit_2(start_sim, tmp_path):
    scene = tmp_path / 'scene.yaml'
    scene.write_text('bodies:\n'
                     '  - {name: a, mass: 1.0, inertia: [0.1, 0.2, 0.3]}\n'
                     '  - {name: floor, static: true}\n')
    for inputs, said in (('[nobody]', "'nobody' is neither a body with topics"),
                         ('[floor]', "'floor' is a static body")):
        sim = start_sim('-p', f'scene_file:={scene}', '-p', 'lockstep:=true',
                        '-p', f'lockstep_inputs:={inputs}')
        assert sim.proc.wait(300) == 2
        assert said in sim.output()
