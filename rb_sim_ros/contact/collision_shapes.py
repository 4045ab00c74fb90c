# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Collision shapes: sphere, box, capsule on any body; infinite plane on static bodies only.

    Sphere(radius=0.1)
    Box(size=(0.4, 0.3, 0.2), position=(0.0, 0.0, 0.1))      # full edge lengths, like scene.py
    Capsule(radius=0.05, length=0.3)                            # cylinder part along local z
    Plane(normal=(0.0, 0.0, 1.0), offset=0.0)                   # the ground z = 0

A shape's ``position`` (m) and ``orientation_xyzw`` place its centre and axes in the frame of
the body that carries it (the body frame: origin at the centre of mass, R maps it to the
world); both are optional. So are ``restitution`` and ``friction``, the shape's material: a
contact between two shapes uses the larger restitution and the geometric mean of the
frictions (``combined_material``), a side without one the world's (the scene's ``contact``).
A plane is the set {p : normal . p = offset} in its body's frame (the world for
``CollisionWorld(planes=...)``); its solid side is normal . p < offset, so the normal points
into the free space. Values are immutable and validated once: a ValueError names
the field. Every length (a radius, a length, an edge, a coordinate of ``position``, a plane's
offset) is at most ``MAX_LENGTH`` in size, and a radius or an edge at least ``MIN_LENGTH``:
what the contact code derives from them (squared distances, support sums, bounding extents,
the inertia of a shape, products of four lengths in the box tests) then stays far inside the
floats, where 1e300 gave inf and every step failed. ``shape_from_dict`` reads the form a
scene file would use (``{'type': 'box', 'size': [...], 'position': [...], 'orientation':
[x, y, z, w]}``) and ``shape_to_dict`` writes it back, exactly (floats kept as they are).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import sys
from typing import Any, Union

import numpy as np

from rb_sim_ros.core import so3
from rb_sim_ros.core.rigid_body import finite_floats, is_number, scaled_to_one, short

IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)
ORIGIN = (0.0, 0.0, 0.0)
# The bounds of a shape's lengths (m): a million kilometres and a nanometre. A product of four
# of them (the narrow phase's largest) lies in [1e-36, 1e36], far from overflow and underflow,
# and a rounding step of the largest (1e-7 m at 1e9 m) is still below a contact's slop. No
# scene of bodies that touch needs more (the Earth is 1.3e7 m across).
MAX_LENGTH = 1e9
MIN_LENGTH = 1e-9


def _number(name: str, value: Any, unit: str = 'm') -> float:
    """A finite float from an int or a float (not a bool or a string); ValueError otherwise."""
    if not is_number(value):
        raise ValueError(f'{name} must be a number ({unit}), got {short(value)}')
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f'{name} must be a finite number ({unit}), got {short(value)}')
    return number


def _positive(name: str, value: Any, unit: str = 'm', allow_zero: bool = False) -> float:
    """A length in [MIN_LENGTH, MAX_LENGTH] (or 0 with ``allow_zero``)."""
    value = _number(name, value, unit)
    if allow_zero and value == 0.0:
        return value
    if not MIN_LENGTH <= value <= MAX_LENGTH:
        low = '0 or ' if allow_zero else ''
        raise ValueError(f'{name} must be {low}between MIN_LENGTH = {MIN_LENGTH:g} and '
                         f'MAX_LENGTH = {MAX_LENGTH:g} {unit}, got {value!r}')
    return value


def _coordinates(name: str, value: Any) -> tuple[float, ...]:
    """3 finite floats, each at most MAX_LENGTH in size (m)."""
    out = finite_floats(name, value, 3)
    if any(abs(c) > MAX_LENGTH for c in out):
        raise ValueError(f'{name} must be 3 coordinates of at most MAX_LENGTH = '
                         f'{MAX_LENGTH:g} m in size, got {list(out)}')
    return out


def _placement(shape) -> None:
    """Validate and store position/orientation; precompute the local rotation Q (shape axes
    in the body frame) and whether the placement is the identity."""
    position = _coordinates('position', shape.position)
    q = finite_floats('orientation_xyzw', shape.orientation_xyzw, 4)
    scaled = scaled_to_one(q)  # any length: 1e200 and 1e-200 neither overflow nor vanish
    if scaled is None:
        raise ValueError(f'orientation_xyzw must be a non-zero quaternion, got {list(q)}')
    rotation = so3.matrix_from_quaternion_xyzw(scaled)
    rotation.flags.writeable = False
    object.__setattr__(shape, 'position', position)
    object.__setattr__(shape, 'orientation_xyzw', q)
    object.__setattr__(shape, 'rotation', rotation)


