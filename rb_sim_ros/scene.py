# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scene files: several bodies, gravity and damping, in YAML.

    gravity: [0.0, 0.0, -9.81]          # m/s^2, world frame; optional (default none)
    contact: {restitution: 0.3, friction: 0.6}   # optional; simulation.ContactSettings fields
                                        # (also velocity_iterations, position_iterations,
                                        #  slop, position_fraction, bounce_threshold,
                                        #  speculative, sleep_time, sleep_speed,
                                        #  rolling_resistance, torsional_friction)
    bodies:
      - name: satellite                 # topics satellite/wrench, satellite/pose, ...
        mass: 120.0                     # kg, with inertia (kg m^2): 3 moments or a 3x3 tensor
        inertia: [[40, 0, 0], [0, 55, 1.5], [0, 1.5, 30]]
        angular_velocity: [0.0, 0.01, 0.2]
      - name: crate
        shape: box                      # or: density (kg/m^3) and a shape, from which both
        size: [0.4, 0.3, 0.2]           #   box: size (m, full edge lengths x y z)
        density: 500                    #   sphere: radius; cylinder: radius, length (along z)
        position: [2.0, 0.0, 1.0]       # m; orientation [x, y, z, w]; linear_velocity m/s;
        linear_damping: 0.1             # angular_velocity rad/s (world); damping rates 1/s
        colliders: shape                # collide as the box above (box or sphere shapes);
                                        # [{type: shape, friction: 0.2}] gives it a material
      - name: dumbbell
        mass: 2.0
        inertia: [0.05, 0.05, 0.01]
        colliders:                      # shapes in the body frame (collision_shapes)
          - {type: capsule, radius: 0.03, length: 0.3}
          - {type: sphere, radius: 0.06, position: [0, 0, 0.18], restitution: 0.9}
          - {type: box, size: [0.1, 0.1, 0.1], position: [0, 0, -0.18],
             orientation: [0, 0, 0.3826834, 0.9238795]}
      - name: ground
        static: true                    # never moves, costs nothing, infinite mass
        colliders: [{type: plane, normal: [0, 0, 1], offset: 0}]   # the plane z = 0

A scene in which no moving body has colliders runs no collision code. Every error names the
file, the body and the field; unknown keys are errors, not ignored.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import yaml

from rb_sim_ros.collision_shapes import Box, shape_from_dict, Sphere
from rb_sim_ros.simulation import BodySpec, ContactSettings

TOP_KEYS = {'gravity', 'contact', 'bodies'}
BODY_KEYS = {'name', 'mass', 'inertia', 'shape', 'size', 'radius', 'length', 'density',
             'position', 'orientation', 'linear_velocity', 'angular_velocity', 'linear_damping',
             'angular_damping', 'static', 'colliders'}
SHAPES = {'box': {'size'}, 'sphere': {'radius'}, 'cylinder': {'radius', 'length'}}


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file, body and field."""


class Scene(NamedTuple):
    """What a scene file holds: gravity (m/s^2, world), the bodies, the contact settings."""

    gravity: tuple[float, float, float]
    bodies: tuple[BodySpec, ...]
    contact: ContactSettings


def _positive(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0):
        raise SceneError(f'{where}: must be a finite number > 0, got {value!r}')
    return float(value)


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


def _body(path: str, index: int, data: Any) -> BodySpec:
    name = data.get('name') if isinstance(data, dict) else None
    where = f'{path}: body {index}' + (f" ('{name}')" if name else '')
    if not isinstance(data, dict):
        raise SceneError(f'{where}: must be a mapping of fields, got {data!r}')
    unknown = sorted(set(data) - BODY_KEYS)
    if unknown:
        raise SceneError(f'{where}: unknown field(s) {unknown} (known: {sorted(BODY_KEYS)})')
    if 'name' not in data:
        raise SceneError(f'{where}: name: missing')
    kwargs: dict[str, Any] = {'name': name}
    shape = data.get('shape')
    static = data.get('static', False)
    if shape is not None:
        if shape not in SHAPES:
            raise SceneError(f'{where}: shape: must be one of {sorted(SHAPES)}, got {shape!r}')
        for key in ('mass', 'inertia'):
            if key in data:
                raise SceneError(f'{where}: {key}: give either mass and inertia or a shape '
                                 'with a density, not both')
        dims = {}
        for key in sorted(SHAPES[shape]):
            if key not in data:
                raise SceneError(f'{where}: {key}: missing (a {shape} needs it)')
            if key == 'size':
                size = data['size']
                if not isinstance(size, list) or len(size) != 3:
                    raise SceneError(f'{where}: size: must be 3 edge lengths (m), got {size!r}')
                dims['size'] = [_positive(f'{where}: size', v) for v in size]
            else:
                dims[key] = _positive(f'{where}: {key}', data[key])
        for key in {'size', 'radius', 'length'} - SHAPES[shape]:
            if key in data:
                raise SceneError(f'{where}: {key}: a {shape} has no {key}')
        if 'density' not in data:
            raise SceneError(f'{where}: density: missing (kg/m^3, needed with a shape)')
        kwargs['mass'], kwargs['inertia'] = mass_and_inertia(
            shape, _positive(f'{where}: density', data['density']), dims)
    else:
        for key in ('size', 'radius', 'length', 'density'):
            if key in data:
                raise SceneError(f'{where}: {key}: only with a shape')
        if not static:
            for key in ('mass', 'inertia'):
                if key not in data:
                    raise SceneError(f'{where}: {key}: missing (or give a shape and density)')
        if 'mass' in data:
            kwargs['mass'] = _positive(f'{where}: mass', data['mass'])
        if 'inertia' in data:
            inertia = data['inertia']
            if isinstance(inertia, list) and inertia and isinstance(inertia[0], list):
                inertia = [c for row in inertia for c in (row if isinstance(row, list)
                                                          else [row])]
            if not isinstance(inertia, list):
                raise SceneError(f'{where}: inertia: must be 3 moments or a 3x3 list')
            kwargs['inertia'] = tuple(inertia)
    for key, field in (('position', 'initial_position'),
                       ('orientation', 'initial_orientation_xyzw'),
                       ('linear_velocity', 'initial_linear_velocity'),
                       ('angular_velocity', 'initial_angular_velocity')):
        if key in data:
            kwargs[field] = data[key]
    for key in ('linear_damping', 'angular_damping', 'static'):
        if key in data:
            kwargs[key] = data[key]
    kwargs['colliders'] = _colliders(where, data.get('colliders', []), shape, data)
    try:
        return BodySpec(**kwargs)
    except (ValueError, TypeError) as e:
        field = str(e).split(' ', 1)[0]
        raise SceneError(f'{where}: {field}: {e}') from None


def _own_shape(shape: Any, data: dict, material: dict):
    """The body's own box or sphere as a collider, with ``material`` (restitution, friction)."""
    if shape == 'box':
        return Box(tuple(float(v) for v in data['size']), **material)
    if shape == 'sphere':
        return Sphere(float(data['radius']), **material)
    raise ValueError(f"'shape' needs a box or sphere shape, got {shape!r} (list the "
                     'colliders instead)')


