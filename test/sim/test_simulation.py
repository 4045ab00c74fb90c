# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run as configuration plus events at steps: the contract replay relies on."""

import json

import numpy as np
import pytest

from rb_sim_ros import State, Stepper, Wrench
from rb_sim_ros.sim.simulation import (BodySpec, Config, Reset, SetPose, SetTwist, SetWrench,
                                       Simulation)

BODY = BodySpec(name='b', mass=1.5, inertia=(0.2, 0.01, 0.0, 0.01, 0.3, 0.0, 0.0, 0.0, 0.4),
                initial_position=(1.0, 2.0, 3.0), initial_angular_velocity=(0.3, -0.2, 1.0))
CONFIG = Config(dt=0.002, steps_per_publish=5, bodies=(BODY,))


def test_config_json_round_trip_is_exact():
    again = Config.from_dict(json.loads(json.dumps(CONFIG.to_dict())))
    assert again == CONFIG


@pytest.mark.parametrize('change, field', [
    ({'mass': -1.0}, 'mass'), ({'inertia': (1.0, 1.0)}, 'inertia'),
    ({'initial_orientation_xyzw': (0, 0, 0, 0)}, 'quaternion'),
    ({'initial_position': (0, float('nan'), 0)}, 'initial_position'),
    ({'linear_damping': -0.1}, 'linear_damping'), ({'name': 'a b'}, 'name'),
])
def test_bad_body(change, field):
    with pytest.raises(ValueError, match=field):
        BodySpec(**{**BODY.__dict__, **change})


@pytest.mark.parametrize('change, field', [
    ({'dt': 0.0}, 'dt'), ({'dt': float('nan')}, 'dt'), ({'dt': 'fast'}, 'dt'),
    ({'steps_per_publish': 0}, 'steps_per_publish'),
    ({'integrator': 'rk4'}, 'integrator'), ({'gravity': (0, 0)}, 'gravity'),
    ({'bodies': (BODY, BODY)}, 'unique'), ({'bodies': ()}, 'bodies'),
])
def test_bad_config(change, field):
    with pytest.raises(ValueError, match=field):
        Config(**{**CONFIG.__dict__, **change})


def test_unknown_config_key():
    with pytest.raises(ValueError, match='unknown configuration keys'):
        Config.from_dict({**CONFIG.to_dict(), 'wind': 9.81})


def test_events_at_steps_equal_the_same_calls_on_a_stepper():
    w1, w2 = Wrench([1, 0, 0], [0, 0.1, 0]), Wrench([0, 1, 0], [0.05, 0, 0], 'body')
    events = [(0, SetWrench(w1)), (7, SetWrench(w2)), (7, SetTwist((0, 0, 1), (0, 1, 0))),
              (12, SetPose((0, 0, 0), (0, 0, 1, 0))), (20, Reset())]
    sim = Simulation(CONFIG)
    assert sim.run_until(30, events) == []
    assert sim.run_until(30, [(30, Reset())]) == [(30, Reset())]  # due, not yet applied
    s = Stepper(BODY.body(), CONFIG.dt, BODY.initial_state())
    s.set_wrench(w1)
    s.step(7)
    s.set_wrench(w2)
    st = s.state
    s.set_state(State(st.position, st.rotation, (0, 0, 1), (0, 1, 0)))
    s.step(5)
    st = s.state
    s.set_state(State.from_quaternion_xyzw((0, 0, 0), (0, 0, 1, 0), st.linear_velocity,
                                           st.angular_velocity))
    s.step(8)
    s.set_wrench(Wrench())
    s.set_state(BODY.initial_state())
    s.step(10)
    assert sim.stepper.pose_twist() == s.pose_twist()
    assert sim.time_ns == 30 * 2_000_000


def test_reset_returns_to_the_initial_state_with_no_wrench():
    sim = Simulation(CONFIG)
    sim.apply(SetWrench(Wrench([5, 0, 0])))
    sim.run(50)
    sim.apply(Reset())
    assert sim.stepper.wrench == Wrench()
    np.testing.assert_array_equal(sim.stepper.state.position, BODY.initial_position)


def test_event_in_the_past_is_refused():
    sim = Simulation(CONFIG)
    sim.run(10)
    with pytest.raises(ValueError, match='in the past'):
        sim.run_until(20, [(5, Reset())])


def test_bodies_are_independent_and_static_ones_never_move():
    other = BodySpec(name='c', mass=3.0, inertia=(1.0, 1.0, 1.0),
                     initial_linear_velocity=(1.0, 0.0, 0.0))
    wall = BodySpec(name='wall', static=True, initial_position=(5.0, 0.0, 0.0))
    sim = Simulation(Config(dt=0.002, bodies=(BODY, other, wall), gravity=(0, 0, -9.81)))
    alone = Simulation(Config(dt=0.002, bodies=(BODY,), gravity=(0, 0, -9.81)))
    w = Wrench([0, 1, 0], [0.01, 0, 0])
    assert sim.run_until(100, [(10, SetWrench(w, 'b')), (20, SetWrench(w, 'c'))]) == []
    alone.run_until(100, [(10, SetWrench(w))])
    assert sim.pose_twist('b') == alone.pose_twist()
    assert sim.pose_twist('wall')[0] == (5.0, 0.0, 0.0)
    assert 'wall' not in sim.steppers
    with pytest.raises(ValueError, match='static'):
        sim.apply(SetWrench(w, 'wall'))
    with pytest.raises(ValueError, match="no body named 'd'"):
        sim.apply(SetWrench(w, 'd'))


def test_a_body_name_must_be_a_ros_name_token():
    """A name becomes '<name>/pose' and a frame id: non-ASCII or odd names are refused even
    when a configuration does not come through the scene loader (a recording, code)."""
    for good in ('b', 'ball_2', 'B' * 64):
        assert BodySpec(name=good).name == good
    for bad in ('ä', 'bäll', '2ball', '_ball', 'a/b', 'a b', 'B' * 65, '', 5):
        with pytest.raises(ValueError, match='ASCII letter'):
            BodySpec(name=bad)


def test_the_read_api_answers_without_reaching_into_steppers():
    """is_moving, wrench, contact_stats and last_contacts answer for moving and static bodies;
    set_initial_states takes new initial states only, and a reset goes to them."""
    bodies = (BodySpec('a', initial_position=(1.0, 0.0, 0.0)), BodySpec('g', static=True))
    sim = Simulation(Config(bodies=bodies))
    assert sim.is_moving('a') and not sim.is_moving('g')
    w = Wrench(force=(0.0, 2.0, 0.0))
    sim.apply(SetWrench(w, 'a'))
    assert sim.wrench('a') == w
    with pytest.raises(ValueError, match="no moving body named 'g'"):
        sim.wrench('g')
    assert sim.contact_stats() is None and sim.last_contacts() == []
    moved = (BodySpec('a', initial_position=(5.0, 0.0, 0.0)), bodies[1])
    sim.set_initial_states(Config(bodies=moved))
    sim.apply(Reset(body='a'))
    assert sim.pose_twist('a')[0] == (5.0, 0.0, 0.0) and sim.wrench('a') == Wrench()
    heavier = (BodySpec('a', mass=2.0), bodies[1])
    with pytest.raises(ValueError, match="not body 'a' mass"):
        sim.set_initial_states(Config(bodies=heavier))
    with pytest.raises(ValueError, match='not dt'):
        sim.set_initial_states(Config(dt=0.002, bodies=moved))
