# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Collision shapes: sphere, box, capsule, cylinder, hull, ellipsoid on any body; infinite
plane and triangle-mesh terrain on static bodies only.

    Sphere(radius=0.1)
    Box(size=(0.4, 0.3, 0.2), position=(0.0, 0.0, 0.1))      # full edge lengths, like scene.py
    Capsule(radius=0.05, length=0.3)                            # cylinder part along local z
    Cylinder(radius=0.1, length=0.3)                            # flat caps, along local z
    Plane(normal=(0.0, 0.0, 1.0), offset=0.0)                   # the ground z = 0

A shape's ``position`` (m) and ``orientation_xyzw`` place its centre and axes in the frame of
the body that carries it (the body frame: origin at the centre of mass, R maps it to the
world); both are optional. So are ``restitution`` and ``friction``, the shape's material: a
contact between two shapes uses the larger restitution and the geometric mean of the
frictions (``world_step``, as Box2D combines them), a side without one the world's (the
scene's ``contact``).
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

Each kind is a module of ``shapes`` (its value type, its kernel row, its support), listed in
``shapes.KINDS``; this module is the names the rest of the package imports them by.
"""

from __future__ import annotations

from rb_sim_ros.contact.shapes import (BY_NAME, is_shape, KINDS, NAMES, RANK, Shape,
                                       shape_from_dict, shape_to_dict, SHAPE_TYPES,
                                       world_pose)
from rb_sim_ros.contact.shapes.base import (IDENTITY_XYZW, MAX_LENGTH, MIN_LENGTH,
                                            ORIGIN)
from rb_sim_ros.contact.shapes.box import Box
from rb_sim_ros.contact.shapes.capsule import Capsule
from rb_sim_ros.contact.shapes.cylinder import Cylinder
from rb_sim_ros.contact.shapes.hull import Hull
from rb_sim_ros.contact.shapes.plane import Plane, UNIT_TOLERANCE
from rb_sim_ros.contact.shapes.sphere import Sphere
from rb_sim_ros.contact.shapes.terrain import Terrain

__all__ = ['Box', 'BY_NAME', 'Capsule', 'Cylinder', 'Hull', 'IDENTITY_XYZW', 'is_shape',
           'KINDS', 'MAX_LENGTH', 'MIN_LENGTH', 'NAMES', 'ORIGIN', 'Plane', 'RANK', 'Shape',
           'shape_from_dict', 'SHAPE_TYPES', 'shape_to_dict', 'Sphere', 'Terrain',
           'UNIT_TOLERANCE', 'world_pose']
