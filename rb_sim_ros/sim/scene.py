# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scene files: several bodies, gravity and damping, in YAML.

    gravity: [0.0, 0.0, -9.81]          # m/s^2, world frame; optional (default none)
    contact: {restitution: 0.3, friction: 0.6}   # optional; simulation.ContactSettings fields
                                        # (also velocity_iterations, position_iterations,
                                        #  slop, position_fraction, bounce_threshold,
                                        #  speculative, continuous_speed, sleep_time,
                                        #  sleep_speed, rolling_resistance,
                                        #  torsional_friction)
    bodies:
      - name: satellite                 # topics satellite/wrench, satellite/pose, ...
        mass: 120.0                     # kg, with inertia (kg m^2): 3 moments or a 3x3 tensor
        inertia: [[40, 0, 0], [0, 55, 1.5], [0, 1.5, 30]]
        angular_velocity: [0.0, 0.01, 0.2]
        points: {left_thruster: [0, 1, 0]}   # application points (m, body frame): a
                                        # wrench_stamped with frame_id left_thruster acts there
      - name: crate
        shape: box                      # or: density (kg/m^3) and a shape, from which both
        size: [0.4, 0.3, 0.2]           #   box: size (m, full edge lengths x y z)
        density: 500                    #   sphere: radius; cylinder: radius, length (along z)
        position: [2.0, 0.0, 1.0]       # m; orientation [x, y, z, w]; linear_velocity m/s;
        linear_damping: 0.1             # angular_velocity rad/s (world); damping rates 1/s
        colliders: shape                # collide as the box above (any of the three shapes);
                                        # [{type: shape, friction: 0.2}] gives it a material
      - name: dumbbell
        mass: 2.0
        inertia: [0.05, 0.05, 0.01]
        colliders:                      # shapes in the body frame (collision_shapes)
          - {type: capsule, radius: 0.03, length: 0.3}
          - {type: sphere, radius: 0.06, position: [0, 0, 0.18], restitution: 0.9}
          - {type: box, size: [0.1, 0.1, 0.1], position: [0, 0, -0.18],
             orientation: [0, 0, 0.3826834, 0.9238795]}
        continuous: true                # default: when fast, its speculative contacts are
                                        # swept along its path (contact: continuous_speed)
      - name: ground
        static: true                    # never moves, costs nothing, infinite mass
        colliders: [{type: plane, normal: [0, 0, 1], offset: 0}]   # the plane z = 0

    templates:                          # optional: bodies to spawn by name at run time
      drone: {mass: 1.5, inertia: [0.02, 0.02, 0.04], position: [0, 0, 1]}

A template is a body entry without a name (its key is the name a spawn gets by default);
simulation_interfaces' SpawnEntity takes one by name, or a body entry as YAML text
(``body_entry``).

A scene in which no moving body has colliders runs no collision code. Every error names the
file, the body and the field; unknown keys are errors, not ignored.

