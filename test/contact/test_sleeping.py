# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Sleeping: bodies at rest in contact stop costing, and wake exactly when they must."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.core.rigid_body import State, Wrench
from rb_sim_ros.core.stepper import IntegrationError, step_all, Stepper
from rb_sim_ros.sim.bodies import collision_world, rebuilt
from rb_sim_ros.sim.simulation import (BodySpec, Config, ContactSettings, SetPose, SetWrench,
                                       Simulation)

G = (0.0, 0.0, -9.81)
GROUND = (Plane(),)
DT = 1e-3


def _cube(name, position, size=0.2, mass=1.0, **kwargs):
    moment = mass * size * size / 6.0
    return BodySpec(name, mass, (moment,) * 3, initial_position=position,
                    colliders=(Box((size,) * 3),), **kwargs)


def _stack(**contact):
    bodies = [_cube(f'box{i}', (0.0, 0.0, 0.1 + 0.2 * i)) for i in range(3)]
    bodies.append(BodySpec('ball', 0.5, (0.002,) * 3, initial_position=(5.0, 0.0, 0.1),
                           colliders=(Sphere(0.1),)))
    return collision_world(bodies, DT, G, planes=GROUND,
                           contact=ContactSettings(friction=0.5, **contact))


STACK = ['box0', 'box1', 'box2']


def test_a_resting_stack_falls_asleep_together_and_then_costs_nothing():
    world = _stack()
    asleep_at = {}
    for k in range(1500):
        world.step(1)
        for name in world.sleeping:
            asleep_at.setdefault(name, k)
    assert sorted(world.sleeping) == ['ball'] + STACK
    assert len({asleep_at[n] for n in STACK}) == 1          # the pile at once
    assert asleep_at['box0'] >= 500                         # after sleep_time at least
    frozen = {n: world.state(n) for n in STACK}
    world.step(1000)
    stats = world.last_stats
    assert stats.contacts == 0 and stats.pairs_tested == 0 and stats.sleeping == 4
    for n in STACK:
        st = world.state(n)
        assert np.array_equal(st.position, frozen[n].position)
        assert not st.linear_velocity.any() and not st.angular_velocity.any()
        assert abs(st.position[2] - (0.1 + 0.2 * STACK.index(n))) < 1e-3  # where _stack put it


def test_a_ball_dropped_on_a_sleeping_stack_wakes_all_of_it_and_matches_an_awake_run():
    """The same drop on a stack that sleeps and on one that never does: the pile wakes in the
    step the ball comes near, whole, with the integration and the resting impulses it would
    have had awake, so the runs agree to what sleeping froze (positions within a micrometre,
    speeds under 1e-6 m/s) as the impact carries it: 8 um measured. (Waking without them,
    a cold solve of a body that missed its step, was 0.8 mm off.)"""
    runs = []
    for sleep_time in (0.5, 0.0):
        world = _stack(sleep_time=sleep_time, restitution=0.3)
        world.step(1500)
        assert bool(world.sleeping) == (sleep_time > 0.0)
        world.set_state('ball', State((0.05, 0.02, 1.2), None, (0.0, 0.0, -2.0)))
        woke, track = None, []
        for k in range(800):
            before = set(world.sleeping)
            world.step(1)
            if before and woke is None and not set(world.sleeping) & set(STACK):
                woke = k
            track.append(np.concatenate([world.state(n).position for n in STACK + ['ball']]))
        runs.append((woke, np.array(track), world))
    (woke, slept, world), (_, awake, _) = runs
    assert woke is not None
    # Woken before the ball reached the top box (it falls 0.7 m: about 0.2 s).
    assert woke < 200
    assert np.abs(slept - awake).max() < 2e-5
    # The ball did land on the stack (top face at 0.6 m) and rests there; the stack stands.
    assert slept[-1, 11] == pytest.approx(0.7, abs=1e-3)
    assert np.abs(slept[-1, [0, 1, 3, 4, 6, 7]]).max() < 1e-2    # nudged 2.7 mm by the hit
    assert slept[-1, 8] == pytest.approx(0.5, abs=1e-3)


