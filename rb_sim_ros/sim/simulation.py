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

from dataclasses import dataclass, fields, replace
import math
from typing import Any, Union

import numpy as np

from rb_sim_ros.contact import world_step
from rb_sim_ros.contact.collision_shapes import shape_from_dict, shape_to_dict, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import multistep, step_kernel as K
from rb_sim_ros.core.rigid_body import finite_floats, State, Wrench, ZERO_WRENCH
from rb_sim_ros.core.stepper import carry_over, check_dt, Stepper, Stepping
from rb_sim_ros.sim.bodies import (BodySpec, colliders_of, collides, make_steppers,
                                   MAX_COLLIDERS, pairs_met)

__all__ = ['BodySpec', 'body_from_dict', 'body_to_dict', 'Config', 'ContactSettings', 'Delete',
           'Event', 'make_steppers', 'Reset', 'SetPose', 'SetTwist', 'SetWrench', 'Simulation',
           'Spawn', 'MAX_BODIES', 'warm_up_bodies', 'warm_up_contacts',
           'contact_probe', 'kernels_after', 'contact_tests', 'config_after']


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
        check_dt(self.dt)

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
        """Whether a collision world steps the run: some moving body has colliders (else no
        collision code runs at all; colliders of static bodies alone touch nothing that
        moves). The one switch (``bodies.collides``)."""
        return collides(self.bodies)

    @property
    def has_colliders(self) -> bool:
        """Whether any body, static or moving, has a collider (something to draw)."""
        return any(b.colliders for b in self.bodies)

    @property
    def moving_bodies(self) -> tuple[BodySpec, ...]:
        """The bodies that are not static: those a step moves (and a collision world steps
        when one of them has colliders)."""
        return tuple(b for b in self.bodies if not b.static)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form; floats are written with repr, so a round trip is exact."""
        def plain(v):
            return list(v) if isinstance(v, tuple) else v
        out = {k: plain(v) for k, v in self.__dict__.items() if k not in ('bodies', 'contact')}
        out['bodies'] = [body_to_dict(b) for b in self.bodies]
        out['contact'] = dict(self.contact.__dict__)
        if out['contact']['continuous_speed'] == math.inf:  # (JSON has no infinity)
            out['contact']['continuous_speed'] = None
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> 'Config':
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f'unknown configuration keys {sorted(unknown)}')
        data = dict(data)
        bodies = [body_from_dict(b) for b in data.pop('bodies', [{}])]
        # Recordings made before collisions existed have no 'contact': the defaults; those
        # made before the swept test none of its speed: none swept, as they ran (and null,
        # JSON's stand-in for infinity, is none swept too).
        contact = data.pop('contact', {})
        if isinstance(contact, dict) and contact.get('continuous_speed') is None:
            contact = dict(contact, continuous_speed=math.inf)
        contact = ContactSettings.from_dict(contact)
        rest: dict[str, Any] = {k: (tuple(v) if isinstance(v, list) else v)
                                for k, v in data.items()}
        return cls(bodies=tuple(bodies), contact=contact, **rest)


def body_to_dict(spec: BodySpec) -> dict[str, Any]:
    """JSON-able form of a body (as in ``Config.to_dict``); an exact round trip."""
    return {k: ([shape_to_dict(c) for c in v] if k == 'colliders' else
                list(v) if isinstance(v, tuple) else v) for k, v in spec.__dict__.items()}


def body_from_dict(data: dict[str, Any]) -> BodySpec:
    """The inverse of ``body_to_dict``; ValueError for anything that is not a valid body."""
    if not isinstance(data, dict):
        raise ValueError(f'a body must be a mapping, got {type(data).__name__}')
    unknown = set(data) - set(BodySpec.__dataclass_fields__)
    if unknown:
        raise ValueError(f'unknown body keys {sorted(unknown)}')
    b = dict(data)
    colliders = b.pop('colliders', ())
    if not isinstance(colliders, (list, tuple)):
        raise ValueError('colliders must be a list')
    name = b.get('name')
    named = f"body '{name}': " if isinstance(name, str) and len(name) <= 64 else ''
    if len(colliders) > MAX_COLLIDERS:  # before they are built
        raise ValueError(f'{named}colliders: {len(colliders)}, more than MAX_COLLIDERS = '
                         f'{MAX_COLLIDERS} on one body')
    try:
        rest: dict[str, Any] = {k: (tuple(v) if isinstance(v, list) else v)
                                for k, v in b.items()}
        return BodySpec(colliders=tuple(shape_from_dict(c) for c in colliders), **rest)
    except TypeError as e:
        raise ValueError(f'{named}not a body: {e}') from None
    except ValueError as e:
        raise ValueError(f'{named}{e}') from None


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


@dataclass(frozen=True)
class Spawn:
    """Add the body ``spec`` to the run, at its initial state (which a reset goes back to);
    its name must be new. The other bodies go on as they were."""

    spec: BodySpec

    @property
    def body(self) -> str:
        return self.spec.name


@dataclass(frozen=True)
class Delete:
    """Take the body called ``body`` out of the run (a run keeps at least one body)."""

    body: str


Event = Union[SetWrench, SetPose, SetTwist, Reset, Spawn, Delete]
# The most bodies a run may have (scene files too): a spawn rebuilds the world around them all.
MAX_BODIES = 20_000
EVENTS = (SetWrench, SetPose, SetTwist, Reset, Spawn, Delete)


class Simulation:
    """A run of ``config``: apply events at step boundaries, advance all bodies, read them.

    Bodies marked static get no stepper: they cost nothing and never move. ``stepper`` is the
    first body's (the single-body case); ``steppers`` maps every moving body's name to its own.
    When a body has colliders, ``world`` is the ``collision_world.CollisionWorld`` that steps
    them (its Steppers are ``steppers``) and teleports go through it; else ``world`` is None
    and no collision code runs. ``tests``: the contact tests its step is compiled with, at
    least (``narrow_kernels.PAIR_BIT``; None: ``world_step.tests_for`` chooses); the bits are
    the same with any.
    """

    def __init__(self, config: Config, tests: int | None = None) -> None:
        # The run's one clock (its step count): a collision world that steps the run is
        # handed it and moves it; without one, run() does.
        self._clock = np.zeros(1, dtype=np.int64)
        self._use(config, *_build(config, tests, self._clock))
        self.spawned: list[str] = []  # bodies spawned and not deleted since, in order

    def _use(self, config: Config, world, steppers, static) -> None:
        self.config, self.world, self.steppers, self.static = config, world, steppers, static
        self._moving = tuple(steppers.values())
        self._stepping = Stepping(self._moving)

    def _rebuild(self, config: Config, recheck: bool) -> None:
        """Go on with the bodies of ``config``: those of the run keep their motion bit for
        bit, a new one starts at its initial state (see CollisionWorld.carry). Built in
        full before anything changes: a ValueError leaves the run as it was."""
        world, steppers, static = _build(config, None, self._clock)
        if world is not None:
            world.carry(self.world, self.steppers, self.step_count, recheck)
            if self.world is None:
                world.warm_up()  # the first world of this run: compiled (or loaded) now
        else:
            carry_over(steppers, self.steppers, self.step_count)
        self._use(config, world, steppers, static)

    @property
    def stepper(self) -> Stepper:
        return self.steppers[self.config.bodies[0].name]

    @property
    def step_count(self) -> int:
        """Steps taken: the run's clock."""
        return int(self._clock[0])

    @property
    def time_ns(self) -> int:
        """Simulated time in integer nanoseconds: step_count * dt, rounded."""
        return round(int(self._clock[0]) * self.config.dt * 1e9)

    def time_ns_of(self, step: int) -> int:
        """``time_ns`` at step ``step``."""
        return round(step * self.config.dt * 1e9)

    # -- the read API (what the node publishes; it does not reach into steppers or world) --
    def is_moving(self, name: str) -> bool:
        """Whether body ``name`` can move (it has a stepper; a static body never does)."""
        return name in self.steppers

    def wrench(self, name: str = '') -> Wrench:
        """The wrench held on moving body ``name`` ('' = the first)."""
        name = name or self.config.bodies[0].name
        if name not in self.steppers:
            raise ValueError(f"no moving body named '{name}'")
        return self.steppers[name].wrench

    def contact_stats(self):
        """The collision world's counts of the last step (contacts, active, sleeping), or None
        when no body collides."""
        return None if self.world is None else self.world.last_stats

    def last_contacts(self) -> list:
        """The contacts that carried an impulse in the last step (collision_world
        WorldContact), empty when no body collides."""
        return [] if self.world is None else self.world.last_contacts()

    def set_initial_states(self, config: Config) -> None:
        """Take the initial states (what a reset goes back to) from ``config``, which must
        describe the same run otherwise: the same clock, method, gravity, contact settings
        and bodies but for their initial_* fields. ValueError naming what differs."""
        if not isinstance(config, Config):
            raise ValueError(f'config must be a Config, got {config!r}')
        old = self.config
        for name in ('dt', 'steps_per_publish', 'integrator', 'gravity', 'contact'):
            if getattr(config, name) != getattr(old, name):
                raise ValueError(f'only initial states may change in a run, not {name}')
        if len(config.bodies) != len(old.bodies):
            raise ValueError('only initial states may change in a run, not the bodies')
        for new, was in zip(config.bodies, old.bodies):
            for f in fields(BodySpec):
                if not f.name.startswith('initial_') and getattr(new, f.name) != \
                        getattr(was, f.name):
                    raise ValueError('only initial states may change in a run, not body '
                                     f"'{was.name}' {f.name}")
        self.config = config

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

    def accelerations(self, name: str = ''):
        """(linear m/s^2, angular rad/s^2) acceleration of a body now, world frame: Thm 1 at
        its state under the held wrench, gravity and damping (the integrator's own), plus, in
        a collision world, what the last step's contacts did to its velocities over dt. A
        static or sleeping body (held at rest) has none. A teleport is not an acceleration."""
        name = name or self.config.bodies[0].name
        if name in self.static:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if name not in self.steppers:
            raise ValueError(f"no body named '{name}'")
        contact = None
        if self.world is not None:
            contact = self.world.contact_accelerations(name)
            if contact is None:  # asleep
                return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        a, b = self.steppers[name].accelerations()
        if contact is not None:
            (ca, cb) = contact
            a = (a[0] + ca[0], a[1] + ca[1], a[2] + ca[2])
            b = (b[0] + cb[0], b[1] + cb[1], b[2] + cb[2])
        return a, b

    def apply(self, event: Event) -> None:
        """Apply ``event`` now: it takes effect from the next step. Validated first."""
        if not isinstance(event, EVENTS):
            raise ValueError(f'event must be one of {", ".join(e.__name__ for e in EVENTS)}, '
                             f'got {event!r}')
        if isinstance(event, Spawn):
            self._spawn(event.spec)
            return
        spec = self.config.body(event.body)
        if isinstance(event, Delete):
            self._delete(spec.name)
            return
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

    def _spawn(self, spec: BodySpec) -> None:
        if not isinstance(spec, BodySpec):
            raise ValueError(f'a spawned body must be a BodySpec, got {spec!r}')
        if len(self.config.bodies) >= MAX_BODIES:
            raise ValueError(f'{len(self.config.bodies)} bodies: at most {MAX_BODIES} in a run')
        if any(b.name == spec.name for b in self.config.bodies):
            raise ValueError(f"there is a body named '{spec.name}' already")
        # Checked against a new body: contacts before the next step integrates.
        self._rebuild(replace(self.config, bodies=self.config.bodies + (spec,)), True)
        self.spawned.append(spec.name)

    def _delete(self, name: str) -> None:
        bodies = tuple(b for b in self.config.bodies if b.name != name)
        if not bodies:
            raise ValueError(f"'{name}' is the last body: a run keeps at least one")
        self._rebuild(replace(self.config, bodies=bodies), False)
        if name in self.spawned:
            self.spawned.remove(name)

    def warm_up(self) -> None:
        """Compile (or load from the compilation cache) every kernel this run's steps need,
        changing nothing: the node calls it while it starts, so that its first step is not
        also the one that compiles (48 s on a clean install for a collision scene)."""
        if self.world is not None:
            self.world.warm_up()  # its bodies' store too
        else:
            for s in self._moving[:1]:
                s.store.warm_up()

    def run(self, n: int) -> None:
        """Advance every moving body n steps. If one goes non-finite the others still advance
        and its IntegrationError is raised after (it stays at its last finite state). With
        collisions, the run stops after the step that raised."""
        if self.world is not None:
            self.world.step(n)  # (it moves the clock, as far as it stepped)
            return
        try:
            self._stepping.run(n)
        finally:
            self._clock[0] += n

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