A scene file is untrusted input: whatever it holds, ``load_scene`` returns a valid Scene or
raises SceneError (a ValueError) naming the file, the body and the field, and nothing else.
The YAML is read by ``safe_yaml`` (no aliases, no duplicate or non-string keys, no types but
null, booleans, numbers and strings, at most ``MAX_DEPTH`` levels and ``MAX_VALUES`` values),
from at most ``MAX_BYTES`` of UTF-8, with at most ``MAX_BODIES`` bodies. A float may be written
``1e-3`` (YAML 1.2) as well as ``1.0e-3``. Numbers are ints or floats (a boolean is not a
number) that fit a finite float. A body name becomes a ROS topic name token and a frame id:
an ASCII letter, then ASCII letters, digits and underscores, at most ``MAX_NAME`` in all.
"""

from __future__ import annotations

from dataclasses import replace
import math
from pathlib import Path
import re
import reprlib
import sys
from typing import Any, NamedTuple, NoReturn
import xml.etree.ElementTree as ElementTree

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.colliders import MAX_COLLIDERS
from rb_sim_ros.contact.collision_shapes import shape_from_dict
from rb_sim_ros.contact.settings import MAX_ITERATIONS
from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import RigidBody
from rb_sim_ros.sim import meshes, mjcf, safe_yaml, urdf
from rb_sim_ros.sim.simulation import BodySpec, ContactSettings, MAX_BODIES

TOP_KEYS = {'gravity', 'contact', 'bodies', 'integrator', 'templates'}
BODY_KEYS = {'name', 'mass', 'inertia', 'shape', 'size', 'radius', 'length', 'density',
             'file', 'scale', 'decompose', 'position', 'orientation', 'linear_velocity',
             'angular_velocity', 'linear_damping', 'angular_damping', 'static', 'colliders',
             'points', 'continuous'}
SHAPES = {'box': {'size'}, 'sphere': {'radius'}, 'cylinder': {'radius', 'length'}}
# a body's own shape from a mesh file: its parts' hulls (sim/meshes.py)
MESH = 'mesh'
MESH_KEYS = {'file', 'scale', 'decompose'}
# a terrain's triangles given inline (vertices, triangles) or read from a mesh file (file, scale)
TERRAIN = shapes.terrain.NAME
# a kind of shapes.KINDS, 'shape': the body's own shape (its size, mass and inertia), or
# 'mesh': the hulls of the parts of a mesh file
COLLIDER_TYPES = tuple(sorted(shapes.NAMES + ('shape', MESH)))

MAX_BYTES = 16 * 1024 * 1024
MAX_DEPTH = 8  # the scene's own structure needs 6 (bodies, a body, colliders, one, position)
MAX_VALUES = 2_000_000  # about 100 values per body at MAX_BODIES; some 100 MB as Python objects
MAX_NAME = 64
MAX_POINTS = 64
MAX_TEMPLATES = 1000
# A body entry given as text (a spawn's resource string) is a few hundred bytes.
MAX_ENTRY_BYTES = 64 * 1024
# A ROS 2 topic name token (rcl/rmw: alphanumerics and '_', not starting with a digit),
# and further: ASCII only, starting with a letter.
NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]*\Z')
# MAX_ITERATIONS (bodies): the bound of the contact solver's iteration counts (each one costs
# a pass over contacts), a recording's as a scene file's.
# The smallest mass or principal moment: the smallest normal float, whose inverse is finite.
TINY = sys.float_info.min

_VECTORS = (('position', 'initial_position', 3), ('orientation', 'initial_orientation_xyzw', 4),
            ('linear_velocity', 'initial_linear_velocity', 3),
            ('angular_velocity', 'initial_angular_velocity', 3))
_SHOW = reprlib.Repr()
_SHOW.maxlevel, _SHOW.maxlist, _SHOW.maxdict = 3, 6, 4
_SHOW.maxstring, _SHOW.maxlong, _SHOW.maxother = 40, 40, 40


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file, body and field."""


class Scene(NamedTuple):
    """What a scene file holds: gravity (m/s^2, world), the bodies, the contact settings,
    the integrator it asks for (a name of multistep.METHODS; None: the node's) and the
    templates of bodies to spawn (each a BodySpec named after its key)."""

    gravity: tuple[float, float, float]
    bodies: tuple[BodySpec, ...]
    contact: ContactSettings
    integrator: str | None = None
    templates: tuple[BodySpec, ...] = ()


def _show(value: Any) -> str:
    """A short repr of ``value`` for a message, whatever it is."""
    return _SHOW.repr(value)


def _key(key: Any) -> str:
    """A key of the file as a message shows it: as it is when it is a plain name."""
    if isinstance(key, int):
        return f'[{key}]'
    key = str(key)
    return key if len(key) <= 40 and re.fullmatch(r'\w+', key, re.ASCII) else _show(key)


def _fail(where: str, field: str, why: str) -> NoReturn:
    raise SceneError(f'{where}: {field}: {why}')