def test_a_changed_wrench_wakes_a_sleeper_which_slides_as_coulomb_says():
    mass, mu, force = 2.0, 0.5, 15.0
    world = collision_world([_cube('box', (0.0, 0.0, 0.1), mass=mass)], DT, G,
                            planes=GROUND, contact=ContactSettings(friction=mu))
    world.step(1000)
    assert world.sleeping == ['box']
    x0 = world.state('box').position.copy()
    world.steppers['box'].set_wrench(Wrench((force, 0.0, 0.0)))
    world.step(500)
    assert world.sleeping == []
    t = 0.5
    expected = 0.5 * (force / mass - mu * 9.81) * t * t
    moved = world.state('box').position - x0
    # Within a step's worth of motion (the wake step and the start-up of the history).
    assert moved[0] == pytest.approx(expected, abs=(force / mass) * t * DT * 2)
    assert abs(moved[1]) < 1e-6 and abs(moved[2]) < 1e-3


def test_a_teleport_wakes_a_sleeper():
    world = _stack()
    world.step(1200)
    assert 'ball' in world.sleeping
    world.set_state('ball', State((5.0, 0.0, 1.0)))
    assert 'ball' not in world.sleeping
    world.step(100)
    assert world.state('ball').position[2] < 1.0 - 0.5 * 9.81 * 0.1 ** 2 * 0.9


def test_slow_bodies_in_free_flight_never_sleep():
    """Only a body pressed by a contact may sleep: slow drift (under sleep_speed) goes on."""
    drift = (4e-4, 0.0, 0.0)
    world = collision_world([BodySpec('probe', 1.0, (0.01,) * 3, initial_position=(0, 0, 1.0),
                                      initial_linear_velocity=drift,
                                      colliders=(Sphere(0.1),))],
                            DT, (0.0, 0.0, 0.0), planes=GROUND)
    world.step(2000)
    assert world.sleeping == []
    assert world.state('probe').position[0] == pytest.approx(0.8e-3, rel=1e-9)


def test_scene_settings_reach_the_world():
    bodies = (_cube('box', (0.0, 0.0, 0.1)),
              BodySpec('ground', static=True, colliders=(Plane(),)))
    for settings, expected in ((ContactSettings(), ['box']),
                               (ContactSettings(sleep_time=0.0), []),
                               (ContactSettings(sleep_time=2.0), [])):
        sim = Simulation(Config(dt=DT, gravity=G, bodies=bodies, contact=settings))
        sim.run(1500)
        assert sim.world.sleeping == expected, settings
    with pytest.raises(ValueError, match='sleep_speed'):
        ContactSettings(sleep_speed=-1.0)


def test_teleporting_a_support_away_wakes_what_rested_on_it():
    bodies = (_cube('bottom', (0.0, 0.0, 0.1)), _cube('top', (0.0, 0.0, 0.3)),
              BodySpec('ground', static=True, colliders=(Plane(),)))
    sim = Simulation(Config(dt=DT, gravity=G, bodies=bodies))
    sim.run(1000)
    assert sim.world.sleeping == ['bottom', 'top']
    sim.apply(SetPose((5.0, 0.0, 0.1), (0.0, 0.0, 0.0, 1.0), 'bottom'))
    sim.run(1000)
    assert sim.pose_twist('top')[0][2] == pytest.approx(0.1, abs=1e-3)   # fell to the ground