def warm_up_contacts(config: Config, tests: int | None = None) -> None:
    """Compile (or load from the cache) the collision kernels a run like ``config`` (its dt
    and method) would need, with the contact tests ``tests`` (None: those a run of
    ``config`` steps with, ``contact_tests``), touching no run: what a spawn bringing them
    would otherwise do in its step."""
    if tests is None:
        tests = contact_tests(config)
    _probe_run(config, _BALL, tests=tests).warm_up()


def contact_tests(config: Config, current=None) -> int:
    """The contact tests (``narrow_kernels.PAIR_BIT``) a collision world of ``config``'s
    bodies steps with: those of ``current`` (a world of the run, whose step is compiled or
    loaded) if they hold those the bodies need, else ``world_step.tests_for`` them (and
    ``current``'s)."""
    family = K.family_of(multistep.method_by_name(config.integrator).steps)
    return world_step.tests_keeping(family, pairs_met(config.bodies),
                                    current.pair_tests if current is not None
                                    else None)  # as CollisionWorld.carry


def config_after(config: Config, event) -> Config:
    """``config`` with the bodies a Spawn or Delete ``event`` leaves (unchecked: what the
    kernels after it are worked out from)."""
    if isinstance(event, Spawn):
        return replace(config, bodies=config.bodies + (event.spec,))
    if isinstance(event, Delete):
        return replace(config, bodies=tuple(b for b in config.bodies if b.name != event.body))
    return config


