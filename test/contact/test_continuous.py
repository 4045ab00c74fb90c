# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Continuous collision (issue 33, item 3): speculative contacts catch every crossing, and the
swept test of a fast body's path keeps those its path misses from stopping it (no ghost
stops). Oracles: where the wall is (a body past its far face went through it), free flight
(a body that touches nothing keeps its velocity and spin exactly), kinetic energy (never
gained), and the same scenes with the test switched off (the ghost stop it removes)."""

import json
import math

import numpy as np
import pytest

from oracles.contact_cases import ball, cube
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import load_scene, SceneError
from rb_sim_ros.sim.simulation import BodySpec, Config

DT = 1e-3


def _orientations(count, seed):
    """``count`` rotations drawn uniformly (normalised Gaussian quaternions), xyzw."""
    q = np.random.default_rng(seed).normal(size=(count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _plate_x(q, speed=100.0, spin=(0.0, 0.0, 0.0)):
    """A plate 20 x 20 x 1 cm turned by ``q`` flying at ``speed`` (m/s) along x at a static
    wall 1 cm thick (x in [-5, 5] mm): its largest x over the run, and the most pairs swept
    in a step. flow4 (exact torque-free): an edge that meets the wall at 100 m/s leaves the
    plate turning at ~1000 rad/s, past eq27's bound of 1 rad a step."""
    wall = BodySpec('wall', static=True, colliders=(Box((0.01, 1.0, 1.0)),))
    plate = cube('plate', (0.2, 0.2, 0.01), (-0.4, 0.0, 0.0), initial_orientation_xyzw=tuple(q),
                 initial_linear_velocity=(speed, 0.0, 0.0), initial_angular_velocity=spin)
    world = collision_world([plate, wall], DT, integrator='flow4',
                            contact=ContactSettings(restitution=0.5, friction=0.5,
                                                    sleep_time=0.0))
    most, swept = -math.inf, 0
    for _ in range(12):
        world.step(1)
        most = max(most, float(world.state('plate').position[0]))
        swept = max(swept, world.last_stats.swept)
    return most, swept


def test_a_fast_thin_plate_never_passes_a_thin_wall():
    """Every orientation of a sample, 100 m/s (10 cm a step, ten times the wall's thickness):
    the plate's centre never passes the wall's far face (the bench draws 1000:
    bench/ccd_bench.py). The swept test follows each of these paths (a bug that called a hit
    a miss would let the plate through)."""
    for q in _orientations(24, 3):
        most, swept = _plate_x(q)
        assert most < 0.005, q
        assert swept > 0
    for q, spin in zip(_orientations(8, 4), np.random.default_rng(5).normal(size=(8, 3)) * 20):
        most, _ = _plate_x(q, spin=tuple(spin))
        assert most < 0.005, (q, spin)


def _skim(clearance, phase, speed=100.0, continuous=True, **contact):
    """A ball (r = 5 cm) at ``speed`` along x past a static 1 m box whose top face is
    ``clearance`` below the ball's path (so it passes the box's near edge and skims its
    face): its final state and the most contacts a step found its path to miss."""
    box = BodySpec('box', static=True, initial_position=(0.0, -0.55 - clearance, 0.0),
                   colliders=(Box((1.0, 1.0, 1.0)),))
    b = ball(radius=0.05, position=(-1.0 - phase * speed * DT, 0.0, 0.0),
             velocity=(speed, 0.0, 0.0))
    b = BodySpec(**{**b.__dict__, 'continuous': continuous})
    world = collision_world([b, box], DT, contact=ContactSettings(**{
        'restitution': 0.5, 'friction': 0.5, 'sleep_time': 0.0, **contact}))
    missed = 0
    for _ in range(30):
        world.step(1)
        missed = max(missed, world.last_stats.missed)
    return world.state('ball'), missed


@pytest.mark.parametrize('clearance', [1e-3, 1e-2])
def test_a_ball_skimming_past_an_edge_at_speed_is_not_stopped(clearance):
    """Past the edge the speculative contact's normal points at the ball's path at an angle:
    it would close the gap within the step if the ball went that way, so without the swept
    test the ball is stopped and spun by an edge it passes (a ghost stop: below). With it,
    the ball flies on exactly: velocity, spin and energy unchanged to the bit."""
    for phase in (0.1, 0.5, 0.9):
        s, missed = _skim(clearance, phase)
        assert missed > 0
        np.testing.assert_array_equal(s.linear_velocity, [100.0, 0.0, 0.0])
        np.testing.assert_array_equal(s.angular_velocity, [0.0, 0.0, 0.0])
        assert s.position[0] > 0.8


