# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The sphere: a ball of ``radius`` (m) about its centre. Its row: geom[RADIUS]."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rb_sim_ros.contact.shapes.base import (IDENTITY_XYZW, material, ORIGIN, placement, Pool,
                                            positive, RADIUS)
from rb_sim_ros.core.jit import inline_kernel

NAME = 'sphere'
KIND = 0
FIELDS = ('radius',)      # what a scene file gives, all of them needed
PLACED = True             # it takes a position and an orientation in its body
STATIC_ONLY = False
ROUND = True              # a turn about its centre leaves it as it was


@dataclass(frozen=True)
class Sphere:
    """A ball of ``radius`` (m) centred at ``position`` (m, body frame)."""

    radius: float
    position: tuple[float, ...] = ORIGIN
    orientation_xyzw: tuple[float, ...] = IDENTITY_XYZW
    restitution: float | None = None
    friction: float | None = None
    rotation: np.ndarray = field(init=False, repr=False, compare=False)

    kind = NAME

    def __post_init__(self) -> None:
        object.__setattr__(self, 'radius', positive('radius', self.radius))
        placement(self)
        material(self)

    @property
    def bounding_radius(self) -> float:
        """Radius (m) of the smallest ball about the shape's centre that holds it."""
        return self.radius


VALUE = Sphere


def pack(shape: Sphere, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s sizes into its row ``geom`` (zeros); ``rotation`` (9, its axes in the
    world) is not read."""
    geom[RADIUS] = shape.radius


def draw(shape: Sphere) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one sphere."""
    return [('sphere', (shape.radius,), np.array(shape.position), np.array(shape.rotation))]


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """How far the shape of row ``c`` of ``geoms`` reaches from its centre along a unit
    direction, (l0, l1, l2) in the shape's axes (m): its radius."""
    return float(geoms[c, RADIUS])


# Its core for the convex narrow phase (convex_kernels): its centre, rounded by its radius.
@inline_kernel
def core_radius(geom):
    """The rounding of its core (m): its radius."""
    return float(geom[RADIUS])


@inline_kernel
def core_point(geom, pool, l0, l1, l2):
    """Its core's farthest point along (l0, l1, l2): its centre."""
    return 0.0, 0.0, 0.0


@inline_kernel
def core_face(geom, pool, l0, l1, l2, out, tags):
    """Its core's part facing (l0, l1, l2): its centre (1 point, tag 0)."""
    out[0, 0], out[0, 1], out[0, 2] = 0.0, 0.0, 0.0
    tags[0] = 0
    return 1
