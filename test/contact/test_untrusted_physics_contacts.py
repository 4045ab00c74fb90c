# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Contacts never create energy, and a solve or step that blows up says so (issue 11).

Oracles: the kinetic energy of the bodies (1/2 m v.v + 1/2 w . I w, computed here from the
masses and inertias, not by the solver), the work gravity can do in a step, and Newton's
law of restitution where it is consistent with energy.
"""

import math

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from rb_sim_ros.contact import contact_solver as cs
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import (BodySpec, Config, Delete, Reset, SetPose, SetTwist,
                                       Simulation, Spawn)


def _energy(velocity, angular_velocity, masses, inertias_world):
    """Kinetic energy (J) of the moving bodies (the first len(masses) rows)."""
    return sum(0.5 * m * v @ v + 0.5 * w @ i @ w for m, i, v, w in
               zip(masses, inertias_world, velocity, angular_velocity))


def _ball_on_a_rising_box(restitution, friction=0.0):
    """A 10 kg box rising at 0.5 m/s off the ground, a 1 kg ball falling on it at 10 m/s."""
    masses = np.array([10.0, 1.0])
    inertias = np.array([np.eye(3), np.eye(3) * 0.1])
    bodies = cs.Bodies(np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.1], [0.0, 0.0, 0.0]]),
                       np.array([[0.0, 0.0, 0.5], [0.0, 0.0, -10.0], [0.0, 0.0, 0.0]]),
                       np.zeros((3, 3)), np.append(1.0 / masses, 0.0),
                       np.concatenate([np.linalg.inv(inertias), np.zeros((1, 3, 3))]))
    contacts = cs.ContactArrays(np.array([2, 0]), np.array([0, 1]),
                                np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
                                np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]), np.zeros(2))
    settings_ = cs.SolverSettings(restitution=restitution, friction=friction,
                                  velocity_iterations=100, tolerance=0.0)
    return bodies, contacts, settings_, masses, inertias


def test_a_separating_contact_pressed_back_gives_no_energy():
    # The ground contact was separating (+0.5 m/s) when the ball's bounce pressed the box
    # back. With the target 0 there, the ground stopped the box (taking its 1.25 J) while the
    # ball still bounced off at the approach speed 10.5 m/s: 51.25 J -> 55.1 J. Now the
    # impacts are the ideal sequence (docs/collisions.md, "Impacts"): the ball and the box
    # collide alone (e = 1, 1 kg on 10 kg), which sends the box down at 1.41 m/s; the box
    # and the ground collide and it rises at 1.41 m/s, slower than the ball: done. Energy is
    # kept, and the velocities are those of the two collisions.
    bodies, contacts, settings_, masses, inertias = _ball_on_a_rising_box(1.0)
    result = cs.solve(contacts, bodies, settings_)
    e0 = _energy(bodies.velocity, bodies.angular_velocity, masses, inertias)
    e1 = _energy(result.velocity, result.angular_velocity, masses, inertias)
    assert e1 <= e0 * (1.0 + 1e-9)
    assert e1 == pytest.approx(e0, rel=1e-6)  # e = 1 and no friction: nothing lost either
    box, ball = 0.5, -10.0
    box, ball = (box + 2.0 * masses[1] * (ball - box) / masses.sum(),
                 ball + 2.0 * masses[0] * (box - ball) / masses.sum())
    box = -box  # off the ground
    assert ball > box
    assert result.velocity[0, 2] == pytest.approx(box, rel=1e-9)
    assert result.velocity[1, 2] == pytest.approx(ball, rel=1e-9)


@st.composite
def contact_sets(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    nb = int(rng.integers(1, 5))
    masses = 10.0 ** rng.uniform(-1.0, 2.0, nb)
    inertias = []
    for m in masses:
        moments = np.sort(10.0 ** rng.uniform(-2.0, 0.0, 3))
        moments[2] = min(moments[2], moments[0] + moments[1])
        rot = so3.exp(rng.normal(size=3))
        inertias.append(rot @ np.diag(m * moments) @ rot.T)
    inverse_inertia = np.concatenate([np.linalg.inv(np.array(inertias)), np.zeros((1, 3, 3))])
    position = np.vstack([rng.normal(size=(nb, 3)), np.zeros((1, 3))])
    speed = draw(st.floats(-2.0, 3.0).map(lambda e: 10.0 ** e))
    velocity = np.vstack([rng.normal(size=(nb, 3)) * speed, np.zeros((1, 3))])
    spin = np.vstack([rng.normal(size=(nb, 3)) * speed, np.zeros((1, 3))])
    count = draw(st.integers(1, 8))
    a, b = rng.integers(0, nb + 1, count), rng.integers(0, nb + 1, count)
    keep = a != b
    a, b = a[keep], b[keep]
    normal = rng.normal(size=(len(a), 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    point = 0.5 * (position[a] + position[b]) + 0.3 * rng.normal(size=(len(a), 3))
    depth = rng.uniform(-0.05, 0.01, len(a)) * rng.choice([0.0, 1.0, 10.0], len(a))
    warm = None
    if draw(st.booleans()):
        warm = (rng.uniform(0.0, 1.0, len(a)) * speed, rng.normal(size=(len(a), 3)) * speed)
    settings_ = cs.SolverSettings(
        restitution=draw(st.sampled_from([0.0, 0.5, 1.0]) | st.floats(0.0, 1.0)),
        friction=draw(st.sampled_from([0.0, 0.3, 1.0, 5.0])),
        velocity_iterations=draw(st.sampled_from([1, 10, 100])),
        rolling_resistance=draw(st.sampled_from([0.0, 0.002])),
        torsional_friction=draw(st.sampled_from([0.0, 0.002])))
    bodies = cs.Bodies(position, velocity, spin, np.append(1.0 / masses, 0.0), inverse_inertia)
    contacts = cs.ContactArrays(a, b, point, normal, depth)
    return contacts, bodies, settings_, warm, masses, np.array(inertias)


@settings(max_examples=300, deadline=None)
@given(contact_sets())
def test_a_contact_solve_never_creates_kinetic_energy(case):
    # Any contacts between up to 4 bodies and the static world, any restitution in [0, 1],
    # friction, couples, warm starts, iteration counts: Newton's law with friction (Kane's
    # paradox) or with simultaneous contacts may ask for more energy than the bodies had;
    # the solver must never give it.
    contacts, bodies, settings_, warm, masses, inertias = case
    if not len(contacts):
        return
    result = cs.solve(contacts, bodies, settings_, *(warm or ()))
    e0 = _energy(bodies.velocity, bodies.angular_velocity, masses, inertias)
    e1 = _energy(result.velocity, result.angular_velocity, masses, inertias)
    assert e1 <= e0 * (1.0 + 1e-8) + 1e-300
    assert np.all(result.normal_impulse >= 0.0)  # each still pushes, never pulls


@st.composite
def scenes(draw):
    """2 to 4 spheres and boxes over a ground plane, at up to 2 km/s."""
    gravity = draw(st.sampled_from([(0.0, 0.0, 0.0), (0.0, 0.0, -9.81)]))
    isotropic = draw(st.booleans())
    bodies = [BodySpec('ground', static=True, colliders=(Plane((0.0, 0.0, 1.0), 0.0),))]
    for k in range(draw(st.integers(2, 4))):
        mass = draw(st.floats(0.1, 100.0))
        if isotropic or draw(st.booleans()):
            size = draw(st.floats(0.05, 0.5))
            shape = draw(st.sampled_from(['sphere', 'cube']))
            collider = Sphere(size) if shape == 'sphere' else Box((2 * size,) * 3)
            inertia = (0.4 if shape == 'sphere' else 2.0 / 3.0) * mass * size * size
            inertia = (inertia,) * 3
        else:
            dims = [draw(st.floats(0.1, 1.0)) for _ in range(3)]
            collider = Box(tuple(dims))
            inertia = tuple(mass / 12.0 * (dims[(i + 1) % 3] ** 2 + dims[(i + 2) % 3] ** 2)
                            for i in range(3))
        speed = draw(st.sampled_from([0.0, 1.0]) | st.floats(0.0, 2000.0))
        direction = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(3)])
        direction = direction / max(np.linalg.norm(direction), 1e-9)
        bodies.append(BodySpec(
            f'b{k}', mass=mass, inertia=inertia,
            initial_position=(draw(st.floats(-1.0, 1.0)), draw(st.floats(-1.0, 1.0)),
                              draw(st.floats(0.5, 1.5))),
            initial_linear_velocity=tuple(speed * direction),
            initial_angular_velocity=tuple(draw(st.floats(-20.0, 20.0)) for _ in range(3)),
            colliders=(collider,)))
    return tuple(bodies), gravity, isotropic


@settings(max_examples=60, deadline=None)
@given(scenes(), st.floats(0.0, 1.0), st.sampled_from([0.0, 0.5, 1.0]))
def test_random_scenes_never_gain_energy_beyond_the_work_of_gravity(scene, e, mu):
    specs, gravity, isotropic = scene
    world = collision_world(specs, 1e-3, gravity,
                            contact=ContactSettings(restitution=e, friction=mu))
    masses = {s.name: s.mass for s in specs if not s.static}
    g = float(np.linalg.norm(gravity))
    dt = world.dt
    solves = []  # (before, after) of each step's contact solve
    for _ in range(40):
        states = {n: world.state(n) for n in masses}
        energies = {n: states[n].kinetic_energy(world.steppers[n].body) for n in masses}
        before = sum(energies.values())
        # Gravity's work in a step: m g . (v dt + g dt^2 / 2) <= m |g| (|v| dt + |g| dt^2).
        work = sum(m * g * (np.linalg.norm(states[n].linear_velocity) * dt + g * dt * dt)
                   for n, m in masses.items())
        # The explicit update of Euler's equations of a turning box errs by O((w dt)^3).
        drift = 0.0 if isotropic else sum(
            energies[n] * (np.linalg.norm(states[n].angular_velocity) * dt) ** 3
            for n in masses)
        try:
            world.step(1)
        except IntegrationError as err:
            # Only a body spun past MAX_TURN, or a non-finite solve, may raise; it is named
            # and every read stays finite. A solve that gained energy is a failure.
            assert any(f"'{n}'" in str(err) for n in masses)
            assert 'gain kinetic energy' not in str(err)
            for n in masses:
                assert all(np.all(np.isfinite(part)) for part in (
                    world.state(n).position, world.state(n).linear_velocity,
                    world.state(n).angular_velocity))
            break
        solves.append(world.last_solve_energy)
        after = sum(world.state(n).kinetic_energy(world.steppers[n].body) for n in masses)
        if isotropic and not any(gravity):
            # Exact rotation of isotropic bodies, no gravity: contacts alone, to rounding.
            assert after <= before * (1.0 + 1e-9) + 1e-12
        else:
            assert after <= before * (1.0 + 1e-9) + work + drift + 1e-12
    for e0, e1 in solves:  # the contacts alone never add energy (the world's own bookkeeping)
        assert e1 <= e0 * (1.0 + 1e-8) + 1e-12


def test_the_fast_ball_among_the_crates_never_publishes_runaway_energy():
    # Issue 11: a 4.2 kg ball at 10 km/s (2.1e8 J) through a settled pile: the energy grew to
    # 6e240 J in five steps, no error. Now every step either keeps the energy within what
    # the contacts and gravity allow, or raises naming a body and keeps finite states.
    g = (0.0, 0.0, -9.81)
    boxes = [BodySpec(f'box{i}', mass=30.0, inertia=(0.6, 0.4, 0.3),
                      initial_position=(0.6 * i, 0.3 * (i % 2), 0.15 + 0.3 * (i // 3)),
                      colliders=(Box((0.5, 0.3, 0.3)),)) for i in range(5)]
    dumbbell = BodySpec('dumbbell', mass=2.0, inertia=(0.03, 0.03, 0.005),
                        initial_position=(0.4, 1.0, 0.06),
                        initial_orientation_xyzw=(0.7071068, 0.0, 0.0, 0.7071068),
                        colliders=(Sphere(0.06, position=(0.0, 0.0, 0.18)),
                                   Sphere(0.06, position=(0.0, 0.0, -0.18))))
    ball = BodySpec('ball', mass=4.19, inertia=(0.0168,) * 3, initial_position=(-1.0, 0.2, 0.1),
                    colliders=(Sphere(0.1),))
    ground = BodySpec('ground', static=True, colliders=(Plane((0.0, 0.0, 1.0), 0.0),))
    config = Config(dt=1e-3, gravity=g, bodies=(ball, *boxes, dumbbell, ground))
    sim = Simulation(config)
    sim.run(600)
    sim.apply(SetTwist((1e4, 0.0, 0.0), (0.0, 0.0, 0.0), 'ball'))
    moving = [b for b in config.bodies if not b.static]

    def energy():
        return sum(sim.steppers[b.name].state.kinetic_energy(b.body()) for b in moving)

    start = energy()
    for _ in range(20):
        try:
            sim.run(1)
        except IntegrationError as err:
            assert any(f"'{b.name}'" in str(err) for b in moving)
            break
        assert energy() <= start * 1.001
    for b in moving:
        assert all(math.isfinite(c) for part in sim.pose_twist(b.name) for c in part)


@pytest.mark.parametrize('continuous_speed', [
    ContactSettings().continuous_speed,
    pytest.param(math.inf, marks=pytest.mark.xfail(
        strict=True, reason='a known energy gain of 8e-9 of the kinetic energy at e = 1 among '
        'deeply overlapping bodies, when the contacts the ball passes are solved too (a CI '
        'run of the test above found it)'))])
def test_a_fast_ball_into_coincident_overlapping_bodies_at_e_1_gains_no_energy(continuous_speed):
    """The case the property test above found in a CI run (shrunk by Hypothesis): no gravity,
    e = 1, mu = 0, a ball at 117 m/s into a sphere and a box whose centres coincide. The gain
    came from contacts of the ball's path with bodies it passes: the swept test leaves them
    unsolved (default); without it (continuous_speed inf) the gain is still there."""
    specs = (BodySpec('ground', static=True, colliders=(Plane((0.0, 0.0, 1.0), 0.0),)),
             BodySpec('b0', mass=1.0, inertia=(0.1,) * 3, initial_position=(0.0, -1.0, 1.5),
                      colliders=(Sphere(0.5),)),
             BodySpec('b1', mass=1.0, inertia=(0.1,) * 3, initial_position=(0.0, 0.0, 1.0),
                      colliders=(Sphere(0.5),)),
             BodySpec('b2', mass=1.0, inertia=(0.1,) * 3, initial_position=(-0.375, 1.0, 1.0),
                      initial_linear_velocity=(117.0, 0.0, 0.0), colliders=(Sphere(0.5),)),
             BodySpec('b3', mass=1.0, inertia=(1.0 / 6.0, 0.125 / 1.2, 0.125 / 1.2),
                      initial_position=(0.0, 0.0, 1.0), colliders=(Box((0.5, 1.0, 1.0)),)))
    world = collision_world(specs, 1e-3, (0.0, 0.0, 0.0),
                            contact=ContactSettings(restitution=1.0, friction=0.0,
                                                    continuous_speed=continuous_speed))
    names = ['b0', 'b1', 'b2', 'b3']
    for _ in range(40):
        states = {n: world.state(n) for n in names}
        before = sum(states[n].kinetic_energy(world.steppers[n].body) for n in names)
        drift = sum(states[n].kinetic_energy(world.steppers[n].body) *
                    (np.linalg.norm(states[n].angular_velocity) * world.dt) ** 3
                    for n in names)
        world.step(1)
        after = sum(world.state(n).kinetic_energy(world.steppers[n].body) for n in names)
        assert after <= before * (1.0 + 1e-9) + drift + 1e-12


def test_rounding_on_bodies_at_rest_is_no_energy_gain():
    """A run of a spawn, a delete, a teleport and a reset (found by a review's stress run): the
    box, at rest on the ground, carries velocities near 1e-19 m/s, and the solve's check once
    called their rounding a gain (1.04265e-37 J -> 1.04265e-37 J, at the teleport) and
    stopped the run. Below the energy of the bodies moving at 1 nm/s it is rounding; the run
    goes on, and the resting box stays on the ground."""
    half = math.sqrt(0.5)
    box = BodySpec('box', 1.0, (1 / 6,) * 3, initial_position=(0.0, 0.0, 0.25),
                   initial_angular_velocity=(0.0, 0.0, 0.3), colliders=(Box((0.5,) * 3),))
    ball = BodySpec('ball', 0.5, (0.002,) * 3, initial_position=(0.05, 0.0, 0.8),
                    colliders=(Sphere(0.1),))
    cap = BodySpec('cap', 1.0, (0.02, 0.02, 0.01), initial_position=(2.0, 0.0, 0.1),
                   initial_orientation_xyzw=(0.0, half, 0.0, half),
                   colliders=(Capsule(0.1, 0.4),))
    free = BodySpec('free', 1.0, (0.1, 0.2, 0.3), initial_position=(50.0, 0.0, 5.0),
                    initial_angular_velocity=(0.3, 40.0, 2.0))
    ground = BodySpec('ground', static=True, colliders=(Plane((0.0, 0.0, 1.0)),))
    extra = BodySpec('extra', 0.5, (0.002,) * 3, initial_position=(-0.1, 0.1, 1.0),
                     colliders=(Sphere(0.1),))
    sim = Simulation(Config(gravity=(0.0, 0.0, -9.81), dt=0.002,
                            bodies=(box, ball, cap, free, ground)))
    events = {60: Spawn(extra), 100: Delete('ball'),
              140: SetPose((2.0, 0.5, 0.12), (0.0, half, 0.0, half), 'cap'),
              170: Reset(body='box')}
    with pytest.warns(Warning):  # the free body spins past eq27's energy bound: said once
        for step in range(200):
            if step in events:
                sim.apply(events[step])
            sim.run(1)  # an IntegrationError here fails the test
    z = sim.pose_twist('box')[0][2]
    assert z == pytest.approx(0.25, abs=1e-3)