def test_the_switch_and_the_speed_threshold():
    """The ghost stop the test removes, back where it is off: a body with continuous false,
    a scene with continuous_speed inf or above the ball's speed. Below the threshold it
    sweeps; bodies slower than it pay nothing (no pair swept)."""
    def stopped(**kw):
        s, missed = _skim(1e-3, 0.5, **kw)
        return not np.array_equal(s.linear_velocity, [100.0, 0.0, 0.0]), missed

    ghost, missed = stopped()
    assert not ghost and missed > 0
    for kw in ({'continuous': False}, {'continuous_speed': math.inf},
               {'continuous_speed': 150.0}):
        ghost, missed = stopped(**kw)
        assert ghost and missed == 0, kw
    assert not stopped(continuous_speed=50.0)[0]
    # a slow scene: a ball landing at 0.6 m/s on a box and resting, under the threshold
    floor = BodySpec('floor', static=True, initial_position=(0.0, 0.0, -0.5),
                     colliders=(Box((2.0, 2.0, 1.0)),))
    world = collision_world([ball(position=(0.0, 0.0, 0.1 + 0.0183)), floor], DT,
                            (0.0, 0.0, -9.81), contact=ContactSettings(sleep_time=0.0))
    contacts = 0
    for _ in range(300):
        world.step(1)
        assert world.last_stats.swept == 0
        contacts += world.last_stats.contacts
    assert contacts > 0


