# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A simulation run: a configuration, a stepper, and inputs that take effect at a step.

This is what the node drives and what ``replay`` re-runs offline: the node turns ROS messages
into the events below and applies each at a step boundary; a recording stores the
configuration, every event with the step at which it took effect, and the outputs. Because the
stepper is deterministic and time is only ``step * dt``, the same configuration and the same
events at the same steps reproduce a run bit for bit, whatever the scheduling was. No ROS here.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
import re
from typing import Any, Union

import numpy as np

from rb_sim_ros import contact_solver, multistep
from rb_sim_ros.collision_shapes import is_shape, Plane, shape_from_dict, shape_to_dict
from rb_sim_ros.rigid_body import (finite_floats, non_negative, rate, RigidBody, State, Wrench,
                                   ZERO_WRENCH)
from rb_sim_ros.stepper import step_all, Stepper


# What a body's name may be: it becomes a topic namespace and a frame id (scene.NAME too).
_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]{0,63}\Z')


@dataclass(frozen=True)
class BodySpec:
    """One body of a scene. SI units; vectors in the world frame.

    inertia: 3 principal moments or 9 row-major components of the body-frame tensor (kg m^2).
    initial_*: the state at step 0 and after a reset. linear/angular_damping: rates (1/s).
    static: never moves and costs nothing (infinite mass in contacts). colliders: shapes of
    ``collision_shapes`` in the body frame (a Plane only on a static body); a scene in which no
    moving body has one skips collision detection entirely.
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
                raise ValueError(f'colliders[{i}] must be a Sphere, Box, Capsule or Plane, '
                                 f'got {c!r}')
            if isinstance(c, Plane) and not self.static:
                raise ValueError(f'colliders[{i}] is a Plane, which only a static body may '
                                 'have')
        self.body()  # validates mass and inertia
        self.initial_state()  # validates the orientation

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
    speculative contacts keep fast bodies from tunnelling. A body pressed by a contact whose
    points all move slower than sleep_speed (m/s) for sleep_time (s) sleeps, at rest and at
    no cost, until an awake body comes near, its wrench changes or it is teleported
    (sleep_time 0: never). Unused by a scene without colliders."""

    restitution: float = 0.0
    friction: float = 0.5
    velocity_iterations: int = 10
    position_iterations: int = 4
    slop: float = 1e-4
    position_fraction: float = 0.8
    bounce_threshold: float = 0.1
    speculative: bool = True
    sleep_time: float = 0.5
    sleep_speed: float = 1e-3
    rolling_resistance: float = 0.0
    torsional_friction: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.speculative, bool):
            raise ValueError(f'speculative must be true or false, got {self.speculative!r}')
        for name in ('sleep_time', 'sleep_speed'):
            non_negative(name, getattr(self, name))
        contact_solver.SolverSettings(**{  # validates the rest
            f.name: getattr(self, f.name) for f in fields(self)
            if f.name in contact_solver.SolverSettings.__dataclass_fields__})

    def world_arguments(self) -> dict[str, Any]:
        """Keyword arguments of ``collision_world.CollisionWorld``."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> 'ContactSettings':
        if not isinstance(data, dict):
            raise ValueError(f'contact must be a mapping, got {data!r}')
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f'unknown contact keys {unknown} (known: '
                             f'{sorted(cls.__dataclass_fields__)})')
        return cls(**data)


@dataclass(frozen=True)
class Config:
    """Everything needed to (re-)simulate a run: the scene and the clock.

    dt: physics step (s); steps_per_publish: physics steps between two published states;
    integrator: a name of multistep.METHODS; gravity: m/s^2, world frame; bodies: at least one,
    names unique; contact: the response of bodies with colliders.
    """

    dt: float = 1e-3
    steps_per_publish: int = 10
    integrator: str = multistep.EQ27.name
    gravity: tuple[float, ...] = (0.0, 0.0, 0.0)
    bodies: tuple[BodySpec, ...] = (BodySpec(),)
    contact: ContactSettings = ContactSettings()

    def __post_init__(self) -> None:
        if (not isinstance(self.steps_per_publish, int) or isinstance(self.steps_per_publish, bool)
                or self.steps_per_publish < 1):
            raise ValueError(
                f'steps_per_publish must be an int >= 1, got {self.steps_per_publish!r}')
        multistep.method_by_name(self.integrator)
        object.__setattr__(self, 'gravity', finite_floats('gravity', self.gravity, 3))
        bodies = tuple(self.bodies)
        if not bodies or not all(isinstance(b, BodySpec) for b in bodies):
            raise ValueError('bodies must be one or more BodySpec')
        names = [b.name for b in bodies]
        if len(set(names)) != len(names):
            raise ValueError(f'body names must be unique, got {names}')
        object.__setattr__(self, 'bodies', bodies)
        if not isinstance(self.contact, ContactSettings):
            raise ValueError(f'contact must be a ContactSettings, got {self.contact!r}')
        Stepper(bodies[0].body(), self.dt)  # validates dt

    def body(self, name: str = '') -> BodySpec:
        """The body called ``name`` ('' = the first)."""
        if not name:
            return self.bodies[0]
        for b in self.bodies:
            if b.name == name:
                return b
        raise ValueError(f"no body named '{name}' (have {[b.name for b in self.bodies]})")

    @property
    def collides(self) -> bool:
        """Whether any body has a collider (else no collision code runs at all)."""
        return any(b.colliders for b in self.bodies)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form; floats are written with repr, so a round trip is exact."""
        def plain(v):
            return list(v) if isinstance(v, tuple) else v
        out = {k: plain(v) for k, v in self.__dict__.items() if k not in ('bodies', 'contact')}
        out['bodies'] = [{k: ([shape_to_dict(c) for c in v] if k == 'colliders' else plain(v))
                          for k, v in b.__dict__.items()} for b in self.bodies]
        out['contact'] = dict(self.contact.__dict__)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> 'Config':
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f'unknown configuration keys {sorted(unknown)}')
        data = dict(data)
        bodies = []
        for b in data.pop('bodies', [{}]):
            unknown = set(b) - set(BodySpec.__dataclass_fields__)
            if unknown:
                raise ValueError(f'unknown body keys {sorted(unknown)}')
            b = dict(b)
            colliders = tuple(shape_from_dict(c) for c in b.pop('colliders', ()))
            bodies.append(BodySpec(colliders=colliders,
                                   **{k: (tuple(v) if isinstance(v, list) else v)
                                      for k, v in b.items()}))
        # Recordings made before collisions existed have no 'contact': the defaults.
        contact = ContactSettings.from_dict(data.pop('contact', {}))
        return cls(bodies=tuple(bodies), contact=contact,
                   **{k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()})


