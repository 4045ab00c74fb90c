# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Scenes from MJCF files (MuJoCo's XML), read through the ``mujoco`` package's own compiler,
so that its defaults, classes, units and inertias computed from geoms are MuJoCo's.

    scene = load_scene('drop.xml')      # (scene.load_scene reads it with load_mjcf)

What a file becomes:

* a body with a free joint (a child of the world) is a moving body; bodies nested in it
  without joints are welded to it: one rigid body whose mass, centre of mass and inertia are
  their sum (the parallel-axis theorem) and whose colliders are all their geoms;
* a body without joints that is a child of the world is a static body (and what is nested
  in it); geoms of the world body itself are a static body called ``mjcf_world``;
* geoms are colliders: sphere, capsule, box, cylinder, mesh (the convex hull of its
  vertices as MuJoCo compiled them, as MuJoCo collides it: given by ``vertex``, or a mesh
  file under the model's folder, its ``meshdir`` or ``assetdir`` a folder of it, checked as
  ``sim/meshes.py`` checks a scene's) (on any body) and plane (on static bodies), with
  their friction (MuJoCo's first coefficient); geoms that collide with nothing (contype and
  conaffinity 0: visual ones) are left out;
* gravity is the file's ``<option gravity>``; the step is the node's (``dt``), not the file's
  ``timestep``; contact settings are the defaults (MuJoCo's soft contacts have no
  counterpart).

A body's frame here has its origin at the centre of mass and the axes of the MJCF body (its
inertia the full tensor in those axes); its pose is the MJCF body's moved to that centre.
Names become ROS names: characters other than ASCII letters, digits and underscores become
``_``, a name not starting with a letter is prefixed ``b_``, an unnamed body is ``body<i>``
and a repeated one gets ``_2``, ``_3``.

Refused, each with one line naming the file, the body or geom and the reason: other joints
(hinge, slide, ball: an articulated model is not one rigid body), other geom types
(height field, SDF), a moving body without mass, any file but an
``include`` or a mesh (no texture, height field or skin file is read), a mesh file outside
the model's folder, of another format or too large, an include outside the model's folder
(absolute, climbing with ``..``, or through a link; MuJoCo reads includes from the model's
folder, and they are checked there), one that is not a regular file, more than
``scene.MAX_BYTES`` of model files in all, the elements of ``REFUSED_ELEMENTS`` and textures
past ``MAX_TEXTURE_PIXELS``, and whatever MuJoCo's compiler refuses. Nothing is read but the
model, its includes and its mesh files.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
from typing import Any
import xml.etree.ElementTree as ElementTree

import numpy as np

from rb_sim_ros.contact.collision_shapes import Box, Capsule, Cylinder, Hull, Plane, Sphere
from rb_sim_ros.contact.shapes import Ellipsoid
from rb_sim_ros.core import so3
from rb_sim_ros.sim import meshes
from rb_sim_ros.sim.bodies import body_at, BodySpec, combined

# Include files followed (each checked in turn) before the model is refused as too deep.
MAX_INCLUDE_DEPTH = 8
# The name of the static body of the world body's own geoms.
WORLD_BODY = 'mjcf_world'
# Attributes that name files (MJCF: include, mesh, hfield, texture, skin; compiler dirs).
# Elements a model may not hold: each can make any number of bodies or a large array from a
# few bytes (MuJoCo's replicate, composite and flexcomp; height fields and skins, which have no
# use here).
REFUSED_ELEMENTS = frozenset(('replicate', 'composite', 'flexcomp', 'hfield', 'skin'))
# The most texture pixels a model may ask for, in all (a cube's six faces count): MuJoCo makes
# each texture's pixels when it compiles (8000 x 8000 took 500 MB).
MAX_TEXTURE_PIXELS = 1 << 22


class ModelError(ValueError):
    """A model file that cannot be used; the message names the file, element and reason."""


def load_mjcf(path: str, max_bytes: int, max_bodies: int
              ) -> tuple[tuple[float, float, float], tuple[BodySpec, ...]]:
    """(gravity, bodies) of the MJCF file ``path``, of at most ``max_bytes`` of XML and
    ``max_bodies`` bodies (``scene.load_scene`` gives its own bounds and makes the Scene);
    ModelError says why not."""
    real = os.path.realpath(path)
    root = os.path.dirname(real)
    _check_files(path, root, max_bytes)
    mujoco = _mujoco(path)
    try:
        model = mujoco.MjModel.from_xml_path(real)  # (its includes: from root, as checked)
    except Exception as e:  # its compiler's refusal (ValueError), one line
        reason = ' '.join(str(e).split())
        raise ModelError(f'{path}: MuJoCo cannot compile it: {reason}') from None
    bodies = _bodies(path, model, mujoco, max_bodies)
    gx, gy, gz = (float(g) for g in model.opt.gravity)
    return (gx, gy, gz), bodies


