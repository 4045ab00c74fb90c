# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scene files are untrusted input: whatever a file holds, load_scene returns a valid scene or
raises SceneError, one line naming the file, the body and the field, and never anything else."""

import copy
import math
from pathlib import Path
import re
import tempfile
import tracemalloc

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest
import yaml

from rb_sim_ros.contact.collision_shapes import Plane
from rb_sim_ros.sim import safe_yaml, scene
from rb_sim_ros.sim.scene import load_scene, Scene, SceneError
from rb_sim_ros.sim.simulation import BodySpec, ContactSettings

SCENES = Path(__file__).resolve().parents[2] / 'scenes'
BODY = '{name: a, mass: 1, inertia: [1, 1, 1]}'
HUGE = '1' + '0' * 399  # 400 digits: more than a float holds


def _file(tmp_path, text, name='scene.yaml'):
    f = tmp_path / name
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text, encoding='utf-8')
    return f


def _refused(tmp_path, text, *parts):
    """The message of the SceneError that loading ``text`` gives, checked to be one line
    beginning with the file name and to hold each of ``parts``."""
    f = _file(tmp_path, text)
    with pytest.raises(SceneError) as e:
        load_scene(str(f))
    message = str(e.value)
    assert message.startswith(f'{f}: '), message
    assert '\n' not in message and len(message) < 1000, message
    for part in parts:
        assert part in message, message
    return message


def _loads(tmp_path, text):
    return load_scene(str(_file(tmp_path, text)))


# -- the defects of issue 11, one by one ---------------------------------------------------

def _laughs(levels):
    lines = ['lol: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f'l{i}: &l{i} [{", ".join([f"*l{i - 1}"] * 9)}]' for i in range(1, levels)]
    return '\n'.join(lines) + f'\nbodies: [{{name: a, mass: 1, inertia: *l{levels - 1}}}]\n'


def test_billion_laughs_is_refused_at_the_first_alias_without_expanding_it(tmp_path):
    tracemalloc.start()
    try:
        message = _refused(tmp_path, _laughs(10), 'l1[0]: aliases (*l0) are not allowed',
                           '(line 2)')
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5e6, (peak, message)  # 9^9 strings would be gigabytes


def test_an_alias_in_a_body_names_the_body_and_the_field(tmp_path):
    _refused(tmp_path, 'bodies:\n  - {name: a, mass: &m 1, inertia: [1, 1, 1]}\n'
             '  - {name: b, mass: *m, inertia: [1, 1, 1]}\n',
             ': body 1: mass: aliases (*m) are not allowed (line 3)')


@pytest.mark.parametrize('text, where, unit', [
    (f'bodies: [{{name: a, mass: {HUGE}, inertia: [1, 1, 1]}}]', "body 0 ('a'): mass", ' (kg)'),
    (f'bodies: [{{name: a, mass: 1, inertia: [1, {HUGE}, 1]}}]', "body 0 ('a'): inertia[1]",
     ' (kg m^2)'),
    (f'gravity: [0, 0, -{HUGE}]\nbodies: [{BODY}]', 'gravity[2]', ' (m/s^2)'),
    (f'bodies: [{{name: a, mass: 1, inertia: [1, 1, 1], position: [-{HUGE}, 0, 0]}}]',
     "body 0 ('a'): position[0]", ''),
    (f'bodies: [{{name: a, shape: sphere, radius: {HUGE}, density: 1}}]',
     "body 0 ('a'): radius", ' (m)'),
    (f'bodies: [{{name: a, mass: 1, inertia: [1, 1, 1], linear_damping: {HUGE}}}]',
     "body 0 ('a'): linear_damping", ' (1/s)'),
    (f'contact: {{friction: {HUGE}}}\nbodies: [{BODY}]', 'contact: friction', ''),
])
def test_a_400_digit_integer_is_refused_by_name(tmp_path, text, where, unit):
    _refused(tmp_path, text,
             f'{where}: must be a finite number{unit}, got an integer of 400 digits')


@pytest.mark.parametrize('collider, field', [
    (f'{{type: sphere, radius: {HUGE}}}', 'radius must be a finite number (m)'),
    (f'{{type: sphere, radius: 1, friction: {HUGE}}}', 'friction must be a finite number >= 0'),
    (f'{{type: box, size: [1, {HUGE}, 1]}}', 'size must be finite'),
    (f'{{type: sphere, radius: 1, orientation: [0, 0, 0, {HUGE}]}}',
     'orientation_xyzw must be finite'),
])
def test_a_400_digit_integer_in_a_collider_is_refused_by_name(tmp_path, collider, field):
    _refused(tmp_path, f'bodies: [{{name: a, mass: 1, inertia: [1, 1, 1], '
             f'colliders: [{collider}]}}]', f"body 0 ('a'): colliders[0]: {field}")


@pytest.mark.parametrize('body', [
    '{name: a, shape: sphere, radius: 1.0e+200, density: 1}',
    '{name: a, shape: box, size: [1.0e+200, 1.0e+200, 1], density: 1}',
    '{name: a, shape: cylinder, radius: 1.0e+200, length: 1, density: 1.0e+300}',
    '{name: a, shape: sphere, radius: 1.0e-200, density: 1}',
])
def test_a_shape_whose_mass_is_not_a_finite_positive_float_is_refused(tmp_path, body):
    _refused(tmp_path, f'bodies: [{body}]', "body 0 ('a'): shape: this ", 'must be finite and > 0')


@pytest.mark.parametrize('body, where', [
    ('{name: a, mass: 5.0e-324, inertia: [1, 1, 1]}',
     "body 0 ('a'): mass: must be a finite number >= 2.23e-308 (kg), got 5e-324"),
    ('{name: a, mass: 1, inertia: [5.0e-324, 5.0e-324, 5.0e-324]}',
     "body 0 ('a'): inertia: principal moments [5e-324, 5e-324, 5e-324] kg m^2: each must be "
     'at least 2.23e-308 (its inverse must be a finite float)'),
])
def test_a_mass_or_moment_whose_inverse_overflows_is_refused(tmp_path, body, where):
    _refused(tmp_path, f'bodies: [{body}]', where)


def test_a_list_as_the_shape_is_refused_by_name(tmp_path):
    _refused(tmp_path, 'bodies: [{name: a, shape: [box], size: [1, 1, 1], density: 1}]',
             "body 0 ('a'): shape: must be one of ['box', 'cylinder', 'sphere'], got ['box']")


@pytest.mark.parametrize('depth', [20, 100_000])
def test_deep_nesting_is_refused(tmp_path, depth):
    message = _refused(tmp_path, f'bodies: [{{name: a, mass: 1, inertia: {"[" * depth}'
                       f'{"]" * depth}}}]')
    assert 'nested more than 8 deep' in message or 'maximum nesting depth' in message


@pytest.mark.parametrize('name', ['h\u00e9llo', '\u0441\u043f\u0443\u0442\u043d\u0438\u043a',
                                  'a\u200bb', 'caf\u00e9_1', '\uff41'])
def test_non_ascii_body_names_are_refused(tmp_path, name):
    _refused(tmp_path, f'bodies: [{{name: "{name}", mass: 1, inertia: [1, 1, 1]}}]',
             'body 0 (', '): name: must be a ROS name token', 'an ASCII letter, then ASCII '
             'letters, digits or underscores')


@pytest.mark.parametrize('name', ['1a', '_a', 'a-b', 'a b', 'a/b', '~a', '{a}', '', 'a' * 65])
def test_names_that_are_not_ros_name_tokens_are_refused(tmp_path, name):
    _refused(tmp_path, f'bodies: [{{name: "{name}", mass: 1, inertia: [1, 1, 1]}}]',
             '): name: must be a ROS name token')


def test_the_longest_name_and_digits_and_underscores_are_accepted(tmp_path):
    names = ['a' * 64, 'A_1', 'b2__c_']
    bodies = ', '.join(f'{{name: {n}, mass: 1, inertia: [1, 1, 1]}}' for n in names)
    assert [b.name for b in _loads(tmp_path, f'bodies: [{bodies}]').bodies] == names


def test_a_non_utf8_file_is_named_with_the_byte_and_where_it_is(tmp_path):
    text = b'bodies:\n  - {name: \xff\xfe, mass: 1, inertia: [1, 1, 1]}\n'
    offset = text.index(b'\xff')
    _refused(tmp_path, text, f'not UTF-8 text: byte 0xff at offset {offset} (line 2)')


@pytest.mark.parametrize('normal, expected', [
    ([0, 1e200, 1e200], (0.0, math.sqrt(0.5), math.sqrt(0.5))),
    ([0, 1e-200, -1e-200], (0.0, math.sqrt(0.5), -math.sqrt(0.5))),
    ([3e307, 4e307, 0], (0.6, 0.8, 0.0)),
    ([0, 0, 5e-324], (0.0, 0.0, 1.0)),
])
def test_a_plane_normal_of_any_length_is_normalised(tmp_path, normal, expected):
    body = _loads(tmp_path, f'bodies: [{{name: ground, static: true, colliders: '
                  f'[{{type: plane, normal: {normal}}}]}}]').bodies[0]
    assert body.colliders[0].normal == pytest.approx(expected, abs=1e-15)
    assert Plane(normal=normal).normal == pytest.approx(expected, abs=1e-15)


# Components whose squares neither overflow nor underflow, so that the unscaled formula holds.
_ORDINARY = st.floats(-1e3, 1e3).map(lambda c: 0.0 if abs(c) < 1e-150 else c)


@given(st.lists(_ORDINARY, min_size=3, max_size=3).filter(any))
@settings(max_examples=200, deadline=None)
def test_normalising_after_scaling_keeps_the_bits_of_ordinary_normals(n):
    norm = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])  # the unscaled formula
    assert Plane(normal=n).normal == (n[0] / norm, n[1] / norm, n[2] / norm)


def test_a_plane_normal_of_zero_is_refused_by_name(tmp_path):
    _refused(tmp_path, 'bodies: [{name: g, static: true, colliders: [{type: plane, '
             'normal: [0, 0, 0]}]}]', "body 0 ('g'): colliders[0]: normal must be a non-zero")


def test_inertia_near_the_largest_float_is_checked_not_blamed_on_eigenvalues(tmp_path):
    body = _loads(tmp_path, 'bodies: [{name: a, mass: 1, inertia: [1e308, 1e308, 1e308]}]'
                  ).bodies[0]
    assert np.array_equal(body.body().inertia, np.diag([1e308] * 3))
    full = _loads(tmp_path, 'bodies: [{name: a, mass: 1, inertia: [[1e308, 5e307, 0], '
                  '[5e307, 1e308, 0], [0, 0, 1e308]]}]').bodies[0]
    np.testing.assert_allclose(full.body().principal_moments, [0.5e308, 1e308, 1.5e308])
    for inertia, why in [('[1e308, 1e308, -1e308]', 'inertia must be positive definite'),
                         ('[1e308, 1e300, 1e300]', 'inertia principal moments must obey '
                          'the triangle inequality'),
                         ('[[1e308, 1e308, 0], [1e308, 1e308, 0], [0, 0, 1e308]]',
                          'inertia must be positive definite')]:
        message = _refused(tmp_path, f'bodies: [{{name: a, mass: 1, inertia: {inertia}}}]',
                           f"body 0 ('a'): inertia: {why}")
        assert 'Eigenvalues' not in message


@pytest.mark.parametrize('text, where', [
    (f'gravity: [0, 0, 0]\ngravity: [0, 0, -9.81]\nbodies: [{BODY}]',
     ': gravity: given twice in one mapping (line 2)'),
    ('bodies:\n  - name: a\n    mass: 1\n    mass: 2\n    inertia: [1, 1, 1]\n',
     ': body 0: mass: given twice in one mapping (line 4)'),
    (f'bodies:\n  - {BODY}\n  - name: b\n    static: true\n    colliders:\n'
     '      - {type: sphere, radius: 1, radius: 2}\n',
     ': body 1: colliders[0].radius: given twice in one mapping (line 6)'),
    (f'contact: {{friction: 0.1, friction: 0.9}}\nbodies: [{BODY}]',
     ': contact.friction: given twice in one mapping (line 1)'),
])
def test_duplicate_keys_are_refused_by_name_and_line(tmp_path, text, where):
    _refused(tmp_path, text, where)


@pytest.mark.parametrize('text, where', [
    ('bodies: [{name: a, mass: 1, inertia: [true, true, true]}]',
     "body 0 ('a'): inertia[0]: must be a number (kg m^2), got True"),
    ('bodies: [{name: a, mass: yes, inertia: [1, 1, 1]}]',
     "body 0 ('a'): mass: must be a number (kg), got True"),
    ('bodies: [{name: a, mass: 1, inertia: [[1, 0, 0], [0, 1, false], [0, 0, 1]]}]',
     "body 0 ('a'): inertia[1][2]: must be a number (kg m^2), got False"),
    (f'gravity: [0, 0, on]\nbodies: [{BODY}]', 'gravity[2]: must be a number (m/s^2), got True'),
    ('bodies: [{name: a, shape: box, size: [1, true, 1], density: 1}]',
     "body 0 ('a'): size[1]: must be a number (m), got True"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: sphere, '
     'radius: true}]}]', "body 0 ('a'): colliders[0]: radius must be a number (m), got True"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: sphere, '
     'radius: 1, friction: true}]}]', "body 0 ('a'): colliders[0]: friction must be a finite"),
    ('bodies: [{name: g, static: true, colliders: [{type: plane, offset: true}]}]',
     "body 0 ('g'): colliders[0]: offset must be a number (m), got True"),
    (f'contact: {{restitution: true}}\nbodies: [{BODY}]',
     'contact: restitution: must be a number, got True'),
    (f'contact: {{velocity_iterations: true}}\nbodies: [{BODY}]',
     'contact: velocity_iterations: must be an integer in [0, 1000], got True'),
    (f'contact: {{speculative: 1}}\nbodies: [{BODY}]',
     'contact: speculative: must be true or false, got 1'),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], static: 1}]',
     "body 0 ('a'): static: must be true or false, got 1"),
])
def test_booleans_are_not_numbers_and_numbers_are_not_booleans(tmp_path, text, where):
    _refused(tmp_path, text, where)


# -- what the loader refuses beyond the listed defects ---------------------------------------

@pytest.mark.parametrize('text, where', [
    (f'bodies: [{BODY}]\n3: x', ': keys must be strings, got 3 (line 2)'),
    (f'bodies: [{BODY}]\non: x', ': keys must be strings, got True (line 2)'),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], [x]: 1}]',
     ': body 0: keys must be strings, got a collection'),
    (f'bodies: [{BODY}]\n<<: {{gravity: [0, 0, 1]}}', ': merge keys (<<) are not allowed'),
    ('bodies: [{name: 2001-12-14, mass: 1, inertia: [1, 1, 1]}]',
     ": body 0: name: values of type 'tag:yaml.org,2002:timestamp' are not allowed"),
    ('bodies: [{name: !!binary aGVsbG8=, mass: 1, inertia: [1, 1, 1]}]',
     ": body 0: name: values of type 'tag:yaml.org,2002:binary' are not allowed"),
    ('bodies: [{name: a, mass: !!python/object/apply:os.getpid [], inertia: [1, 1, 1]}]',
     ': body 0: mass: values of type'),
    ('bodies: !!set {a}', ": bodies: values of type 'tag:yaml.org,2002:set' are not allowed"),
    (f'bodies: [{BODY}]\n---\nbodies: [{BODY}]\n', ': more than one document (---) (line 2)'),
    (f'bodies: [{{name: a{"b" * 5000}, mass: 1, inertia: [1, 1, 1]}}]',
     ': body 0: name: a value of 5001 characters (at most 4096)'),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1]', ': body 0: not valid YAML'),
    (f'bodies: [{BODY}]\n\x07', 'not valid YAML: unacceptable character #x0007'),
    ('', ': must be a mapping with a bodies list, got NoneType'),
    ('bodies: [[1, 2]]', ': body 0: must be a mapping of fields, got [1, 2]'),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], colliders: [{type: [sphere]}]}]',
     "body 0 ('a'): colliders[0]: type must be one of"),
    ('bodies: [{name: a, mass: 1, inertia: [1, 1, 1], orientation: [0, 0, 0, 0]}]',
     "body 0 ('a'): orientation: must be a non-zero quaternion"),
    (f'contact: {{velocity_iterations: 1000000000}}\nbodies: [{BODY}]',
     'contact: velocity_iterations: must be an integer in [0, 1000]'),
])
def test_refusals_name_the_file_the_body_and_the_field(tmp_path, text, where):
    _refused(tmp_path, text, where)


def test_too_many_bodies_are_refused_and_the_bound_allows_ten_thousand(tmp_path, monkeypatch):
    assert scene.MAX_BODIES >= 10_000
    monkeypatch.setattr(scene, 'MAX_BODIES', 2)
    bodies = ', '.join(f'{{name: b{i}, mass: 1, inertia: [1, 1, 1]}}' for i in range(3))
    _refused(tmp_path, f'bodies: [{bodies}]', ': bodies: 3 bodies, more than MAX_BODIES = 2')


def test_a_file_larger_than_the_bound_is_refused_unread(tmp_path, monkeypatch):
    monkeypatch.setattr(scene, 'MAX_BYTES', 100)
    _refused(tmp_path, f'bodies: [{BODY}]\n' + '#' * 100,
             ': larger than 100 bytes (MAX_BYTES): not a scene')


def test_a_scene_of_too_many_values_is_refused_where_it_crosses_the_bound(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setattr(scene, 'MAX_VALUES', 20)
    _refused(tmp_path, 'bodies: [{name: a, mass: 1, inertia: [1, 1, 1]}, '
             '{name: b, mass: 1, inertia: [1, 1, 1]}, {name: c, mass: 1, inertia: [1, 1, 1]}]',
             ': body 1: inertia[0]: more than 20 values (line 1)')  # 3 + 10 + 7 before it


def test_the_loader_bounds_the_number_of_values():
    with pytest.raises(safe_yaml.YamlError, match=r'more than 5 values \(line 1\)') as e:
        safe_yaml.load('a: [1, 2, 3, 4, 5]', max_nodes=5)
    assert e.value.path == ('a', 2)  # the mapping, 'a', the list, 1, 2: then 3 is the 6th


def test_ten_thousand_bodies_load(tmp_path):
    lines = ['gravity: [0.0, 0.0, -9.81]', 'bodies:']
    for i in range(10_000):
        lines.append(f'  - {{name: ball_{i}, shape: sphere, radius: 0.05, density: 1000.0, '
                     f'position: [{i * 0.2}, 0.0, 1.0], orientation: [0, 0, 0.6, 0.8], '
                     'colliders: [{type: shape, friction: 0.3}, {type: capsule, radius: 0.01, '
                     'length: 0.1, position: [0, 0, 0.1]}]}')
    text = '\n'.join(lines) + '\n'
    assert len(text.encode()) < scene.MAX_BYTES
    loaded = _loads(tmp_path, text)
    assert len(loaded.bodies) == 10_000 and loaded.bodies[-1].name == 'ball_9999'
    assert loaded.bodies[-1].initial_position == (9999 * 0.2, 0.0, 1.0)


# -- properties: any input gives a valid scene or a SceneError ---------------------------------

# What follows 'body i: ' in a message: a field of the body (with an index or a key under it,
# which may hold spaces: colliders[0].type.' '[0]), or what is wrong with the body's mapping.
_BODY_FIELD = re.compile(r'(%s)(\[\d+\])*(\..*?)?: |must be a mapping of fields|unknown field|'
                         r'(\S+: )?keys must be strings|not valid YAML|more than \d+ values'
                         % '|'.join(sorted(scene.BODY_KEYS)))


def _load_text(text):
    """load_scene of ``text`` (str or bytes) in a fresh file: a Scene, checked valid, or the
    SceneError, checked to begin with the file's name and, for a body with a plain name (or
    none), to name the field. Any other exception fails the test."""
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / 'scene.yaml'
        f.write_bytes(text if isinstance(text, bytes) else text.encode('utf-8', 'surrogatepass'))
        try:
            loaded = load_scene(str(f))
        except SceneError as e:
            message = str(e)
            assert message.startswith(f'{f}: '), message
            assert '\n' not in message and len(message) < 2000, message
            body = re.match(r": body \d+( \('\w*'\))?: (.*)", message[len(str(f)):])
            if body:
                assert _BODY_FIELD.match(body.group(2)), message
            return e
    assert isinstance(loaded, Scene) and loaded.bodies
    assert all(isinstance(b, BodySpec) and scene.NAME.match(b.name) for b in loaded.bodies)
    assert len({b.name for b in loaded.bodies}) == len(loaded.bodies)
    assert all(math.isfinite(g) for g in loaded.gravity)
    return loaded


_SCALARS = (st.none() | st.booleans() | st.integers() | st.just(10 ** 400) | st.just(-10 ** 400)
            | st.floats() | st.text(st.characters(blacklist_categories=('Cs',)), max_size=12)
            | st.sampled_from(['box', 'sphere', 'cylinder', 'capsule', 'plane', 'shape', 'a',
                               '1e400', '.nan', 'yes', '~', '*a', '&a', '<<', '!!binary x'])
            | st.sampled_from([1e308, -1e308, 1e200, 1e-200, 5e-324, -0.0, 0, 1, -1]))
_KEYS = st.sampled_from(sorted(scene.BODY_KEYS | scene.TOP_KEYS | {
    'type', 'normal', 'offset', 'restitution', 'friction', 'speculative', 'slop'})) | st.text(
        st.characters(blacklist_categories=('Cs',)), max_size=6)
_VALUES = st.recursive(_SCALARS, lambda inner: st.lists(inner, max_size=4)
                       | st.dictionaries(_KEYS, inner, max_size=4), max_leaves=20)


# Well-typed values of each field (some at the ends of the float range, some inertias that are
# not physical), mixed with anything: so that a random body gets past its first checks as often
# as not, and every later check meets anything too.
_V3 = [0.0, 1.0, 2.0]
_GOOD = {'name': ['a', 'b', 'ball_1'], 'mass': [1.0, 2, 1e308, 5e-324],
         'inertia': [[1, 2, 1.5], [[1, 0.1, 0], [0.1, 1, 0], [0, 0, 1]],
                     [1, 0, 0, 0, 1, 0, 0, 0, 1], [1e308] * 3, [5e-324] * 3, [1, 1, 5],
                     [[1, 2, 0], [2, 1, 0], [0, 0, 1]], [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]],
         'shape': ['box', 'sphere', 'cylinder', 'mesh'], 'size': [[1, 2, 3], [1e200, 1e200, 1]],
         'file': ['m.stl', '../m.stl', '/etc/passwd'], 'scale': [1.0, [1, 2, 3], 1e308],
         'decompose': [False, True],
         'radius': [0.5, 1e200, 1e-200], 'length': [1.0, 1e308], 'density': [100.0, 1e300],
         'position': [_V3, [1e308, -1e308, 0]], 'linear_velocity': [_V3],
         'orientation': [[0, 0, 0, 1], [1e200, 0, 0, 1e200], [0, 0, 0, 5e-324]],
         'angular_velocity': [_V3, [0, 0, 1e308]], 'linear_damping': [0.1, 1e308],
         'angular_damping': [0.0], 'static': [True, False], 'continuous': [True, False],
         'colliders': ['shape', []],
         'points': [{}, {'p': [0, 1e308, -1]}, {'left': [0.5, 0, 0], 'right': [-0.5, 0, 0]}],
         'type': ['sphere', 'box', 'capsule', 'plane', 'shape', 'mesh', 'hull'],
         'normal': [[0, 0, 1], [0, 1e200, 1e200], [0, 0, 5e-324]], 'offset': [0.5, -1e308],
         'restitution': [0.5, 1], 'friction': [0.3, 1e308]}


def _mostly(good):
    """Mostly ``good``, else anything (and ``good`` as what shrinking aims for)."""
    return st.integers(0, 9).flatmap(lambda k: good if k < 9 else _VALUES)


def _field(key):
    """Mostly a good value of ``key`` (a fresh copy: a shared one would be dumped as an
    alias)."""
    return _mostly(st.sampled_from(_GOOD[key]).map(copy.deepcopy))


_COLLIDER = st.fixed_dictionaries({'type': _field('type')}, optional={
    k: _field(k) for k in ('radius', 'length', 'size', 'normal', 'offset', 'position',
                           'orientation', 'restitution', 'friction')})
_COMMON = {k: _field(k) for k in (
    'position', 'orientation', 'linear_velocity', 'angular_velocity', 'linear_damping',
    'angular_damping', 'static')}
_COMMON['colliders'] = _field('colliders') | st.lists(_COLLIDER | _VALUES, max_size=3)
_SHAPE_DIMENSIONS = {'box': ('size',), 'sphere': ('radius',), 'cylinder': ('radius', 'length')}
# A body given by mass and inertia, one given by a shape (with the dimensions it needs), or
# any fields at all: mostly bodies that get as far as their last checks.
_BODY = st.one_of(
    st.fixed_dictionaries({k: _field(k) for k in ('name', 'mass', 'inertia')},
                          optional=_COMMON),
    st.sampled_from(sorted(_SHAPE_DIMENSIONS)).flatmap(lambda shape: st.fixed_dictionaries(
        {'name': _field('name'), 'shape': st.just(shape), 'density': _field('density'),
         **{k: _field(k) for k in _SHAPE_DIMENSIONS[shape]}}, optional=_COMMON)),
    st.fixed_dictionaries({'name': _field('name')}, optional={
        **{k: _field(k) for k in sorted(scene.BODY_KEYS - {'name'})}, **_COMMON}))
_CONTACT = st.dictionaries(
    st.integers(0, 9).flatmap(lambda k: st.sampled_from(
        sorted(ContactSettings.__dataclass_fields__)) if k < 9 else _KEYS),
    _mostly(st.sampled_from([0, 1, 0.5, 10, True, False])), max_size=3)


@given(gravity=_mostly(st.just([0.0, 0.0, -9.81])), contact=_mostly(_CONTACT),
       bodies=_mostly(st.lists(_mostly(_BODY), min_size=1, max_size=4)),
       top=_mostly(st.just({})), unicode=st.booleans(), flow=st.booleans())
@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_any_structure_gives_a_scene_or_a_scene_error(gravity, contact, bodies, top, unicode,
                                                      flow):
    data = {'gravity': gravity, 'contact': contact, 'bodies': bodies}
    if isinstance(top, dict):
        data.update(top)
    _load_text(yaml.safe_dump(data, allow_unicode=unicode, default_flow_style=flow))


def _mutate(data, draw):
    """``data`` with one random change somewhere: a value replaced, a key removed or added, a
    list item removed or duplicated; returns the path of keys and indices to the change."""
    path, node = [], data
    while isinstance(node, (dict, list)) and node and draw(st.integers(0, 3)) > 0:
        key = draw(st.sampled_from(sorted(node) if isinstance(node, dict)
                                   else range(len(node))))
        if not isinstance(node[key], (dict, list)) or not node[key]:
            break
        path.append(key)
        node = node[key]
    if isinstance(node, dict):
        action = draw(st.sampled_from(['replace', 'remove', 'add']))
        if action == 'add' or not node:
            node[draw(_KEYS)] = draw(_VALUES)
        else:
            key = draw(st.sampled_from(sorted(node)))
            path.append(key)
            if action == 'remove':
                del node[key]
            else:
                node[key] = draw(_VALUES)
    elif isinstance(node, list):
        i = draw(st.integers(0, len(node) - 1))
        path.append(i)
        action = draw(st.sampled_from(['replace', 'remove', 'duplicate']))
        if action == 'remove':
            del node[i]
        elif action == 'duplicate':
            node.insert(i, yaml.safe_load(yaml.safe_dump(node[i])))
        else:
            node[i] = draw(_VALUES)
    return path


@pytest.mark.parametrize('source', ['example.yaml', 'collisions.yaml'])
@given(data=st.data())
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_any_change_to_a_valid_scene_gives_a_scene_or_an_error_naming_the_body(source, data):
    scene_data = yaml.safe_load((SCENES / source).read_text())
    changes = data.draw(st.integers(1, 3))
    paths = [_mutate(scene_data, data.draw) for _ in range(changes)]
    result = _load_text(yaml.safe_dump(scene_data, default_flow_style=data.draw(st.booleans())))
    touched = {p[1] for p in paths if len(p) >= 2 and p[0] == 'bodies'}
    if isinstance(result, SceneError) and len(paths) == 1 and touched:
        (i,) = touched
        # A duplicated or removed body shifts the indices after it; else the body is named.
        if re.search(r'^bodies\b', str(result).split(': ', 1)[1]) is None:
            assert re.search(rf': body ({i}|{i + 1})\b', str(result)), (paths, str(result))


@given(st.text(max_size=200))
@settings(max_examples=300, deadline=None)
def test_any_text_gives_a_scene_or_a_scene_error(text):
    _load_text(text)


@given(st.binary(max_size=200))
@settings(max_examples=200, deadline=None)
def test_any_bytes_give_a_scene_or_a_scene_error(raw):
    _load_text(raw)


@given(st.text(max_size=80))
@settings(max_examples=300, deadline=None)
def test_a_name_is_accepted_only_when_ros_accepts_its_topics(name):
    validate = pytest.importorskip('rclpy.validate_full_topic_name').validate_full_topic_name
    result = _load_text(yaml.safe_dump({'bodies': [{'name': name, 'mass': 1,
                                                    'inertia': [1, 1, 1]}]}))
    ascii_token = re.fullmatch(r'[A-Za-z][A-Za-z0-9_]{0,63}', name) is not None
    assert isinstance(result, Scene) == ascii_token, result
    if ascii_token:
        for topic in ('wrench', 'wrench_stamped', 'set_pose', 'set_twist', 'pose', 'twist',
                      'odom', 'applied_wrench'):
            validate(f'/rb_sim/{name}/{topic}')
    else:
        assert ': name: ' in str(result), str(result)
