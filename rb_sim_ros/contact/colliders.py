# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The colliders of a collision world, built once from shapes and the rows that own them
(as Rapier's collider set is built apart from its pipeline): what the world's step reads of
them that never changes (kinds, kernel rows, offsets in their bodies, owners, the static
ones placed in the world, materials), and the ids a rebuilt world matches its warm starts by.

    colliders = ColliderSet([Owner('ball', (Sphere(0.1),), row=0),
                             Owner('ground', (Plane((0.0, 0.0, 1.0), 0.0),), pose=State())])

An ``Owner`` is a body that carries colliders: a moving one is a row of the world's
``BodyStore`` (``row``), a static one has a fixed ``pose`` in the world. ``planes`` are
planes of the world frame owned by no body. The set is read, never written: a world copies
what its step moves (the placed colliders, their bounds).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rb_sim_ros.contact import narrow_kernels as nk
from rb_sim_ros.contact import shapes
from rb_sim_ros.contact import world_kernels as wk
from rb_sim_ros.contact.collision_shapes import is_shape, Plane
from rb_sim_ros.core.rigid_body import State

# The most colliders of one body. Two bodies' colliders make up to MAX_COLLIDERS^2 = 4096
# candidate pairs where they overlap (350 each made 122,500 contacts and an 18 s step); a
# compound shape needs a handful (a dumbbell 3, a table 5, a robot link a dozen).
MAX_COLLIDERS = 64


@dataclass(frozen=True)
class Owner:
    """A body that carries colliders: ``name``, ``shapes`` (of ``collision_shapes``, in its
    frame), and either ``row``, its row of the world's BodyStore (a moving body), or ``pose``,
    its fixed state in the world (a static body). ``continuous``: a moving body's speculative
    contacts are swept along its path when it is fast (``ContactSettings.continuous_speed``)."""

    name: str
    shapes: tuple
    row: int | None = None
    pose: State | None = None
    continuous: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f'owner name must be a non-empty string (planes of the world '
                             f"are owned by ''), got {self.name!r}")
        object.__setattr__(self, 'shapes', tuple(self.shapes))
        if not self.shapes or len(self.shapes) > MAX_COLLIDERS:
            raise ValueError(f"owner '{self.name}': 1 to MAX_COLLIDERS = {MAX_COLLIDERS} "
                             f'shapes, got {len(self.shapes)}')
        for i, c in enumerate(self.shapes):
            if not is_shape(c):
                raise ValueError(f"owner '{self.name}': shapes[{i}] is not a shape: {c!r}")
        if not isinstance(self.continuous, bool):
            raise ValueError(f"owner '{self.name}': continuous must be true or false, got "
                             f'{self.continuous!r}')
        if (self.row is None) == (self.pose is None):
            raise ValueError(f"owner '{self.name}': give a row (moving) or a pose (static), "
                             'not both or neither')
        if self.row is not None:
            if isinstance(self.row, bool) or not isinstance(self.row, int) or self.row < 0:
                raise ValueError(f"owner '{self.name}': row must be an int >= 0, got "
                                 f'{self.row!r}')
            for i, c in enumerate(self.shapes):
                if shapes.module_of(c).STATIC_ONLY:
                    raise ValueError(f"owner '{self.name}': shapes[{i}] is a {c.kind}, which "
                                     'only a static body may have')
        elif not isinstance(self.pose, State):
            raise ValueError(f"owner '{self.name}': pose must be a State, got {self.pose!r}")

    @property
    def moving(self) -> bool:
        return self.row is not None