def bodies_from_text(text: str, where: str, max_bodies: int
                     ) -> tuple[tuple[float, float, float], tuple[BodySpec, ...]]:
    """(gravity, bodies) of an MJCF model given as text (a spawn request's), which may name
    no file at all (not even an include: nothing is read); ModelError naming ``where`` says
    why not."""
    try:
        tree = ElementTree.fromstring(text)
    except ElementTree.ParseError as e:
        raise ModelError(f'{where}: not XML: {e}') from None
    _check_tree(tree, where, None)
    mujoco = _mujoco(where)
    try:
        model = mujoco.MjModel.from_xml_string(text)
    except Exception as e:  # its compiler's refusal (ValueError), one line
        reason = ' '.join(str(e).split())
        raise ModelError(f'{where}: MuJoCo cannot compile it: {reason}') from None
    gx, gy, gz = (float(g) for g in model.opt.gravity)
    return (gx, gy, gz), _bodies(where, model, mujoco, max_bodies)


def _mujoco(where: str):
    try:
        import mujoco
    except ImportError:
        raise ModelError(f'{where}: reading MJCF needs the mujoco package (pip install '
                         'mujoco)') from None
    return mujoco


def _inside(root: str, file: str) -> bool:
    return os.path.commonpath([root, os.path.realpath(file)]) == root


def _check_tree(tree, where: str, include, mesh=None) -> None:
    """ModelError for what a model may not hold (REFUSED_ELEMENTS, a file named by any
    attribute but an include's or a mesh's, textures past MAX_TEXTURE_PIXELS);
    ``include(value)`` is called for each ``<include file>`` and ``mesh(value)`` for each
    ``<mesh file>`` (None: refused too)."""
    pixels = 0
    for element in tree.iter():
        tag = element.tag
        if tag in REFUSED_ELEMENTS:
            raise ModelError(f'{where}: <{tag}> is not read here (it may make any number of '
                             'bodies, or large arrays, from a few bytes)')
        if tag == 'texture':
            try:
                size = int(element.get('width', '0')) * int(element.get('height', '0'))
            except ValueError:
                size = 0  # MuJoCo refuses it
            pixels += size * (6 if element.get('type') in ('cube', 'skybox') else 1)
            if pixels > MAX_TEXTURE_PIXELS:
                raise ModelError(f'{where}: textures of more than {MAX_TEXTURE_PIXELS} pixels '
                                 'in all (MAX_TEXTURE_PIXELS)')
        if tag == 'include' and include is None:
            raise ModelError(f'{where}: <include>: a model sent as text may name no file')
        for name, value in element.attrib.items():
            if not name.startswith('file') or (tag == 'include' and name == 'file'):
                continue
            if tag == 'mesh' and name == 'file' and mesh is not None:
                mesh(value)
                continue
            if tag == 'mesh' and name == 'file':
                raise ModelError(f'{where}: <mesh file="{value[:80]}">: a model sent as text '
                                 'may name no file (give the mesh by its vertices)')
            raise ModelError(f'{where}: <{tag} {name}="{value[:80]}">: no file but an '
                             'include or a mesh is read (textures, height fields and skins '
                             'have no use here)')
        if tag == 'include':
            include(element.get('file') or '')