def _material(shape) -> None:
    """Validate the optional restitution (in [0, 1]) and friction (>= 0) of a shape."""
    for name, high in (('restitution', 1.0), ('friction', math.inf)):
        value = getattr(shape, name)
        if value is None:
            continue
        try:
            number = float(value) if is_number(value) else math.nan
        except OverflowError:
            number = math.inf
        if not (math.isfinite(number) and 0.0 <= number <= high):
            bound = 'a number in [0, 1]' if high == 1.0 else 'a finite number >= 0'
            raise ValueError(f'{name} must be {bound}, got {short(value)}')
        object.__setattr__(shape, name, number)


def combined_material(restitution_a: np.ndarray, friction_a: np.ndarray,
                      restitution_b: np.ndarray, friction_b: np.ndarray):
    """(e, mu) of contacts between shapes of these materials: the larger restitution (a
    bouncy ball bounces on anything) and the geometric mean of the frictions (either side
    frictionless makes the contact frictionless), as Box2D combines them."""
    # The geometric mean never exceeds the larger; saying so keeps huge frictions, whose
    # product overflows, from becoming inf (and inf * 0 a nan in the friction cone).
    with np.errstate(over='ignore'):
        mean = np.sqrt(friction_a * friction_b)
    return (np.maximum(restitution_a, restitution_b),
            np.minimum(mean, np.maximum(friction_a, friction_b)))


@dataclass(frozen=True)
class Sphere:
    """A ball of ``radius`` (m) centred at ``position`` (m, body frame)."""

    radius: float
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = 'sphere'

    def __post_init__(self) -> None:
        object.__setattr__(self, 'radius', _positive('radius', self.radius))
        _placement(self)
        _material(self)

    @property
    def bounding_radius(self) -> float:
        """Radius (m) of the smallest ball about the shape's centre that holds it."""
        return self.radius


@dataclass(frozen=True)
class Box:
    """A box of full edge lengths ``size`` (m) along its local x, y, z axes, centred at
    ``position`` (m, body frame) with axes turned by ``orientation_xyzw``."""

    size: tuple[float, ...]
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = 'box'

    def __post_init__(self) -> None:
        size = finite_floats('size', self.size, 3)
        for i, s in enumerate(size):
            _positive(f'size[{i}]', s)
        object.__setattr__(self, 'size', size)
        _placement(self)
        _material(self)

    @property
    def half_extents(self) -> tuple[float, float, float]:
        """Half edge lengths (m)."""
        return (0.5 * self.size[0], 0.5 * self.size[1], 0.5 * self.size[2])

    @property
    def bounding_radius(self) -> float:
        return 0.5 * math.sqrt(sum(s * s for s in self.size))


@dataclass(frozen=True)
class Capsule:
    """The points within ``radius`` (m) of a segment of ``length`` (m) along the local z axis,
    centred at ``position`` (m, body frame); total length is length + 2 radius. ``length`` 0
    is a sphere."""

    radius: float
    length: float
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = 'capsule'

    def __post_init__(self) -> None:
        object.__setattr__(self, 'radius', _positive('radius', self.radius))
        object.__setattr__(self, 'length', _positive('length', self.length, allow_zero=True))
        _placement(self)
        _material(self)

    @property
    def half_length(self) -> float:
        return 0.5 * self.length

    @property
    def bounding_radius(self) -> float:
        return 0.5 * self.length + self.radius


# |n|^2 - 1 of a normal this module normalised is at most a few units in the last place.
UNIT_TOLERANCE = 8 * sys.float_info.epsilon


