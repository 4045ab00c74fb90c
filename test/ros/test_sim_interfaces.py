# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap rosbags
# built-msgs: simulation_interfaces
"""The standard simulator API (simulation_interfaces, Jazzy's 1.5.1) on the node: its type
hashes against a build of the release's own files, each service against the physics it
claims, refusals that change nothing, and a recording of it all that replays bit for bit."""

import importlib.util
import json
from pathlib import Path
import struct
import subprocess
import time

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, Wrench, WrenchStamped
import pytest
from rclpy.action import ActionClient
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import (EntityCategory, EntityState, Result, SimulationState,
                                       SimulatorFeatures, SpawnResult)
from simulation_interfaces.msg import SpawnEntity as SpawnRequest
from simulation_interfaces.srv import (DeleteEntity, GetEntities, GetEntityState,
                                       GetSimulationState, GetSimulatorFeatures, GetSpawnables,
                                       ResetSimulation, SetEntityState, SetSimulationState,
                                       SpawnEntities, SpawnEntity, StepSimulation)

from rb_sim_ros.ros.body_ports import APPLIED_QOS
from support.ros_harness import stamp_ns

ROOT = Path(__file__).resolve().parents[2]
HASHES = json.loads((ROOT / 'test' / 'fixtures' / 'simulation_interfaces_jazzy_hashes.json')
                    .read_text())['hashes']

OK = Result.RESULT_OK
SCENE = ('bodies:\n'
         '  - {name: a, mass: 1.0, inertia: [0.1, 0.2, 0.3], position: [1, 0, 0], '
         'angular_velocity: [0, 0, 0.5]}\n'
         '  - {name: b, mass: 2.0, inertia: [0.2, 0.2, 0.2], position: [0, 2, 0]}\n'
         '  - {name: wall, static: true, position: [5, 0, 0]}\n')


def _bits(*values) -> bytes:
    return struct.pack(f'<{len(values)}d', *values)


def test_every_interface_has_jazzys_type_hash():
    """The hashes rosidl gave our files equal those it gives the 1.5.1 release's own files
    (the fixture; how it was made is in its _source): real clients interoperate."""
    share = Path(importlib.util.find_spec('simulation_interfaces').origin).parents[3] / \
        'share' / 'simulation_interfaces'
    if not share.is_dir():  # an install with share/ elsewhere: the ament index
        from ament_index_python.packages import get_package_share_directory
        share = Path(get_package_share_directory('simulation_interfaces'))
    ours = {}
    for f in sorted(share.glob('*/*.json')):
        name = f'simulation_interfaces/{f.parent.name}/{f.stem}'
        ours[name] = {h['type_name']: h['hash_string']
                      for h in json.loads(f.read_text())['type_hashes']}[name]
    assert len(HASHES) == 38 and ours == HASHES


def _state(probe, name):
    reply = probe.call(GetEntityState, 'get_entity_state', GetEntityState.Request(entity=name))
    assert reply.result.result == OK, reply.result.error_message
    return reply.state


def _pose(state):
    p, o = state.pose.position, state.pose.orientation
    return (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)


def _set(probe, name, position, q, linear=(0.0,) * 3, angular=(0.0,) * 3, frame=''):
    s = EntityState()
    s.header.frame_id = frame
    p, o = s.pose.position, s.pose.orientation
    p.x, p.y, p.z = position
    o.x, o.y, o.z, o.w = q
    s.twist.linear.x, s.twist.linear.y, s.twist.linear.z = linear
    s.twist.angular.x, s.twist.angular.y, s.twist.angular.z = angular
    return probe.call(SetEntityState, 'set_entity_state',
                      SetEntityState.Request(entity=name, state=s)).result


