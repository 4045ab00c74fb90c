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

from dataclasses import dataclass, field
import math
from typing import Any, Union

import numpy as np

from rb_sim_ros import multistep
from rb_sim_ros.rigid_body import RigidBody, State, Wrench, ZERO_WRENCH
from rb_sim_ros.stepper import Stepper


def _floats(name: str, value: Any, size: int) -> tuple[float, ...]:
    try:
        out = tuple(float(c) for c in value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be {size} numbers, got {value!r}') from None
    if len(out) != size:
        raise ValueError(f'{name} must be {size} numbers, got {len(out)}')
    if not all(math.isfinite(c) for c in out):
        raise ValueError(f'{name} must be finite, got {list(out)}')
    return out


@dataclass(frozen=True)
class Config:
    """Everything needed to (re-)simulate a run. SI units; vectors in the world frame.

    inertia: 3 principal moments or 9 row-major components of the body-frame tensor (kg m^2).
    dt: physics step (s); steps_per_publish: physics steps between two published states.
    initial_*: the state at step 0 and after a reset.
    """

    mass: float = 1.0
    inertia: tuple[float, ...] = (0.1, 0.1, 0.1)
    dt: float = 1e-3
    steps_per_publish: int = 10
    integrator: str = multistep.EQ27.name
    initial_position: tuple[float, ...] = (0.0, 0.0, 0.0)
    initial_orientation_xyzw: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0)
    initial_linear_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    initial_angular_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        inertia = _floats('inertia', self.inertia, len(tuple(self.inertia)))
        if len(inertia) not in (3, 9):
            raise ValueError(f'inertia must be 3 principal moments or 9 components, '
                             f'got {len(inertia)} numbers')
        object.__setattr__(self, 'inertia', inertia)
        for name, size in (('initial_position', 3), ('initial_orientation_xyzw', 4),
                           ('initial_linear_velocity', 3), ('initial_angular_velocity', 3)):
            object.__setattr__(self, name, _floats(name, getattr(self, name), size))
        if (not isinstance(self.steps_per_publish, int) or isinstance(self.steps_per_publish, bool)
                or self.steps_per_publish < 1):
            raise ValueError(
                f'steps_per_publish must be an int >= 1, got {self.steps_per_publish!r}')
        multistep.method_by_name(self.integrator)
        self.body()  # validates mass and inertia
        self.initial_state()  # validates the orientation
        Stepper(self.body(), self.dt)  # validates dt

    def body(self) -> RigidBody:
        inertia = (np.array(self.inertia) if len(self.inertia) == 3
                   else np.array(self.inertia).reshape(3, 3))
        return RigidBody(self.mass, inertia)

    def initial_state(self) -> State:
        return State.from_quaternion_xyzw(self.initial_position, self.initial_orientation_xyzw,
                                          self.initial_linear_velocity,
                                          self.initial_angular_velocity)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form; floats are written with repr, so a round trip is exact."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> 'Config':
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f'unknown configuration keys {sorted(unknown)}')
        return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()})


@dataclass(frozen=True)
class SetWrench:
    """Hold ``wrench`` from this step on."""

    wrench: Wrench


@dataclass(frozen=True)
class SetPose:
    """Teleport: position (m) and orientation (x, y, z, w), world frame; velocities kept."""

    position: tuple[float, ...]
    orientation_xyzw: tuple[float, ...]


@dataclass(frozen=True)
class SetTwist:
    """Teleport: linear (m/s) and angular (rad/s) velocity, world frame; pose kept."""

    linear: tuple[float, ...]
    angular: tuple[float, ...]


@dataclass(frozen=True)
class Reset:
    """Zero the wrench and jump to a state: the given one (world frame: position m,
    orientation x-y-z-w, linear m/s, angular rad/s), or else the configuration's initial one."""

    position: tuple[float, ...] | None = None
    orientation_xyzw: tuple[float, ...] | None = None
    linear: tuple[float, ...] | None = None
    angular: tuple[float, ...] | None = None

    @classmethod
    def to_initial(cls, config: 'Config') -> 'Reset':
        """A reset to ``config``'s initial state, spelled out (so a recording holds it)."""
        return cls(config.initial_position, config.initial_orientation_xyzw,
                   config.initial_linear_velocity, config.initial_angular_velocity)

    def state(self, config: 'Config') -> State:
        if self.position is None:
            return config.initial_state()
        return State.from_quaternion_xyzw(self.position, self.orientation_xyzw, self.linear,
                                          self.angular)


Event = Union[SetWrench, SetPose, SetTwist, Reset]


@dataclass
class Simulation:
    """A run of ``config``: apply events at step boundaries, advance, read the state."""

    config: Config
    stepper: Stepper = field(init=False)

    def __post_init__(self) -> None:
        self.stepper = Stepper(self.config.body(), self.config.dt, self.config.initial_state(),
                               method=self.config.integrator)

    @property
    def step_count(self) -> int:
        return self.stepper.step_count

    @property
    def time_ns(self) -> int:
        """Simulated time in integer nanoseconds: step_count * dt, rounded."""
        return round(self.stepper.step_count * self.config.dt * 1e9)

    def apply(self, event: Event) -> None:
        """Apply ``event`` now: it takes effect from the next step. Validated first."""
        s = self.stepper
        if isinstance(event, SetWrench):
            s.set_wrench(event.wrench)
        elif isinstance(event, SetPose):
            old = s.state
            s.set_state(State.from_quaternion_xyzw(event.position, event.orientation_xyzw,
                                                   old.linear_velocity, old.angular_velocity))
        elif isinstance(event, SetTwist):
            old = s.state
            s.set_state(State(old.position, old.rotation, event.linear, event.angular))
        elif isinstance(event, Reset):
            state = event.state(self.config)
            s.set_wrench(ZERO_WRENCH)
            s.set_state(state)
        else:
            raise ValueError(f'event must be SetWrench, SetPose, SetTwist or Reset, '
                             f'got {event!r}')

    def run(self, n: int) -> None:
        """Advance n steps."""
        self.stepper.step(n)

    def run_until(self, step: int, events: list[tuple[int, Event]]) -> list[tuple[int, Event]]:
        """Advance to ``step``, applying each (step, event) of ``events`` (sorted by step) when
        the simulation reaches its step. Returns the events not yet due."""
        i = 0
        while True:
            while i < len(events) and events[i][0] <= self.step_count:
                if events[i][0] < self.step_count:
                    raise ValueError(f'event at step {events[i][0]} is in the past '
                                     f'(now at step {self.step_count})')
                self.apply(events[i][1])
                i += 1
            if self.step_count >= step:
                return events[i:]
            due = events[i][0] if i < len(events) else step
            self.run(min(due, step) - self.step_count)
