# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Spawning and deleting bodies mid-run, without ROS: the bodies that stay go on bit for bit
as in a run without the change, a spawned body moves as the same body alone would from its
state, contacts start and stop with the bodies, and a bad change changes nothing."""

import json
import math

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.sim import simulation
from rb_sim_ros.sim.bodies import collision_world, rebuilt
from rb_sim_ros.sim.simulation import (BodySpec, Config, ContactSettings, Delete, Reset,
                                       SetWrench, Simulation, Spawn)

G = (0.0, 0.0, -9.81)
SPIN = BodySpec('spin', 2.0, (0.1, 0.2, 0.3), initial_position=(0.0, 0.0, 5.0),
                initial_angular_velocity=(0.3, 1.0, 2.0))
PUSHED = BodySpec('pushed', 1.0, (0.1, 0.1, 0.1), initial_position=(3.0, 0.0, 5.0))
FAR = BodySpec('far', 0.5, (0.01, 0.02, 0.015), initial_position=(100.0, 0.0, 0.0),
               initial_linear_velocity=(1.0, 0.0, 2.0),
               initial_angular_velocity=(0.0, 3.0, 0.1))
WRENCH = Wrench((1.0, 0.0, 0.0), (0.0, 0.02, 0.01))


def _with(spec, **colliders):
    from dataclasses import replace
    return replace(spec, **colliders)


def _box_on_ground(spin=0.0):
    """A 1 kg box of 0.5 m edges resting on the plane z = 0 (turning about z at ``spin``)."""
    box = BodySpec('box', 1.0, (1 / 6,) * 3, initial_position=(0.0, 0.0, 0.25),
                   initial_angular_velocity=(0.0, 0.0, spin), colliders=(Box((0.5,) * 3),))
    return box, BodySpec('ground', static=True, colliders=(Plane((0.0, 0.0, 1.0)),))


def _pair(bodies, method):
    config = Config(gravity=G, bodies=bodies, integrator=method)
    return Simulation(config), Simulation(config)


@pytest.mark.parametrize('method', sorted(multistep.METHODS))
@pytest.mark.parametrize('collide', [False, True])
def test_the_bodies_that_stay_go_on_bit_for_bit(method, collide):
    """Spawn a body far away and delete another: the remaining body's every bit is that of
    the run with neither (its history, held wrench and clock carried over), with or without
    a collision world, for every method."""
    extra = {'colliders': (Sphere(0.1),)} if collide else {}
    spin, pushed, far = (_with(b, **extra) for b in (SPIN, PUSHED, FAR))
    plain, changed = _pair((spin, pushed), method)
    for sim in (plain, changed):
        sim.run(23)
        sim.apply(SetWrench(WRENCH, 'spin'))
        sim.run(7)
    changed.apply(Spawn(far))
    changed.run(40)
    changed.apply(Delete('pushed'))
    plain.run(40)
    for sim in (plain, changed):
        sim.run(61)
    assert changed.pose_twist('spin') == plain.pose_twist('spin')
    assert changed.wrench('spin') == WRENCH
    assert changed.step_count == plain.step_count == 131
    assert changed.steppers['spin'].step_count == 131
    assert [b.name for b in changed.config.bodies] == ['spin', 'far']
    assert changed.spawned == ['far']
    assert (changed.world is not None) == collide
    # The spawned body moved as it would alone from its initial state: dynamics do not
    # depend on the clock.
    alone = Simulation(Config(gravity=G, bodies=(far,), integrator=method))
    alone.run(101)
    assert changed.pose_twist('far') == alone.pose_twist('far')
    assert changed.steppers['far'].step_count == 131  # on the run's clock


def test_a_spawned_ball_lands_on_the_ground_and_rests():
    """A ball spawned over a scene without colliders brings the collision world in: it falls
    freely (x = x0 - g t^2 / 2 while in the air) and comes to rest on the ground."""
    ground = BodySpec('ground', static=True)  # no colliders yet: no collision code
    sim = Simulation(Config(gravity=G, bodies=(SPIN, ground)))
    sim.run(10)
    assert sim.world is None
    sim.apply(Delete('ground'))
    sim.apply(Spawn(BodySpec('ground', static=True,
                             colliders=(Plane((0.0, 0.0, 1.0)),))))
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(5.0, 0.0, 1.0),
                    colliders=(Sphere(0.1),))
    sim.apply(Spawn(ball))
    assert sim.world is not None
    sim.run(200)  # 0.2 s: 0.196 m down, still in the air
    t = 0.2
    z = sim.pose_twist('ball')[0][2]
    assert z == pytest.approx(1.0 - 0.5 * 9.81 * t * t, abs=0.01)
    sim.run(3000)
    x, _, v, _ = sim.pose_twist('ball')
    assert x[2] == pytest.approx(0.1, abs=2e-3)
    assert math.hypot(*v) < 1e-2


def test_deleting_the_ground_drops_what_rested_on_it():
    """A box asleep on a static plane wakes and falls freely once the plane is deleted."""
    box, ground = _box_on_ground()
    sim = Simulation(Config(gravity=G, bodies=(box, ground),
                            contact=ContactSettings(sleep_time=0.2)))
    sim.run(1000)
    assert sim.world.sleeping == ['box']
    z0 = sim.pose_twist('box')[0][2]
    assert z0 == pytest.approx(0.25, abs=2e-3)  # half of the 0.5 m edge
    sim.apply(Delete('ground'))
    sim.run(300)
    z, v = sim.pose_twist('box')[0][2], sim.pose_twist('box')[2][2]
    assert v == pytest.approx(-9.81 * 0.3, rel=1e-9)
    assert z == pytest.approx(z0 - 0.5 * 9.81 * 0.3 ** 2, abs=1e-3)


def test_without_warm_starts_a_delete_wakes_every_sleeper():
    """No warm start records what rested on what: every sleeper wakes (and falls)."""
    box, ground = _box_on_ground()
    world = collision_world((box, ground), 1e-3, G,
                            contact=ContactSettings(warm_start=False, sleep_time=0.2))
    world.step(1000)
    assert world.sleeping == ['box']
    world = rebuilt(world, (box,), False, G)
    assert world.sleeping == []
    world.step(100)
    assert world.state('box').linear_velocity[2] == pytest.approx(-9.81 * 0.1, rel=1e-9)


def test_a_resting_pile_stays_put_when_a_body_appears_elsewhere():
    """Sleep state and warm starts carry over: a box asleep on the ground stays asleep and
    exactly where it was when a ball is spawned far away, and keeps resting after it lands."""
    box, ground = _box_on_ground()
    sim = Simulation(Config(gravity=G, bodies=(box, ground),
                            contact=ContactSettings(sleep_time=0.2)))
    sim.run(1000)
    assert sim.world.sleeping == ['box']
    rest = sim.pose_twist('box')
    sim.apply(Spawn(BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(20.0, 0.0, 1.0),
                             colliders=(Sphere(0.1),))))
    sim.run(1000)
    assert 'box' in sim.world.sleeping
    assert sim.pose_twist('box') == rest


def test_reset_puts_a_spawned_body_back_where_it_appeared():
    sim = Simulation(Config(gravity=G, bodies=(SPIN,)))
    sim.run(5)
    sim.apply(Spawn(FAR))
    sim.run(50)
    assert sim.pose_twist('far')[0] != FAR.initial_position
    sim.apply(Reset(body='far'))
    assert sim.pose_twist('far') == (FAR.initial_position, FAR.initial_orientation_xyzw,
                                     FAR.initial_linear_velocity, FAR.initial_angular_velocity)


def test_bad_changes_change_nothing():
    sim = Simulation(Config(gravity=G, bodies=(SPIN, PUSHED)))
    sim.run(3)
    before = (sim.config, sim.pose_twist('spin'), sim.pose_twist('pushed'))
    with pytest.raises(ValueError, match="a body named 'pushed' already"):
        sim.apply(Spawn(_with(FAR, name='pushed')))
    with pytest.raises(ValueError, match="no body named 'nobody'"):
        sim.apply(Delete('nobody'))
    with pytest.raises(ValueError, match='must be a BodySpec'):
        sim.apply(Spawn('far'))
    sim.apply(Delete('pushed'))
    with pytest.raises(ValueError, match='last body'):
        sim.apply(Delete('spin'))
    with pytest.raises(ValueError, match="no body named 'pushed'"):
        sim.apply(SetWrench(WRENCH, 'pushed'))
    assert sim.pose_twist('spin') == before[1]
    assert [b.name for b in sim.config.bodies] == ['spin']


def test_a_body_resting_in_contact_goes_on_bit_for_bit_when_another_is_deleted():
    """Awake (no sleeping) on the ground, a box's contacts are warm-started from the step
    before, by collider numbers: deleting a body renumbers them, and the box still takes
    every bit of the run in which that body never was."""
    box, ground = _box_on_ground(spin=0.3)
    high = BodySpec('high', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 1000.0),
                    colliders=(Sphere(0.1),))
    contact = ContactSettings(sleep_time=0.0, friction=0.3)
    changed = Simulation(Config(gravity=G, bodies=(high, box, ground), contact=contact))
    plain = Simulation(Config(gravity=G, bodies=(box, ground), contact=contact))
    changed.run(300)
    changed.apply(Delete('high'))
    changed.run(300)
    plain.run(600)
    assert changed.last_contacts() and plain.pose_twist('box') == changed.pose_twist('box')


def test_a_tilted_plane_is_the_same_bits_after_a_round_trip():
    """A recording stores the config (and a spawned body) as JSON and replay builds it again:
    a normalised normal must come back unchanged, for every direction (normalising twice is
    not exact for about a third of them; (1, 1, 0) is one)."""
    rng = np.random.default_rng(3)
    for v in [(1.0, 1.0, 0.0)] + [tuple(c) for c in rng.normal(size=(2000, 3))
                                  * 10.0 ** rng.uniform(-5, 5, size=(2000, 1))]:
        ramp = BodySpec('ramp', static=True, colliders=(Plane(v, 0.3),))
        config = Config(gravity=G, bodies=(SPIN, ramp))
        again = Config.from_dict(json.loads(json.dumps(config.to_dict())))
        assert again.bodies[1].colliders[0].normal == ramp.colliders[0].normal
        assert again == config


def test_a_run_keeps_at_most_max_bodies(monkeypatch):
    monkeypatch.setattr(simulation, 'MAX_BODIES', 3)
    sim = Simulation(Config(bodies=(SPIN, PUSHED)))
    sim.apply(Spawn(FAR))
    with pytest.raises(ValueError, match='at most 3'):
        sim.apply(Spawn(_with(FAR, name='more')))
    assert [b.name for b in sim.config.bodies] == ['spin', 'pushed', 'far']


def test_without_warm_starts_a_spawn_leaves_sleepers_asleep():
    box, ground = _box_on_ground()
    world = collision_world((box, ground), 1e-3, G,
                            contact=ContactSettings(warm_start=False, sleep_time=0.2))
    world.step(1000)
    far = _with(FAR, colliders=(Sphere(0.1),))
    world = rebuilt(world, (box, ground, far), True, G)
    assert world.sleeping == ['box']


def test_a_spawn_whose_frame_would_be_world_frame_is_refused(start_sim, probe):
    """Over DDS: frame_prefix 'wor' + a body 'ld' is the frame 'world', world_frame: refused
    with the reason (/tf would say world -> world), nothing spawned; 'world' is the frame
    'worworld' and spawns."""
    pytest.importorskip('simulation_interfaces', reason='tools/build_msgs.sh builds it')
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import GetEntities, SpawnEntity
    start_sim('-p', 'frame_prefix:=wor', '-p', 'start_paused:=true')
    entry = '{mass: 1.0, inertia: [0.1, 0.1, 0.1]}'

    def spawn(name):
        reply = probe.call(SpawnEntity, 'spawn_entity',
                           SpawnEntity.Request(name=name, resource_string=entry))
        return reply.result.result, reply.result.error_message

    code, why = spawn('ld')
    assert code == Result.RESULT_OPERATION_FAILED, why
    assert "body 'ld': its frame 'world' is world_frame" in why
    assert spawn('world') == (Result.RESULT_OK, '')
    names = probe.call(GetEntities, 'get_entities', GetEntities.Request()).entities
    assert list(names) == ['body', 'world']

    def topics():
        return {name for name, _ in probe.node.get_topic_names_and_types()}
    probe.wait_for(lambda: '/world/pose' in topics(), what="the spawned body's topics")
    assert not any(t.startswith('/ld/') for t in topics())


def test_a_run_has_one_clock_which_its_world_moves():
    """The run's step count is one clock: a world that comes with a spawn starts on it and
    moves it as it steps (stepped directly too), and it goes on after the world goes; every
    body's own clock agrees with it."""
    sim = Simulation(Config(dt=1e-3, bodies=(BodySpec('a'),)))
    sim.run(5)
    assert sim.world is None and sim.step_count == 5
    ball = BodySpec('ball', initial_position=(3.0, 0.0, 0.0), colliders=(Sphere(0.1),))
    sim.apply(Spawn(ball))
    assert sim.world is not None and sim.world.step_count == 5
    sim.world.step(3)
    assert sim.step_count == 8 and sim.time_ns == 8_000_000
    sim.run(4)
    assert sim.world.step_count == sim.step_count == 12
    sim.apply(Delete('ball'))
    assert sim.world is None
    sim.run(2)
    assert sim.step_count == 14
    assert [s.step_count for s in sim.steppers.values()] == [14]
