# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The plane: a half-space, on static bodies only. Its row: its unit world normal in
geom[NORMAL:NORMAL + 3] (its point is its centre)."""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import sys

import numpy as np

from rb_sim_ros.contact.shapes.base import material, MAX_LENGTH, NORMAL, number, Pool
from rb_sim_ros.core import so3
from rb_sim_ros.core.jit import inline_kernel
from rb_sim_ros.core.rigid_body import finite_floats, scaled_to_one

NAME = 'plane'
KIND = 3
FIELDS = ('normal', 'offset')   # both optional: the ground z = 0
PLACED = False                  # its normal and offset place it
STATIC_ONLY = True              # a half-space: never moves

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

    kind = NAME

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
        offset = number('offset', self.offset)
        if abs(offset) > MAX_LENGTH:
            raise ValueError(f'offset must be at most MAX_LENGTH = {MAX_LENGTH:g} m in size, '
                             f'got {offset!r}')
        object.__setattr__(self, 'offset', offset)
        rotation = np.eye(3)
        rotation.flags.writeable = False
        object.__setattr__(self, 'rotation', rotation)
        material(self)

    @property
    def position(self) -> tuple[float, float, float]:
        """The point of the plane nearest the body origin (m, body frame): offset * normal."""
        return tuple(self.offset * c for c in self.normal)

    @property
    def bounding_radius(self) -> float:
        return math.inf


VALUE = Plane


def pack(shape: Plane, geom: np.ndarray, rotation: np.ndarray, pool: Pool) -> None:
    """Write ``shape``'s normal turned into the world, R n written out, into its row ``geom``
    (zeros); ``rotation`` (9, row-major) is its axes in the world."""
    nx, ny, nz = shape.normal
    r = [float(v) for v in rotation]
    geom[NORMAL:NORMAL + 3] = (r[0] * nx + r[1] * ny + r[2] * nz,
                               r[3] * nx + r[4] * ny + r[5] * nz,
                               r[6] * nx + r[7] * ny + r[8] * nz)


def draw(shape: Plane) -> list[tuple]:
    """Its pieces to draw (base.PRIMITIVES): one plane, its z along the normal, at the point
    nearest the body origin."""
    n = np.array(shape.normal)
    return [('plane', (), n * shape.offset, _z_to(n))]


def _z_to(normal: np.ndarray) -> np.ndarray:
    """A rotation taking +z to the unit ``normal``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, normal)
    s, c = np.linalg.norm(axis), float(normal @ z)
    if s < 1e-12:
        return np.eye(3) if c > 0.0 else np.diag([1.0, -1.0, -1.0])
    return so3.exp(axis / s * np.arctan2(s, c))


@inline_kernel
def support(geoms, pool, c, l0, l1, l2):
    """A half-space reaches without bound (no plane has bounds: the broad phase tests
    planes by their distance)."""
    return math.inf