class ColliderSet:
    """The colliders of ``owners`` (moving and static bodies, in the order given: the
    numbering of colliders follows it) and the world's ``planes``.

    Read by the world: ``moving`` (the moving owners; a world's body i is ``moving[i]``, its
    store row ``rows[i]``), ``kinds`` and ``geoms`` (colliders then planes, the narrow
    phase's rows), ``pool`` (what their kinds keep beyond their rows: ``shapes.Pool``),
    ``body`` (each collider's moving body, or len(moving) for a static one),
    ``owner`` (its owner's index, what the broad phase keeps apart), ``local_position`` and
    ``local_rotation9`` (in its body), ``reach`` (each moving body's colliders' reach from its
    centre of mass), ``centres``, ``rotations9``, ``lower`` and ``upper`` (colliders then
    planes placed in the world: a static one where it is, a moving one's rows filled by the
    step), ``plane_normals`` and ``plane_points``, ``ids`` ((owner name, index among its
    shapes), or ('', k) for ``planes[k]``)."""

    def __init__(self, owners: Sequence[Owner], planes: Sequence[Plane] = ()) -> None:
        owners, planes = tuple(owners), tuple(planes)
        for i, o in enumerate(owners):
            if not isinstance(o, Owner):
                raise ValueError(f'owners[{i}] must be an Owner, got {o!r}')
        names = [o.name for o in owners]
        if len(set(names)) != len(names):
            raise ValueError(f'owner names must be unique, got {names}')
        rows = [o.row for o in owners if o.row is not None]
        if len(set(rows)) != len(rows):
            raise ValueError(f'owner rows must be unique, got {rows}')
        for i, p in enumerate(planes):
            if not isinstance(p, Plane):
                raise ValueError(f'planes[{i}] must be a Plane, got {p!r}')
        self.owners, self.planes = owners, planes
        self.moving = tuple(o for o in owners if o.moving)
        self.rows = np.array([o.row for o in self.moving], dtype=np.int64)
        self.continuous = np.array([o.continuous for o in self.moving], dtype=bool)
        nb = len(self.moving)
        body_of = {o.name: i for i, o in enumerate(self.moving)}
        # Colliders (not planes) as (shape, owner index, moving body or nb, position and
        # rotation: in the body for a moving one, in the world for a static one).
        colliders = []
        normals, points, plane_owner, plane_shapes = [], [], [], []
        ids, plane_ids = [], []
        for owner, o in enumerate(owners):
            for k, shape in enumerate(o.shapes):
                (plane_ids if isinstance(shape, Plane) else ids).append((o.name, k))
            if o.pose is not None:
                st = o.pose
                for shape in o.shapes:
                    centre, rot = (st.position + st.rotation @ np.array(shape.position),
                                   st.rotation @ shape.rotation)
                    if isinstance(shape, Plane):
                        normals.append(rot @ np.array(shape.normal))
                        points.append(centre)
                        plane_owner.append(owner)
                        plane_shapes.append(shape)
                    else:
                        colliders.append((shape, owner, nb, centre, rot))
            else:
                for shape in o.shapes:
                    colliders.append((shape, owner, body_of[o.name],
                                      np.array(shape.position, dtype=float),
                                      np.array(shape.rotation)))
        for k, p in enumerate(planes):
            plane_ids.append(('', k))
            normals.append(np.array(p.normal))
            points.append(np.array(p.position))
            plane_owner.append(-1)
            plane_shapes.append(p)
        self.ids = tuple(ids + plane_ids)
        self.shapes = tuple(c[0] for c in colliders) + tuple(plane_shapes)
        # The owner of each collider then plane (-1: a plane of ``planes``).
        self.owner_of = tuple(c[1] for c in colliders) + tuple(plane_owner)
        self.count = nc = len(colliders)
        npl = len(normals)
        self.plane_normals = np.array(normals, dtype=float).reshape(-1, 3)
        self.plane_points = np.array(points, dtype=float).reshape(-1, 3)
        self.body = np.array([c[2] for c in colliders], dtype=np.int64)
        self.owner = np.array([c[1] for c in colliders], dtype=np.int64)
        self.static = self.body == nb
        self.dynamic = np.flatnonzero(~self.static)
        self.local_position = np.array([c[3] for c in colliders]).reshape(-1, 3)
        local_rotation = np.array([c[4] for c in colliders]).reshape(-1, 3, 3)
        self.local_rotation9 = np.ascontiguousarray(local_rotation.reshape(-1, 9))
        # Colliders then planes, as the kernels take them: kinds and rows (each kind's module
        # packs its sizes; a plane's row is its world normal).
        self.kinds = np.array([shapes.kind_of(c[0]) for c in colliders]
                              + [nk.KIND_PLANE] * npl, dtype=np.int64)
        self.geoms = np.zeros((nc + npl, nk.GEOM_WIDTH))
        pool = shapes.Pool()
        for k, c in enumerate(colliders):
            self.geoms[k] = shapes.packed(c[0], c[4], pool)
        self.pool = pool.array()
        self.geoms[nc:, nk.NORMAL:nk.NORMAL + 3] = self.plane_normals
        reach = np.zeros(nb)
        for shape, _, body, position, _ in colliders:
            if body < nb:
                r = float(np.linalg.norm(position)) + shape.bounding_radius
                reach[body] = max(reach[body], r)
        self.reach = reach
        # How far a turn about the centre of mass can move each moving body's colliders'
        # surfaces: a ball's centre moves, its surface does not move relative to it (the swept
        # test's bound: a spinning ball closes on nothing).
        turn_reach = np.zeros(nb)
        for shape, _, body, position, _ in colliders:
            if body < nb:
                r = float(np.linalg.norm(position)) + (
                    0.0 if shapes.ROUND[shapes.kind_of(shape)] else shape.bounding_radius)
                turn_reach[body] = max(turn_reach[body], r)
        self.turn_reach = turn_reach
        # Placed in the world (centres, rotations as 9 row-major values): a static collider
        # where it is, a moving one at the origin until the first step places it; then the
        # planes (a plane's centre: a point of it).
        centres = np.array([c[3] if c[2] == nb else np.zeros(3)
                            for c in colliders]).reshape(-1, 3)
        rotations9 = np.array([c[4] if c[2] == nb else np.eye(3)
                               for c in colliders]).reshape(-1, 9)
        self.lower = np.zeros((nc, 3))
        self.upper = np.zeros((nc, 3))
        for c in np.flatnonzero(self.static).tolist():
            wk.extents(c, rotations9, self.kinds, self.geoms, self.pool, 0.0, centres,
                       self.lower, self.upper)
        self.centres = np.concatenate([centres, self.plane_points])
        self.rotations9 = np.concatenate([rotations9, np.tile(np.eye(3).reshape(9), (npl, 1))])
        # (Left writable: the compiled step is typed for writable C arrays, and a read-only
        # one would be another signature, compiled again. Nothing writes them: a world copies
        # what its step moves.)

    def __len__(self) -> int:
        """Colliders and planes."""
        return len(self.kinds)

    def tests(self) -> int:
        """The contact tests (a set of ``narrow_kernels.PAIR_BIT``) a world of these colliders
        can call: those of the kinds of a moving body's collider and another body's."""
        return tests_met([o.shapes for o in self.owners], [o.moving for o in self.owners],
                         len(self.planes))

    def materials(self, restitution: float, friction: float):
        """(restitution, friction, given): each collider's and plane's, the world's
        ``restitution`` and ``friction`` where a shape has none; ``given``: whether any shape
        has one (else the solver uses the world's alone)."""
        every = self.shapes
        given = any(sh.restitution is not None or sh.friction is not None for sh in every)
        if not given:
            return (np.full(len(every), restitution), np.full(len(every), friction), False)
        return (np.array([restitution if sh.restitution is None else sh.restitution
                          for sh in every], dtype=float),
                np.array([friction if sh.friction is None else sh.friction for sh in every],
                         dtype=float), True)


def tests_met(shapes_of: Sequence[Sequence], moving: Sequence[bool], planes: int = 0) -> int:
    """The contact tests (a set of ``narrow_kernels.PAIR_BIT``) that bodies carrying the shapes
    ``shapes_of`` (one sequence per body; ``moving``: whether it moves) and ``planes`` planes
    of the world can call: those of the kinds of a moving body's collider and another body's
    (``narrow_kernels.pair_set``)."""
    kinds = [[shapes.kind_of(sh) for sh in group] for group in shapes_of]
    return nk.pair_set(kinds + [[nk.KIND_PLANE] * planes], list(moving) + [False])