@dataclass(frozen=True)
class SetWrench:
    """Hold ``wrench`` on ``body`` ('' = the first) from this step on."""

    wrench: Wrench
    body: str = ''


@dataclass(frozen=True)
class SetPose:
    """Teleport: position (m) and orientation (x, y, z, w), world frame; velocities kept."""

    position: tuple[float, ...]
    orientation_xyzw: tuple[float, ...]
    body: str = ''


@dataclass(frozen=True)
class SetTwist:
    """Teleport: linear (m/s) and angular (rad/s) velocity, world frame; pose kept."""

    linear: tuple[float, ...]
    angular: tuple[float, ...]
    body: str = ''


@dataclass(frozen=True)
class Reset:
    """Zero the wrench of ``body`` and jump to a state: the given one (world frame: position m,
    orientation x-y-z-w, linear m/s, angular rad/s), or else the body's initial one."""

    position: tuple[float, ...] | None = None
    orientation_xyzw: tuple[float, ...] | None = None
    linear: tuple[float, ...] | None = None
    angular: tuple[float, ...] | None = None
    body: str = ''

    @classmethod
    def to_initial(cls, spec: BodySpec) -> 'Reset':
        """A reset of ``spec`` to its initial state, spelled out (so a recording holds it)."""
        return cls(spec.initial_position, spec.initial_orientation_xyzw,
                   spec.initial_linear_velocity, spec.initial_angular_velocity, spec.name)

    def state(self, spec: BodySpec) -> State:
        if self.position is None:
            return spec.initial_state()
        return State.from_quaternion_xyzw(self.position, self.orientation_xyzw, self.linear,
                                          self.angular)


Event = Union[SetWrench, SetPose, SetTwist, Reset]


def make_steppers(bodies, dt: float, integrator: str,
                  gravity) -> tuple[dict[str, Stepper], dict[str, State]]:
    """A Stepper (at its initial state, with its damping) for each moving body of ``bodies``,
    and the initial state of each static one, by name."""
    steppers: dict[str, Stepper] = {}
    static: dict[str, State] = {}
    for spec in bodies:
        if spec.static:
            static[spec.name] = spec.initial_state()
        else:
            steppers[spec.name] = Stepper(
                spec.body(), dt, spec.initial_state(), method=integrator, gravity=gravity,
                linear_damping=spec.linear_damping, angular_damping=spec.angular_damping)
    return steppers, static


