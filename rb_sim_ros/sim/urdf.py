# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scenes from URDF files: a robot's links joined by fixed joints are one rigid body.

    scene = load_scene('drone.urdf')    # (scene.load_scene reads it with load_urdf)

What a file becomes:

* each tree of links joined by ``fixed`` joints is one moving body named after its root
  link: the links' masses summed, centres and inertias (each ``<inertial>``: origin, mass,
  the tensor in the frame its ``rpy`` turns) combined by the parallel-axis theorem, its
  colliders every ``<collision>`` of its links (box, sphere and cylinder geometry, and a
  mesh as the convex hulls of its parts: ``sim/meshes.py``, its ``filename`` resolved as ROS
  does, ``package://`` by the installed packages' share folders, a relative path from the
  URDF's folder, and only there or in those folders);
* a ``floating`` joint splits the tree: the child's links are a body of their own, placed
  where the joint's origin puts them;
* a root link called ``world`` is the world (URDF's idiom): what is fixed to it is a static
  body called ``urdf_world`` (its collisions where they are), and a ``floating`` joint from it
  places a free body;
* the root link's frame is the world's at the start (REP-103: x forward, z up); the body's
  frame has its origin at the centre of mass and the root link's axes;
* a URDF says nothing of gravity or contact: none, and the default contact settings (a
  YAML scene says them).

``rpy`` is roll about x, pitch about y, yaw about z, fixed axes (R = Rz Ry Rx), as URDF
defines it. Refused, each with one line naming the file, the element and the reason:
revolute, continuous, prismatic and planar joints (an articulated robot is not one rigid
body), a mesh file that cannot be read or lies elsewhere, a body without mass, joints that
do not make a tree (a link with two parents, a loop, a missing link), numbers that are not
finite, more than ``scene.MAX_BYTES`` of XML, or more than ``MAX_LINKS`` links. Nothing but
the file and its meshes are read.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
import xml.etree.ElementTree as ElementTree

import numpy as np

from rb_sim_ros.contact.collision_shapes import Box, Cylinder, Sphere
from rb_sim_ros.core import so3
from rb_sim_ros.sim import meshes
from rb_sim_ros.sim.bodies import body_at, BodySpec, combined
from rb_sim_ros.sim.mjcf import ModelError, ros_name, unique_name

# The most links a file may have (each a dict and a few arrays here).
MAX_LINKS = 10_000
# What joins links into one body, and what splits them into bodies.
_WELDED, _SPLIT = 'fixed', 'floating'
# The link that is the world (URDF's idiom for a robot fixed in place: a ``fixed`` joint from
# it), and the name of the static body its tree becomes (``world`` names the world frame).
WORLD_LINK, STATIC_BODY = 'world', 'urdf_world'


def load_urdf(path: str, max_bytes: int, max_bodies: int
              ) -> tuple[tuple[float, float, float], tuple[BodySpec, ...]]:
    """(gravity, bodies) of the URDF file ``path``, of at most ``max_bytes`` and
    ``max_bodies`` bodies; ModelError says why not."""
    return _bodies(path, _parse(path, max_bytes), max_bodies)


def bodies_from_text(text: str, where: str, max_bodies: int
                     ) -> tuple[tuple[float, float, float], tuple[BodySpec, ...]]:
    """(gravity, bodies) of a URDF given as text (a spawn request's); ModelError naming
    ``where`` says why not."""
    return _bodies(where, _robot(text.encode('utf-8', 'surrogatepass'), where), max_bodies)


def _bodies(path: str, robot, max_bodies: int):
    links, joints = _links(path, robot), _joints(path, robot)
    parent_of: dict[str, tuple] = {}
    for joint in joints:
        name, kind, parent, child, origin = joint
        for link in (parent, child):
            if link not in links:
                raise ModelError(f"{path}: joint '{name}': no link named '{link}'")
        if child in parent_of:
            raise ModelError(f"{path}: joint '{name}': link '{child}' has two parents "
                             f"(joint '{parent_of[child][0]}' too)")
        if kind not in (_WELDED, _SPLIT):
            raise ModelError(f"{path}: joint '{name}' is a {kind} joint: only fixed and "
                             'floating joints are supported (an articulated robot is not one '
                             'rigid body)')
        parent_of[child] = joint
    children: dict[str, list] = {link: [] for link in links}
    for joint in joints:
        children[joint[2]].append(joint)
    roots = [link for link in links if link not in parent_of]
    if not roots:
        raise ModelError(f'{path}: the joints make a loop: no root link')
    # Each body: its root link and where it starts (the world pose of that link).
    starts = [(root, np.eye(3), np.zeros(3)) for root in roots]
    specs: list[BodySpec] = []
    taken: set[str] = set()
    reached: set[str] = set()
    while starts:
        root, rot0, pos0 = starts.pop(0)
        members = []  # (link, rotation, position in the root's frame)
        stack = [(root, np.eye(3), np.zeros(3))]
        while stack:
            link, rot, pos = stack.pop()
            if link in reached:
                raise ModelError(f"{path}: the joints make a loop through link '{link}'")
            reached.add(link)
            members.append((link, rot, pos))
            for name, kind, _, child, (r, p) in children[link]:
                if kind == _WELDED:
                    stack.append((child, rot @ r, pos + rot @ p))
                else:  # a body of its own, where the joint's origin puts it at the start
                    starts.append((child, rot0 @ rot @ r, pos0 + rot0 @ (pos + rot @ p)))
        spec = _body(path, links, root, members, rot0, pos0, taken)
        if spec is not None:
            specs.append(spec)
        if len(specs) > max_bodies:
            raise ModelError(f'{path}: more than MAX_BODIES = {max_bodies} bodies')
    if len(reached) != len(links):
        loop = sorted(set(links) - reached)[0]
        raise ModelError(f"{path}: the joints make a loop through link '{loop}'")
    if not specs:
        raise ModelError(f"{path}: no body: only a link '{WORLD_LINK}' without collisions")
    return (0.0, 0.0, 0.0), tuple(specs)


def _parse(path: str, max_bytes: int):
    try:
        if not os.path.isfile(path):
            raise ModelError(f'{path}: cannot read: not a regular file')
        with open(path, 'rb') as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise ModelError(f'{path}: cannot read: {e.strerror or e}') from None
    if len(raw) > max_bytes:
        raise ModelError(f'{path}: larger than {max_bytes} bytes (scene.MAX_BYTES)')
    return _robot(raw, path)


def _robot(raw: bytes, path: str):
    try:
        robot = ElementTree.fromstring(raw)
    except ElementTree.ParseError as e:
        raise ModelError(f'{path}: not XML: {e}') from None
    if robot.tag != 'robot':
        raise ModelError(f'{path}: not a URDF: its root element is <{robot.tag}>, not <robot>')
    return robot


def _number(path: str, where: str, text, default: float | None = None) -> float:
    if text is None and default is not None:
        return default
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ModelError(f'{path}: {where}: not a number: {text!r}') from None
    if not math.isfinite(value):
        raise ModelError(f'{path}: {where}: not finite: {text!r}')
    return value


def _numbers(path: str, where: str, text, size: int, default: str) -> np.ndarray:
    parts = (default if text is None else text).split()
    if len(parts) != size:
        raise ModelError(f'{path}: {where}: {size} numbers, got {text!r}')
    return np.array([_number(path, where, p) for p in parts])


def _origin(path: str, where: str, element) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of an element's ``<origin xyz rpy>`` (identity without one)."""
    origin = element.find('origin') if element is not None else None
    if origin is None:
        return np.eye(3), np.zeros(3)
    xyz = _numbers(path, f'{where} origin xyz', origin.get('xyz'), 3, '0 0 0')
    roll, pitch, yaw = _numbers(path, f'{where} origin rpy', origin.get('rpy'), 3, '0 0 0')
    return (so3.exp(np.array([0.0, 0.0, yaw])) @ so3.exp(np.array([0.0, pitch, 0.0]))
            @ so3.exp(np.array([roll, 0.0, 0.0]))), xyz


def _links(path: str, robot) -> dict:
    links: dict = {}
    for element in robot.findall('link'):
        name = element.get('name')
        if not name:
            raise ModelError(f'{path}: a <link> without a name')
        if name in links:
            raise ModelError(f"{path}: link '{name}' is defined twice")
        if len(links) >= MAX_LINKS:
            raise ModelError(f'{path}: more than MAX_LINKS = {MAX_LINKS} links')
        where = f"link '{name}'"
        inertial = element.find('inertial')
        mass, inertia = 0.0, np.zeros((3, 3))
        rot, pos = np.eye(3), np.zeros(3)
        if inertial is not None:
            rot, pos = _origin(path, f'{where} inertial', inertial)
            m = inertial.find('mass')
            mass = _number(path, f'{where} mass', None if m is None else m.get('value'))
            if mass < 0.0:
                raise ModelError(f'{path}: {where} mass: negative: {mass!r}')
            i = inertial.find('inertia')
            if i is None:
                raise ModelError(f'{path}: {where}: an <inertial> without <inertia>')
            c = {k: _number(path, f'{where} inertia {k}', i.get(k), 0.0)
                 for k in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')}
            tensor = np.array([[c['ixx'], c['ixy'], c['ixz']], [c['ixy'], c['iyy'], c['iyz']],
                               [c['ixz'], c['iyz'], c['izz']]])
            inertia = rot @ tensor @ rot.T
        colliders = []
        for k, collision in enumerate(element.findall('collision')):
            colliders.append((_origin(path, f'{where} collision {k}', collision),
                              _geometry(path, f'{where} collision {k}', collision)))
        links[name] = (mass, pos, inertia, colliders)
    if not links:
        raise ModelError(f'{path}: no <link>')
    return links


def _geometry(path: str, where: str, collision):
    geometry = collision.find('geometry')
    shape = None if geometry is None or not len(geometry) else geometry[0]
    if shape is None:
        raise ModelError(f'{path}: {where}: no <geometry>')
    if shape.tag == 'box':
        return ('box', tuple(_numbers(path, f'{where} box size', shape.get('size'), 3, '')))
    if shape.tag == 'sphere':
        return ('sphere', _number(path, f'{where} sphere radius', shape.get('radius')))
    if shape.tag == 'cylinder':  # (URDF's cylinder: along the z axis of its origin)
        return ('cylinder', (_number(path, f'{where} cylinder radius', shape.get('radius')),
                             _number(path, f'{where} cylinder length', shape.get('length'))))
    if shape.tag == 'mesh':
        scale = shape.get('scale')
        scale = (1.0, 1.0, 1.0) if scale is None else tuple(
            _numbers(path, f'{where} mesh scale', scale, 3, ''))
        folder = Path(path).resolve().parent if os.path.isfile(path) else None
        try:
            name, roots = meshes.ros_resource(shape.get('filename'), folder)
            return ('mesh', meshes.mesh_parts(name, roots, scale))
        except meshes.MeshError as e:
            raise ModelError(f'{path}: {where}: mesh: {e}') from None
    raise ModelError(f'{path}: {where}: {shape.tag} geometry: only box, sphere, cylinder and '
                     'mesh collide here')


def _joints(path: str, robot) -> list:
    joints = []
    names = set()
    for element in robot.findall('joint'):
        name = element.get('name') or ''
        if name in names:
            raise ModelError(f"{path}: joint '{name}' is defined twice")
        names.add(name)
        parent, child = element.find('parent'), element.find('child')
        if parent is None or child is None:
            raise ModelError(f"{path}: joint '{name}': needs a <parent> and a <child>")
        joints.append((name, element.get('type'), parent.get('link'), child.get('link'),
                       _origin(path, f"joint '{name}'", element)))
    return joints


def _body(path: str, links: dict, root: str, members: list, rot0, pos0, taken: set):
    parts, shapes = [], []
    for link, rot, pos in members:
        mass, centre, inertia, colliders = links[link]
        parts.append((mass, pos + rot @ centre, rot @ inertia @ rot.T))
        for (r, p), geometry in colliders:
            shapes.append((link, rot @ r, pos + rot @ p, geometry))
    static = root == WORLD_LINK
    mass, centre, inertia = combined(parts)
    if static:  # what is fixed to the world: where its links are, mass left out
        mass, centre, inertia = 1.0, np.zeros(3), np.eye(3)
        if not shapes:
            return None
    where = f"{path}: link '{root}'"
    if not mass > 0.0:
        raise ModelError(f'{where}: its body has no mass (give its links an <inertial>)')
    colliders = []
    try:
        for link, r, p, (kind, size) in shapes:
            at = tuple((p - centre).tolist())
            quat = tuple(so3.quaternion_xyzw_from_matrix(r).tolist())
            if kind == 'box':
                colliders.append(Box(size, position=at, orientation_xyzw=quat))
            elif kind == 'cylinder':
                radius, length = size
                colliders.append(Cylinder(radius, length, position=at, orientation_xyzw=quat))
            elif kind == 'mesh':
                colliders.extend(meshes.hulls(size, f'link {link!r} mesh', position=at,
                                              orientation_xyzw=quat))
            else:
                colliders.append(Sphere(size, position=at, orientation_xyzw=quat))
        name = unique_name(STATIC_BODY if static else ros_name(root, len(taken)), taken)
        return body_at(name, mass, inertia.reshape(9).tolist(), rot0, pos0, centre,
                       colliders, static)
    except ValueError as e:
        raise ModelError(f'{where}: {" ".join(str(e).split())}') from None
