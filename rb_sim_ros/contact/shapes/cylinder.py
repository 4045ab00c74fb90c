# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The cylinder: a solid of ``radius`` about the local z axis between two flat caps at
z = -+ length / 2 (not a capsule: its caps are discs with sharp rims). Its row: geom[RADIUS],
geom[HALF_LENGTH].

Its contacts are those of the convex narrow phase (``convex_kernels``): its core is itself
(no rounding radius), its ``core_point`` the farthest point along a direction and its
``core_face`` the part of its surface facing that way: a cap (a regular octagon of its rim,
with the exact farthest rim point put in its place between two of the octagon's corners, so
that a tilted cylinder's lowest point is never cut off), the straight line of its side, or
one rim point.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from rb_sim_ros.contact.shapes.base import (HALF_LENGTH, IDENTITY_XYZW, material, ORIGIN,
                                            placement, Pool, positive, RADIUS)
from rb_sim_ros.core.jit import inline_kernel

NAME = 'cylinder'
KIND = 4
FIELDS = ('radius', 'length')
PLACED = True
STATIC_ONLY = False

# A direction within acos(CAP_COS) (about 25 degrees) of the axis faces a cap; within
# asin(SIDE_SIN) (about 6 degrees) of square to it, the side. Between, one rim point. The faces
# are candidates only: the narrow phase keeps the points within the margin of the other shape.
CAP_COS = 0.9
SIDE_SIN = 0.1
# cos 45 degrees (the octagon's corners): a correctly rounded square root, the same bits in
# either tier.
_C45 = math.sqrt(0.5)
# A cap facing a direction within TILTED (rad) of the axis is the octagon alone: the exact
# farthest rim point of a nearly upright cylinder would turn with every tremor of its
# tilt and move a contact round the rim each step (it rocks); that point lies at most
# r (1 - cos 22.5 deg) TILTED = 7.6e-5 r beyond the octagon's corners.
TILTED = 1e-3
_TINY = 1e-300


@dataclass(frozen=True)
class Cylinder:
    """A solid cylinder of ``radius`` (m) and ``length`` (m, between its flat caps) along its
    local z axis, centred at ``position`` (m, body frame) with axes turned by
    ``orientation_xyzw``."""

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
        object.__setattr__(self, 'length', positive('length', self.length))
        placement(self)
        material(self)

    @property
    def half_length(self) -> float:
        return 0.5 * self.length

    @property
    def bounding_radius(self) -> float:
        return math.sqrt(self.radius * self.radius + 0.25 * self.length * self.length)


VALUE = Cylinder


def pack(shape: Cylinder, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s sizes into its row ``geom`` (zeros)."""
    geom[RADIUS], geom[HALF_LENGTH] = shape.radius, shape.half_length


def draw(shape: Cylinder) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one cylinder."""
    return [('cylinder', (shape.radius, shape.half_length), np.array(shape.position),
             np.array(shape.rotation))]


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the cylinder of row ``c`` reaches along (l0, l1, l2) (its axes, unit): its rim
    point that way, r sqrt(l0^2 + l1^2) + h |l2|."""
    return (float(geoms[c, RADIUS]) * math.sqrt(l0 * l0 + l1 * l1)
            + float(geoms[c, HALF_LENGTH]) * abs(l2))


@inline_kernel
def core_radius(geom):
    """No rounding: the cylinder is its own core."""
    return 0.0


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its farthest point along (l0, l1, l2) (its axes, any length): the rim point that way on
    the cap that way (the cap's centre for a direction along the axis)."""
    r, h = float(geom[RADIUS]), float(geom[HALF_LENGTH])
    z = h if l2 >= 0.0 else -h
    rho = math.sqrt(l0 * l0 + l1 * l1)
    if rho > _TINY:
        return r * (l0 / rho), r * (l1 / rho), z
    return 0.0, 0.0, z


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """The part of its surface facing (l0, l1, l2) (its axes, unit), into out[:n] in order
    round its edge (tags: the points' features, stable while the face is the same); returns
    n: 9 for a cap (the octagon with the exact farthest rim point), 2 for the side's line, 1
    for a rim point."""
    r, h = float(geom[RADIUS]), float(geom[HALF_LENGTH])
    rho = math.sqrt(l0 * l0 + l1 * l1)
    if abs(l2) >= CAP_COS:
        z = h if l2 >= 0.0 else -h
        base = 0 if l2 >= 0.0 else 10
        ux, uy = 1.0, 0.0
        tilted = rho > TILTED * math.sqrt(rho * rho + l2 * l2)
        if tilted:
            ux, uy = l0 / rho, l1 / rho
        # the octant of (ux, uy): the corner k at k * 45 degrees that comes before it
        first = _octant(ux, uy)
        n = 0
        for k in range(8):
            cx, cy = _corner(k)
            out[n, 0], out[n, 1], out[n, 2] = r * cx, r * cy, z
            tags[n] = base + k
            n += 1
            ex, ey = ux - cx, uy - cy
            if tilted and k == first and ex * ex + ey * ey > 1e-24:  # not a corner already
                out[n, 0], out[n, 1], out[n, 2] = r * ux, r * uy, z
                tags[n] = base + 8
                n += 1
        return n
    x, y, z = core_point(geom, pool, l0, l1, l2)
    if abs(l2) <= SIDE_SIN * math.sqrt(l0 * l0 + l1 * l1 + l2 * l2):
        out[0, 0], out[0, 1], out[0, 2] = x, y, -h
        out[1, 0], out[1, 1], out[1, 2] = x, y, h
        tags[0], tags[1] = 20, 21
        return 2
    out[0, 0], out[0, 1], out[0, 2] = x, y, z
    tags[0] = 22 if z > 0.0 else 23
    return 1


@inline_kernel
def _corner(k):
    """The octagon's corner k (cos, sin of k * 45 degrees)."""
    if k == 0:
        return 1.0, 0.0
    if k == 1:
        return _C45, _C45
    if k == 2:
        return 0.0, 1.0
    if k == 3:
        return -_C45, _C45
    if k == 4:
        return -1.0, 0.0
    if k == 5:
        return -_C45, -_C45
    if k == 6:
        return 0.0, -1.0
    return _C45, -_C45


@inline_kernel
def _octant(x, y):
    """k in 0..7 with the angle of (x, y) in [k * 45, (k + 1) * 45) degrees, by comparisons
    alone (the same in either tier)."""
    if y > 0.0 or (y == 0.0 and x >= 0.0):  # [0, 180) degrees
        if x > 0.0:
            return 0 if x > y else 1
        return 2 if -x < y else 3
    if x < 0.0:
        return 4 if -x > -y else 5
    return 6 if x < -y else 7
