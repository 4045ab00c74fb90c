# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The table of shape kinds: one module each, and what the rest of the contact layer reads
of a kind only through this table (as MuJoCo's geom types index its collision table).

A kind's module (``sphere``, ``capsule``, ``box``, ``plane``, ``cylinder``, ``hull``,
``ellipsoid``, ``terrain``) holds,
and nothing else needs to know more of it:

* ``NAME`` (a scene file's ``type``) and ``KIND``, its number: its index in ``KINDS`` and its
  rank in the narrow phase (a pair is computed lower kind first);
* ``VALUE``, its immutable value type (validated once: a ValueError names the field), with
  ``kind`` = NAME, ``position``, ``rotation`` (its axes in its body), ``bounding_radius``;
  ``FIELDS`` (a scene file's keys for it) and ``PLACED`` (whether it takes a position and an
  orientation);
* ``pack(shape, geom, rotation, pool)``, its sizes into its kernels' row
  (``base.GEOM_WIDTH``), what does not fit there added to ``pool`` (``base.Pool``), whose
  array every kernel below is handed as ``pool``;
* ``support(geoms, pool, c, l0, l1, l2)``, a kernel: how far it reaches from its centre along a
  unit direction given in its own axes, which bounds (``world_kernels.extents``) and the
  plane test of the broad phase read through ``support_of``;
* ``draw(shape)``, the pieces that draw it (``base.PRIMITIVES``: sphere, box, capsule,
  cylinder, plane), which RViz's markers (``ros.collision_markers``) and the pictures of a
  recording (``pictures.render``) read through ``pieces``;
* for a solid kind (not the plane), its core for the convex narrow phase
  (``convex_kernels``): the shape is its core (a point, a segment, itself) rounded by
  ``core_radius(geom)``; ``core_point(geom, pool, l0, l1, l2)`` the core's farthest point along a
  direction in its axes, and ``core_face(geom, pool, l0, l1, l2, out, tags)`` the core's points
  facing that way, in order round the face (a polygon, a segment, a point) with their
  features, read through ``core_point_of`` and the like; and, optional, ``CURVED = True``
  when the core's farthest point turns with every direction (no face, edge or corner: an
  ellipsoid's), which the convex narrow phase reads through ``CURVED`` to refine its normal;
  optional, ``ROUND = True`` when a turn about its centre leaves it as it was (a ball's), which
  the swept test reads through ``ROUND`` (a spinning ball closes on nothing).

The contact tests of each pair of kinds are rows of ``narrow_kernels.PAIR_TESTS``. A new kind
is a module here, its place in ``KINDS``, and its rows there (docs/collisions.md).
"""

from __future__ import annotations

import math  # noqa: F401 - the generated support_of's
from typing import Any, Union

import numpy as np

from rb_sim_ros.contact.shapes import (box, capsule, cylinder, ellipsoid, hull, plane, sphere,
                                       terrain)
from rb_sim_ros.contact.shapes.base import FACE_CAPACITY, GEOM_WIDTH, IDENTITY_XYZW, ORIGIN, Pool
from rb_sim_ros.core.jit import generated_kernel
from rb_sim_ros.core.rigid_body import short

# In narrow-phase rank order: a kind's number is its index.
KINDS = (sphere, capsule, box, plane, cylinder, hull, ellipsoid, terrain)
for _number, _module in enumerate(KINDS):
    if _module.KIND != _number:
        raise ImportError(f'shape kind {_module.NAME!r}: KIND {_module.KIND} is not its place '
                          f'{_number} in shapes.KINDS')
NAMES = tuple(m.NAME for m in KINDS)
BY_NAME = {m.NAME: m for m in KINDS}
# A kind's number by its name (the narrow phase's rank).
RANK = {m.NAME: m.KIND for m in KINDS}
SHAPE_TYPES = tuple(m.VALUE for m in KINDS)
Shape = Union[SHAPE_TYPES]  # type: ignore[valid-type]

Sphere, Capsule, Box, Plane = sphere.Sphere, capsule.Capsule, box.Box, plane.Plane
Cylinder, Hull, Ellipsoid = cylinder.Cylinder, hull.Hull, ellipsoid.Ellipsoid
Terrain = terrain.Terrain


def is_shape(value: Any) -> bool:
    return isinstance(value, SHAPE_TYPES)


def module_of(shape):
    """The module of ``shape``'s kind."""
    return BY_NAME[shape.kind]


def pieces(shape) -> list[tuple]:
    """What draws ``shape``: (primitive, size, position, rotation) in its body's frame, of
    ``base.PRIMITIVES`` (its module's ``draw``)."""
    return BY_NAME[shape.kind].draw(shape)


def kind_of(shape) -> int:
    """The number of ``shape``'s kind."""
    return BY_NAME[shape.kind].KIND


def packed(shape, rotation, pool: Pool) -> np.ndarray:
    """``shape``'s kernel row (GEOM_WIDTH,), its axes in the world being ``rotation`` (3 x 3 or
    9, row-major), what it needs beyond it added to ``pool``."""
    geom = np.zeros(GEOM_WIDTH)
    module_of(shape).pack(shape, geom, np.asarray(rotation, dtype=np.float64).reshape(9), pool)
    return geom


# The support of each kind, chosen by its number (written from KINDS; numba compiles it into
# its callers as the if-chain it is).
def _support_source() -> str:
    lines = ['def support_of(kind, geoms, pool, c, l0, l1, l2):',
             '    """How far the shape of row c of geoms, of kind ``kind``, reaches from its',
             '    centre along the unit direction (l0, l1, l2) in its axes (m); nan for no',
             '    kind."""']
    for m in KINDS:
        lines += [f'    if kind == {m.KIND}:',
                  f'        return {_global_name(m)}.support(geoms, pool, c, l0, l1, l2)']
    lines.append('    return math.nan')
    return '\n'.join(lines) + '\n'


def _global_name(module) -> str:
    """The name this module's globals know ``module`` by (a kind's module is imported here)."""
    name = module.__name__.rpartition('.')[2]
    if globals().get(name) is not module:
        raise ImportError(f'shape kind {module.NAME!r}: its module must be imported in '
                          f'shapes/__init__.py as {name}')
    return name


support_of = generated_kernel(globals(), 'support_of', _support_source())


# Each solid kind's core (written from KINDS, as support_of): what the convex narrow phase
# reads of a kind. The plane has no core (a half-space has no farthest point).
CORE_FACE_CAPACITY = FACE_CAPACITY  # the most points of a core_face (the cylinder's cap)


def _core_source(name: str, args: str, absent: str, doc: str) -> str:
    lines = [f'def {name}_of(kind, {args}):', f'    """{doc}"""']
    for m in KINDS:
        if hasattr(m, 'core_point'):
            lines += [f'    if kind == {m.KIND}:',
                      f'        return {_global_name(m)}.{name}({args})']
    lines.append(f'    return {absent}')
    return '\n'.join(lines) + '\n'


# Whether each kind's core is curved (by number): its module's CURVED, else False.
CURVED = tuple(bool(getattr(m, 'CURVED', False)) for m in KINDS)
# Whether a turn about its centre leaves each kind as it was (by number): its module's ROUND.
ROUND = tuple(bool(getattr(m, 'ROUND', False)) for m in KINDS)

core_radius_of = generated_kernel(globals(), 'core_radius_of', _core_source(
    'core_radius', 'geom', 'math.nan', 'The rounding (m) of the core of a shape of ``kind``.'))
core_point_of = generated_kernel(globals(), 'core_point_of', _core_source(
    'core_point', 'geom, pool, l0, l1, l2', '(math.nan, math.nan, math.nan)',
    'The farthest point of the core of a shape of ``kind`` along (l0, l1, l2), its axes.'))
core_face_of = generated_kernel(globals(), 'core_face_of', _core_source(
    'core_face', 'geom, pool, l0, l1, l2, out, tags', '0',
    'The points of the core of a shape of ``kind`` facing (l0, l1, l2) (unit, its axes), in '
    'out[:n], tags[:n]; n.'))


def world_pose(shape, body_position: np.ndarray,
               body_rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre (m), rotation of the shape's axes), world frame, for a body at ``body_position``
    with rotation ``body_rotation`` (body to world). For a plane the centre is a point of the
    plane and rotation @ normal is its world normal."""
    body_rotation = np.asarray(body_rotation, dtype=float)
    centre = np.asarray(body_position, dtype=float) + body_rotation @ np.array(shape.position)
    return centre, body_rotation @ shape.rotation


def shape_from_dict(data: dict[str, Any]):
    """A shape from ``{'type': <a kind's NAME>, <its FIELDS>, 'position': [m], 'orientation':
    [x, y, z, w], 'restitution', 'friction'}``; unknown or missing keys are errors."""
    if not isinstance(data, dict):
        raise ValueError(f'a collider must be a mapping, got {short(data)}')
    name = data.get('type')
    if not isinstance(name, str) or name not in BY_NAME:
        raise ValueError(f'type must be one of {sorted(BY_NAME)}, got {short(name)}')
    module = BY_NAME[name]
    allowed = set(module.FIELDS) | {'type', 'restitution', 'friction'}
    if module.PLACED:
        allowed |= {'position', 'orientation'}
    unknown = sorted(str(k) for k in set(data) - allowed)
    if unknown:
        raise ValueError(f'{name}: unknown keys {short(unknown)} (allowed: {sorted(allowed)})')
    kwargs = {}
    for key in module.FIELDS:
        if key not in data:
            if not module.PLACED:  # a plane: each field has its default
                continue
            raise ValueError(f'{key} missing (a {name} needs {list(module.FIELDS)})')
        kwargs[key] = data[key]
    if 'position' in data:
        kwargs['position'] = data['position']
    if 'orientation' in data:
        kwargs['orientation_xyzw'] = data['orientation']
    for key in ('restitution', 'friction'):
        if key in data:
            kwargs[key] = data[key]
    return module.VALUE(**kwargs)


def _listed(value):
    """Tuples, nested or not, as lists."""
    return [_listed(v) for v in value] if isinstance(value, tuple) else value


def shape_to_dict(shape) -> dict[str, Any]:
    """The JSON-able form read by ``shape_from_dict`` (placement only when not the identity)."""
    module = module_of(shape)
    out: dict[str, Any] = {'type': shape.kind}
    for key in module.FIELDS:
        out[key] = _listed(getattr(shape, key))
    if module.PLACED:
        if shape.position != ORIGIN:
            out['position'] = list(shape.position)
        if shape.orientation_xyzw != IDENTITY_XYZW:
            out['orientation'] = list(shape.orientation_xyzw)
    for key in ('restitution', 'friction'):
        if getattr(shape, key) is not None:
            out[key] = getattr(shape, key)
    return out
