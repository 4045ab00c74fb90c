# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Per-shape materials: restitution and friction of each collider, combined per contact."""

import json

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Plane, shape_from_dict, shape_to_dict, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec, Config

G = (0.0, 0.0, -9.81)
DT = 1e-3


def _ball(name, x, h, r=0.1, **material):
    return BodySpec(name, 1.0, (0.4 * r * r,) * 3, initial_position=(x, 0.0, h + r),
                    colliders=(Sphere(r, **material),))


def _box(name, y, v, **material):
    return BodySpec(name, 2.0, (0.01, 0.01, 0.01), initial_position=(0.0, y, 0.05),
                    initial_linear_velocity=(v, 0.0, 0.0),
                    colliders=(Box((0.2, 0.2, 0.1), **material),))


def _top_after_bounce(world, name, r):
    """Highest centre height, less r, after the first impact."""
    heights, rising = [], False
    for _ in range(int(1.3 / DT)):
        world.step(1)
        st = world.state(name)
        rising = rising or st.linear_velocity[2] > 0.0
        if rising:
            heights.append(st.position[2] - r)
    return max(heights)


def test_each_ball_bounces_with_its_own_restitution():
    """e = max(e_ball, e_ground): the ground has none, so the world's 0 loses to each ball's."""
    h = 1.0
    ground = BodySpec('ground', static=True, colliders=(Plane(),))
    tops = {}
    balls = (_ball('bouncy', 0.0, h, restitution=0.9), _ball('dull', 1.0, h, restitution=0.3))
    for ball in balls:
        world = collision_world([ball, ground], DT, G,
                                contact=ContactSettings(restitution=0.0, friction=0.0))
        tops[ball.name] = _top_after_bounce(world, ball.name, 0.1)
    # (1 - e^2) v dt bounds the error of landing between steps (docs/collisions.md).
    v = (2 * 9.81 * h) ** 0.5
    assert tops['bouncy'] == pytest.approx(0.81 * h, abs=v * DT + 1e-4)
    assert tops['dull'] == pytest.approx(0.09 * h, abs=v * DT + 1e-4)


def test_each_box_slides_as_far_as_its_combined_friction_says():
    """mu = sqrt(mu_box mu_ground): a box sliding at v0 stops after v0^2 / (2 mu g)."""
    v0, ground_mu = 2.0, 0.5
    world = collision_world([_box('ice', 0.0, v0, friction=0.2),
                            _box('rubber', 1.0, v0, friction=0.8), _box('plain', 2.0, v0),
                            BodySpec('ground', static=True,
                                     colliders=(Plane(friction=ground_mu),))],
                            DT, G, contact=ContactSettings(friction=0.3))
    world.step(2000)
    for name, mu in (('ice', (0.2 * ground_mu) ** 0.5), ('rubber', (0.8 * ground_mu) ** 0.5),
                     ('plain', (0.3 * ground_mu) ** 0.5)):
        st = world.state(name)
        assert np.abs(st.linear_velocity).max() < 1e-6, name
        assert st.position[0] == pytest.approx(v0 * v0 / (2 * mu * 9.81), abs=v0 * DT), name


def test_materials_equal_to_the_defaults_change_no_bit():
    """The per-contact path is the scalar one when every shape says what the world says
    (max(e, e) = e, and sqrt(mu mu) = mu exactly in binary floating point)."""
    def world(material):
        bodies = [_ball(f'b{i}', 0.15 * i, 0.2 + 0.25 * i, **material) for i in range(4)]
        bodies += [_box('crate', 0.5, 1.0, **material),
                   BodySpec('ground', static=True, colliders=(Plane(**material),))]
        w = collision_world(bodies, DT, G, contact=ContactSettings(restitution=0.35, friction=0.6))
        w.step(800)
        return [w.steppers[b.name].pose_twist() for b in bodies[:-1]], w.totals.active
    plain, active = world({})
    assert active > 100
    assert world({'restitution': 0.35, 'friction': 0.6}) == (plain, active)


def test_materials_round_trip_through_dicts_scenes_and_json(tmp_path):
    shape = Box((0.1, 0.2, 0.3), restitution=0.4, friction=1.2)
    assert shape_to_dict(shape) == {'type': 'box', 'size': [0.1, 0.2, 0.3],
                                    'restitution': 0.4, 'friction': 1.2}
    assert shape_from_dict(shape_to_dict(shape)) == shape
    config = Config(bodies=(BodySpec('a', colliders=(shape, Sphere(0.1, friction=0.0))),
                            BodySpec('g', static=True, colliders=(Plane(restitution=1.0),))))
    assert Config.from_dict(json.loads(json.dumps(config.to_dict()))) == config


@pytest.mark.parametrize('material, message', [
    ({'restitution': 1.5}, 'restitution must be a number in [0, 1]'),
    ({'restitution': -0.1}, 'restitution must be a number in [0, 1]'),
    ({'friction': -1.0}, 'friction must be a finite number >= 0'),
    ({'friction': float('inf')}, 'friction must be a finite number >= 0'),
    ({'friction': 'high'}, 'friction must be a finite number >= 0'),
])
def test_bad_materials_are_refused_naming_the_field(material, message):
    with pytest.raises(ValueError, match=message.replace('[', r'\[').replace(']', r'\]')):
        Sphere(0.1, **material)


def test_colliders_planes_and_world_planes_each_have_their_material():
    """A frictionless static platform (a box collider), the ground as a world plane of friction
    0.8: a box sliding on the platform keeps its speed, one on the ground stops where its
    combined friction says (the material arrays hold colliders, then planes)."""
    v0 = 1.0
    platform = BodySpec('platform', static=True, initial_position=(0.0, 5.0, 0.05),
                        colliders=(Box((20.0, 1.0, 0.1), friction=0.0),))
    on_platform = BodySpec('skater', 2.0, (0.01,) * 3, initial_position=(0.0, 5.0, 0.15),
                           initial_linear_velocity=(v0, 0.0, 0.0),
                           colliders=(Box((0.2, 0.2, 0.1)),))
    world = collision_world([platform, on_platform, _box('walker', 0.0, v0)], DT, G,
                            planes=(Plane(friction=0.8),), contact=ContactSettings(friction=0.5))
    world.step(1000)
    assert world.state('skater').linear_velocity[0] == pytest.approx(v0, rel=1e-6)
    mu = (0.5 * 0.8) ** 0.5
    assert world.state('walker').position[0] == pytest.approx(v0 * v0 / (2 * mu * 9.81),
                                                              abs=v0 * DT)


def test_huge_frictions_do_not_overflow_into_friction_through_a_gap():
    """sqrt(mu_a mu_b) of two frictions above 1e154 would be inf, and inf * 0 a NaN limit:
    a ball sliding 0.5 mm above the ground (a speculative contact, no normal impulse) must
    keep its speed."""
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 0.1005),
                    initial_linear_velocity=(2.0, 0.0, 0.0),
                    colliders=(Sphere(0.1, friction=1e200),))
    world = collision_world([ball], DT, (0.0, 0.0, 0.0), planes=(Plane(friction=1e200),))
    world.step(1)
    assert world.last_stats.contacts == 1 and world.last_stats.active == 0
    assert world.state('ball').linear_velocity[0] == 2.0
