# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What a body of a run is (``BodySpec``: mass, inertia, initial state, damping, colliders,
application points), and what the layers below are handed for bodies: the core's Steppers,
rows of one ``BodyStore`` (``make_steppers``), and, when a moving body has colliders, the
collision world of them (``collision_world``: its ``ColliderSet`` built from their shapes and
rows). A run whose moving bodies have no colliders has no world (``collides``)."""

from __future__ import annotations

from dataclasses import dataclass
import re
from typing import Any, Sequence

import numpy as np

from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.colliders import ColliderSet, MAX_COLLIDERS, Owner, tests_met
from rb_sim_ros.contact.collision_shapes import is_shape, Plane
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings, MAX_CONTACT_MASS, MIN_CONTACT_MASS
from rb_sim_ros.core import multistep, so3
from rb_sim_ros.core.rigid_body import finite_floats, rate, RigidBody, State
from rb_sim_ros.core.stepper import BodyStore, check_dt, Stepper

__all__ = ['body_at', 'BodySpec', 'collides', 'collision_world', 'colliders_of', 'combined',
           'make_steppers', 'MAX_COLLIDERS', 'pairs_met', 'rebuilt']

# What a body's name may be: it becomes a topic namespace and a frame id (scene.NAME too).
_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]{0,63}\Z')


@dataclass(frozen=True)
class BodySpec:
    """One body of a scene. SI units; vectors in the world frame.

    inertia: 3 principal moments or 9 row-major components of the body-frame tensor (kg m^2).
    initial_*: the state at step 0 and after a reset. linear/angular_damping: rates (1/s).
    static: never moves and costs nothing (infinite mass in contacts). colliders: shapes of
    ``collision_shapes`` in the body frame (a Plane only on a static body); a scene in which no
    moving body has one skips collision detection entirely. points: named application points
    ((name, (x, y, z)) pairs, m, body frame): a wrench sent in a point's frame acts there.
    continuous: when the body is fast, its speculative contacts are swept along its path, so
    that one it would pass does not stop it (``ContactSettings.continuous_speed``).
    """

    name: str = 'body'
    mass: float = 1.0
    inertia: tuple[float, ...] = (0.1, 0.1, 0.1)
    initial_position: tuple[float, ...] = (0.0, 0.0, 0.0)
    initial_orientation_xyzw: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0)
    initial_linear_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    initial_angular_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    linear_damping: float = 0.0
    angular_damping: float = 0.0
    static: bool = False
    colliders: tuple = ()
    points: tuple = ()
    continuous: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(f'name must be an ASCII letter, then ASCII letters, digits and '
                             f'underscores, at most 64 in all (it names topics and a frame), '
                             f'got {self.name!r}')
        inertia = finite_floats('inertia', self.inertia, len(tuple(self.inertia)))
        if len(inertia) not in (3, 9):
            raise ValueError(f'inertia must be 3 principal moments or 9 components, '
                             f'got {len(inertia)} numbers')
        object.__setattr__(self, 'inertia', inertia)
        for name, size in (('initial_position', 3), ('initial_orientation_xyzw', 4),
                           ('initial_linear_velocity', 3), ('initial_angular_velocity', 3)):
            object.__setattr__(self, name, finite_floats(name, getattr(self, name), size))
        for name in ('linear_damping', 'angular_damping'):
            object.__setattr__(self, name, rate(name, getattr(self, name)))
        for name in ('static', 'continuous'):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f'{name} must be true or false, got {getattr(self, name)!r}')
        object.__setattr__(self, 'colliders', tuple(self.colliders))
        for i, c in enumerate(self.colliders):
            if not is_shape(c):
                kinds = ', '.join(m.VALUE.__name__ for m in shapes.KINDS)
                raise ValueError(f'colliders[{i}] must be a shape ({kinds}), got {c!r}')
            if shapes.module_of(c).STATIC_ONLY and not self.static:
                raise ValueError(f'colliders[{i}] is a {c.kind}, which only a static body may '
                                 'have')
        points: list[tuple[str, tuple[float, ...]]] = []
        for i, pair in enumerate(self.points):
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise ValueError(f'points[{i}] must be a (name, [x, y, z]) pair, got {pair!r}')
            name, at = pair
            if not isinstance(name, str) or not _NAME.match(name) or name in (
                    self.name, 'world', 'body'):
                raise ValueError(f'points[{i}]: name must be an ASCII letter, then ASCII '
                                 f"letters, digits and underscores, not the body's name, "
                                 f"'world' or 'body' (it names a frame), got {name!r}")
            if any(name == other for other, _ in points):
                raise ValueError(f"points[{i}]: '{name}' is used twice")
            points.append((name, finite_floats(f"point '{name}'", at, 3)))
        object.__setattr__(self, 'points', tuple(points))
        if len(self.colliders) > MAX_COLLIDERS:
            raise ValueError(f'colliders: {len(self.colliders)}, more than MAX_COLLIDERS = '
                             f'{MAX_COLLIDERS} on one body')
        body = self.body()  # validates mass and inertia
        if self.colliders and not self.static:
            self._check_contact_mass(body)
        self.initial_state()  # validates the orientation

    def _check_contact_mass(self, body: RigidBody) -> None:
        """ValueError unless the mass and principal moments are ones the contact solve can
        take (MIN_CONTACT_MASS to MAX_CONTACT_MASS)."""
        low, high = MIN_CONTACT_MASS, MAX_CONTACT_MASS
        if not low <= self.mass <= high:
            raise ValueError(f'mass: a moving body with colliders needs one in [{low:g}, '
                             f'{high:g}] kg (the contact solve cannot take more or less), got '
                             f'{self.mass!r}')
        moments = body.principal_moments.tolist()
        if not all(low <= m <= high for m in moments):
            raise ValueError(f'inertia: a moving body with colliders needs principal moments '
                             f'in [{low:g}, {high:g}] kg m^2 (the contact solve cannot take '
                             f'more or less), got {moments}')

    def point(self, name: str) -> tuple[float, float, float] | None:
        """The position (m, body frame) of the application point ``name``, or None."""
        for other, at in self.points:
            if other == name:
                return at
        return None

    def body(self) -> RigidBody:
        inertia = (np.array(self.inertia) if len(self.inertia) == 3
                   else np.array(self.inertia).reshape(3, 3))
        return RigidBody(self.mass, inertia)

    def initial_state(self) -> State:
        return State.from_quaternion_xyzw(self.initial_position, self.initial_orientation_xyzw,
                                          self.initial_linear_velocity,
                                          self.initial_angular_velocity)


def make_steppers(bodies, dt: float, integrator: str,
                  gravity) -> tuple[dict[str, Stepper], dict[str, State]]:
    """A Stepper (at its initial state, with its damping) for each moving body of ``bodies``,
    all rows of one ``BodyStore`` (so that they step in one call), and the initial state of
    each static one, by name."""
    steppers: dict[str, Stepper] = {}
    static: dict[str, State] = {}
    store = BodyStore(sum(1 for spec in bodies if not spec.static), check_dt(dt),
                      multistep.method_by_name(integrator))
    for spec in bodies:
        if spec.static:
            static[spec.name] = spec.initial_state()
        else:
            steppers[spec.name] = Stepper(
                spec.body(), dt, spec.initial_state(), method=integrator, gravity=gravity,
                linear_damping=spec.linear_damping, angular_damping=spec.angular_damping,
                store=store)
    return steppers, static


def combined(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, centre of mass m, inertia kg m^2 about it) of rigid parts welded together,
    each (mass, centre, inertia tensor about its own centre), all in one frame: the masses
    summed, the inertias moved to the common centre by the parallel-axis theorem,
    I + m (|d|^2 E - d d^T). A massless whole has its centre at the origin."""
    mass, first = 0.0, np.zeros(3)
    for m, c, _ in parts:
        mass += float(m)
        first += float(m) * np.asarray(c, dtype=float)
    centre = first / mass if mass > 0.0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        d = np.asarray(c, dtype=float) - centre
        inertia += np.asarray(i, dtype=float) + float(m) * (float(d @ d) * np.eye(3)
                                                            - np.outer(d, d))
    return mass, centre, inertia