def kernels_after(sim: 'Simulation', event) -> str | None:
    """The kernels a run steps with after ``event``, if they change: 'contact' for a Spawn
    bringing ``sim``'s first moving body with colliders (a collision world then steps the
    bodies; colliders on static bodies alone do not make one), or colliders that need
    contact tests the world's step was not compiled with (``contact_tests``); 'bodies' for a
    Delete taking the last one away (the step kernel then steps them), 'blocks' if it leaves
    ``step_kernel.BLOCK_MIN`` moving bodies or more, or for a Spawn making them that many
    without a collision world (``warm_up_bodies(blocks=True)``); else None."""
    enabled = sim.world is not None
    moving = sim.config.moving_bodies
    if isinstance(event, Spawn):
        if enabled:
            tests = contact_tests(config_after(sim.config, event), sim.world)
            return None if tests == sim.world.pair_tests else 'contact'
        if event.spec.static:
            return None
        if event.spec.colliders:
            return 'contact'
        return 'blocks' if len(moving) + 1 == K.BLOCK_MIN else None
    if isinstance(event, Delete) and enabled:
        left = [b for b in moving if b.name != event.body]
        if not any(b.colliders for b in left):
            return 'blocks' if len(left) >= K.BLOCK_MIN else 'bodies'
    return None