def test_a_push_just_before_the_sleep_timer_runs_out_still_moves_the_body():
    """A changed wrench starts the slow count again: a push too gentle to exceed sleep_speed
    for a while must not be frozen by the count that ran before it."""
    mass, mu, accel = 2.0, 0.5, 0.5
    world = collision_world([_cube('box', (0.0, 0.0, 0.1), mass=mass)], DT, G,
                            planes=GROUND, contact=ContactSettings(friction=mu))
    world.step(499)                      # it would sleep at the 500th step at rest
    assert world.sleeping == []
    x0 = world.state('box').position[0]
    world.steppers['box'].set_wrench(Wrench((mass * (mu * 9.81 + accel), 0.0, 0.0)))
    world.step(2000)
    assert world.sleeping == []
    # Sliding friction here is 0.05% short of mu m g (10 iterations), which the small net
    # push turns into 0.5%; a frozen body would not have moved at all.
    assert world.state('box').position[0] - x0 == pytest.approx(0.5 * accel * 2.0 ** 2,
                                                                rel=0.01)


def test_sleepers_keep_the_world_clock():
    """A sleeper's Stepper counts the steps it slept, however it wakes: its step number (in
    an IntegrationError, say) is the world's."""
    world = _stack()
    world.step(1500)
    assert world.sleeping
    world.steppers['box2'].set_wrench(Wrench((0.0, 0.0, 0.1)))      # wakes it
    world.step(3)
    world.set_state('ball', State((0.0, 0.0, 0.95), None, (0.0, 0.0, -1.0)))   # onto the top
    world.step(400)
    for name, s in world.steppers.items():
        assert s.step_count == world.step_count, name


def test_chunking_does_not_change_a_run_that_sleeps_and_wakes():
    """The node steps by publish periods, replay from event to event: the same states, with
    bodies falling asleep and waking by a drop, a push and a teleport between."""
    bodies = (_cube('a', (0.0, 0.0, 0.1)), _cube('b', (0.0, 0.0, 0.3)),
              _cube('c', (1.0, 0.0, 0.1)),
              BodySpec('ball', 0.5, (0.002,) * 3, initial_position=(3.0, 0.0, 0.1),
                       colliders=(Sphere(0.1),)),
              BodySpec('ground', static=True, colliders=(Plane(),)))
    config = Config(dt=DT, gravity=G, bodies=bodies,
                    contact=ContactSettings(restitution=0.2, sleep_time=0.2))
    events = [(700, SetPose((0.02, 0.0, 0.9), (0.0, 0.0, 0.0, 1.0), 'ball')),   # onto a, b
              (1500, SetWrench(Wrench((30.0, 0.0, 0.0)), 'c')),
              (1700, SetWrench(Wrench(), 'c')),
              (2300, SetPose((1.0, 0.0, 0.5), (0.0, 0.0, 0.0, 1.0), 'a'))]      # away from b
    by_period = Simulation(config)
    pending, sleepers = list(events), []
    while by_period.step_count < 3000:
        pending = by_period.run_until(by_period.step_count + 10, pending)
        sleepers.append(tuple(by_period.world.sleeping))
    one_go = Simulation(config)
    assert not one_go.run_until(3000, list(events))
    names = [b.name for b in bodies[:-1]]
    assert [by_period.pose_twist(n) for n in names] == [one_go.pose_twist(n) for n in names]
    # It did sleep and wake: all four asleep before the drop, then awake, then asleep again.
    assert sleepers[68] == ('a', 'b', 'c', 'ball') and 'a' not in sleepers[105]
    assert len(set(sleepers)) >= 4


def test_a_non_finite_contact_result_spares_the_other_bodies():
    """If the solver hands one body a non-finite velocity, that body keeps its state, every
    other body gets its contacts as usual, and the error names the step. The guard is kernel
    code, the same compiled or interpreted (test_kernels); to poison the solver's result it
    runs interpreted, where the solver can be replaced."""
    out = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                          f'{__file__}::test_poisoned_solve_interpreted'],
                         env={**{k: v for k, v in os.environ.items()  # colcon test's
                                 if k != 'PYTEST_ADDOPTS'}, 'NUMBA_DISABLE_JIT': '1'},
                         capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0 and '1 passed' in out.stdout, out.stdout[-3000:]