class Simulation:
    """A run of ``config``: apply events at step boundaries, advance all bodies, read them.

    Bodies marked static get no stepper: they cost nothing and never move. ``stepper`` is the
    first body's (the single-body case); ``steppers`` maps every moving body's name to its own.
    When a body has colliders, ``world`` is the ``collision_world.CollisionWorld`` that steps
    them (its Steppers are ``steppers``) and teleports go through it; else ``world`` is None
    and no collision code runs.
    """

    def __init__(self, config: Config) -> None:
        self.config = config
        self._step_count = 0
        self.world = None
        if config.collides:
            # Imported here: collision_world builds on this module's BodySpec and Config.
            from rb_sim_ros.collision_world import CollisionWorld
            self.world = CollisionWorld.from_config(config, **config.contact.world_arguments())
            self.steppers = self.world.steppers
            self.static = self.world.static
        else:
            self.steppers, self.static = make_steppers(config.bodies, config.dt,
                                                       config.integrator, config.gravity)
        self._moving = tuple(self.steppers.values())

    @property
    def stepper(self) -> Stepper:
        return self.steppers[self.config.bodies[0].name]

    @property
    def step_count(self) -> int:
        return self._step_count

    @property
    def time_ns(self) -> int:
        """Simulated time in integer nanoseconds: step_count * dt, rounded."""
        return round(self._step_count * self.config.dt * 1e9)

    def pose_twist(self, name: str = ''):
        """(position, quaternion x-y-z-w, linear velocity, angular velocity) of a body, world."""
        name = name or self.config.bodies[0].name
        if name in self.steppers:
            return self.steppers[name].pose_twist()
        if name in self.static:
            st = self.static[name]
            return (tuple(st.position), tuple(st.quaternion_xyzw), (0.0, 0.0, 0.0),
                    (0.0, 0.0, 0.0))
        raise ValueError(f"no body named '{name}'")

    def apply(self, event: Event) -> None:
        """Apply ``event`` now: it takes effect from the next step. Validated first."""
        if not isinstance(event, (SetWrench, SetPose, SetTwist, Reset)):
            raise ValueError(f'event must be SetWrench, SetPose, SetTwist or Reset, '
                             f'got {event!r}')
        spec = self.config.body(event.body)
        if spec.static:
            raise ValueError(f"body '{spec.name}' is static")
        s = self.steppers[spec.name]
        if isinstance(event, SetWrench):
            s.set_wrench(event.wrench)
            return
        old = s.state
        if isinstance(event, SetPose):
            state = State.from_quaternion_xyzw(event.position, event.orientation_xyzw,
                                               old.linear_velocity, old.angular_velocity)
        elif isinstance(event, SetTwist):
            state = State(old.position, old.rotation, event.linear, event.angular)
        else:
            state = event.state(spec)
            s.set_wrench(ZERO_WRENCH)
        if self.world is not None:
            self.world.set_state(spec.name, state)  # contacts are checked before the next step
        else:
            s.set_state(state)

    def run(self, n: int) -> None:
        """Advance every moving body n steps. If one goes non-finite the others still advance
        and its IntegrationError is raised after (it stays at its last finite state). With
        collisions, the run stops after the step that raised."""
        if self.world is not None:
            try:
                self.world.step(n)
            finally:
                self._step_count = self.world.step_count
            return
        try:
            step_all(self._moving, n)
        finally:
            self._step_count += n

    def run_until(self, step: int, events: list[tuple[int, Event]]) -> list[tuple[int, Event]]:
        """Advance to ``step``, applying each (step, event) of ``events`` (sorted by step) when
        the simulation is at its step, before stepping on. Events at ``step`` itself are left
        pending (returned with the later ones): the state read at ``step`` is the one before
        them, as the node publishes it."""
        i = 0
        while self.step_count < step:
            while i < len(events) and events[i][0] <= self.step_count:
                if events[i][0] < self.step_count:
                    raise ValueError(f'event at step {events[i][0]} is in the past '
                                     f'(now at step {self.step_count})')
                self.apply(events[i][1])
                i += 1
            due = events[i][0] if i < len(events) else step
            self.run(min(due, step) - self.step_count)
        if i < len(events) and events[i][0] < self.step_count:
            raise ValueError(f'event at step {events[i][0]} is in the past '
                             f'(now at step {self.step_count})')
        return events[i:]