def _check_files(path: str, root: str, max_bytes: int) -> None:
    """ModelError unless ``path`` and the files it includes (MuJoCo reads an include from
    the folder of the model, ``root``, wherever it is written) are regular files in ``root``
    (named relative, without ``..``; links followed), of at most ``max_bytes`` in all, and
    what they hold passes ``_check_tree``."""
    seen = [0]

    def visit(file: str, depth: int) -> None:
        real = os.path.realpath(file)
        if not _inside(root, real):
            raise ModelError(f'{path}: {file} is outside the folder of the model ({root})')
        if not os.path.isfile(real):
            raise ModelError(f'{path}: cannot read {file}: '
                             f'{"not a regular file" if os.path.exists(real) else "no file"}')
        try:
            with open(real, 'rb') as f:
                raw = f.read(max_bytes - seen[0] + 1)
        except OSError as e:
            raise ModelError(f'{path}: cannot read {file}: {e.strerror or e}') from None
        seen[0] += len(raw)
        if seen[0] > max_bytes:
            raise ModelError(f'{path}: more than {max_bytes} bytes of model files '
                             '(scene.MAX_BYTES)')
        try:
            tree = ElementTree.fromstring(raw)
        except ElementTree.ParseError as e:
            raise ModelError(f'{path}: {file} is not XML: {e}') from None

        def include(value: str) -> None:
            if os.path.isabs(value) or '..' in value.replace('\\', '/').split('/'):
                raise ModelError(f'{path}: <include file="{value[:80]}"> is outside the folder '
                                 f'of the model ({root}): names must be relative, without ..')
            if depth >= MAX_INCLUDE_DEPTH:
                raise ModelError(f'{path}: includes nested deeper than {MAX_INCLUDE_DEPTH} '
                                 '(MAX_INCLUDE_DEPTH)')
            visit(os.path.join(root, value), depth + 1)

        def mesh(value: str) -> None:
            try:
                meshes.resolve(os.path.join(folder[0], value), [Path(root)])
            except meshes.MeshError as e:
                raise ModelError(f'{path}: <mesh file="{value[:80]}">: {e}') from None

        for compiler in tree.iter('compiler'):
            named = compiler.get('meshdir', compiler.get('assetdir'))
            if named is None:
                continue
            if depth > 0 or os.path.isabs(named) or '..' in named.replace('\\', '/').split('/'):
                raise ModelError(f'{path}: <compiler meshdir="{named[:80]}">: a folder of the '
                                 'model (relative, without .., in the main file)')
            folder[0] = named
        _check_tree(tree, path, include, mesh)

    folder = ['']  # the model's meshdir (or assetdir): where MuJoCo reads its mesh files
    visit(path, 0)


def ros_name(name: str, index: int) -> str:
    """``name`` as a ROS name token (see the module doc); ``body<index>`` for no name."""
    if not name:
        return f'body{index}'
    clean = re.sub(r'[^A-Za-z0-9_]', '_', name)
    if not clean[0].isalpha() or not clean[0].isascii():
        clean = 'b_' + clean
    return clean[:64]


def _rotation(mujoco, quat_wxyz) -> np.ndarray:
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(quat_wxyz, dtype=float))
    return rot.reshape(3, 3)


def _bodies(path: str, model, mujoco, max_bodies: int) -> tuple[BodySpec, ...]:
    free = mujoco.mjtJoint.mjJNT_FREE
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or '' for b in
             range(model.nbody)]
    for j in range(model.njnt):
        body = int(model.jnt_bodyid[j])
        if model.jnt_type[j] != free:
            kind = str(mujoco.mjtJoint(model.jnt_type[j])).split('_')[-1].lower()
            joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f'#{j}'
            raise ModelError(f"{path}: body '{names[body]}': joint '{joint}' is a {kind} "
                             'joint: only free joints are supported (an articulated model '
                             'is not one rigid body)')
        if model.body_parentid[body] != 0:
            raise ModelError(f"{path}: body '{names[body]}': a free joint on a nested body")
    # Each top-level body (a child of the world) and what is welded into it.
    roots = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    members: dict[int, list[int]] = {r: [] for r in roots}
    members[0] = [0]
    for b in range(1, model.nbody):
        top = b
        while model.body_parentid[top] != 0:
            top = int(model.body_parentid[top])
        members[top].append(b)
    if len(roots) + 1 > max_bodies:
        raise ModelError(f'{path}: {len(roots)} bodies, more than MAX_BODIES = {max_bodies}')
    specs = []
    taken: set[str] = set()
    for top in [0] + roots:
        moving = bool(model.body_jntnum[top])
        spec = _body(path, model, mujoco, top, members[top], moving, names, taken)
        if spec is not None:
            specs.append(spec)
    if not specs:
        raise ModelError(f'{path}: no body with a free joint or a geom')
    return tuple(specs)


def _pose_in(model, mujoco, top: int, body: int):
    """(R, p) of ``body`` in the frame of ``top`` (its ancestor, or itself)."""
    rot, pos = np.eye(3), np.zeros(3)
    while body != top:
        r = _rotation(mujoco, model.body_quat[body])
        rot, pos = r @ rot, r @ pos + model.body_pos[body]
        body = int(model.body_parentid[body])
    return rot, pos


