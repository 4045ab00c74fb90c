# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The box: edges ``size`` along its local axes. Its row: the half extents in geom[HX:HZ + 1]."""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from rb_sim_ros.contact.shapes.base import (HX, HY, HZ, IDENTITY_XYZW, material, ORIGIN,
                                            placement, Pool, positive)
from rb_sim_ros.core.jit import inline_kernel
from rb_sim_ros.core.rigid_body import finite_floats

NAME = 'box'
KIND = 2
FIELDS = ('size',)
PLACED = True
STATIC_ONLY = False


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

    kind = NAME

    def __post_init__(self) -> None:
        size = finite_floats('size', self.size, 3)
        for i, s in enumerate(size):
            positive(f'size[{i}]', s)
        object.__setattr__(self, 'size', size)
        placement(self)
        material(self)

    @property
    def half_extents(self) -> tuple[float, float, float]:
        """Half edge lengths (m)."""
        return (0.5 * self.size[0], 0.5 * self.size[1], 0.5 * self.size[2])

    @property
    def bounding_radius(self) -> float:
        return 0.5 * math.sqrt(sum(s * s for s in self.size))


VALUE = Box


def pack(shape: Box, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s half extents into its row ``geom`` (zeros)."""
    geom[HX:HZ + 1] = shape.half_extents


def draw(shape: Box) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one box."""
    return [('box', shape.half_extents, np.array(shape.position), np.array(shape.rotation))]


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the box of row ``c`` reaches along (l0, l1, l2) (its axes, unit): its corner
    that way, sum_j h_j |l_j|."""
    return (abs(l0) * float(geoms[c, HX]) + abs(l1) * float(geoms[c, HY])
            + abs(l2) * float(geoms[c, HZ]))


# Its core for the convex narrow phase (convex_kernels): itself.
@inline_kernel
def core_radius(geom):
    """No rounding: the box is its own core."""
    return 0.0


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its corner along (l0, l1, l2) (any length; + on a tie)."""
    hx, hy, hz = float(geom[HX]), float(geom[HY]), float(geom[HZ])
    return (hx if l0 >= 0.0 else -hx), (hy if l1 >= 0.0 else -hy), (hz if l2 >= 0.0 else -hz)


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """Its face most along (l0, l1, l2) (the first axis on a tie): its 4 corners in order
    round it, tags 4 f + k with f = 2 axis + (1 on the + side)."""
    a0, a1, a2 = abs(l0), abs(l1), abs(l2)
    axis = 0 if a0 >= a1 and a0 >= a2 else (1 if a1 >= a2 else 2)
    value = l0 if axis == 0 else (l1 if axis == 1 else l2)
    side = 1.0 if value >= 0.0 else -1.0
    face = 2 * axis + (1 if side > 0.0 else 0)
    hx, hy, hz = float(geom[HX]), float(geom[HY]), float(geom[HZ])
    for m in range(4):  # (+, +), (-, +), (-, -), (+, -) along the next two axes, cyclically
        sj = 1.0 if m == 0 or m == 3 else -1.0
        sk = 1.0 if m < 2 else -1.0
        if axis == 0:
            x, y, z = side * hx, sj * hy, sk * hz
        elif axis == 1:
            x, y, z = sk * hx, side * hy, sj * hz
        else:
            x, y, z = sj * hx, sk * hy, side * hz
        out[m, 0], out[m, 1], out[m, 2] = x, y, z
        tags[m] = 4 * face + m
    return 4
