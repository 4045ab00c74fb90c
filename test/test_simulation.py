# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run as configuration plus events at steps: the contract replay relies on."""

import json

import numpy as np
import pytest

from rb_sim_ros import State, Stepper, Wrench
from rb_sim_ros.simulation import Config, Reset, SetPose, SetTwist, SetWrench, Simulation

CONFIG = Config(mass=1.5, inertia=(0.2, 0.01, 0.0, 0.01, 0.3, 0.0, 0.0, 0.0, 0.4), dt=0.002,
                steps_per_publish=5, initial_position=(1.0, 2.0, 3.0),
                initial_angular_velocity=(0.3, -0.2, 1.0))


def test_config_json_round_trip_is_exact():
    again = Config.from_dict(json.loads(json.dumps(CONFIG.to_dict())))
    assert again == CONFIG


@pytest.mark.parametrize('change, field', [
    ({'mass': -1.0}, 'mass'), ({'inertia': (1.0, 1.0)}, 'inertia'),
    ({'dt': 0.0}, 'dt'), ({'steps_per_publish': 0}, 'steps_per_publish'),
    ({'integrator': 'rk4'}, 'integrator'),
    ({'initial_orientation_xyzw': (0, 0, 0, 0)}, 'quaternion'),
    ({'initial_position': (0, float('nan'), 0)}, 'initial_position'),
])
def test_bad_config(change, field):
    with pytest.raises(ValueError, match=field):
        Config(**{**CONFIG.__dict__, **change})


def test_unknown_config_key():
    with pytest.raises(ValueError, match='unknown configuration keys'):
        Config.from_dict({**CONFIG.to_dict(), 'gravity': 9.81})


def test_events_at_steps_equal_the_same_calls_on_a_stepper():
    w1, w2 = Wrench([1, 0, 0], [0, 0.1, 0]), Wrench([0, 1, 0], [0.05, 0, 0], 'body')
    events = [(0, SetWrench(w1)), (7, SetWrench(w2)), (7, SetTwist((0, 0, 1), (0, 1, 0))),
              (12, SetPose((0, 0, 0), (0, 0, 1, 0))), (20, Reset())]
    sim = Simulation(CONFIG)
    assert sim.run_until(30, events) == []
    s = Stepper(CONFIG.body(), CONFIG.dt, CONFIG.initial_state())
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
    s.set_state(CONFIG.initial_state())
    s.step(10)
    assert sim.stepper.pose_twist() == s.pose_twist()
    assert sim.time_ns == 30 * 2_000_000


def test_reset_returns_to_the_initial_state_with_no_wrench():
    sim = Simulation(CONFIG)
    sim.apply(SetWrench(Wrench([5, 0, 0])))
    sim.run(50)
    sim.apply(Reset())
    assert sim.stepper.wrench == Wrench()
    np.testing.assert_array_equal(sim.stepper.state.position, CONFIG.initial_position)


def test_event_in_the_past_is_refused():
    sim = Simulation(CONFIG)
    sim.run(10)
    with pytest.raises(ValueError, match='in the past'):
        sim.run_until(20, [(5, Reset())])