@pytest.mark.skipif(os.environ.get('NUMBA_DISABLE_JIT') != '1',
                    reason='run interpreted by test_a_non_finite_contact_result_spares_...')
def test_poisoned_solve_interpreted(monkeypatch):
    from rb_sim_ros.contact import solver_kernels
    from rb_sim_ros.core.stepper import IntegrationError
    solve, poison = solver_kernels.solve_arrays, []

    def poisoned(*args):
        result = solve(*args)
        if poison:
            args[16][0, 0] = np.nan  # out_velocity of body 0
        return result
    monkeypatch.setattr(solver_kernels, 'solve_arrays', poisoned)

    def world():
        return collision_world([BodySpec(f'b{i}', 1.0, (0.004,) * 3,
                                         initial_position=(2.0 * i, 0.0, 0.1),
                                         colliders=(Sphere(0.1),)) for i in range(2)],
                               DT, G, planes=GROUND, contact=ContactSettings(sleep_time=0.0))
    reference, w = world(), world()
    reference.step(10)
    w.step(9)
    before = w.state('b0')
    poison.append(True)
    with pytest.raises(IntegrationError, match="'b0' non-finite at step 9 ") as e:
        w.step(1)
    assert e.value.step == 9
    assert np.array_equal(w.state('b1').position, reference.state('b1').position)
    assert np.array_equal(w.state('b1').linear_velocity, reference.state('b1').linear_velocity)
    # b0 kept its state before the contact: integrated, with the speed gravity gave it.
    assert np.all(np.isfinite(w.state('b0').linear_velocity))
    assert w.state('b0').linear_velocity[2] < 0.0 == before.linear_velocity[2]


def test_a_sleep_time_beyond_any_run_never_sleeps():
    """A sleep time too long to ever run out (here 1e17 s) means no sleeping: not a count that
    overflows into 'everything sleeps now' (a flying ball once froze in mid-air)."""
    world = collision_world([BodySpec('rest', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 0.1),
                                      colliders=(Sphere(0.1),)),
                            BodySpec('fly', 1.0, (0.004,) * 3, initial_position=(5.0, 0.0, 3.0),
                                     initial_linear_velocity=(1.0, 0.0, 0.0),
                                     colliders=(Sphere(0.1),))],
                            DT, G, planes=GROUND, contact=ContactSettings(sleep_time=1e17))
    world.step(50)
    assert world.sleeping == []
    assert world.state('fly').linear_velocity[0] == 1.0 and world.state('fly').position[2] < 3.0


def test_contacts_and_totals_survive_a_failed_step():
    """A body that cannot be integrated stops the step; the contacts of the step before stay
    readable, and totals count from wherever the user reset them."""
    world = collision_world([BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 0.1),
                                      colliders=(Sphere(0.1),)),
                            BodySpec('top', 1.0, (0.1, 0.2, 0.3))],  # no colliders
                            DT, G, planes=GROUND, contact=ContactSettings(sleep_time=0.0))
    world.step(5)
    before = world.last_contacts()
    assert len(before) == 1 and before[0].a == 'ball'
    world.totals = type(world.totals)()
    world.step(3)
    assert world.totals.contacts == 3 and world.last_stats.contacts == 1
    world.steppers['top'].set_wrench(Wrench(torque=(0.0, 0.0, 1e9)))
    with pytest.raises(IntegrationError, match="'top'"):
        world.step(1)
    assert [(c.a, c.b) for c in world.last_contacts()] == [(c.a, c.b) for c in before]


def test_step_all_refuses_a_stepper_listed_twice():
    from rb_sim_ros.core.rigid_body import RigidBody
    s = Stepper(RigidBody(1.0, [1.0, 2.0, 3.0]), DT, State(angular_velocity=(0.0, 0.0, 1.0)))
    with pytest.raises(ValueError, match='twice'):
        step_all([s, s], 1)
    assert s.step_count == 0