def _verified_counts(installed, ros_env, f):
    """The installed replay --verify passes on recording ``f``; its messages per topic, as
    rosbags (an independent reader) counts them."""
    result = subprocess.run([str(installed / 'lib' / 'rb_sim_ros' / 'replay'), '--verify',
                             str(f)], env=ros_env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    with AnyReader([f]) as reader:
        return {c.topic: c.msgcount for c in reader.connections}


def _sim_state(probe):
    return probe.call(GetSimulationState, 'get_simulation_state',
                      GetSimulationState.Request()).state.state


def test_the_standard_api_drives_the_simulator(start_sim, probe, tmp_path, installed, ros_env):
    scene = tmp_path / 'scene.yaml'
    scene.write_text(SCENE)
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'start_paused:=true',
                    '-p', f'record:={f}')
    features = probe.call(GetSimulatorFeatures, 'get_simulator_features',
                          GetSimulatorFeatures.Request()).features
    # Truthful: what is served is listed, time reset is not.
    assert {SimulatorFeatures.STEP_SIMULATION_ACTION, SimulatorFeatures.ENTITY_STATE_SETTING,
            SimulatorFeatures.SIMULATION_RESET_STATE, SimulatorFeatures.SPAWNING,
            SimulatorFeatures.DELETING, SimulatorFeatures.SPAWNABLES} <= set(features.features)
    assert SimulatorFeatures.SIMULATION_RESET_TIME not in features.features
    assert list(features.spawn_formats) == ['yaml', 'urdf', 'mjcf']

    # Entities, by name pattern and category.
    def entities(pattern='', *categories):
        req = GetEntities.Request()
        req.filters.filter = pattern
        req.filters.categories = [EntityCategory(category=c) for c in categories]
        reply = probe.call(GetEntities, 'get_entities', req)
        return reply.result.result, list(reply.entities)
    assert entities() == (OK, ['a', 'b', 'wall'])
    assert entities('^[ab]$') == (OK, ['a', 'b'])
    assert entities('', EntityCategory.CATEGORY_STATIC_OBJECT) == (OK, ['wall'])
    assert entities('(')[0] == Result.RESULT_OPERATION_FAILED
    req = GetEntities.Request()
    req.filters.tags.tags = ['red']
    assert probe.call(GetEntities, 'get_entities', req).result.result == \
        Result.RESULT_FEATURE_UNSUPPORTED

    # Stepping, paused: time moves by exactly the steps asked (dt = 1 ms), a odd count too.
    assert _sim_state(probe) == SimulationState.STATE_PAUSED
    t0 = stamp_ns(_state(probe, 'a').header.stamp)
    reply = probe.call(StepSimulation, 'step_simulation', StepSimulation.Request(steps=37))
    assert reply.result.result == OK
    state = _state(probe, 'a')
    assert stamp_ns(state.header.stamp) - t0 == 37_000_000 and state.header.frame_id == 'world'
    # Torque-free symmetric spin about z at 0.5 rad/s: angle 0.5 * 0.037 rad, omega unchanged.
    assert state.twist.angular.z == pytest.approx(0.5, abs=1e-12)
    q = _pose(state)[1]
    assert Rotation.from_quat(q).as_rotvec() == pytest.approx([0, 0, 0.5 * 0.037], abs=1e-9)

    # The action: feedback on the way, all steps done. The feedback is read off its topic:
    # rclpy's ActionClient drops a goal's feedback that comes after its result (a topic and a
    # service race: a loaded CI lost the last one so), and the test wants every one.
    client = ActionClient(probe.node, SimulateSteps, 'simulate_steps')
    probe.wait_for(client.server_is_ready, what='the simulate_steps action')
    seen: list = []
    probe.node.create_subscription(
        SimulateSteps.Impl.FeedbackMessage, '/simulate_steps/_action/feedback', seen.append,
        QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))

    def feedback_of(goal):
        uuid = bytes(goal.result().goal_id.uuid)
        return [m.feedback for m in seen if bytes(m.goal_id.uuid) == uuid]

    def run(steps):
        goal = client.send_goal_async(SimulateSteps.Goal(steps=steps))
        probe.wait_for(goal.done, what='goal accepted')
        result = goal.result().get_result_async()
        probe.wait_for(result.done, what='the action result')
        assert result.result().result.result.result == OK
        return goal

    # Feedback sent before the server's writer matched our reader is lost: goals of one step
    # until one's feedback has come (their steps counted into t0).
    deadline = time.monotonic() + 300
    while True:
        assert time.monotonic() < deadline, 'no feedback of simulate_steps in 300 s'
        warm_up = run(1)
        t0 += 1_000_000
        try:
            probe.wait_for(lambda: feedback_of(warm_up), timeout=2.0,
                           what='a feedback of one step')
            break
        except TimeoutError:
            pass
    goal = run(45)
    probe.wait_for(lambda: [(m.completed_steps, m.remaining_steps)
                            for m in feedback_of(goal)][-1:] == [(45, 0)],
                   what='the last feedback, 45 steps done and none left')
    feedback = feedback_of(goal)
    assert [m.completed_steps for m in feedback] == [10, 20, 30, 40, 45]  # a period at a time
    assert all(m.completed_steps + m.remaining_steps == 45 for m in feedback)
    assert stamp_ns(_state(probe, 'a').header.stamp) - t0 == 82_000_000
    # A cancel stops a long one at the end of a publish period (10 steps here).
    goal = client.send_goal_async(SimulateSteps.Goal(steps=10 ** 9))
    probe.wait_for(lambda: goal.done() and feedback_of(goal), what='a long goal under way')
    second = client.send_goal_async(SimulateSteps.Goal(steps=10))
    probe.wait_for(second.done, what='a second goal')
    refused = second.result().get_result_async()
    probe.wait_for(refused.done, what='the second goal refused')
    assert refused.result().result.result.result == Result.RESULT_OPERATION_FAILED
    assert 'under way' in refused.result().result.result.error_message
    cancel = goal.result().cancel_goal_async()
    probe.wait_for(cancel.done, what='the cancel answered')
    result = goal.result().get_result_async()
    probe.wait_for(result.done, what='the cancelled result')
    assert result.result().status == GoalStatus.STATUS_CANCELED
    ran = stamp_ns(_state(probe, 'a').header.stamp) - t0 - 82_000_000
    assert 0 < ran < 10 ** 9 * 1_000_000 and ran % 10_000_000 == 0
    probe.wait_for(lambda: feedback_of(goal)[-1].completed_steps * 1_000_000 == ran,
                   what='the feedback of the last period run')
    t0 += ran

    # Set a state in the world frame, read it back bit for bit.
    q_new = tuple(Rotation.from_rotvec([0.1, 0.2, 0.3]).as_quat())
    assert _set(probe, 'b', (0.5, 2.5, -1.0), q_new, (0.1, 0.0, 0.0)).result == OK
    x, q = _pose(_state(probe, 'b'))
    assert _bits(*x) == _bits(0.5, 2.5, -1.0)
    assert q == pytest.approx(q_new, abs=1e-15)
    # ... and relative to body b's frame: composed with b's pose and motion.
    rel_x, rel_q = (0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0)
    assert _set(probe, 'a', rel_x, rel_q, frame='b').result == OK
    a = _state(probe, 'a')
    rb = Rotation.from_quat(q_new)
    want = rb.apply(rel_x) + (0.5, 2.5, -1.0)
    assert _pose(a)[0] == pytest.approx(tuple(want), abs=1e-12)
    assert (a.twist.linear.x, a.twist.linear.y) == pytest.approx((0.1, 0.0), abs=1e-12)

    # Refusals change nothing.
    before = _pose(_state(probe, 'a'))
    assert _set(probe, 'a', (float('nan'), 0, 0), (0, 0, 0, 1)).result == \
        Result.RESULT_OPERATION_FAILED
    assert _set(probe, 'a', (0, 0, 0), (0, 0, 0, 1), frame='elsewhere').result == \
        Result.RESULT_OPERATION_FAILED
    assert _set(probe, 'wall', (0, 0, 0), (0, 0, 0, 1)).result == Result.RESULT_OPERATION_FAILED
    assert _set(probe, 'nobody', (0, 0, 0), (0, 0, 0, 1)).result == Result.RESULT_NOT_FOUND
    assert probe.call(GetEntityState, 'get_entity_state',
                      GetEntityState.Request(entity='nobody')).result.result == \
        Result.RESULT_NOT_FOUND
    # In b's frame a finite request can still overflow in the world's: refused, both halves.
    huge = (1.7e308,) * 3
    assert _set(probe, 'a', huge, (0, 0, 0, 1), frame='b').result == \
        Result.RESULT_OPERATION_FAILED
    assert _pose(_state(probe, 'a')) == before
    assert probe.call(ResetSimulation, 'reset_simulation', ResetSimulation.Request(
        scope=ResetSimulation.Request.SCOPE_SPAWNED)).result.result == OK  # nothing spawned
    assert _pose(_state(probe, 'a')) == before

    # Reset: the state only (time goes on), and stop = reset + pause.
    reply = probe.call(ResetSimulation, 'reset_simulation', ResetSimulation.Request())
    assert reply.result.result == Result.RESULT_FEATURE_UNSUPPORTED  # SCOPE_DEFAULT is time too
    assert _pose(_state(probe, 'a')) == before
    reply = probe.call(ResetSimulation, 'reset_simulation', ResetSimulation.Request(
        scope=ResetSimulation.Request.SCOPE_STATE))
    assert reply.result.result == OK and _pose(_state(probe, 'b'))[0] == (0.0, 2.0, 0.0)

    def set_state(s):
        return probe.call(SetSimulationState, 'set_simulation_state', SetSimulationState.Request(
            state=SimulationState(state=s))).result.result
    assert set_state(SimulationState.STATE_PAUSED) == \
        SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    assert set_state(SimulationState.STATE_PLAYING) == OK
    assert probe.call(StepSimulation, 'step_simulation', StepSimulation.Request(
        steps=1)).result.result == Result.RESULT_OPERATION_FAILED  # not paused
    poses = probe.collect(PoseStamped, 'a/pose')
    probe.wait_for(lambda: len(poses) > 5, what='the simulation playing')
    assert _sim_state(probe) == SimulationState.STATE_PLAYING
    assert set_state(SimulationState.STATE_STOPPED) == OK
    assert _sim_state(probe) == SimulationState.STATE_STOPPED
    assert _pose(_state(probe, 'a'))[0] == (1.0, 0.0, 0.0)
    assert set_state(SimulationState.STATE_PAUSED) == \
        SetSimulationState.Response.INCORRECT_TRANSITION
    assert set_state(SimulationState.STATE_PLAYING) == OK
    n = len(poses)
    probe.wait_for(lambda: len(poses) > n + 5, what='playing after the stop')
    sim.stop()

    # All of it was recorded at the steps it took effect, and replays bit for bit.
    counts = _verified_counts(installed, ros_env, f)
    # b: one world-frame set (pose and twist), then the reset and the stop; a: the relative set
    assert counts['/rb_sim/input/b/set_pose'] == counts['/rb_sim/input/b/set_twist'] == 1
    assert counts['/rb_sim/input/a/set_pose'] == 1 and counts['/rb_sim/input/a/reset'] == 2