def contact_probe(config: Config, tests: int):
    """The collision world of a run like ``config`` (its dt and method) of one ball, its
    step compiled with the contact tests ``tests``, touching no run: its
    ``compile_leaves(group)`` compiles (or loads) one group of the kernels its step calls
    (``world_step.LEAF_GROUPS``), and its ``warm_up`` then loads them. Building it compiles
    (or loads) the few kernels a new body's state needs."""
    return _probe_run(config, _BALL, tests=tests).world


def warm_up_bodies(config: Config, blocks: bool | None = None) -> None:
    """Compile (or load from the cache) the step kernel of bodies without a collision world,
    touching no run: what a run whose last collider is deleted would otherwise do in its
    step (an enabled world's warm-up leaves it out). ``blocks``: with the kernels that step
    ``step_kernel.BLOCK_MIN`` bodies or more a block at a time (two-step methods,
    ``step_kernel.blocked``); None: if ``config`` has that many moving bodies."""
    if blocks is None:
        blocks = len(config.moving_bodies) >= K.BLOCK_MIN
    _probe_run(config, *(BodySpec(f'probe{i}', initial_position=(2.0 * i, 0.0, 0.0))
                         for i in range(K.BLOCK_MIN if blocks else 1))).warm_up()


# The probe of the collision kernels: one ball.
_BALL = BodySpec('probe', colliders=(Sphere(0.1),))


def _probe_run(config: Config, *probes: BodySpec, tests: int | None = None) -> 'Simulation':
    """A run of ``probes`` alone with ``config``'s dt, output period and method (and the
    contact tests ``tests``, if they collide), touching no other run: what the warm-ups
    compile (or load) a run's kernels with."""
    return Simulation(Config(dt=config.dt, steps_per_publish=config.steps_per_publish,
                             integrator=config.integrator, bodies=probes), tests)


def _build(config: Config, tests: int | None, clock=None):
    """(collision world or None, steppers by name, static states by name) of ``config``'s
    bodies at their initial states; the world's step compiled with the contact tests
    ``tests`` (and those its bodies need; None: ``world_step.tests_for`` chooses), moving the
    run's ``clock`` (None: a clock of its own)."""
    steppers, static = make_steppers(config.bodies, config.dt, config.integrator,
                                     config.gravity)
    if not config.collides:
        return None, steppers, static
    return (CollisionWorld(steppers, colliders_of(config.bodies, steppers), config.contact,
                           tests, clock), steppers, static)