def _number(where: str, field: str, value: Any, low: float = -math.inf,
            strict: bool = False, unit: str = '') -> float:
    """``value`` as a finite float >= ``low`` (> with ``strict``); SceneError otherwise. Only
    an int or a float is a number (not a bool, not a string)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(where, field, f'must be a number{unit}, got {_show(value)}')
    try:
        number = float(value)
    except OverflowError:
        _fail(where, field, f'must be a finite number{unit}, got an integer of '
              f'{len(str(abs(value)))} digits')
    if not math.isfinite(number):
        _fail(where, field, f'must be a finite number{unit}, got {number!r}')
    if number < low or (strict and number == low):
        _fail(where, field, f'must be a finite number {">" if strict else ">="} {low:.3g}{unit}, '
              f'got {_show(value)}')
    return number


def _vector(where: str, field: str, value: Any, size: int, unit: str = '') -> tuple:
    if not isinstance(value, list) or len(value) != size:
        _fail(where, field, f'must be a list of {size} numbers{unit}, got {_show(value)}')
    return tuple(_number(where, f'{field}[{i}]', v, unit=unit) for i, v in enumerate(value))


def mass_and_inertia(shape: str, density: float, dims: dict) -> tuple[float, tuple]:
    """Mass (kg) and principal moments (kg m^2) of a uniform solid about its centre."""
    if shape == 'box':
        x, y, z = dims['size']
        m = density * x * y * z
        return m, (m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12)
    if shape == 'sphere':
        r = dims['radius']
        m = density * 4.0 / 3.0 * math.pi * r ** 3
        return m, (0.4 * m * r * r,) * 3
    r, h = dims['radius'], dims['length']
    m = density * math.pi * r * r * h
    side = m * (3 * r * r + h * h) / 12
    return m, (side, side, 0.5 * m * r * r)


def _name(where: str, data: dict) -> str:
    if 'name' not in data:
        _fail(where, 'name', 'missing')
    name = data['name']
    if not isinstance(name, str) or len(name) > MAX_NAME or not NAME.match(name):
        _fail(where, 'name', 'must be a ROS name token (it names the topics and the frame): an '
              'ASCII letter, then ASCII letters, digits or underscores, at most '
              f'{MAX_NAME} characters; got {_show(name)}')
    return name


def _shape_mass(where: str, data: dict, shape: Any) -> tuple[float, tuple, dict]:
    """Mass, principal moments and dimensions of a body given by a shape and a density."""
    if not isinstance(shape, str) or shape not in SHAPES:
        _fail(where, 'shape', f'must be one of {sorted(SHAPES)}, got {_show(shape)}')
    for key in ('mass', 'inertia'):
        if key in data:
            _fail(where, key, 'give either mass and inertia or a shape with a density, not both')
    dims: dict[str, Any] = {}
    for key in sorted(SHAPES[shape]):
        if key not in data:
            _fail(where, key, f'missing (a {shape} needs it)')
        if key == 'size':
            size = data['size']
            if not isinstance(size, list) or len(size) != 3:
                _fail(where, 'size', f'must be 3 edge lengths (m), got {_show(size)}')
            dims['size'] = [_number(where, f'size[{i}]', v, 0.0, True, ' (m)')
                            for i, v in enumerate(size)]
        else:
            dims[key] = _number(where, key, data[key], 0.0, True, ' (m)')
    for key in sorted({'size', 'radius', 'length'} - SHAPES[shape]):
        if key in data:
            _fail(where, key, f'a {shape} has no {key}')
    if 'density' not in data:
        _fail(where, 'density', 'missing (kg/m^3, needed with a shape)')
    density = _number(where, 'density', data['density'], 0.0, True, ' (kg/m^3)')
    try:
        mass, moments = mass_and_inertia(shape, density, dims)
    except OverflowError:  # r ** 3 raises where a product would give inf
        mass, moments = math.inf, (math.inf,) * 3
    if not all(math.isfinite(v) and v >= TINY for v in (mass, *moments)):
        _fail(where, 'shape', f'this {shape} and density give mass {mass!r} kg and moments '
              f'{list(moments)} kg m^2, which must be finite and > 0, and at least {TINY:.3g} '
              '(their inverses must be finite floats)')
    return mass, moments, dims


def _inertia(where: str, value: Any) -> tuple:
    """3 moments, 9 components or 3 rows of 3, as a flat tuple of floats."""
    unit = ' (kg m^2)'
    if isinstance(value, list) and len(value) == 3 and any(isinstance(r, list) for r in value):
        out: list[float] = []
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != 3:
                _fail(where, 'inertia', f'row {i} must be a list of 3 numbers, got {_show(row)}')
            out.extend(_number(where, f'inertia[{i}][{j}]', v, unit=unit)
                       for j, v in enumerate(row))
        return tuple(out)
    if not isinstance(value, list) or len(value) not in (3, 9):
        _fail(where, 'inertia', 'must be 3 principal moments, 9 components or 3 rows of 3 '
              f'(kg m^2), got {_show(value)}')
    return tuple(_number(where, f'inertia[{i}]', v, unit=unit) for i, v in enumerate(value))


def _plainly_valid(inertia: tuple) -> bool:
    """True for 3 principal moments > 0 that obey the triangle inequality with room to spare
    (the common case, checked without numpy); False means: ask RigidBody."""
    if len(inertia) != 3:
        return False
    a, b, c = sorted(inertia)
    return 1e-300 < a and a + b > c and c < 1e300


def _body(path: str, index: int, data: Any, where: str = '') -> BodySpec:
    where = where or f'{path}: body {index}'
    if not isinstance(data, dict):
        raise SceneError(f'{where}: must be a mapping of fields, got {_show(data)}')
    if isinstance(data.get('name'), str):
        where += f' ({_show(data["name"])})'
    unknown = sorted(set(data) - BODY_KEYS)
    if unknown:
        raise SceneError(f'{where}: unknown field(s) {_show(unknown)} (known: '
                         f'{sorted(BODY_KEYS)})')
    kwargs: dict[str, Any] = {'name': _name(where, data)}
    static = data.get('static', False)
    if not isinstance(static, bool):
        _fail(where, 'static', f'must be true or false, got {_show(static)}')
    kwargs['static'] = static
    continuous = data.get('continuous', True)
    if not isinstance(continuous, bool):
        _fail(where, 'continuous', f'must be true or false, got {_show(continuous)}')
    kwargs['continuous'] = continuous
    shape = data.get('shape')
    dims: dict[str, Any] = {}
    roots = _roots(path)
    if shape == MESH:
        kwargs['mass'], kwargs['inertia'], dims = _mesh_mass(where, data, roots)
        field = 'shape'
    elif 'shape' in data:
        for key in sorted(MESH_KEYS & set(data)):
            _fail(where, key, f'only with shape: {MESH}')
        kwargs['mass'], kwargs['inertia'], dims = _shape_mass(where, data, shape)
        field = 'shape'
    else:
        for key in ('size', 'radius', 'length', 'density', *sorted(MESH_KEYS)):
            if key in data:
                _fail(where, key, 'only with a shape')
        if not static:
            for key in ('mass', 'inertia'):
                if key not in data:
                    _fail(where, key, 'missing (or give a shape and density)')
        if 'mass' in data:
            kwargs['mass'] = _number(where, 'mass', data['mass'], TINY, unit=' (kg)')
        if 'inertia' in data:
            kwargs['inertia'] = _inertia(where, data['inertia'])
        field = 'inertia'
    inertia = kwargs.get('inertia', BodySpec.inertia)
    if not _plainly_valid(inertia):
        try:  # what numbers alone cannot say: positive definite, the triangle inequality
            body = RigidBody(kwargs.get('mass', BodySpec.mass), inertia if len(inertia) == 3
                             else [inertia[0:3], inertia[3:6], inertia[6:9]])
        except ValueError as e:
            _fail(where, field, str(e))
        if min(body.principal_moments) < TINY:
            _fail(where, field, f'principal moments {body.principal_moments.tolist()} kg m^2: '
                  f'each must be at least {TINY:.3g} (its inverse must be a finite float)')
    for key, spec_field, size in _VECTORS:
        if key in data:
            kwargs[spec_field] = _vector(where, key, data[key], size)
    if 'orientation' in data and not any(kwargs['initial_orientation_xyzw']):
        _fail(where, 'orientation', 'must be a non-zero quaternion [x, y, z, w] (of any '
              'length), got [0, 0, 0, 0]')
    for key in ('linear_damping', 'angular_damping'):
        if key in data:
            kwargs[key] = _number(where, key, data[key], 0.0, unit=' (1/s)')
    kwargs['colliders'] = _colliders(where, data.get('colliders', []), shape, dims, static,
                                     roots)
    kwargs['points'] = _points(where, data.get('points', {}), kwargs['name'])
    try:
        return BodySpec(**kwargs)
    except (ValueError, TypeError, ArithmeticError) as e:  # all checked above: never expected
        raise SceneError(f'{where}: {e}') from None


def _points(where: str, points: Any, body: str) -> tuple:
    """points: {name: [x, y, z]} (m, body frame): the body's named application points."""
    if not isinstance(points, dict):
        _fail(where, 'points', f'must be a mapping of names to [x, y, z] (m, body frame), got '
              f'{_show(points)}')
    if len(points) > MAX_POINTS:
        _fail(where, 'points', f'{len(points)} points, more than MAX_POINTS = {MAX_POINTS}')
    out = []
    for name, at in points.items():
        if not NAME.match(name) or len(name) > MAX_NAME or name in (body, 'world', 'body'):
            _fail(where, f'points.{_key(name)}', 'a point name must be an ASCII letter, then '
                  f'ASCII letters, digits and underscores, at most {MAX_NAME}, and not the '
                  "name of its body, 'world' or 'body' (it names a frame)")
        out.append((name, _vector(where, f'points.{name}', at, 3)))
    return tuple(out)