@dataclass(frozen=True)
class Plane:
    """The half-space normal . p <= offset (m) of its body's frame; ``normal`` (any non-zero
    length, stored normalised: scaled by a power of two first, exactly, so that no length
    overflows or underflows) points out of the solid. Only on static bodies."""

    normal: tuple[float, ...] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = 'plane'

    def __post_init__(self) -> None:
        scaled = scaled_to_one(finite_floats('normal', self.normal, 3))
        if scaled is None:
            raise ValueError('normal must be a non-zero vector, got [0.0, 0.0, 0.0]')
        n = [float(c) for c in scaled]
        squared = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
        if abs(squared - 1.0) > UNIT_TOLERANCE:  # else normalised already: kept as it is,
            # so that a normal written out and read back (a recording's config) is the same
            # bits (normalising twice is not exact for about a third of directions)
            norm = math.sqrt(squared)
            n = [n[0] / norm, n[1] / norm, n[2] / norm]
        object.__setattr__(self, 'normal', tuple(n))
        offset = _number('offset', self.offset)
        if abs(offset) > MAX_LENGTH:
            raise ValueError(f'offset must be at most MAX_LENGTH = {MAX_LENGTH:g} m in size, '
                             f'got {offset!r}')
        object.__setattr__(self, 'offset', offset)
        rotation = np.eye(3)
        rotation.flags.writeable = False
        object.__setattr__(self, 'rotation', rotation)
        _material(self)

    @property
    def position(self) -> tuple[float, float, float]:
        """The point of the plane nearest the body origin (m, body frame): offset * normal."""
        return tuple(self.offset * c for c in self.normal)

    @property
    def bounding_radius(self) -> float:
        return math.inf


Shape = Union[Sphere, Box, Capsule, Plane]
SHAPE_TYPES = (Sphere, Box, Capsule, Plane)
# Narrow-phase order of the kinds: a pair (a, b) is tested with rank(a) <= rank(b).
RANK = {'sphere': 0, 'capsule': 1, 'box': 2, 'plane': 3}


def is_shape(value: Any) -> bool:
    return isinstance(value, SHAPE_TYPES)


def world_pose(shape: Shape, body_position: np.ndarray,
               body_rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre (m), rotation of the shape's axes), world frame, for a body at ``body_position``
    with rotation ``body_rotation`` (body to world). For a plane the centre is a point of the
    plane and rotation @ normal is its world normal."""
    body_rotation = np.asarray(body_rotation, dtype=float)
    centre = np.asarray(body_position, dtype=float) + body_rotation @ np.array(shape.position)
    return centre, body_rotation @ shape.rotation


_FIELDS = {'sphere': ('radius',), 'box': ('size',), 'capsule': ('radius', 'length'),
           'plane': ('normal', 'offset')}
_CLASSES = {'sphere': Sphere, 'box': Box, 'capsule': Capsule, 'plane': Plane}


def shape_from_dict(data: dict[str, Any]) -> Shape:
    """A shape from ``{'type': 'sphere' | 'box' | 'capsule' | 'plane', <its fields>,
    'position': [m], 'orientation': [x, y, z, w]}``; unknown or missing keys are errors."""
    if not isinstance(data, dict):
        raise ValueError(f'a collider must be a mapping, got {short(data)}')
    kind = data.get('type')
    if not isinstance(kind, str) or kind not in _CLASSES:
        raise ValueError(f'type must be one of {sorted(_CLASSES)}, got {short(kind)}')
    allowed = set(_FIELDS[kind]) | {'type', 'restitution', 'friction'}
    if kind != 'plane':
        allowed |= {'position', 'orientation'}
    unknown = sorted(str(k) for k in set(data) - allowed)
    if unknown:
        raise ValueError(f'{kind}: unknown keys {short(unknown)} (allowed: {sorted(allowed)})')
    kwargs = {}
    for key in _FIELDS[kind]:
        if key not in data:
            if kind == 'plane':
                continue
            raise ValueError(f'{key} missing (a {kind} needs {list(_FIELDS[kind])})')
        kwargs[key] = data[key]
    if 'position' in data:
        kwargs['position'] = data['position']
    if 'orientation' in data:
        kwargs['orientation_xyzw'] = data['orientation']
    for key in ('restitution', 'friction'):
        if key in data:
            kwargs[key] = data[key]
    return _CLASSES[kind](**kwargs)


def shape_to_dict(shape: Shape) -> dict[str, Any]:
    """The JSON-able form read by ``shape_from_dict`` (placement only when not the identity)."""
    out: dict[str, Any] = {'type': shape.kind}
    for key in _FIELDS[shape.kind]:
        value = getattr(shape, key)
        out[key] = list(value) if isinstance(value, tuple) else value
    if shape.kind != 'plane':
        if shape.position != ORIGIN:
            out['position'] = list(shape.position)
        if shape.orientation_xyzw != IDENTITY_XYZW:
            out['orientation'] = list(shape.orientation_xyzw)
    for key in ('restitution', 'friction'):
        if getattr(shape, key) is not None:
            out[key] = getattr(shape, key)
    return out
