# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The collision world handed its data: core Steppers (rows of one BodyStore), a ColliderSet
built from shapes and owner rows, one ContactSettings. Built by hand, without a BodySpec,
it is the world ``sim.bodies.collision_world`` builds, bit for bit; bad parts are refused
with the part named; a set is never written by the worlds that read it."""

import copy

import numpy as np
import pytest

from rb_sim_ros.contact.colliders import ColliderSet, Owner
from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import RigidBody, State
from rb_sim_ros.core.stepper import BodyStore, Stepper
from rb_sim_ros.sim.bodies import BodySpec, collision_world

DT, G = 1e-3, (0.0, 0.0, -9.81)
GROUND = (Plane((0.0, 0.0, 1.0), 0.0),)
BALL = Sphere(0.1, friction=0.3)
CRATE = Box((0.4, 0.3, 0.2))
TABLE = Box((1.0, 1.0, 0.1))
CONTACT = ContactSettings(restitution=0.2, sleep_time=0.0)


def _by_hand(store_rows=3):
    """A ball and a crate falling on a static table beside the ground, and a free body
    without colliders, all from the core's parts."""
    store = BodyStore(store_rows, DT, multistep.EQ27)
    ball = Stepper(RigidBody(1.0, np.full(3, 4e-3)), DT, State((0.0, 0.0, 0.5)),
                   gravity=G, store=store)
    crate = Stepper(RigidBody(2.0, np.array([0.02, 0.03, 0.04])), DT,
                    State((0.3, 0.0, 1.0), None, (0.0, 0.0, 0.0), (0.3, 0.0, 0.0)),
                    gravity=G, store=store)
    free = Stepper(RigidBody(1.0, np.full(3, 0.1)), DT, State((5.0, 0.0, 0.0)), gravity=G,
                   store=store)
    steppers = {'ball': ball, 'crate': crate, 'free': free}
    table = State((0.0, 0.0, 0.2))
    colliders = ColliderSet([Owner('ball', (BALL,), row=ball.row),
                             Owner('crate', (CRATE,), row=crate.row),
                             Owner('table', (TABLE,), pose=table)], GROUND)
    return steppers, colliders


def _specs():
    return (BodySpec('ball', 1.0, (4e-3,) * 3, initial_position=(0.0, 0.0, 0.5),
                     colliders=(BALL,)),
            BodySpec('crate', 2.0, (0.02, 0.03, 0.04), initial_position=(0.3, 0.0, 1.0),
                     initial_angular_velocity=(0.3, 0.0, 0.0), colliders=(CRATE,)),
            BodySpec('free', 1.0, (0.1,) * 3, initial_position=(5.0, 0.0, 0.0)),
            BodySpec('table', static=True, initial_position=(0.0, 0.0, 0.2),
                     colliders=(TABLE,)))


def test_a_world_handed_its_parts_is_the_world_built_from_bodies():
    steppers, colliders = _by_hand()
    hand = CollisionWorld(steppers, colliders, CONTACT)
    built = collision_world(_specs(), DT, G, GROUND, contact=CONTACT)
    for _ in range(3):
        hand.step(400)
        built.step(400)
        for name in ('ball', 'crate', 'free'):
            assert hand.steppers[name].pose_twist() == built.steppers[name].pose_twist()
        assert [(c.a, c.b) for c in hand.last_contacts()] == \
            [(c.a, c.b) for c in built.last_contacts()]
    # and it is physics: the ball rests on the table top (0.25 m) at its radius, the crate on
    # the ball or the table, the free body falls freely from rest (x = x0 + g t^2 / 2)
    assert hand.state('ball').position[2] == pytest.approx(0.35, abs=1e-3)
    assert hand.state('table').position.tolist() == [0.0, 0.0, 0.2]
    t = hand.time
    assert hand.state('free').position[2] == pytest.approx(-9.81 * t * t / 2, rel=1e-9)
    assert {c.a for c in hand.last_contacts()} | {c.b for c in hand.last_contacts()} <= {
        'ball', 'crate', 'table', ''}


def test_a_collider_set_is_read_and_never_written_by_its_worlds():
    steppers, colliders = _by_hand()
    before = copy.deepcopy(colliders.__dict__)
    world = CollisionWorld(steppers, colliders, CONTACT)
    world.step(800)
    assert world.last_stats.contacts > 0
    for name, value in before.items():
        now = getattr(colliders, name)
        if isinstance(value, np.ndarray):
            assert np.array_equal(now, value), name
        else:
            assert repr(now) == repr(value), name  # (a State compares by identity)


