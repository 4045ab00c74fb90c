# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What every shape kind's module shares: the row its kernels read, the bounds of its lengths,
and the checks of a placement and a material.

A shape's row ``geom`` (float64[GEOM_WIDTH]) holds its sizes in the slots its kind uses:
(radius, half_length, hx, hy, hz); a plane's unit world normal in (hx, hy, hz) (NORMAL). What
a kind needs beyond its row (a hull's vertices and faces) it adds to the ``Pool`` of the shapes
packed with it, the one float64 array every kernel of theirs is handed, and keeps its offset in
its row. Its
kind's number (``KIND`` of its module, its index in ``shapes.KINDS``) is its rank in the
narrow phase: a pair is computed lower kind first.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rb_sim_ros.core import so3
from rb_sim_ros.core.rigid_body import finite_floats, is_number, scaled_to_one, short

GEOM_WIDTH = 5
# The most points of a kind's ``core_face`` (the cylinder's cap: its octagon and one more).
FACE_CAPACITY = 9
RADIUS, HALF_LENGTH, HX, HY, HZ = 0, 1, 2, 3, 4
NORMAL = HX


class Pool:
    """The data of variable size of shapes packed together (a collider set's), gathered as
    each kind's ``pack`` adds its part: ``add(values)`` gives the offset of its first value;
    ``array()`` all of it, the float64 array the kernels are handed (``pool``)."""

    def __init__(self) -> None:
        self._parts: list[np.ndarray] = []
        self.size = 0

    def add(self, values) -> int:
        part = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
        offset = self.size
        self._parts.append(part)
        self.size += part.size
        return offset

    def array(self) -> np.ndarray:
        if not self._parts:
            return np.zeros(0)
        return np.ascontiguousarray(np.concatenate(self._parts))


# What a kind's ``draw(shape)`` gives: its pieces (primitive, size, position, rotation), in its
# body's frame, of these primitives, which each drawing (ros.collision_markers,
# pictures.render) knows: 'sphere' (radius,); 'box' (its half extents); 'capsule' and
# 'cylinder' (radius, half length along the piece's z); 'plane' (): the plane z = 0 of the
# piece, the half-space below it solid (a patch in RViz, the ground grid in a picture);
# 'mesh' (vertices (V, 3), triangles (T, 3) of vertex indices, counter-clockwise from
# outside): a closed surface.
PRIMITIVES = ('sphere', 'box', 'capsule', 'cylinder', 'plane', 'mesh')

IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)
ORIGIN = (0.0, 0.0, 0.0)
# The bounds of a shape's lengths (m): a million kilometres and a nanometre. A product of four
# of them (the narrow phase's largest) lies in [1e-36, 1e36], far from overflow and underflow,
# and a rounding step of the largest (1e-7 m at 1e9 m) is still below a contact's slop. No
# scene of bodies that touch needs more (the Earth is 1.3e7 m across).
MAX_LENGTH = 1e9
MIN_LENGTH = 1e-9


def number(name: str, value: Any, unit: str = 'm') -> float:
    """A finite float from an int or a float (not a bool or a string); ValueError otherwise."""
    if not is_number(value):
        raise ValueError(f'{name} must be a number ({unit}), got {short(value)}')
    try:
        out = float(value)
    except OverflowError:
        out = math.inf
    if not math.isfinite(out):
        raise ValueError(f'{name} must be a finite number ({unit}), got {short(value)}')
    return out


def positive(name: str, value: Any, unit: str = 'm', allow_zero: bool = False) -> float:
    """A length in [MIN_LENGTH, MAX_LENGTH] (or 0 with ``allow_zero``)."""
    value = number(name, value, unit)
    if allow_zero and value == 0.0:
        return value
    if not MIN_LENGTH <= value <= MAX_LENGTH:
        low = '0 or ' if allow_zero else ''
        raise ValueError(f'{name} must be {low}between MIN_LENGTH = {MIN_LENGTH:g} and '
                         f'MAX_LENGTH = {MAX_LENGTH:g} {unit}, got {value!r}')
    return value


def coordinates(name: str, value: Any) -> tuple[float, ...]:
    """3 finite floats, each at most MAX_LENGTH in size (m)."""
    out = finite_floats(name, value, 3)
    if any(abs(c) > MAX_LENGTH for c in out):
        raise ValueError(f'{name} must be 3 coordinates of at most MAX_LENGTH = '
                         f'{MAX_LENGTH:g} m in size, got {list(out)}')
    return out


def placement(shape) -> None:
    """Validate and store position/orientation; precompute the local rotation Q (shape axes
    in the body frame)."""
    position = coordinates('position', shape.position)
    q = finite_floats('orientation_xyzw', shape.orientation_xyzw, 4)
    scaled = scaled_to_one(q)  # any length: 1e200 and 1e-200 neither overflow nor vanish
    if scaled is None:
        raise ValueError(f'orientation_xyzw must be a non-zero quaternion, got {list(q)}')
    rotation = so3.matrix_from_quaternion_xyzw(scaled)
    rotation.flags.writeable = False
    object.__setattr__(shape, 'position', position)
    object.__setattr__(shape, 'orientation_xyzw', q)
    object.__setattr__(shape, 'rotation', rotation)


def material(shape) -> None:
    """Validate the optional restitution (in [0, 1]) and friction (>= 0) of a shape."""
    for name, high in (('restitution', 1.0), ('friction', math.inf)):
        value = getattr(shape, name)
        if value is None:
            continue
        try:
            out = float(value) if is_number(value) else math.nan
        except OverflowError:
            out = math.inf
        if not (math.isfinite(out) and 0.0 <= out <= high):
            bound = 'a number in [0, 1]' if high == 1.0 else 'a finite number >= 0'
            raise ValueError(f'{name} must be {bound}, got {short(value)}')
        object.__setattr__(shape, name, out)