def _colliders(where: str, colliders: Any, shape: Any, data: dict) -> tuple:
    """The collision shapes of a body: a list of collision_shapes mappings, or 'shape' for the
    body's own box or sphere (in a list: ``{type: shape, restitution: ..., friction: ...}``)."""
    if colliders == 'shape':
        try:
            return (_own_shape(shape, data, {}),)
        except ValueError as e:
            raise SceneError(f'{where}: colliders: {e}') from None
    if not isinstance(colliders, list):
        raise SceneError(f"{where}: colliders: must be a list of shapes or 'shape', "
                         f'got {colliders!r}')
    out = []
    for i, c in enumerate(colliders):
        try:
            if isinstance(c, dict) and c.get('type') == 'shape':
                unknown = sorted(set(c) - {'type', 'restitution', 'friction'})
                if unknown:
                    raise ValueError(f'shape: unknown keys {unknown} (allowed: friction, '
                                     'restitution, type)')
                out.append(_own_shape(shape, data,
                                      {k: v for k, v in c.items() if k != 'type'}))
            else:
                out.append(shape_from_dict(c))
        except (ValueError, TypeError) as e:
            raise SceneError(f'{where}: colliders[{i}]: {e}') from None
    return tuple(out)


def load_scene(path: str) -> Scene:
    """The scene of the file ``path``; SceneError says what and where."""
    try:
        with open(path) as f:
            data = yaml.safe_load(f)
    except OSError as e:
        raise SceneError(f'{path}: cannot read: {e.strerror}') from None
    except yaml.YAMLError as e:
        raise SceneError(f'{path}: not valid YAML: {e}') from None
    if not isinstance(data, dict):
        raise SceneError(
            f'{path}: must be a mapping with a bodies list, got {type(data).__name__}')
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise SceneError(f'{path}: unknown key(s) {unknown} (known: {sorted(TOP_KEYS)})')
    gravity = data.get('gravity', [0.0, 0.0, 0.0])
    if (not isinstance(gravity, list) or len(gravity) != 3 or not all(
            isinstance(g, (int, float)) and not isinstance(g, bool) and math.isfinite(g)
            for g in gravity)):
        raise SceneError(f'{path}: gravity: must be 3 finite numbers (m/s^2), got {gravity!r}')
    bodies = data.get('bodies')
    if not isinstance(bodies, list) or not bodies:
        raise SceneError(f'{path}: bodies: must be a non-empty list')
    try:
        contact = ContactSettings.from_dict(data.get('contact', {}))
    except (ValueError, TypeError) as e:
        raise SceneError(f'{path}: contact: {e}') from None
    specs = tuple(_body(path, i, b) for i, b in enumerate(bodies))
    names = [s.name for s in specs]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise SceneError(f"{path}: body {i} ('{n}'): name: used twice")
    return Scene(tuple(float(g) for g in gravity), specs, contact)