def _roots(path: str) -> tuple[Path, ...]:
    """The folders a scene file's mesh files are read from: its own (none for a body given
    as text)."""
    try:
        file = Path(path)
        return (file.resolve().parent,) if file.is_file() else ()
    except (OSError, ValueError):
        return ()


def _mesh_mass(where: str, data: dict, roots) -> tuple[float, tuple, dict]:
    """Mass, inertia (about the centre of mass, 9 components) and the hulls (placed about the
    centre of mass, which is the body's origin) of a body of ``shape: mesh``: its file's parts
    of uniform density."""
    for key in ('mass', 'inertia'):
        if key in data:
            _fail(where, key, 'give either mass and inertia or a shape with a density, not both')
    for key in ('size', 'radius', 'length'):
        if key in data:
            _fail(where, key, f'a {MESH} has no {key} (it has file and scale)')
    if 'file' not in data:
        _fail(where, 'file', f'missing (a {MESH} is read from a mesh file)')
    if 'density' not in data:
        _fail(where, 'density', 'missing (kg/m^3, needed with a shape)')
    density = _number(where, 'density', data['density'], 0.0, True, ' (kg/m^3)')
    try:
        parts = meshes.mesh_parts(data['file'], roots, data.get('scale', 1.0),
                                  data.get('decompose', False))
        hulls = meshes.hulls(parts, str(data['file']))
        mass, centre, inertia = meshes.combined_mass(hulls, density)
        if not (math.isfinite(mass) and mass >= TINY and np.all(np.isfinite(inertia))):
            _fail(where, 'shape', f'this {MESH} and density give mass {mass!r} kg: it must be '
                  f'finite and at least {TINY:.3g}')
        # about the centre of mass, the body's origin
        placed = [replace(h, points=h.vertices - centre) for h in hulls]
    except (ValueError, TypeError, ArithmeticError) as e:
        if isinstance(e, SceneError):
            raise
        _fail(where, 'file', str(e))
    return mass, tuple(float(v) for v in inertia.ravel()), {'hulls': placed}


