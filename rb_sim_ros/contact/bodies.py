# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What a body of a run is (``BodySpec``: mass, inertia, initial state, damping, colliders)
and how bodies that touch respond (``ContactSettings``); ``make_steppers`` builds the core's
Steppers for them. The collision world and a simulation's configuration both use these."""

from __future__ import annotations

from dataclasses import dataclass, fields
import re
from typing import Any

import numpy as np

from rb_sim_ros.contact import contact_solver
from rb_sim_ros.contact import shapes
from rb_sim_ros.contact.collision_shapes import is_shape
from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import finite_floats, non_negative, rate, RigidBody, State
from rb_sim_ros.core.stepper import BodyStore, check_dt, Stepper


# What a body's name may be: it becomes a topic namespace and a frame id (scene.NAME too).
_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]{0,63}\Z')
# The most colliders of one body. Two bodies' colliders make up to MAX_COLLIDERS^2 = 4096
# candidate pairs where they overlap (350 each made 122,500 contacts and an 18 s step); a
# compound shape needs a handful (a dumbbell 3, a table 5, a robot link a dozen).
MAX_COLLIDERS = 64
# The masses (kg) and principal moments (kg m^2) of a moving body with colliders: the contact
# solve forms 1 / m, the world inverse inertia R diag(1 / I) R^T and, for its energy guard,
# the inertia back from it through its determinant, a product of three inverse moments. At
# 1e-200 kg that product overflowed, the guard read nan for every body in contact and let
# the others gain energy. Within these bounds every such product (at most 1e180, at least
# 1e-180) and every ratio of two masses in contact (1e120) is a normal float; a dust grain
# (1e-15 kg) and a planet (6e24 kg) are both inside.
MIN_CONTACT_MASS, MAX_CONTACT_MASS = 1e-60, 1e60
# The most Gauss-Seidel iterations of either pass a run may ask for (each is a pass over all
# contacts): a scene file's bound, and a recording's config's too (which reached the solver's
# 2^31 - 1 before).
MAX_ITERATIONS = 1000


@dataclass(frozen=True)
class BodySpec:
    """One body of a scene. SI units; vectors in the world frame.

    inertia: 3 principal moments or 9 row-major components of the body-frame tensor (kg m^2).
    initial_*: the state at step 0 and after a reset. linear/angular_damping: rates (1/s).
    static: never moves and costs nothing (infinite mass in contacts). colliders: shapes of
    ``collision_shapes`` in the body frame (a Plane only on a static body); a scene in which no
    moving body has one skips collision detection entirely. points: named application points
    ((name, (x, y, z)) pairs, m, body frame): a wrench sent in a point's frame acts there.
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
        if not isinstance(self.static, bool):
            raise ValueError(f'static must be true or false, got {self.static!r}')
        object.__setattr__(self, 'colliders', tuple(self.colliders))
        for i, c in enumerate(self.colliders):
            if not is_shape(c):
                kinds = ', '.join(m.VALUE.__name__ for m in shapes.KINDS)
                raise ValueError(f'colliders[{i}] must be a shape ({kinds}), got {c!r}')
            if shapes.module_of(c).STATIC_ONLY and not self.static:
                raise ValueError(f'colliders[{i}] is a {c.kind}, which only a static body may '
                                 'have')
        points = []
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


@dataclass(frozen=True)
class ContactSettings:
    """How bodies with colliders respond when they touch (docs/collisions.md): restitution e
    in [0, 1], Coulomb friction mu >= 0, of every collider without a material of its own;
    Gauss-Seidel iterations of the velocity and the position pass; slop (m) of penetration
    left uncorrected; position_fraction of the rest corrected per step; rolling_resistance
    (m): the lever arm of the moment that resists rolling (0: balls roll for ever);
    torsional_friction (m): that of the moment resisting spin about the contact normal;
    approaches slower than bounce_threshold (m/s) do not bounce (keep it above |g| dt);
    tolerance (m/s): a Gauss-Seidel pass stops after an iteration that changed no contact's
    velocity by more (the position pass: by more than tolerance dt, in m); speculative
    contacts keep fast bodies from tunnelling; warm_start: each solve starts from the
    impulses of the same contacts at the step before. A body pressed by a contact whose
    points all move slower than sleep_speed (m/s) for sleep_time (s) sleeps, at rest and at
    no cost, until an awake body comes near, its wrench changes or it is teleported
    (sleep_time 0: never). Unused by a scene without colliders.

    The one place a world's contact settings are given and checked (a scene's ``contact:``,
    ``Config.contact``, ``CollisionWorld(contact=...)``); the solver's view of them, with
    the step, is ``solver_settings(dt)``."""

    restitution: float = 0.0
    friction: float = 0.5
    velocity_iterations: int = 10
    position_iterations: int = 4
    slop: float = 1e-4
    position_fraction: float = 0.8
    bounce_threshold: float = 0.1
    tolerance: float = 1e-6
    speculative: bool = True
    warm_start: bool = True
    sleep_time: float = 0.5
    sleep_speed: float = 1e-3
    rolling_resistance: float = 0.0
    torsional_friction: float = 0.0

    def __post_init__(self) -> None:
        for name in ('speculative', 'warm_start'):
            flag = getattr(self, name)
            if not isinstance(flag, bool):
                raise ValueError(f'{name} must be true or false, got {flag!r}')
        for name in ('sleep_time', 'sleep_speed'):
            non_negative(name, getattr(self, name))
        for name in ('velocity_iterations', 'position_iterations'):
            value = getattr(self, name)
            if (not isinstance(value, int) or isinstance(value, bool)
                    or not 0 <= value <= MAX_ITERATIONS):
                raise ValueError(f'{name} must be an integer in [0, {MAX_ITERATIONS}] '
                                 f'(MAX_ITERATIONS), got {value!r}')
        self.solver_settings(contact_solver.SolverSettings.dt)  # validates the rest

    def solver_settings(self, dt: float) -> contact_solver.SolverSettings:
        """What the solver reads of these, with the step ``dt`` (s): its settings array is
        made from it (``contact_solver.settings_array``)."""
        return contact_solver.SolverSettings(dt=dt, **{
            f.name: getattr(self, f.name) for f in fields(self)
            if f.name in contact_solver.SolverSettings.__dataclass_fields__})

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> 'ContactSettings':
        if not isinstance(data, dict):
            raise ValueError(f'contact must be a mapping, got {data!r}')
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f'unknown contact keys {unknown} (known: '
                             f'{sorted(cls.__dataclass_fields__)})')
        return cls(**data)


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