def _resting_balls(names=('a', 'b', 'c')):
    """Balls of 0.1 m on the ground: a and b side by side, touching; c alone, 5 m away."""
    where = {'a': (0.0, 0.0, 0.1), 'b': (0.2, 0.0, 0.1), 'c': (5.0, 0.0, 0.1)}
    return [BodySpec(n, 1.0, (0.004,) * 3, initial_position=where[n], colliders=(Sphere(0.1),))
            for n in names]


def _asleep_story():
    """What a user can read of a world of three balls while all of them sleep, after a
    teleport, and after a delete made with all of them asleep (every body's state, the
    sleepers, the contact accelerations, the last contacts and statistics at each point)."""
    seen = []

    def look(world, moment):
        counts = [{k: v for k, v in vars(s).items() if k != 'seconds'}  # not the times
                  for s in (world.last_stats, world.totals)]
        seen.append((moment, world.sleeping, counts, world.last_solve_energy,
                     [(c.a, c.b, c.point.tolist(), c.normal_impulse)
                      for c in world.last_contacts()],
                     [(n, world.state(n).position.tolist(),
                       world.state(n).linear_velocity.tolist(),
                       world.state(n).angular_velocity.tolist(),
                       world.contact_accelerations(n)) for n in world.steppers]))

    def sleep(world):
        for _ in range(200):
            if len(world.sleeping) == len(world.steppers):
                return
            world.step(1)
        raise AssertionError('the balls never slept')
    world = collision_world(_resting_balls(), 1e-2, G, planes=GROUND,
                            contact=ContactSettings(sleep_time=0.1))
    sleep(world)
    look(world, 'asleep')
    world.step(3)
    look(world, 'asleep 3 steps on')
    branch = rebuilt(world, _resting_balls(), False, G)
    world.set_state('b', world.state('b'))
    look(world, 'b teleported where it was')
    world.step(10)
    look(world, 'b teleported, 10 steps on')
    sleep(world)  # again, after passes that found contacts
    world.step(3)
    look(world, 'asleep again, 3 steps on')
    world.set_state('a', world.state('a'))
    look(world, 'a teleported where it was')
    world.step(3)
    look(world, 'a teleported, 3 steps on')
    # c deleted while everything sleeps: the new world has never placed its colliders
    deleted = rebuilt(branch, _resting_balls(('a', 'b')), False, G)
    deleted.step(2)
    look(deleted, 'c deleted, 2 steps on')
    deleted.set_state('b', deleted.state('b'))
    look(deleted, 'c deleted, b teleported')
    deleted.step(10)
    look(deleted, 'c deleted, b teleported, 10 steps on')
    return seen