def _own_shape(shape: Any, dims: dict, material: dict) -> list:
    """The body's own box, sphere or cylinder as a collider, or its mesh's hulls, with
    ``material`` (restitution, friction)."""
    if shape == MESH:
        return [replace(h, **material) for h in dims['hulls']]
    if shape in SHAPES:  # each of SHAPES is a kind of collider with the same fields
        return [shapes.BY_NAME[shape].VALUE(**dims, **material)]
    raise ValueError(f"'shape' needs a body shape ({', '.join(sorted([*SHAPES, MESH]))}), "
                     f'got {_show(shape)} (list the colliders instead)')


def _mesh_colliders(data: dict, roots) -> list:
    """The hulls of a ``{type: mesh, file, scale, position, orientation, restitution,
    friction}`` collider: one for each part of its file."""
    allowed = {'type', 'file', 'scale', 'decompose', 'position', 'orientation', 'restitution',
               'friction'}
    unknown = sorted(str(k) for k in set(data) - allowed)
    if unknown:
        raise ValueError(f'{MESH}: unknown keys {_show(unknown)} (allowed: {sorted(allowed)})')
    if 'file' not in data:
        raise ValueError(f'{MESH}: file missing (a mesh file, relative to the scene file)')
    placement = {key: data[key] for key in ('position', 'restitution', 'friction')
                 if key in data}
    if 'orientation' in data:
        placement['orientation_xyzw'] = data['orientation']
    parts = meshes.mesh_parts(data['file'], roots, data.get('scale', 1.0),
                              data.get('decompose', False))
    return meshes.hulls(parts, str(data['file']), **placement)