def test_a_name_pattern_that_backtracks_for_ever_cannot_hang_the_node():
    from rb_sim_ros.ros.sim_interfaces import match_names
    names = ['body', 'ball_1', 'wall']
    assert match_names('all', names) == ['ball_1', 'wall']  # literal: a substring
    assert match_names('^b.*[0-9]$', names) == ['ball_1']
    with pytest.raises(ValueError, match='not a regular expression'):
        match_names('(', names)
    # Exponential in a backtracking engine such as re's: regex answers at once (no z) ...
    assert match_names('(?:.?){400}z', names) == []
    # ... or within its time limit, the query's whole: a refusal of one line.
    started = time.monotonic()
    with pytest.raises(ValueError, match='took more than 50 ms') as e:
        match_names('(a|aa)+$', ['a' * 60 + 'b'] * 5)
    assert '\n' not in str(e.value)
    assert time.monotonic() - started < 30  # (not the 2**60 steps of the search)
    # The POSIX classes re lacks.
    assert match_names('^[[:alpha:]]+$', names) == ['body', 'wall']
    assert match_names('[[:digit:]]', names) == ['ball_1']
    with pytest.raises(ValueError, match='characters long'):
        match_names('a' * 2000, names)
    for bad, why in (('a{4294967296}', 'at most 10000'),  # not re.error: overflow, recursion
                     ('(' * 499 + ')' * 499, 'not a regular expression')):
        with pytest.raises(ValueError, match=why):
            match_names(bad, names)


