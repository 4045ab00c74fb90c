# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""How bodies that touch respond (``ContactSettings``, validated once, and the solver's view
of it), and the bounds of what the contact solve can take (masses, iterations)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from rb_sim_ros.contact import contact_solver
from rb_sim_ros.core.rigid_body import is_number, non_negative, short


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
    contacts keep fast bodies from tunnelling, and those of a body moving faster than
    continuous_speed (m/s, |v| + |omega| rho; inf: none, 0: every body's) are swept along its
    path through the step, so that a contact its path misses does not stop it (continuous
    collision, docs/collisions.md); warm_start: each solve starts from the
    impulses of the same contacts at the step before. A body pressed by a contact whose
    points all move slower than sleep_speed (m/s) for sleep_time (s) sleeps, at rest and at
    no cost, until an awake body comes near, its wrench changes or it is teleported
    (sleep_time 0: never). Unused by a scene without colliders.

    The one place a world's contact settings are given and checked (a scene's ``contact:``,
    ``Config.contact``, ``CollisionWorld(..., contact)``); the solver's view of them, with
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
    continuous_speed: float = 1.0
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
        speed = self.continuous_speed
        if not (is_number(speed) and speed >= 0.0):  # (inf: no body is swept)
            raise ValueError(f'continuous_speed must be a number >= 0 (m/s; .inf: none), got '
                             f'{short(speed)}')
        object.__setattr__(self, 'continuous_speed', float(speed))
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
