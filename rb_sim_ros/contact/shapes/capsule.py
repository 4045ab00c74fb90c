# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The capsule: the points within ``radius`` of a segment along the local z axis. Its row:
geom[RADIUS], geom[HALF_LENGTH]."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rb_sim_ros.contact.shapes.base import (HALF_LENGTH, IDENTITY_XYZW, material, ORIGIN,
                                            placement, Pool, positive, RADIUS)
from rb_sim_ros.core.jit import inline_kernel

NAME = 'capsule'
KIND = 1
FIELDS = ('radius', 'length')
PLACED = True
STATIC_ONLY = False


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

    kind = NAME

    def __post_init__(self) -> None:
        object.__setattr__(self, 'radius', positive('radius', self.radius))
        object.__setattr__(self, 'length', positive('length', self.length, allow_zero=True))
        placement(self)
        material(self)

    @property
    def half_length(self) -> float:
        return 0.5 * self.length

    @property
    def bounding_radius(self) -> float:
        return 0.5 * self.length + self.radius


VALUE = Capsule


def draw(shape: Capsule) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one capsule."""
    return [('capsule', (shape.radius, shape.half_length), np.array(shape.position),
             np.array(shape.rotation))]


def pack(shape: Capsule, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s sizes into its row ``geom`` (zeros)."""
    geom[RADIUS], geom[HALF_LENGTH] = shape.radius, shape.half_length


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the capsule of row ``c`` reaches along (l0, l1, l2) (its axes, unit): the end
    of its segment that way, plus its radius."""
    return float(geoms[c, HALF_LENGTH]) * abs(l2) + float(geoms[c, RADIUS])


# Its core for the convex narrow phase (convex_kernels): its segment, rounded by its radius.
# A direction within asin(SIDE_SIN) (about 6 degrees) of square to the segment faces all of it.
SIDE_SIN = 0.1


@inline_kernel
def core_radius(geom):
    """The rounding of its core (m): its radius."""
    return float(geom[RADIUS])


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its segment's end along (l0, l1, l2) (any length)."""
    h = float(geom[HALF_LENGTH])
    return 0.0, 0.0, (h if l2 >= 0.0 else -h)


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """Its segment's part facing (l0, l1, l2) (unit): both ends (tags 0, 1) when the direction
    is nearly square to it, else the end that way (tag 0 or 1)."""
    h = float(geom[HALF_LENGTH])
    if abs(l2) <= SIDE_SIN:
        out[0, 0], out[0, 1], out[0, 2] = 0.0, 0.0, -h
        out[1, 0], out[1, 1], out[1, 2] = 0.0, 0.0, h
        tags[0], tags[1] = 0, 1
        return 2
    out[0, 0], out[0, 1], out[0, 2] = 0.0, 0.0, (h if l2 >= 0.0 else -h)
    tags[0] = 1 if l2 >= 0.0 else 0
    return 1