def _terrain_from_file(data: dict, roots) -> Any:
    """The terrain of a ``{type: terrain, file, scale, position, orientation, restitution,
    friction}`` collider: its mesh file's whole surface."""
    allowed = {'type', 'file', 'scale', 'position', 'orientation', 'restitution', 'friction'}
    unknown = sorted(str(k) for k in set(data) - allowed)
    if unknown:
        raise ValueError(f'{TERRAIN} from a file: unknown keys {_show(unknown)} (allowed: '
                         f'{sorted(allowed)})')
    vertices, triangles = meshes.mesh_surface(data['file'], roots, data.get('scale', 1.0))
    given = {k: v for k, v in data.items() if k not in ('file', 'scale')}
    try:
        return shape_from_dict({**given, 'vertices': vertices, 'triangles': triangles})
    except ValueError as e:
        raise ValueError(f"{_show(data['file'])}: {e}") from None


def _colliders(where: str, colliders: Any, shape: Any, dims: dict, static: bool,
               roots=()) -> tuple:
    """The collision shapes of a body: a list of collision_shapes mappings (or of ``{type:
    mesh, file: ...}``, the hulls of a mesh file's parts), or 'shape' for the body's own shape
    (in a list: ``{type: shape, restitution: ..., friction: ...}``)."""
    if isinstance(colliders, str) and colliders == 'shape':
        try:
            return tuple(_own_shape(shape, dims, {}))
        except ValueError as e:
            _fail(where, 'colliders', str(e))
    if not isinstance(colliders, list):
        _fail(where, 'colliders', f"must be a list of shapes or 'shape', got {_show(colliders)}")
    if len(colliders) > MAX_COLLIDERS:
        _fail(where, 'colliders', f'{len(colliders)} colliders, more than MAX_COLLIDERS = '
              f'{MAX_COLLIDERS} on one body')
    out = []
    for i, c in enumerate(colliders):
        field = f'colliders[{i}]'
        if not isinstance(c, dict):
            _fail(where, field, f'must be a mapping with a type, got {_show(c)}')
        kind = c.get('type')
        if not isinstance(kind, str) or kind not in COLLIDER_TYPES:
            _fail(where, field, f'type must be one of {list(COLLIDER_TYPES)}, got {_show(kind)}')
        try:
            if kind == 'shape':
                unknown = sorted(set(c) - {'type', 'restitution', 'friction'})
                if unknown:
                    raise ValueError(f'shape: unknown keys {_show(unknown)} (allowed: friction, '
                                     'restitution, type)')
                out.extend(_own_shape(shape, dims, {k: v for k, v in c.items() if k != 'type'}))
            elif kind == MESH:
                out.extend(_mesh_colliders(c, roots))
            elif kind == TERRAIN and 'file' in c:
                out.append(_terrain_from_file(c, roots))
            else:
                out.append(shape_from_dict(c))
        except (ValueError, TypeError, ArithmeticError) as e:
            _fail(where, field, str(e))
        if len(out) > MAX_COLLIDERS:
            _fail(where, field, f'{len(out)} colliders with its parts, more than MAX_COLLIDERS '
                  f'= {MAX_COLLIDERS} on one body')
        if shapes.module_of(out[-1]).STATIC_ONLY and not static:
            _fail(where, field, f'a {out[-1].kind} is only allowed on a static body '
                  '(static: true)')
    return tuple(out)


def _contact(path: str, data: Any) -> ContactSettings:
    where = f'{path}: contact'
    if not isinstance(data, dict):
        raise SceneError(f'{where}: must be a mapping, got {_show(data)}')
    fields = ContactSettings.__dataclass_fields__
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise SceneError(f'{where}: unknown contact keys {_show(unknown)} (known: '
                         f'{sorted(fields)})')
    values: dict[str, Any] = {}
    for key, value in data.items():
        default = getattr(ContactSettings, key)
        if isinstance(default, bool):
            if not isinstance(value, bool):
                _fail(where, key, f'must be true or false, got {_show(value)}')
            values[key] = value
        elif isinstance(default, int):
            if (isinstance(value, bool) or not isinstance(value, int)
                    or not 0 <= value <= MAX_ITERATIONS):
                _fail(where, key, f'must be an integer in [0, {MAX_ITERATIONS}], '
                      f'got {_show(value)}')
            values[key] = value
        elif key == 'continuous_speed' and value == math.inf:  # .inf: no body swept
            values[key] = value
        else:
            values[key] = _number(where, key, value)
    try:
        return ContactSettings(**values)
    except (ValueError, TypeError, ArithmeticError) as e:
        raise SceneError(f'{where}: {e}') from None


