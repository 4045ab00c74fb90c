# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scene files: every refusal names the file, the body and the field; shapes' inertia."""

import json
import math
from pathlib import Path
import re

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, Sphere
from rb_sim_ros.sim.scene import body_entry, load_scene, mass_and_inertia, SceneError
from rb_sim_ros.sim.simulation import Config, ContactSettings

SCENES = Path(__file__).resolve().parents[2] / 'scenes'
EXAMPLE = SCENES / 'example.yaml'


def test_example_scene_loads():
    gravity, bodies, contact = load_scene(str(EXAMPLE))[:3]
    assert gravity == (0.0, 0.0, -9.81)
    assert [b.name for b in bodies] == ['satellite', 'crate', 'ball', 'pillar']
    crate = bodies[1]
    assert crate.mass == pytest.approx(500 * 0.4 * 0.3 * 0.2)
    assert bodies[3].static and not bodies[0].static
    assert bodies[2].angular_damping == 0.05


def test_collision_scene_loads_colliders_and_contact_settings():
    gravity, bodies, contact = load_scene(str(SCENES / 'collisions.yaml'))[:3]
    assert contact == ContactSettings(restitution=0.5, friction=0.6, rolling_resistance=0.002)
    by_name = {b.name: b for b in bodies}
    assert by_name['ball'].colliders == (Sphere(0.1),)           # 'shape': the body's own
    assert by_name['crate'].colliders == (Box((0.4, 0.3, 0.2)),)
    assert by_name['dumbbell'].colliders == (
        Capsule(0.02, 0.3), Sphere(0.06, position=(0.0, 0.0, 0.18)),
        Sphere(0.06, position=(0.0, 0.0, -0.18)))
    assert by_name['ground'].static and by_name['ground'].colliders == (Plane(),)
    wall = by_name['wall'].colliders[0]
    assert wall.size == (0.1, 4.0, 1.0) and by_name['wall'].initial_position == (2.5, 0.0, 0.5)


def test_own_shape_with_a_material(tmp_path):
    f = tmp_path / 'scene.yaml'
    f.write_text('bodies:\n  - {name: puck, shape: box, size: [0.1, 0.1, 0.02], density: 900, '
                 'colliders: [{type: shape, friction: 0.05, restitution: 0.3}, '
                 '{type: sphere, radius: 0.01, position: [0, 0, 0.02]}]}\n')
    puck = load_scene(str(f)).bodies[0]
    assert puck.colliders == (Box((0.1, 0.1, 0.02), friction=0.05, restitution=0.3),
                              Sphere(0.01, position=(0.0, 0.0, 0.02)))


def test_integrator_key(tmp_path):
    f = tmp_path / 'scene.yaml'
    f.write_text('integrator: lie4\nbodies:\n  - {name: a, mass: 1, inertia: [1, 1, 1]}\n')
    assert load_scene(str(f)).integrator == 'lie4'
    assert load_scene(str(EXAMPLE)).integrator is None  # absent: the node's
    for bad in ('rk4', '[lie4]', '4'):
        f.write_text(f'integrator: {bad}\nbodies:\n  - {{name: a, mass: 1, inertia: [1, 1, 1]}}\n')
        with pytest.raises(SceneError, match=r'scene.yaml: integrator: must be one of'):
            load_scene(str(f))


def test_contact_settings_default_when_absent():
    assert load_scene(str(EXAMPLE)).contact == ContactSettings()


def test_shapes_against_textbook_and_a_point_cloud():
    m, (ix, iy, iz) = mass_and_inertia('box', 1000.0, {'size': [2.0, 2.0, 2.0]})
    assert m == 8000.0 and ix == iy == iz == pytest.approx(m * 8 / 12)
    m, moments = mass_and_inertia('sphere', 3.0, {'radius': 0.5})
    assert m == pytest.approx(3.0 * 4 / 3 * math.pi / 8)
    assert moments == pytest.approx((0.4 * m * 0.25,) * 3)
    # The cylinder against a Monte Carlo integral of its mass distribution.
    r, h, rho = 0.3, 1.2, 700.0
    m, (ix, iy, iz) = mass_and_inertia('cylinder', rho, {'radius': r, 'length': h})
    rng = np.random.default_rng(1)
    pts = rng.uniform([-r, -r, -h / 2], [r, r, h / 2], size=(400_000, 3))
    pts = pts[pts[:, 0] ** 2 + pts[:, 1] ** 2 <= r * r]
    dm = m / len(pts)
    assert ix == pytest.approx(dm * np.sum(pts[:, 1] ** 2 + pts[:, 2] ** 2), rel=1e-2)
    assert iz == pytest.approx(dm * np.sum(pts[:, 0] ** 2 + pts[:, 1] ** 2), rel=1e-2)
    assert ix == iy