def test_backtracking_filters_in_flight_never_hold_up_the_wrenches(start_sim, probe,
                                                                   tmp_path):
    """Three get_entities with backtracking filters always in flight, a wrench command at a
    time (each sent once the one before was applied): every wrench is applied, and every
    filter is answered, a timeout as an error of one line. A filter once held the one
    executor 2 s (its subprocess's limit): 6 of 500 wrenches got through in 10 s."""
    name = 'a' * 60 + 'b'  # 61 characters: (a+)+$ and (a|aa)+$ backtrack on it
    scene = tmp_path / 'scene.yaml'
    scene.write_text(f'bodies:\n  - {{name: {name}, mass: 1.0, inertia: [0.1, 0.1, 0.1]}}\n')
    # Paused: a wrench is applied (and applied_wrench sent) as it arrives.
    start_sim('-p', f'scene_file:={scene}', '-p', 'start_paused:=true',
              '-p', 'command_timeout:=0.0')
    applied = probe.collect(WrenchStamped, f'{name}/applied_wrench', APPLIED_QOS)
    pub = probe.publisher(Wrench, f'{name}/wrench')
    client = probe.node.create_client(GetEntities, 'get_entities')
    probe.wait_for(client.service_is_ready, what='get_entities')
    filters = ('(a+)+$', '(a|aa)+$', '^(a|a?)+$')
    in_flight, answers = [], []

    def keep_three_in_flight():
        for f in [f for f in in_flight if f.done()]:
            in_flight.remove(f)
            answers.append(f.result())
        while len(in_flight) < 3:
            req = GetEntities.Request()
            req.filters.filter = filters[(len(answers) + len(in_flight)) % len(filters)]
            in_flight.append(client.call_async(req))
        return True

    wrenches = 60
    # A bound, not a budget: the 60 take about 2 s here; when each filter held the executor
    # for its 2 s, each wrench waited behind one, so 120 s at the least (133 s measured).
    end = time.monotonic() + 60.0
    for k in range(1, wrenches + 1):
        keep_three_in_flight()
        msg = Wrench()
        msg.force.x = float(k)
        pub.publish(msg)
        probe.wait_for(lambda: keep_three_in_flight() and len(applied) >= k,
                       timeout=max(end - time.monotonic(), 0.1),
                       what=f'wrench {k} applied while filters are in flight')
    assert [m.wrench.force.x for m in applied] == [float(k) for k in range(1, wrenches + 1)]
    probe.wait_for(lambda: all(f.done() for f in in_flight), what='the last filters answered')
    answers += [f.result() for f in in_flight]
    # three were in flight at every wrench (keep_three_in_flight); how many were answered
    # meanwhile depends on the load (a CI run answered 18 while the 60 wrenches went through)
    assert len(answers) >= 3
    for a in answers:
        if a.result.result == OK:  # regex finds at once that (a+)+$ does not match
            assert list(a.entities) == []
        else:
            assert a.result.result == Result.RESULT_OPERATION_FAILED
            assert 'took more than 50 ms' in a.result.error_message
            assert '\n' not in a.result.error_message
    assert any(a.result.result != OK for a in answers)  # (a|aa)+$ does time out