def unique_name(name: str, taken: set) -> str:
    """``name``, or ``name_2``, ``name_3``... (within 64 characters): the first not taken."""
    count, unique = 1, name
    while unique in taken:
        count += 1
        suffix = f'_{count}'
        unique = name[:64 - len(suffix)] + suffix
    taken.add(unique)
    return unique


def _body(path, model, mujoco, top, bodies, moving, names, taken) -> BodySpec | None:
    where = f"{path}: body '{names[top] or top}'"
    # Mass, centre of mass and inertia in the top body's axes (the parallel-axis theorem).
    poses = {b: _pose_in(model, mujoco, top, b) for b in bodies}
    parts = []
    for b in bodies:
        rot, pos = poses[b]
        axes = rot @ _rotation(mujoco, model.body_iquat[b])
        parts.append((float(model.body_mass[b]), pos + rot @ model.body_ipos[b],
                      axes @ np.diag(model.body_inertia[b]) @ axes.T))
    mass, centre, inertia = combined(parts)
    if moving and not mass > 0.0:
        raise ModelError(f'{where}: has no mass (give its geoms a density or mass, or the '
                         'body an inertial)')
    colliders = []
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b not in poses or (model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0):
            continue
        rot, pos = poses[b]
        geom_rot = rot @ _rotation(mujoco, model.geom_quat[g])
        geom_pos = pos + rot @ model.geom_pos[g] - centre
        colliders.append(_collider(path, model, mujoco, g, geom_rot, geom_pos, moving))
    if not moving and not colliders:
        return None  # a static body that touches nothing: nothing to simulate
    name = unique_name(WORLD_BODY if top == 0 else ros_name(names[top], top), taken)
    rot0, pos0 = (np.eye(3), np.zeros(3)) if top == 0 else (
        _rotation(mujoco, model.body_quat[top]), np.array(model.body_pos[top], dtype=float))
    try:
        if not moving:  # (a static body's mass is never read: BodySpec's defaults)
            return body_at(name, BodySpec.mass, BodySpec.inertia, rot0, pos0, centre,
                           colliders, static=True)
        return body_at(name, mass, inertia.reshape(9).tolist(), rot0, pos0, centre, colliders)
    except ValueError as e:
        raise ModelError(f'{where}: {e}') from None


def _collider(path, model, mujoco, g, rot, pos, moving) -> Any:
    types = mujoco.mjtGeom
    kind = model.geom_type[g]
    size = [float(s) for s in model.geom_size[g]]
    friction = float(model.geom_friction[g, 0])
    where = f"{path}: geom '{mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or g}'"
    quat = tuple(so3.quaternion_xyzw_from_matrix(rot).tolist())
    at = tuple(pos.tolist())
    try:
        if kind == types.mjGEOM_SPHERE:
            return Sphere(size[0], position=at, orientation_xyzw=quat, friction=friction)
        if kind == types.mjGEOM_CAPSULE:
            return Capsule(size[0], 2.0 * size[1], position=at, orientation_xyzw=quat,
                           friction=friction)
        if kind == types.mjGEOM_BOX:
            return Box(tuple(2.0 * s for s in size), position=at, orientation_xyzw=quat,
                       friction=friction)
        if kind == types.mjGEOM_CYLINDER:
            return Cylinder(size[0], 2.0 * size[1], position=at, orientation_xyzw=quat,
                            friction=friction)
        if kind == types.mjGEOM_ELLIPSOID:
            return Ellipsoid(tuple(size[:3]), position=at, orientation_xyzw=quat,
                             friction=friction)
        if kind == types.mjGEOM_MESH:  # the hull of its vertices, as MuJoCo collides it
            mesh = int(model.geom_dataid[g])
            start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
            return Hull(np.array(model.mesh_vert[start:start + count], dtype=float),
                        position=at, orientation_xyzw=quat, friction=friction)
        if kind == types.mjGEOM_PLANE:
            if moving:
                raise ModelError(f'{where}: a plane on a moving body')
            normal = rot[:, 2]
            return Plane(tuple(normal.tolist()), float(normal @ pos), friction=friction)
    except ModelError:
        raise
    except ValueError as e:
        raise ModelError(f'{where}: {e}') from None
    name = str(types(kind)).split('_')[-1].lower()
    raise ModelError(f'{where}: a {name} geom: only sphere, capsule, box, cylinder, ellipsoid, '
                     'mesh (given by its vertices) and plane collide here')
