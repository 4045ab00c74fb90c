# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Contact behaviour that no other test pinned (issue 12: mutants of the contact solver that
survived the suite; tools/mutate.py), each against a geometric fact of the contact or a closed
form of the flight: a ball and the ground plane z = 0, so its depth is r - z exactly."""

import numpy as np
import pytest

from oracles.contact_cases import ball, G, GROUND
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world

R, DT = 0.1, 1e-3


def test_a_ball_inside_the_ground_with_no_impulse_is_pushed_out():
    """Zero gravity, at rest, 2 cm inside the plane: no impulse (nothing approaches), but the
    position correction must move it out. One contact of a sphere on a plane is a single row
    along the normal with no lever arm, so each correction removes exactly position_fraction
    of the depth beyond the slop: d - slop shrinks by (1 - fraction) a correction (two in the
    first step: the start is checked before integrating), the velocity stays 0, and the ball
    ends at the slop."""
    d0 = 0.02
    world = collision_world([ball(radius=R, position=(0.0, 0.0, R - d0))], DT, planes=GROUND,
                            contact=ContactSettings(sleep_time=0.0))
    slop, keep = world.settings.slop, 1.0 - world.settings.position_fraction
    excess = [d0 - slop]
    for _ in range(12):
        world.step(1)
        st = world.state('ball')
        np.testing.assert_array_equal(st.linear_velocity, 0.0)
        np.testing.assert_array_equal(st.position[:2], 0.0)
        excess.append(R - float(st.position[2]) - slop)
    assert excess[1] == pytest.approx(keep * keep * excess[0], rel=1e-9)
    for before, after in zip(excess[1:], excess[2:]):
        assert after == pytest.approx(keep * before, rel=1e-6, abs=1e-15)
    assert 0.0 <= excess[-1] < 1e-9


@pytest.mark.parametrize('height, vx, vz', [(0.004, 10.0, -0.5), (0.006, 5.0, -2.0),
                                            (0.0015, 20.0, -0.2)])
def test_a_ball_skimming_the_ground_flies_until_it_reaches_it(height, vx, vz):
    """A ball a few mm above the ground, fast sideways and slowly down: its speculative margin
    (|v| dt + |g| dt^2) covers the gap, yet it does not reach the ground in the step, so the
    contact must do nothing and the ball fly as the closed form says (AB2 integrates a constant
    acceleration exactly): x = vx t, z = z0 + vz t - g t^2 / 2, v = (vx, 0, vz - g t). A
    bounce there (an impact on a speculative contact the body cannot close) would throw it up
    from mid-air."""
    z0 = R + height
    world = collision_world([ball(radius=R, position=(0.0, 0.0, z0), velocity=(vx, 0.0, vz))], DT,
                            G, planes=GROUND,
                            contact=ContactSettings(restitution=0.5, friction=0.5))
    g = -G[2]
    steps = speculative = 0
    while True:
        # A step's contacts act on the next step: stop where that one would reach the ground.
        t, t_next = (steps + 1) * DT, (steps + 2) * DT
        if z0 + vz * t_next - 0.5 * g * t_next * t_next - R <= 0.0:
            break
        world.step(1)
        steps += 1
        st = world.state('ball')
        expected_x = np.array([vx * t, 0.0, z0 + vz * t - 0.5 * g * t * t])
        np.testing.assert_allclose(st.position, expected_x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(st.linear_velocity, [vx, 0.0, vz - g * t], rtol=0,
                                   atol=1e-12)
        np.testing.assert_array_equal(st.angular_velocity, 0.0)
        contacts = world.last_contacts()
        assert all(c.depth < 0.0 and c.normal_impulse == 0.0 for c in contacts)
        speculative += len(contacts)
    assert speculative >= 1       # the speculative contact was there, doing nothing


@pytest.mark.parametrize('gap, speed', [(0.23e-3, 0.05), (0.0101e-3, 0.02), (0.3e-3, 0.09)])
def test_a_slow_ball_closes_its_gap_in_one_step_and_stops_on_the_ground(gap, speed):
    """Zero gravity, e = 0, approaching slower than the bounce threshold: free flight at
    constant speed until the step in which it would cross the plane; a speculative contact
    lets it close the gap in that step but not more, so the ball ends that step touching
    (depth 0, not short of the ground and not in it) and the next contact stops it: a plastic
    impact. Oracle: the flight z = z0 - speed t, the geometry of the touch and the momentum
    m speed taken by the ground."""
    z0 = R + gap
    world = collision_world([ball(radius=R, position=(0.0, 0.0, z0),
                                  velocity=(0.0, 0.0, -speed))], DT, planes=GROUND,
                            contact=ContactSettings(sleep_time=0.0))
    assert speed < world.settings.bounce_threshold
    arrival = int(np.ceil(gap / (speed * DT)))      # the step in which it reaches the plane
    for k in range(1, arrival):
        world.step(1)
        assert float(world.state('ball').position[2]) == pytest.approx(z0 - speed * k * DT,
                                                                       abs=1e-15)
        if k + 1 < arrival:     # (the contacts of step k act on step k + 1)
            np.testing.assert_array_equal(world.state('ball').linear_velocity,
                                          [0.0, 0.0, -speed])
    world.step(1)
    assert abs(float(world.state('ball').position[2]) - R) < 1e-15
    for _ in range(5):
        world.step(1)
        st = world.state('ball')
        assert abs(float(st.position[2]) - R) < 1e-15
        assert np.abs(st.linear_velocity).max() < 1e-12


@pytest.mark.parametrize('speed, gap', [(20.0, 0.013), (5.0, 0.004), (100.0, 0.09)])
def test_a_fast_ball_without_restitution_stops_on_the_ground_not_short_of_it(speed, gap):
    """No gravity, e = 0, approach faster than the bounce threshold and than the gap closes
    in one step: the ball must end the step touching the plane and stay there (plastic
    impact), not stop dead where the speculative contact began (mutation-run finding)."""
    r = 0.1
    world = collision_world([ball(position=(0.0, 0.0, r + gap), velocity=(0.0, 0.0, -speed))],
                            1e-3, planes=GROUND, contact=ContactSettings(restitution=0.0))
    for _ in range(5):
        world.step(1)
    z = world.state('ball').position[2]
    assert abs(z - r) < 1e-12, z - r
    assert np.all(np.abs(world.state('ball').linear_velocity) < 1e-9)