@pytest.mark.parametrize('pattern', ['(a{1000}){1000}', '((a{100}){100}){100}',
                                     r'(\w{999}){999}', '(?:[[:alpha:]]{500}){500}',
                                     '[[](a{1000}){1000}', 'a{99999999999}'])
def test_a_filter_whose_compile_would_take_seconds_is_refused_before_it(pattern):
    """regex's compile has no time limit, and spells nested counted repeats out: (a{1000}){1000}
    took 4 s, ((a{100}){100}){100} 6 s (10^8 items fit in 30 characters). Refused by size,
    in one line, at once."""
    from rb_sim_ros.ros.sim_interfaces import match_names, MAX_PATTERN_SIZE
    started = time.monotonic()
    with pytest.raises(ValueError, match=f'at most {MAX_PATTERN_SIZE}$') as e:
        match_names(pattern, ['a' * 60 + 'b'])
    assert '\n' not in str(e.value)
    assert time.monotonic() - started < 0.5 * 10  # (not the seconds of a compile)


def test_the_size_of_a_filter_counts_its_counted_repeats_as_written_out():
    from rb_sim_ros.ros.sim_interfaces import match_names, pattern_size
    assert pattern_size('abc') == 3 and pattern_size('(ab){3}') == 6
    assert pattern_size('(a{10}b){10}') == 110 and pattern_size('[[:alpha:]]{5}') == 5
    assert pattern_size('a{2,7}') == 7 and pattern_size('x{,5}') == 5
    assert pattern_size(r'\{9}') == 3  # an escaped brace is no count
    # At the bound, a filter still compiles and matches: names of at most 64 characters.
    assert match_names('([ab]{100}){100}', ['ab' * 30, 'a' * 60 + 'b']) == []
    assert match_names('^a{60}b$', ['a' * 60 + 'b', 'a' * 59 + 'b']) == ['a' * 60 + 'b']