def body_at(name: str, mass: float, inertia: Sequence[float], rotation: np.ndarray,
            origin: np.ndarray, centre: np.ndarray, colliders: Sequence,
            static: bool = False) -> BodySpec:
    """The body of a model file's frame at ``origin`` (m) turned by ``rotation`` (world),
    whose centre of mass is at ``centre`` in that frame: a body frame with its origin there
    and the model's axes (``mass``, ``inertia`` and ``colliders`` given in it). ValueError
    as BodySpec's."""
    return BodySpec(name, mass, tuple(inertia), static=static,
                    initial_position=tuple((origin + rotation @ centre).tolist()),
                    initial_orientation_xyzw=tuple(
                        so3.quaternion_xyzw_from_matrix(rotation).tolist()),
                    colliders=tuple(colliders))


def collides(bodies: Sequence[BodySpec]) -> bool:
    """Whether a run of ``bodies`` has a collision world: some moving body has colliders (the
    one switch; colliders of static bodies alone touch nothing that moves)."""
    return any(b.colliders and not b.static for b in bodies)


def colliders_of(bodies: Sequence[BodySpec], steppers: dict[str, Stepper],
                 planes: Sequence[Plane] = ()) -> ColliderSet:
    """The colliders of ``bodies`` (a moving one as the row of its Stepper in ``steppers``,
    a static one at its initial pose) and the world's ``planes``."""
    return ColliderSet([Owner(b.name, b.colliders, pose=b.initial_state()) if b.static else
                        Owner(b.name, b.colliders, row=steppers[b.name].row,
                              continuous=b.continuous)
                        for b in bodies if b.colliders], planes)