def _read(path: str) -> str:
    """The text of the file: at most MAX_BYTES of UTF-8."""
    try:
        with open(path, 'rb') as f:
            chunks, size = [], 0
            while size <= MAX_BYTES:  # in pieces: read(MAX_BYTES + 1) would allocate it all
                chunk = f.read(min(1 << 20, MAX_BYTES + 1 - size))
                if not chunk:
                    break
                chunks.append(chunk)
                size += len(chunk)
            raw = b''.join(chunks)
    except OSError as e:
        raise SceneError(f'{path}: cannot read: {e.strerror or e}') from None
    if len(raw) > MAX_BYTES:
        raise SceneError(f'{path}: larger than {MAX_BYTES} bytes (MAX_BYTES): not a scene')
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError as e:
        line = raw.count(b'\n', 0, e.start) + 1
        raise SceneError(f'{path}: not UTF-8 text: byte 0x{raw[e.start]:02x} at offset '
                         f'{e.start} (line {line})') from None
    return text[1:] if text.startswith('\ufeff') else text


def _yaml_error(path: str, e: safe_yaml.YamlError) -> SceneError:
    """The YAML refusal ``e`` as a SceneError naming the file, the body and the field."""
    where, keys = path, list(e.path)
    if len(keys) >= 2 and keys[0] == 'bodies' and isinstance(keys[1], int):
        where, keys = f'{path}: body {keys[1]}', keys[2:]
    return _yaml_refusal(where, keys, e)


def _yaml_refusal(where: str, keys: list, e: safe_yaml.YamlError) -> SceneError:
    """``where: field.path: reason (line n)`` of the YAML refusal ``e`` at ``keys``."""
    field = ''.join((_key(k) if isinstance(k, int) or i == 0 else '.' + _key(k))
                    for i, k in enumerate(keys))
    line = f' (line {e.line})' if e.line else ''
    return SceneError(f'{where}: {field + ": " if field else ""}{e.reason}{line}')


# What a scene file whose name ends so is read as: MJCF (``mjcf.load_mjcf``), URDF
# (``urdf.load_urdf``); else YAML.
MJCF_SUFFIXES = ('.xml', '.mjcf')
URDF_SUFFIXES = ('.urdf',)


def load_scene(path: str) -> Scene:
    """The scene of the file ``path`` (YAML; MJCF for a name ending in ``.xml`` or
    ``.mjcf``, URDF for ``.urdf``); SceneError says what and where."""
    lower = str(path).lower()
    if lower.endswith(MJCF_SUFFIXES + URDF_SUFFIXES):
        load = mjcf.load_mjcf if lower.endswith(MJCF_SUFFIXES) else urdf.load_urdf
        try:
            gravity, bodies = load(str(path), MAX_BYTES, MAX_BODIES)
        except mjcf.ModelError as e:
            raise SceneError(str(e)) from None
        return Scene(gravity, bodies, ContactSettings())
    return scene_from_data(read_scene_data(path), path)


def read_scene_data(path: str) -> Any:
    """The YAML of the scene file ``path``, read within the limits, not yet checked."""
    text = _read(path)
    try:
        return safe_yaml.load(text, max_depth=MAX_DEPTH, max_nodes=MAX_VALUES)
    except safe_yaml.YamlError as e:
        raise _yaml_error(path, e) from None


def scene_from_data(data: Any, path: str) -> Scene:
    """The scene of ``data`` (what ``read_scene_data`` gives, perhaps changed), checked as a
    file's; ``path`` names it in errors."""
    if not isinstance(data, dict):
        raise SceneError(
            f'{path}: must be a mapping with a bodies list, got {type(data).__name__}')
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise SceneError(f'{path}: unknown key(s) {_show(unknown)} (known: {sorted(TOP_KEYS)})')
    gravity = _vector(path, 'gravity', data.get('gravity', [0.0, 0.0, 0.0]), 3, ' (m/s^2)')
    bodies = data.get('bodies')
    if not isinstance(bodies, list) or not bodies:
        raise SceneError(f'{path}: bodies: must be a non-empty list, got {_show(bodies)}')
    if len(bodies) > MAX_BODIES:
        raise SceneError(f'{path}: bodies: {len(bodies)} bodies, more than MAX_BODIES = '
                         f'{MAX_BODIES}')
    contact = _contact(path, data.get('contact', {}))
    integrator = data.get('integrator')
    if integrator is not None and (not isinstance(integrator, str)
                                   or integrator not in multistep.METHODS):
        raise SceneError(f'{path}: integrator: must be one of {sorted(multistep.METHODS)}, got '
                         f'{_show(integrator)}')
    templates = _templates(path, data.get('templates', {}))
    specs = []
    first: dict[str, int] = {}
    for i, b in enumerate(bodies):
        spec = _body(path, i, b)
        if first.setdefault(spec.name, i) != i:
            raise SceneError(f"{path}: body {i} ('{spec.name}'): name: used twice (body "
                             f'{first[spec.name]} has it too)')
        specs.append(spec)
    return Scene(gravity, tuple(specs), contact, integrator, templates)