def test_a_world_asleep_skips_its_pass_and_leaves_what_the_pass_would(monkeypatch):
    """Once a pass has found every body asleep, the steps after it skip the pass (a sleeping
    world costs nothing) and must leave what running it would: the same sleepers, states,
    contacts, statistics and contact accelerations, also after a teleport or a delete (whose
    wakes read the placed colliders). The oracle is the same world with the skip turned off
    (interpreted, where the kernel's stages can be replaced), and the compiled tier."""
    from rb_sim_ros.contact import world_kernels, world_step
    from rb_sim_ros.core import jit
    compiled = _asleep_story()
    reads = []
    read_bodies = world_kernels.read_bodies
    jit.run_interpreted()
    try:
        monkeypatch.setattr(world_kernels, 'read_bodies',
                            lambda *args: (reads.append(1), read_bodies(*args))[1])
        skipping = _asleep_story()
        skipped_reads = len(reads)
        monkeypatch.setattr(world_step, '_all_asleep', lambda asleep, nb: False)
        reads.clear()
        full = _asleep_story()
    finally:
        monkeypatch.undo()
        jit.run_compiled()
    assert skipped_reads < len(reads)  # the skip was taken
    assert skipping == full
    assert compiled == full
    # What the story must show, whatever the tier: the skip saw sleepers; a teleport wakes
    # its neighbour a, which was at rest, so its contacts had not accelerated it.
    moments = {moment: rest for moment, *rest in full}
    assert moments['asleep 3 steps on'][0] == ['a', 'b', 'c']
    # a skipped pass found nothing and solved nothing (the sleepers hold their rest)
    sleeping, (last, _), energy, contacts = moments['asleep 3 steps on'][:4]
    assert last == {**{k: 0 for k in last}, 'sleeping': 3} and energy == (0.0, 0.0)
    # and kept the sleepers' contacts as they were (issue 33: markers show a resting pile)
    assert contacts and contacts == moments['asleep'][3]
    assert moments['b teleported where it was'][0] == ['c']
    woken_a = moments['b teleported where it was'][4][0]
    assert woken_a[0] == 'a' and woken_a[4] == ((0.0,) * 3, (0.0,) * 3)
    assert moments['asleep again, 3 steps on'][0] == ['a', 'b', 'c']
    assert moments['a teleported where it was'][0] == ['c']
    assert moments['c deleted, b teleported'][0] == []


def test_a_world_that_slept_takes_over_a_sleeping_run_and_places_its_colliders_anew():
    """A world that stepped until all its bodies slept (its pass skipped from then on)
    takes over a sleeping stack: its colliders are where its own bodies were, so its next
    pass must run, not be skipped. Then a teleport of the bottom box wakes what rested on it:
    the top box falls onto the ground, as it does in a world built afresh for the stack."""
    def boxes(where):
        moment = 0.2 * 0.2 / 6
        return [BodySpec(n, 1.0, (moment,) * 3, initial_position=where[n],
                         colliders=(Box((0.2,) * 3),)) for n in ('bottom', 'top')]

    def sleep(world):
        for _ in range(3000):
            if len(world.sleeping) == 2:
                world.step(2)  # a pass that finds all asleep, then one skipped
                return
            world.step(1)
        raise AssertionError('never slept')

    stack = {'bottom': (0.0, 0.0, 0.1), 'top': (0.0, 0.0, 0.3)}
    apart = {'bottom': (0.0, 0.0, 0.1), 'top': (5.0, 0.0, 0.1)}
    settings = dict(dt=1e-3, gravity=G, planes=GROUND, contact=ContactSettings())
    old = collision_world(boxes(stack), **settings)
    sleep(old)
    fresh = rebuilt(old, boxes(stack), False, G)
    stepped = collision_world(boxes(apart), **settings)
    sleep(stepped)
    stepped.carry(old, old.steppers, old.step_count, False)
    for world in (fresh, stepped):
        world.step(3)
        world.set_state('bottom', State((3.0, 0.0, 0.1)))
        world.step(1000)
        assert world.state('top').position[2] == pytest.approx(0.1, abs=1e-3)


def _seen(contacts):
    return [(c.a, c.b, c.point.tolist(), c.normal.tolist(), c.depth, c.normal_impulse)
            for c in contacts]


