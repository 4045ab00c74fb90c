# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The colliders and contacts of a scene as visualization_msgs/MarkerArray, for RViz or Foxglove.

Markers per collider, in namespace ``<body>``, drawn from the pieces its kind gives
(``contact.shapes.pieces``): a sphere piece is a SPHERE, a box a CUBE, a capsule a CYLINDER
with two SPHERE caps, a cylinder a CYLINDER, a mesh (a hull's surface) a TRIANGLE_LIST of
its triangles, a plane a thin square CUBE of ``PLANE_SIZE`` m centred on the piece's origin
(the point of the plane nearest its body's origin). Collider
k's markers have ids ``3 k``, ``3 k + 1``, ... (at most 3 each, so that every collider's ids
stay fixed). Moving bodies are blue-grey, static ones grey. ``contacts`` (namespace
``contacts``, id 0) is a SPHERE_LIST of the last step's contact points that carried an
impulse, in red. All poses are in ``world_frame``; the messages are built once and only
their poses change.
"""

from __future__ import annotations

from geometry_msgs.msg import Point
import numpy as np
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from rb_sim_ros.contact import shapes
from rb_sim_ros.core import so3
from rb_sim_ros.ros.ros_messages import time_msg

PLANE_SIZE = 20.0       # m, edge of the square drawn for an infinite plane
PLANE_THICKNESS = 1e-3  # m
MOVING = ColorRGBA(r=0.45, g=0.6, b=0.8, a=0.9)
STATIC = ColorRGBA(r=0.6, g=0.6, b=0.6, a=0.5)
CONTACT = ColorRGBA(r=0.9, g=0.1, b=0.1, a=1.0)
CONTACT_SIZE = 0.02     # m


class CollisionMarkers:
    """Markers of every collider of ``config`` (a ``simulation.Config``)."""

    def __init__(self, config, world_frame: str) -> None:
        self.array = MarkerArray()
        self._parts = []  # (body name, marker, position in the body frame, rotation in it)
        for spec in config.bodies:
            colour = STATIC if spec.static else MOVING
            for k, shape in enumerate(spec.colliders):
                for j, (kind, scale, pos, rot, points) in enumerate(_pieces(shape)):
                    m = Marker(ns=spec.name, id=3 * k + j, type=kind, action=Marker.ADD,
                               color=colour)
                    m.header.frame_id = world_frame
                    m.scale.x, m.scale.y, m.scale.z = scale
                    m.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
                                for p in points]
                    self.array.markers.append(m)
                    self._parts.append((spec.name, m, pos, rot))
        self.contacts = Marker(ns='contacts', id=0, type=Marker.SPHERE_LIST, action=Marker.ADD,
                               color=CONTACT)
        self.contacts.header.frame_id = world_frame
        self.contacts.pose.orientation.w = 1.0
        self.contacts.scale.x = self.contacts.scale.y = self.contacts.scale.z = CONTACT_SIZE
        self.array.markers.append(self.contacts)

    def fill(self, time_ns: int, poses, contacts=()) -> MarkerArray:
        """Place the markers: ``poses`` maps a body name to its (position, quaternion x-y-z-w)
        in the world frame; ``contacts`` are ``collision_world.WorldContact`` values."""
        stamp = time_msg(time_ns)
        rotations = {}
        for name, m, pos, rot in self._parts:
            x, q = poses[name]
            if name not in rotations:
                rotations[name] = so3.matrix_from_quaternion_xyzw(q)
            r = rotations[name]
            c = np.asarray(x, dtype=float) + r @ pos
            qx, qy, qz, qw = so3.quaternion_xyzw_from_matrix(r @ rot)
            m.header.stamp = stamp
            m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in c)
            o = m.pose.orientation
            o.x, o.y, o.z, o.w = float(qx), float(qy), float(qz), float(qw)
        self.contacts.header.stamp = stamp
        self.contacts.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
                                for p in (c.point for c in contacts if c.normal_impulse > 0.0)]
        return self.array


def _pieces(shape):
    """(marker type, scale, position, rotation in the body frame, points in the marker's
    frame) of the markers of ``shape``: one or more of each piece its kind draws it with
    (``contact.shapes.pieces``)."""
    out = []
    for primitive, size, pos, rot in shapes.pieces(shape):
        out += MARKERS[primitive](size, pos, rot)
    if len(out) > 3:
        raise ValueError(f'a {shape.kind} takes {len(out)} markers: at most 3 fit its ids')
    return out


def _sphere(size, pos, rot):
    d = 2.0 * size[0]
    return [(Marker.SPHERE, (d, d, d), pos, rot, ())]


def _box(size, pos, rot):
    return [(Marker.CUBE, tuple(2.0 * h for h in size), pos, rot, ())]


def _capsule(size, pos, rot):
    (radius, h), axis = size, rot[:, 2]
    d = 2.0 * radius
    return [(Marker.CYLINDER, (d, d, 2.0 * h), pos, rot, ()),
            (Marker.SPHERE, (d, d, d), pos + h * axis, rot, ()),
            (Marker.SPHERE, (d, d, d), pos - h * axis, rot, ())]


def _cylinder(size, pos, rot):
    radius, h = size
    return [(Marker.CYLINDER, (2.0 * radius, 2.0 * radius, 2.0 * h), pos, rot, ())]


def _mesh(size, pos, rot):
    vertices, triangles = size
    return [(Marker.TRIANGLE_LIST, (1.0, 1.0, 1.0), pos, rot,
             np.asarray(vertices)[np.asarray(triangles).reshape(-1)])]


def _plane(size, pos, rot):
    return [(Marker.CUBE, (PLANE_SIZE, PLANE_SIZE, PLANE_THICKNESS),
             pos - rot[:, 2] * PLANE_THICKNESS / 2, rot, ())]


# The markers of each drawing primitive (contact.shapes.base.PRIMITIVES).
MARKERS = {'sphere': _sphere, 'box': _box, 'capsule': _capsule, 'cylinder': _cylinder,
           'plane': _plane, 'mesh': _mesh}