@pytest.mark.parametrize('text, where', [
    ('bodies: []', 'bodies: must be a non-empty list'),
    ('gravity: [0, 0]\nbodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]', 'gravity:'),
    ('wind: 3\nbodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]', "unknown key(s) ['wind']"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colour: red}]',
     "body 0 ('a'): unknown field(s) ['colour']"),
    ('bodies: [{mass: 1, inertia: [1, 1, 1]}]', 'body 0: name: missing'),
    ('bodies: [{name: a, inertia: [1, 1, 1]}]', "body 0 ('a'): mass: missing"),
    ('bodies: [{name: a, mass: -2, inertia: [1, 1, 1]}]', "body 0 ('a'): mass: must be"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 5]}]', "body 0 ('a'): inertia:"),
    ('bodies: [{name: a, shape: box, size: [1, 1, 1]}]', "body 0 ('a'): density: missing"),
    ('bodies: [{name: a, shape: cone, density: 1}]', "body 0 ('a'): shape: must be one of"),
    ('bodies: [{name: a, shape: sphere, density: 1, radius: 1, size: [1, 1, 1]}]',
     "body 0 ('a'): size: a sphere has no size"),
    ('bodies: [{name: a, shape: box, density: 1, size: [1, 0, 1]}]',
     "body 0 ('a'): size[1]: must be a finite number > 0"),
    ('bodies: [{name: a, shape: box, density: 1, size: [1, 1, 1], mass: 2}]',
     "body 0 ('a'): mass: give either"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], position: [0, 0]}]',
     "body 0 ('a'): position: must be a list of 3 numbers"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], orientation: [0, 0, 0, 0]}]',
     "body 0 ('a'): orientation: must be a non-zero quaternion"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], linear_damping: -1}]',
     "body 0 ('a'): linear_damping:"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{sphere: 1}]}]',
     "body 0 ('a'): colliders[0]: type must be one of"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: box, size: [1, 1]}]}]',
     "body 0 ('a'): colliders[0]: size"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: sphere}]}]',
     "body 0 ('a'): colliders[0]: radius missing"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: plane}]}]',
     "body 0 ('a'): colliders[0]: a plane is only allowed on a static body"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: shape}]}]',
     "body 0 ('a'): colliders[0]: 'shape' needs a body shape (box, cylinder, mesh, sphere), got "
     'None'),
    ('bodies: [{name: a, shape: box, size: [1, 1, 1], density: 1, '
     'colliders: [{type: shape, size: 2}]}]',
     "body 0 ('a'): colliders[0]: shape: unknown keys ['size']"),
    ('bodies: [{name: a, shape: box, size: [1, 1, 1], density: 1, '
     'colliders: [{type: shape, friction: -1}]}]',
     "body 0 ('a'): colliders[0]: friction must be a finite number >= 0"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: {type: sphere}}]',
     "body 0 ('a'): colliders: must be a list"),
    ('contact: {restitution: 1.5}\nbodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]',
     'contact: restitution'),
    ('contact: {bounciness: 1}\nbodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]',
     "contact: unknown contact keys ['bounciness']"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1]}, {name: a, static: true}]',
     "body 1 ('a'): name: used twice"),
    ('bodies: [{name: my-body, mass: 1, inertia: [1, 1, 1]}]', "body 0 ('my-body'): name:"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1]', 'not valid YAML'),
    ('[1, 2]', 'must be a mapping'),
])
def test_refusals_name_file_body_and_field(tmp_path, text, where):
    f = tmp_path / 'scene.yaml'
    f.write_text(text)
    with pytest.raises(SceneError) as e:
        load_scene(str(f))
    assert str(e.value).startswith(f'{f}: ')
    assert where in str(e.value)


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match='cannot read'):
        load_scene(str(tmp_path / 'nope.yaml'))


def test_points(tmp_path):
    f = tmp_path / 'scene.yaml'
    f.write_text('bodies:\n  - {name: a, mass: 1, inertia: [1, 1, 1], '
                 'points: {left: [0, 0.5, 0], right: [0, -0.5, 0.1]}}\n')
    body = load_scene(str(f)).bodies[0]
    assert body.point('left') == (0.0, 0.5, 0.0) and body.point('right') == (0.0, -0.5, 0.1)
    assert body.point('nope') is None
    # recordings carry them: a JSON round trip of the configuration is exact
    config = Config(bodies=(body,))
    assert Config.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    for bad, why in (('[1, 2]', 'must be a mapping'), ('{1x: [0, 0, 0]}', 'point name'),
                     ('{a: [0, 0, 0]}', 'point name'), ('{world: [0, 0, 0]}', 'point name'),
                     ('{body: [0, 0, 0]}', 'point name'), ('{p: [0, 0]}', 'list of 3 numbers'),
                     ('{p: [0, 0, .nan]}', 'finite'), ('{p: [0, 0, true]}', 'number')):
        f.write_text(f'bodies:\n  - {{name: a, mass: 1, inertia: [1, 1, 1], points: {bad}}}\n')
        with pytest.raises(SceneError, match=why):
            load_scene(str(f))