def test_a_spinning_body_skimming_past_gains_no_energy():
    """A rod (capsule r = 2 cm, 10 cm between its caps' centres) turning at 40 rad/s end over
    end and flying at 60 m/s past a static box's edge, 3 mm clear of the circle its tips
    sweep, pointing down as it passes the edge: nothing touches it, so its motion is free
    flight (velocity, spin and energy kept to rounding), where the speculative contacts of
    its tips stopped it and spun it up to ~700 rad/s (flow4: eq27 raises at that spin)."""
    turn = math.pi / 2 - 0.33   # its tips point along -y 8.3 ms on, at the edge

    def run(continuous):
        top = -(0.07 + 3e-3)
        box = BodySpec('box', static=True, initial_position=(0.0, top - 0.5, 0.0),
                       colliders=(Box((1.0, 1.0, 1.0)),))
        rod = BodySpec('rod', 0.5, (1e-3, 1e-3, 2e-4), initial_position=(-1.0, 0.0, 0.0),
                       initial_linear_velocity=(60.0, 0.0, 0.0),
                       initial_angular_velocity=(40.0, 0.0, 0.0), continuous=continuous,
                       initial_orientation_xyzw=(math.sin(turn / 2), 0.0, 0.0,
                                                 math.cos(turn / 2)),
                       colliders=(Capsule(0.02, 0.1),))
        world = collision_world([rod, box], DT, integrator='flow4',
                                contact=ContactSettings(restitution=0.5, sleep_time=0.0))
        body = rod.body()
        e0 = world.state('rod').kinetic_energy(body)
        world.step(40)
        s = world.state('rod')
        return s, s.kinetic_energy(body) / e0
    s, ratio = run(True)
    np.testing.assert_allclose(s.linear_velocity, [60.0, 0.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(s.angular_velocity, [40.0, 0.0, 0.0], rtol=0, atol=1e-9)
    assert abs(ratio - 1.0) < 1e-12
    ghost, ratio_off = run(False)
    assert ratio_off <= 1.0 + 1e-12   # a ghost stop loses energy, never gains it
    assert not np.allclose(ghost.linear_velocity, [60.0, 0.0, 0.0], rtol=0, atol=1e-6)


def test_a_contact_the_solve_turns_a_body_towards_is_swept_again():
    """A ball at 100 m/s whose path skims a box's edge below (1 mm clear: its contact is
    missed) meets, in the same step, a wall at 45 degrees that sends it straight down at the
    box. Its new path meets the box within the step: the missed contact is swept again at
    the velocity the solve gave, and solved with the wall's, so the ball does not sink into
    the box (without the second sweep it would move 10 cm into it in the next step)."""
    r, clear = 0.05, 1e-3
    top = -r - clear
    box = BodySpec('box', static=True, initial_position=(0.02 + 0.5, top - 0.5, 0.0),
                   colliders=(Box((1.0, 1.0, 1.0)),))
    n = (-math.sqrt(0.5), -math.sqrt(0.5), 0.0)
    wall = BodySpec('wall', static=True,
                    colliders=(Plane(n, -0.05 * math.sqrt(0.5) - r),))
    # from 30 cm back: the box's edge is found (and missed) one step before the wall
    b = ball(radius=r, position=(-0.3, 0.0, 0.0), velocity=(100.0, 0.0, 0.0))
    world = collision_world([b, box, wall], DT,
                            contact=ContactSettings(restitution=1.0, friction=0.0,
                                                    sleep_time=0.0))
    deepest = 0.0
    stats = []
    for _ in range(20):
        world.step(1)
        s = world.state('ball')
        stats.append((world.last_stats.missed, world.last_stats.solves))
        if s.position[0] > 0.02:   # above the box's top face
            deepest = max(deepest, top - (s.position[1] - r))
    assert deepest < 2e-3
    # the step before the wall: the box missed, one solve; at the wall: two solves, the
    # second with the box (not the last one of SWEEP_ROUNDS, which solves everything)
    assert (1, 1) in stats and (0, 2) in stats


def test_a_body_touching_the_ground_skims_past_an_edge_in_one_solve():
    """A ball sliding at 100 m/s on frictionless ground, 1 mm past a box's side: every solve
    changes its velocity (the ground holds it up), so its missed pair is swept again each
    step at the new velocity, finds it missed again and keeps the solve it had: the box never
    pushes it (vx and vy to the bit) and no step solves twice."""
    r = 0.05
    box = BodySpec('box', static=True, initial_position=(0.0, -r - 1e-3 - 0.5, 0.5),
                   colliders=(Box((1.0, 1.0, 1.0)),))
    b = ball(radius=r, position=(-1.0, 0.0, r), velocity=(100.0, 0.0, 0.0))
    world = collision_world([b, box], DT, (0.0, 0.0, -9.81),
                            planes=(Plane((0.0, 0.0, 1.0), 0.0),),
                            contact=ContactSettings(restitution=0.0, friction=0.0,
                                                    sleep_time=0.0))
    missed = 0
    for _ in range(25):
        world.step(1)
        assert world.last_stats.solves == 1
        missed += world.last_stats.missed
        v = world.state('ball').linear_velocity
        assert v[0] == 100.0 and v[1] == 0.0
    assert missed > 0 and world.state('ball').position[0] > 1.0


def test_continuous_in_scenes_and_recordings(tmp_path):
    """A body's ``continuous`` and the scene's ``continuous_speed`` are read from YAML, bad
    values refused with the field named; a recording's config made before the swept test
    (no continuous_speed) replays with none swept, as it ran."""
    path = tmp_path / 'scene.yaml'
    path.write_text('contact: {continuous_speed: 5.0}\n'
                    'bodies:\n'
                    '  - {name: a, shape: sphere, radius: 0.1, density: 1000, continuous: false}\n'
                    '  - {name: b, shape: sphere, radius: 0.1, density: 1000,'
                    ' position: [1, 0, 0]}\n')
    scene = load_scene(path)
    assert [b.continuous for b in scene.bodies] == [False, True]
    assert scene.contact.continuous_speed == 5.0
    path.write_text('contact: {continuous_speed: .inf}\n'
                    'bodies:\n  - {name: a, shape: sphere, radius: 0.1, density: 1000}\n')
    assert load_scene(path).contact.continuous_speed == math.inf
    path.write_text('bodies:\n  - {name: a, shape: sphere, radius: 0.1, density: 1000,'
                    ' continuous: 1}\n')
    with pytest.raises(SceneError, match='continuous'):
        load_scene(path)
    for bad in (-1.0, math.nan, 'fast', True):
        with pytest.raises(ValueError, match='continuous_speed'):
            ContactSettings(continuous_speed=bad)
    assert ContactSettings(continuous_speed=math.inf).continuous_speed == math.inf
    config = Config(bodies=(ball(),)).to_dict()
    assert config['contact']['continuous_speed'] == ContactSettings().continuous_speed
    del config['contact']['continuous_speed']
    assert Config.from_dict(config).contact.continuous_speed == math.inf
    # none swept: written as null (JSON has no infinity), read back as inf
    off = Config(bodies=(ball(),), contact=ContactSettings(continuous_speed=math.inf))
    text = json.dumps(off.to_dict(), allow_nan=False)
    assert Config.from_dict(json.loads(text)) == off