def test_the_set_numbers_and_places_what_it_is_given():
    """Colliders in the owners' order, then the planes; a static one placed by its owner's
    pose, a moving one at its offset in its body; the owners of planes of the world -1."""
    steppers, colliders = _by_hand()
    assert colliders.ids == (('ball', 0), ('crate', 0), ('table', 0), ('', 0))
    assert colliders.owner_of == (0, 1, 2, -1)
    assert colliders.rows.tolist() == [steppers['ball'].row, steppers['crate'].row]
    assert colliders.body.tolist() == [0, 1, 2]  # the table: a static slot, len(moving)
    assert colliders.centres[2].tolist() == [0.0, 0.0, 0.2]
    assert colliders.lower[2].tolist() == pytest.approx([-0.5, -0.5, 0.15])
    assert colliders.upper[2].tolist() == pytest.approx([0.5, 0.5, 0.25])
    assert colliders.reach.tolist() == pytest.approx([0.1, np.linalg.norm((0.2, 0.15, 0.1))])
    restitution, friction, given = colliders.materials(0.5, 0.7)
    assert given and friction.tolist() == [0.3, 0.7, 0.7, 0.7]
    assert restitution.tolist() == [0.5] * 4


@pytest.mark.parametrize('make, match', [
    (lambda: Owner('a', (BALL,)), "owner 'a': give a row"),
    (lambda: Owner('a', (BALL,), row=0, pose=State()), "owner 'a': give a row"),
    (lambda: Owner('a', (), row=0), "owner 'a': 1 to MAX_COLLIDERS"),
    (lambda: Owner('a', (GROUND[0],), row=0), "owner 'a': shapes.0. is a plane"),
    (lambda: Owner('a', ('ball',), row=0), r"owner 'a': shapes\[0\] is not a shape"),
    (lambda: Owner('a', (BALL,), row=True), "owner 'a': row must be an int"),
    (lambda: Owner('a', (BALL,), pose=(0, 0, 0)), "owner 'a': pose must be a State"),
    (lambda: ColliderSet([Owner('a', (BALL,), row=0), Owner('a', (BALL,), row=1)]),
     'owner names must be unique'),
    (lambda: ColliderSet([Owner('a', (BALL,), row=0), Owner('b', (BALL,), row=0)]),
     'owner rows must be unique'),
    (lambda: ColliderSet([('a', (BALL,), 0)]), r'owners\[0\] must be an Owner'),
    (lambda: ColliderSet([], (BALL,)), r'planes\[0\] must be a Plane'),
    (lambda: Owner('', (GROUND[0],), pose=State()), 'owner name must be a non-empty string'),
])
def test_bad_parts_of_a_set_are_refused_by_name(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_bad_parts_of_a_world_are_refused_by_name():
    steppers, colliders = _by_hand()
    other = Stepper(RigidBody(1.0, np.full(3, 0.1)), DT)  # a store of its own
    with pytest.raises(ValueError, match='rows of one BodyStore'):
        CollisionWorld({**steppers, 'other': other}, colliders)
    with pytest.raises(ValueError, match="owner 'crate' .row 1. is not the row of a stepper"):
        CollisionWorld({'ball': steppers['ball'], 'free': steppers['free']}, colliders)
    swapped = {'ball': steppers['crate'], 'crate': steppers['ball'], 'free': steppers['free']}
    with pytest.raises(ValueError, match="owner 'ball' .row 0. is not the row"):
        CollisionWorld(swapped, colliders)
    roomy, roomy_colliders = _by_hand(store_rows=4)
    table = Stepper(RigidBody(1.0, np.full(3, 0.1)), DT, store=roomy['ball'].store)
    with pytest.raises(ValueError, match="static owner 'table' has a stepper"):
        CollisionWorld({**roomy, 'table': table}, roomy_colliders)
    with pytest.raises(ValueError, match='colliders must be a ColliderSet'):
        CollisionWorld(steppers, [Owner('ball', (BALL,), row=0)])
    with pytest.raises(ValueError, match='contact must be a ContactSettings'):
        CollisionWorld(steppers, colliders, {'restitution': 0.2})
    with pytest.raises(ValueError, match='steppers must map'):
        CollisionWorld({}, colliders)
    twice = {'ball': steppers['ball'], 'again': steppers['ball'], 'crate': steppers['crate']}
    with pytest.raises(ValueError, match='steppers must be distinct rows'):
        CollisionWorld(twice, colliders)
    store = BodyStore(1, DT, multistep.EQ27)
    dust = Stepper(RigidBody(1e-70, np.full(3, 1e-72)), DT, store=store)
    with pytest.raises(ValueError, match=r"owner 'dust': mass and principal moments must lie"):
        CollisionWorld({'dust': dust}, ColliderSet([Owner('dust', (BALL,), row=dust.row)]))
    for clock in (np.zeros(1), np.zeros(2, dtype=np.int64), [0]):
        with pytest.raises(ValueError, match='clock must be a writable int64 array'):
            CollisionWorld(steppers, colliders, clock=clock)


def test_a_world_moves_the_clock_it_is_handed():
    steppers, colliders = _by_hand()
    clock = np.array([7], dtype=np.int64)
    world = CollisionWorld(steppers, colliders, CONTACT, clock=clock)
    assert world.step_count == 7
    world.step(5)
    assert clock[0] == 12 and world.time == pytest.approx(12 * DT)