SPAWN_SCENE = ('gravity: [0, 0, -9.81]\n'
               'bodies:\n'
               '  - {name: sat, mass: 1.0, inertia: [0.1, 0.2, 0.3], position: [0, 5, 3]}\n'
               '  - name: ground\n'
               '    static: true\n'
               '    colliders: [{type: plane, normal: [0, 0, 1], offset: 0}]\n'
               'templates:\n'
               '  ball: {shape: sphere, radius: 0.1, density: 1000, colliders: shape}\n')


def _spawn(probe, name='', uri='', resource='', position=None, frame='', rename=False,
           namespace=''):
    req = SpawnEntity.Request(name=name, uri=uri, resource_string=resource,
                              allow_renaming=rename, entity_namespace=namespace)
    if position is not None:
        req.initial_pose.pose.position.x, req.initial_pose.pose.position.y, \
            req.initial_pose.pose.position.z = position
    req.initial_pose.header.frame_id = frame
    reply = probe.call(SpawnEntity, 'spawn_entity', req)
    return reply.result.result, reply.entity_name, reply.result.error_message


def _names(probe):
    return list(probe.call(GetEntities, 'get_entities', GetEntities.Request()).entities)


def _delete(probe, name):
    return probe.call(DeleteEntity, 'delete_entity',
                      DeleteEntity.Request(entity=name)).result.result


def _published(probe, which) -> bool:
    """Whether the node publishes a topic for which ``which(name)`` holds."""
    return any(which(t) for t, _ in
               probe.node.get_publisher_names_and_types_by_node('rb_sim', '/'))


