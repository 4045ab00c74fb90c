# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ellipsoid: the solid x^2 / a^2 + y^2 / b^2 + z^2 / c^2 <= 1 of semi-axes ``radii``
(a, b, c) along its local x, y, z axes (MuJoCo's ellipsoid geom; a sphere when they are
equal). Its row: geom[HX], geom[HY], geom[HZ] = a, b, c.

Its contacts are those of the convex narrow phase (``convex_kernels``): its core is itself
(no rounding radius), its ``core_point`` the farthest point along a direction, and being
smooth it has no face: ``core_face`` is that one point, so it touches anything at one
point, as a ball does. Its core is ``CURVED``: the narrow phase refines the normal of its
pairs to where the two surfaces' normals are opposite.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from rb_sim_ros.contact.shapes.base import (HX, HY, HZ, IDENTITY_XYZW, material, ORIGIN,
                                            placement, Pool, positive)
from rb_sim_ros.core.jit import inline_kernel
from rb_sim_ros.core.rigid_body import finite_floats

NAME = 'ellipsoid'
KIND = 6
FIELDS = ('radii',)
PLACED = True
STATIC_ONLY = False
CURVED = True

# The mesh that draws it: this many rings of latitude between the poles and points round each
# (a multiple of 4, so that the ends of its axes are vertices: its farthest one is its reach).
DRAW_RINGS, DRAW_ROUND = 12, 24


@dataclass(frozen=True)
class Ellipsoid:
    """A solid ellipsoid of semi-axes ``radii`` (m, a, b, c along its local x, y, z axes),
    centred at ``position`` (m, body frame) with axes turned by ``orientation_xyzw``."""

    radii: tuple[float, ...]
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = NAME

    def __post_init__(self) -> None:
        radii = finite_floats('radii', self.radii, 3)
        for i, r in enumerate(radii):
            positive(f'radii[{i}]', r)
        object.__setattr__(self, 'radii', radii)
        placement(self)
        material(self)

    @property
    def bounding_radius(self) -> float:
        """Its longest semi-axis (m)."""
        return max(self.radii)


VALUE = Ellipsoid


def pack(shape: Ellipsoid, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s semi-axes into its row ``geom`` (zeros)."""
    geom[HX:HZ + 1] = shape.radii


def draw(shape: Ellipsoid) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one mesh, DRAW_RINGS rings of DRAW_ROUND points
    on its surface between its poles (the ends of its axes among them)."""
    a, b, c = shape.radii
    vertices = [(0.0, 0.0, -c)]
    for i in range(1, DRAW_RINGS):
        lat = math.pi * i / DRAW_RINGS - 0.5 * math.pi
        for j in range(DRAW_ROUND):
            lon = 2.0 * math.pi * j / DRAW_ROUND
            vertices.append((a * math.cos(lat) * math.cos(lon), b * math.cos(lat) * math.sin(lon),
                             c * math.sin(lat)))
    vertices.append((0.0, 0.0, c))
    top = len(vertices) - 1
    triangles = []
    for j in range(DRAW_ROUND):  # the caps' fans, then the bands between the rings
        k = (j + 1) % DRAW_ROUND
        triangles.append((0, 1 + k, 1 + j))
        last = 1 + (DRAW_RINGS - 2) * DRAW_ROUND
        triangles.append((top, last + j, last + k))
    for i in range(DRAW_RINGS - 2):
        row, up = 1 + i * DRAW_ROUND, 1 + (i + 1) * DRAW_ROUND
        for j in range(DRAW_ROUND):
            k = (j + 1) % DRAW_ROUND
            triangles += [(row + j, row + k, up + k), (row + j, up + k, up + j)]
    return [('mesh', (np.array(vertices), np.array(triangles, dtype=np.int64)),
             np.array(shape.position), np.array(shape.rotation))]


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the ellipsoid of row ``c`` reaches along (l0, l1, l2) (its axes, unit):
    sqrt(a^2 l0^2 + b^2 l1^2 + c^2 l2^2)."""
    a, b, h = float(geoms[c, HX]), float(geoms[c, HY]), float(geoms[c, HZ])
    return math.sqrt(a * a * l0 * l0 + b * b * l1 * l1 + h * h * l2 * l2)


@inline_kernel
def core_radius(geom):
    """No rounding: the ellipsoid is its own core."""
    return 0.0


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its farthest point along (l0, l1, l2) (its axes, any length): (a^2 l0, b^2 l1, c^2 l2)
    / sqrt(a^2 l0^2 + b^2 l1^2 + c^2 l2^2), where the normal is along l (the top of the z
    axis for no direction). The direction is scaled to its largest component first, so that
    no square overflows or vanishes."""
    a, b, h = float(geom[HX]), float(geom[HY]), float(geom[HZ])
    big = max(abs(l0), abs(l1), abs(l2))
    if not big > 0.0:
        return 0.0, 0.0, h
    l0, l1, l2 = l0 / big, l1 / big, l2 / big
    x, y, z = a * a * l0, b * b * l1, h * h * l2
    size = math.sqrt(a * a * l0 * l0 + b * b * l1 * l1 + h * h * l2 * l2)
    return x / size, y / size, z / size


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """The part of its surface facing (l0, l1, l2): the one point there (it is smooth)."""
    x, y, z = core_point(geom, pool, l0, l1, l2)
    out[0, 0], out[0, 1], out[0, 2] = x, y, z
    tags[0] = 0
    return 1