def test_templates_are_bodies_named_by_their_key(tmp_path):
    f = tmp_path / 's.yaml'
    f.write_text('bodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]\n'
                 'templates:\n'
                 '  crate: {shape: box, size: [0.4, 0.3, 0.2], density: 500, colliders: shape}\n'
                 '  post: {static: true, position: [1, 2, 3]}\n')
    crate, post = load_scene(str(f)).templates
    assert crate.name == 'crate' and crate.mass == pytest.approx(500 * 0.4 * 0.3 * 0.2)
    assert crate.colliders == (Box((0.4, 0.3, 0.2)),)
    assert post.static and post.initial_position == (1.0, 2.0, 3.0)


@pytest.mark.parametrize('templates, words', [
    ('[1]', 'templates: must be a mapping'),
    ('{t: 1}', 'template t: must be a mapping'),
    ('{t: {name: u, mass: 1, inertia: [1, 1, 1]}}', 'template t: name: a template is named'),
    ('{t: {mass: -1, inertia: [1, 1, 1]}}', 'template t'),
    ('{1t: {mass: 1, inertia: [1, 1, 1]}}', 'name'),
])
def test_bad_templates_name_the_template_and_field(tmp_path, templates, words):
    f = tmp_path / 's.yaml'
    f.write_text(f'bodies: [{{name: a, mass: 1, inertia: [1, 1, 1]}}]\ntemplates: {templates}\n')
    with pytest.raises(SceneError, match=re.escape(words)):
        load_scene(str(f))


def test_a_body_entry_as_text_is_a_scene_body():
    spec = body_entry('{mass: 2, inertia: [0.1, 0.2, 0.3], position: [1, 2, 3], '
                      'colliders: [{type: sphere, radius: 0.1}]}', 'probe')
    assert (spec.name, spec.mass, spec.initial_position) == ('probe', 2.0, (1.0, 2.0, 3.0))
    assert spec.colliders == (Sphere(0.1),)
    assert body_entry('{"name": "j", "mass": 1, "inertia": [1, 1, 1]}').name == 'j'  # JSON
    assert body_entry('{mass: 1, inertia: [1, 1, 1]}', default='entity').name == 'entity'


@pytest.mark.parametrize('text, words', [
    ('[1, 2]', 'must be a body entry'),
    ('{mass: 1, inertia: [1, 1, 1]}', 'name: missing'),
    ('{mass: [', 'not valid YAML'),
    ('{mass: 1, inertia: [1, 1, 1], mass: 2}', 'given twice'),
    ('{mass: 1, inertia: [1, 1, 5]}', 'inertia'),
    ('{mass: 1, inertia: [1, 1, 1], wings: 2}', 'unknown field'),
    ('{mass: 1, inertia: [1, 1, 1], colliders: [{type: plane}]}', 'only allowed on a static'),
    ('x' * 70_000, 'longer than'),
    ('[' * 100 + ']' * 100, 'resource_string'),
])
def test_a_bad_body_entry_is_one_line_naming_the_field(text, words):
    with pytest.raises(SceneError, match=re.escape(words)) as e:
        body_entry(text, '' if 'name: missing' in words else 'x')
    assert str(e.value).startswith('resource_string') and '\n' not in str(e.value)


def test_the_hull_scene_loads_and_its_bodies_slide_off_the_wedge_to_rest():
    """scenes/hulls.yaml: each body's mass and inertia are its hull's at the density its
    comment says; the die and the nut slide down the wedge and rest on the ground beyond
    it, each on a face (the die's centre at a quarter of its height, the nut's at half its
    thickness)."""
    from rb_sim_ros.sim.bodies import collision_world
    scene = load_scene(str(SCENES / 'hulls.yaml'))
    by_name = {b.name: b for b in scene.bodies}
    for name, density in (('die', 1200.0), ('nut', 7800.0)):
        (hull,) = by_name[name].colliders
        mass, centre, inertia = hull.mass_properties(density)
        assert by_name[name].mass == pytest.approx(mass, rel=1e-4)  # (points to 6 digits)
        np.testing.assert_allclose(by_name[name].inertia, np.diag(inertia), rtol=1e-4)
        np.testing.assert_allclose(centre, 0.0, atol=1e-9)
    world = collision_world(scene.bodies, 1e-3, scene.gravity, contact=scene.contact)
    world.step(4000)
    die, nut = world.state('die'), world.state('nut')
    assert die.position[0] > 0.0 and nut.position[0] > 0.0  # past the wedge's foot
    height = 0.1 * math.sqrt(2.0 / 3.0)  # a regular tetrahedron's, edge 0.1
    assert die.position[2] == pytest.approx(height / 4, abs=5e-4)
    assert nut.position[2] == pytest.approx(0.015, abs=5e-4)
    for body in (die, nut):
        assert np.linalg.norm(body.linear_velocity) < 1e-3