def test_spawned_and_deleted_bodies_move_publish_and_replay(
        start_sim, probe, tmp_path, installed, ros_env):
    """Bodies spawned from a template and from a body entry fall as free bodies do and land,
    get their own topics, go away when deleted or reset; every change is recorded and the
    run replays bit for bit (IMU noise streams and /tf included)."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text(SPAWN_SCENE)
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'start_paused:=true',
                    '-p', f'record:={f}', '-p', 'imu_accel_noise:=0.01',
                    '-p', 'qos_overrides./bad/imu.publisher.depth:=-5')
    spawnables = probe.call(GetSpawnables, 'get_spawnables', GetSpawnables.Request())
    assert [s.uri for s in spawnables.spawnables] == ['ball']

    assert _spawn(probe, uri='ball', position=(0.0, 0.0, 1.0))[:2] == (OK, 'ball')
    assert _spawn(probe, uri='ball')[0] == SpawnEntity.Response.NAME_NOT_UNIQUE
    assert _spawn(probe, uri='ball', position=(2.0, 0.0, 1.0), rename=True)[:2] == \
        (OK, 'ball_2')
    entry = '{mass: 2.0, inertia: [0.1, 0.2, 0.3], angular_velocity: [0, 0, 1]}'
    assert _spawn(probe, 'probe', resource=entry, position=(0.0, 0.0, 1.0),
                  frame='ball_2')[:2] == (OK, 'probe')
    # In ball_2's frame (identity rotation at (2, 0, 1)): at (2, 0, 2), exactly.
    assert _bits(*_pose(_state(probe, 'probe'))[0]) == _bits(2.0, 0.0, 2.0)
    assert _state(probe, 'probe').twist.angular.z == 1.0

    # Refusals, each with its code, change nothing.
    names = _names(probe)
    assert names == ['sat', 'ground', 'ball', 'ball_2', 'probe']
    R = SpawnEntity.Response
    assert _spawn(probe, 'x', resource='{mass: -1, inertia: [1, 1, 1]}')[0] == \
        R.RESOURCE_PARSE_ERROR
    assert _spawn(probe, 'x', resource='mass: [')[0] == R.RESOURCE_PARSE_ERROR
    assert _spawn(probe, 'x', uri='file:///etc/passwd')[0] == R.UNSUPPORTED_FORMAT
    assert _spawn(probe, 'x')[0] == R.NO_RESOURCE
    assert _spawn(probe, '1x', uri='ball')[0] == R.NAME_INVALID
    assert _spawn(probe, 'x', uri='ball', namespace='ns')[0] == R.NAMESPACE_INVALID
    assert _spawn(probe, 'x', uri='ball', position=(float('nan'), 0.0, 0.0))[0] == \
        R.INVALID_POSE
    assert _spawn(probe, 'x', uri='ball', position=(1.0, 0.0, 0.0), frame='nowhere')[0] == \
        R.INVALID_POSE
    assert _delete(probe, 'nobody') == Result.RESULT_NOT_FOUND
    # One of its topics cannot be made (a bad QoS override): refused whole, no topic left.
    assert _spawn(probe, 'bad', uri='ball')[0] == Result.RESULT_OPERATION_FAILED
    # The graph is learnt by discovery: a topic made and taken back may show for a while.
    probe.wait_for(lambda: not _published(probe, lambda t: t.startswith('/bad/')),
                   timeout=60.0, what='no /bad/ topic left')
    assert _names(probe) == names
    # A static body: on /tf_static (sent again, stamped when sent) until it is deleted.
    assert _spawn(probe, 'post', resource='{static: true, position: [3, 0, 0]}')[:2] == \
        (OK, 'post')

    # They move: the balls fall freely (0.2 s: z = 1 - g t^2 / 2), then land on the ground
    # (a collision world that a spawn brought along), on their own topics.
    poses = probe.collect(PoseStamped, 'ball/pose')
    imu = probe.collect(Imu, 'probe/imu')
    assert probe.call(StepSimulation, 'step_simulation',
                      StepSimulation.Request(steps=200)).result.result == OK
    z = _pose(_state(probe, 'ball'))[0][2]
    assert z == pytest.approx(1.0 - 0.5 * 9.81 * 0.2 ** 2, abs=1e-3)
    probe.wait_for(lambda: poses and imu, what='the spawned bodies on their topics')
    assert probe.call(StepSimulation, 'step_simulation',
                      StepSimulation.Request(steps=1500)).result.result == OK
    assert _pose(_state(probe, 'ball_2'))[0][2] == pytest.approx(0.1, abs=2e-3)
    assert _pose(_state(probe, 'sat'))[0][2] < 3.0 - 9.0  # the scene's own body fell freely

    # Deleted: gone, its topics too; the others go on.
    assert _delete(probe, 'post') == OK
    assert _delete(probe, 'ball_2') == OK
    assert _delete(probe, 'ball_2') == Result.RESULT_NOT_FOUND
    assert 'ball_2' not in _names(probe)
    probe.wait_for(lambda: not _published(probe, lambda t: t == '/ball_2/pose'),
                   timeout=60.0, what='/ball_2/pose gone')
    assert probe.call(StepSimulation, 'step_simulation',
                      StepSimulation.Request(steps=30)).result.result == OK
    # Reset of what was spawned: the scene's bodies again; a name can come back.
    assert probe.call(ResetSimulation, 'reset_simulation', ResetSimulation.Request(
        scope=ResetSimulation.Request.SCOPE_SPAWNED)).result.result == OK
    assert _names(probe) == ['sat', 'ground']
    assert _spawn(probe, uri='ball', position=(0.0, 0.0, 0.5))[:2] == (OK, 'ball')
    # While playing, too.
    assert probe.call(SetSimulationState, 'set_simulation_state', SetSimulationState.Request(
        state=SimulationState(state=SimulationState.STATE_PLAYING))).result.result == OK
    late = probe.collect(PoseStamped, 'late/pose')
    assert _spawn(probe, 'late', resource=entry)[:2] == (OK, 'late')
    probe.wait_for(lambda: len(late) > 5, what='a body spawned while playing, publishing')
    sim.stop()

    counts = _verified_counts(installed, ros_env, f)
    assert counts['/rb_sim/input/ball/spawn'] == 2 and counts['/rb_sim/input/ball/delete'] == 1
    assert counts['/rb_sim/input/ball_2/delete'] == 1 and counts['/late/imu'] > 5
    assert counts['/ball/pose'] > 0
    assert counts['/tf_static'] == 3  # at the start, after post came and after it went


def _many(probe, *requests):
    """spawn_entities of (name, uri, resource, position, frame) requests: the call's result
    code and each request's (code, name)."""
    req = SpawnEntities.Request()
    for name, uri, resource, position, frame in requests:
        r = SpawnRequest(name=name)
        r.entity_resource.uri, r.entity_resource.resource_string = uri, resource
        p = r.initial_pose.pose.position
        p.x, p.y, p.z = position
        r.initial_pose.header.frame_id = frame
        req.spawn_requests.append(r)
    reply = probe.call(SpawnEntities, 'spawn_entities', req)
    return reply.result.result, [(r.result.result, r.entity_name) for r in reply.results]