def _templates(path: str, data: Any) -> tuple[BodySpec, ...]:
    """templates: {name: body entry without a name}."""
    if not isinstance(data, dict):
        raise SceneError(f'{path}: templates: must be a mapping of names to body entries, got '
                         f'{_show(data)}')
    if len(data) > MAX_TEMPLATES:
        raise SceneError(f'{path}: templates: {len(data)}, more than MAX_TEMPLATES = '
                         f'{MAX_TEMPLATES}')
    out = []
    for name, entry in data.items():
        where = f'{path}: template {_key(name)}'
        if not isinstance(entry, dict):
            raise SceneError(f'{where}: must be a mapping of fields, got {_show(entry)}')
        if 'name' in entry:
            _fail(where, 'name', 'a template is named by its key; give no name field')
        out.append(_body(path, 0, {**entry, 'name': name}, where))
    return tuple(out)


def model_body(text: str, name: str = '', where: str = 'resource_string') -> BodySpec:
    """The one body of a URDF (``<robot>``) or MJCF (``<mujoco>``) model given as text, e.g.
    a spawn request's resource string (``body_entry`` sends XML here): read as the files are
    (``urdf``, ``mjcf``), but naming no other file; a non-empty ``name`` replaces the
    model's. SceneError naming ``where`` unless the model makes exactly one body."""
    try:
        tag = ElementTree.fromstring(text).tag
    except ElementTree.ParseError as e:
        raise SceneError(f'{where}: not XML: {e}') from None
    if tag not in ('robot', 'mujoco'):
        raise SceneError(f'{where}: XML that is neither a URDF (<robot>) nor an MJCF '
                         f'(<mujoco>) model: <{_show(tag)}>')
    load = urdf.bodies_from_text if tag == 'robot' else mjcf.bodies_from_text
    try:
        _, bodies = load(text, where, MAX_BODIES)
    except mjcf.ModelError as e:
        raise SceneError(str(e)) from None
    if len(bodies) != 1:
        raise SceneError(f'{where}: a spawn makes one body; this model makes {len(bodies)} '
                         f'({", ".join(b.name for b in bodies[:5])})')
    body, = bodies
    return replace(body, name=name) if name else body


def body_entry(text: Any, name: str = '', where: str = 'resource_string',
               default: str = '') -> BodySpec:
    """The body of a scene-file body entry given as YAML (or JSON) text, e.g. a spawn
    request's resource string: ``{name: probe, mass: 1, inertia: [0.1, 0.1, 0.1]}``. A
    non-empty ``name`` replaces the entry's (which may then be left out; ``default``, if
    given, names an entry that has none). SceneError, naming
    ``where`` and the field, for anything else: untrusted text, checked as a scene file."""
    if not isinstance(text, str):
        raise SceneError(f'{where}: must be text, got {type(text).__name__}')
    if len(text.encode('utf-8', 'surrogatepass')) > MAX_ENTRY_BYTES:
        raise SceneError(f'{where}: longer than {MAX_ENTRY_BYTES} bytes: not a body entry')
    if text.lstrip().startswith('<'):
        return model_body(text, name, where)
    try:
        data = safe_yaml.load(text, max_depth=MAX_DEPTH - 2, max_nodes=MAX_ENTRY_BYTES)
    except safe_yaml.YamlError as e:
        raise _yaml_refusal(where, list(e.path), e) from None
    if not isinstance(data, dict):
        raise SceneError(f'{where}: must be a body entry (a mapping of fields such as mass, '
                         f'inertia, position, colliders), got {_show(data)}')
    if name:
        data = {**data, 'name': name}
    elif default and 'name' not in data:
        data = {**data, 'name': default}
    return _body(where, 0, data, where)