def pairs_met(bodies: Sequence[BodySpec], planes: Sequence[Plane] = ()) -> int:
    """The contact tests (a set of ``narrow_kernels.PAIR_BIT``) a world of ``bodies`` and
    ``planes`` can call (``ColliderSet.tests`` of their colliders, without building them)."""
    return tests_met([b.colliders for b in bodies], [not b.static for b in bodies],
                     len(planes))


def collision_world(bodies: Sequence[BodySpec], dt: float, gravity: Any = (0.0, 0.0, 0.0),
                    planes: Sequence[Plane] = (), integrator: str = 'eq27',
                    contact: ContactSettings = ContactSettings(),
                    pair_tests: int | None = None) -> CollisionWorld:
    """The collision world of ``bodies`` (``BodySpec``, names unique, a moving one with
    colliders among them) at their initial states, with ``planes`` of the world frame,
    ``gravity`` (m/s^2), the ``integrator`` of multistep.METHODS and the ``contact``
    settings; ``pair_tests`` as ``CollisionWorld`` takes it. ValueError naming what is wrong,
    before anything is built."""
    bodies = _checked(bodies)
    gravity = finite_floats('gravity', gravity, 3)
    planes = tuple(planes)
    for i, p in enumerate(planes):
        if not isinstance(p, Plane):
            raise ValueError(f'planes[{i}] must be a Plane, got {p!r}')
    if not collides(bodies):
        raise ValueError('no moving body has colliders: a run of these bodies has no '
                         'collision world (step their Steppers: make_steppers)')
    if not isinstance(contact, ContactSettings):
        raise ValueError(f'contact must be a ContactSettings, got {contact!r}')
    steppers, _ = make_steppers(bodies, dt, integrator, gravity)
    return CollisionWorld(steppers, colliders_of(bodies, steppers, planes), contact,
                          pair_tests)


def rebuilt(world: CollisionWorld, bodies: Sequence[BodySpec], recheck: bool,
            gravity: Any) -> CollisionWorld:
    """A world of ``bodies`` with ``world``'s dt, method, planes and contact settings that
    goes on from it: the bodies of both keep their motion bit for bit (``Stepper.take_over``),
    sleep state, the velocities their accelerations are read against and their contacts'
    warm starts; a new body starts at its initial state (under ``gravity``) on the world's
    clock. ``recheck``: check contacts before the next step integrates (as after a
    teleport: a new body may touch). ``world`` is left as it was; ValueError (nothing
    built) for bad bodies."""
    new = collision_world(bodies, world.dt, gravity, world.colliders.planes,
                          world.store.method.name, world.contact)
    new.carry(world, world.steppers, world.step_count, recheck)
    return new


def _checked(bodies: Sequence[BodySpec]) -> tuple[BodySpec, ...]:
    bodies = tuple(bodies)
    if not bodies or not all(isinstance(b, BodySpec) for b in bodies):
        raise ValueError('bodies must be one or more BodySpec')
    names = [b.name for b in bodies]
    if len(set(names)) != len(names):
        raise ValueError(f'body names must be unique, got {names}')
    return bodies