def test_spawn_entities_spawns_all_at_one_step_or_none(start_sim, probe, tmp_path):
    """simulation_interfaces 1.5's spawn_entities: every request or none, each refusal with
    its code (the others saying they were not spawned because of it), all at the same step;
    a later request may be placed in the frame of an earlier one. Recorded, and replayed bit
    for bit, refusals at the step itself (taken back) included."""
    from rb_sim_ros.recording.reader import RecordingReader
    from rb_sim_ros.offline import replay
    scene = tmp_path / 'scene.yaml'
    scene.write_text(SPAWN_SCENE)
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'scene_file:={scene}', '-p', 'start_paused:=true',
                    '-p', f'record:={f}', '-p', 'qos_overrides./bad/imu.publisher.depth:=-5')
    features = probe.call(GetSimulatorFeatures, 'get_simulator_features',
                          GetSimulatorFeatures.Request()).features.features
    assert SimulatorFeatures.SPAWNING_ENTITIES in features
    names = _names(probe)
    failed, not_spawned = SpawnEntities.Response.ENTITIES_SPAWN_FAILED, \
        Result.RESULT_OPERATION_FAILED
    # Refused before the step: by its own code; nothing spawned.
    code, results = _many(probe, ('a', 'ball', '', (0.0, 0.0, 1.0), ''),
                          ('b', 'ball', '', (float('nan'), 0.0, 1.0), ''),
                          ('a', 'ball', '', (1.0, 0.0, 1.0), ''))
    assert code == failed and [c for c, _ in results] == \
        [not_spawned, SpawnResult.INVALID_POSE, SpawnResult.NAME_NOT_UNIQUE]
    code, results = _many(probe, ('c', 'ball', '', (0.0, 0.0, 1.0), ''),
                          ('d', 'nothing', '', (0.0, 0.0, 1.0), ''))
    assert code == failed and [c for c, _ in results] == \
        [not_spawned, SpawnResult.UNSUPPORTED_FORMAT]
    # Refused at the step (a topic cannot be made): the one before it taken back.
    code, results = _many(probe, ('e', 'ball', '', (0.0, 0.0, 1.0), ''),
                          ('bad', 'ball', '', (0.0, 0.0, 2.0), ''))
    assert code == failed and results == [(not_spawned, ''), (not_spawned, '')]
    assert _names(probe) == names
    # All of them, the second placed in the frame of the first.
    code, results = _many(probe, ('a', 'ball', '', (0.0, 0.0, 1.0), ''),
                          ('b', '', '{mass: 1, inertia: [0.1, 0.1, 0.1]}', (0.0, 0.0, 1.0),
                           'a'))
    assert code == OK and results == [(OK, 'a'), (OK, 'b')]
    assert _names(probe) == names + ['a', 'b']
    assert _bits(*_pose(_state(probe, 'b'))[0]) == _bits(0.0, 0.0, 2.0)
    assert probe.call(StepSimulation, 'step_simulation',
                      StepSimulation.Request(steps=50)).result.result == OK
    sim.stop()
    events = sorted((m.topic, m.sequence) for m in RecordingReader(str(f)).messages()
                    if m.topic.rpartition('/')[2] in ('spawn', 'delete'))
    assert events == [('/rb_sim/input/a/spawn', 0), ('/rb_sim/input/b/spawn', 0),
                      ('/rb_sim/input/e/delete', 0), ('/rb_sim/input/e/spawn', 0)]
    assert replay.verify(str(f)).identical