def test_a_sleeping_stack_keeps_its_contacts_for_reads_and_markers_across_a_spawn_and_a_delete():
    """Contacts of sleepers stay in last_contacts (which collision_markers draws) while they
    sleep, though no pass finds them: those of the stack's last pass, as they were. Their
    impulses still carry the stack (statics: the ground's normal impulses on it sum to its
    weight times dt). A body spawned far away (the world rebuilt) leaves them; deleting the
    top box drops its contact and wakes the box under it, which then finds its own again."""
    bodies = [_cube(f'box{i}', (0.0, 0.0, 0.1 + 0.2 * i)) for i in range(3)]
    world = collision_world(bodies, DT, G, planes=GROUND,
                            contact=ContactSettings(friction=0.5))
    for _ in range(3000):
        world.step(1)
        if sorted(world.sleeping) == STACK:
            break
    assert sorted(world.sleeping) == STACK
    before = _seen(world.last_contacts())
    world.step(500)
    assert world.last_stats.contacts == 0 and world.last_stats.pairs_tested == 0
    assert _seen(world.last_contacts()) == before and len(before) >= 12  # 4 a face, 3 faces
    ground = sum(c.normal_impulse for c in world.last_contacts() if c.b == '')
    assert ground == pytest.approx(3 * 1.0 * 9.81 * DT, rel=1e-3)
    far = _cube('far', (50.0, 0.0, 5.0))
    spawned = rebuilt(world, bodies + [far], False, G)
    assert _seen(spawned.last_contacts()) == before
    spawned.step(1)  # the new body falls; the sleepers' contacts stay
    assert [c for c in _seen(spawned.last_contacts()) if 'far' not in c[:2]] == before
    deleted = rebuilt(world, bodies[:2], False, G)
    # box1, which the top box rested on, wakes: none of its contacts is kept (a pass finds
    # them anew); box0's with the ground stay
    assert 'box1' not in deleted.sleeping and deleted.sleeping == ['box0']
    kept = _seen(deleted.last_contacts())
    assert kept and all('box1' not in c[:2] and 'box2' not in c[:2] for c in kept)
    assert kept == [c for c in before if c[:2] == ('box0', '')]
    deleted.step(1)
    assert 'box1' not in deleted.sleeping
    assert any('box1' in (c.a, c.b) for c in deleted.last_contacts())


def test_a_refused_step_keeps_the_contacts_of_the_sleepers():
    """A step refused (more contacts than the solve's bound) leaves no contact of the awake
    bodies, which it did not solve, but those of the sleepers stay as they were: nothing of
    them moved. Interpreted (NUMBA_DISABLE_JIT=1, where the bound is read when the step runs),
    with the bound at 6: three boxes asleep on the ground, two of them woken by a wrench, make
    8 contacts."""
    code = textwrap.dedent("""
        from rb_sim_ros.contact import world_step
        from rb_sim_ros.contact.collision_shapes import Box, Plane
        from rb_sim_ros.core.rigid_body import Wrench
        from rb_sim_ros.core.stepper import IntegrationError
        from rb_sim_ros.sim.bodies import collision_world
        from rb_sim_ros.sim.simulation import BodySpec, ContactSettings
        world_step.MAX_CONTACTS = 12
        boxes = [BodySpec(f'box{i}', 1.0, (1 / 150,) * 3, initial_position=(0.5 * i, 0, 0.1),
                          colliders=(Box((0.2,) * 3),)) for i in range(3)]
        world = collision_world(boxes, 0.01, (0, 0, -9.81), planes=(Plane(),),
                                contact=ContactSettings(friction=0.5, sleep_time=0.1))
        for _ in range(300):
            world.step(1)
            if len(world.sleeping) == 3:
                break
        seen = lambda: sorted((c.a, c.b, c.point.tolist(), c.depth, c.normal_impulse)
                              for c in world.last_contacts())
        before = seen()
        print(len(world.sleeping), len(before))
        world_step.MAX_CONTACTS = 6
        for name in ('box1', 'box2'):
            world.steppers[name].set_wrench(Wrench((0.0, 0.0, 1.0)))
        try:
            world.step(1)
            print('stepped')
        except IntegrationError as e:
            print('refused' if 'MAX_CONTACTS' in str(e) else str(e))
        print(world.sleeping, seen() == [c for c in before if c[0] == 'box0'], len(seen()))
        """)
    env = dict(os.environ, NUMBA_DISABLE_JIT='1')
    run = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    asleep, refused, after = run.stdout.strip().splitlines()
    assert asleep == '3 12'  # all asleep, 4 contacts a box
    assert refused == 'refused'
    assert after == "['box0'] True 4"
