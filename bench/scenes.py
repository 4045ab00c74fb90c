# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The benchmark scenes: one free body, zero gravity, a torque held piecewise constant.

A scene fixes the body (mass, inertia in the body frame), the initial orientation R0 (body to
world) and angular velocity (given in the body frame, as the oracles want it), a schedule of
world-frame torques (each held until the next starts, so that every peer, MuJoCo included, can
apply it exactly), the length of the run and which reference it is checked against
(``references.reference``). The body starts at the origin at rest in translation: these scenes
are about rotation, which is where the integrators differ.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from rb_sim_ros.core import so3

# Sample times (s) of every scene are multiples of this; every dt of a sweep divides it.
SAMPLE_SPACING = 0.05
# Each torque of a schedule is held this long (s).
SEGMENT = 0.1


@dataclass(frozen=True)
class Scene:
    """One body and its motion; every vector in SI units.

    inertia: 3x3 body-frame tensor about the centre of mass (kg m^2); mass (kg).
    rotation0_vector: rotation vector (rad, axis times angle) of R0 = exp([.]), body to world.
    omega0_body: initial angular velocity (rad/s) in the body frame.
    schedule: ((t_start s, torque N m world), ...) sorted, first at 0; empty: torque-free.
    reference: 'elliptic' (torque-free asymmetric, principal axes, I1 < I2 < I3),
        'top' (torque-free, I1 = I2, principal axes) or 'dop853'.
    """

    name: str
    inertia: tuple
    omega0_body: tuple[float, float, float]
    t_end: float
    rotation0_vector: tuple[float, float, float] = (0.0, 0.0, 0.0)
    schedule: tuple = ()
    reference: str = 'dop853'
    mass: float = 1.0

    @property
    def key(self) -> str:
        """A file-name-safe form of the name ('torque every 0.1 s' -> 'torque_every_01_s')."""
        return ''.join(c for c in self.name.replace(' ', '_') if c.isalnum() or c == '_')

    @property
    def inertia_body(self) -> np.ndarray:
        return np.array(self.inertia, dtype=float).reshape(3, 3)

    @property
    def rotation0(self) -> np.ndarray:
        return so3.exp(self.rotation0_vector)

    @property
    def omega0_world(self) -> np.ndarray:
        return self.rotation0 @ np.asarray(self.omega0_body, dtype=float)

    @property
    def torque_free(self) -> bool:
        return all(not np.any(tau) for _, tau in self.schedule)

    def segments(self) -> list[tuple[float, float, np.ndarray]]:
        """[(t0, t1, torque world (N m))] covering [0, t_end]; one segment if torque-free."""
        rows = list(self.schedule) or [(0.0, (0.0, 0.0, 0.0))]
        ends = [r[0] for r in rows[1:]] + [self.t_end]
        return [(t0, t1, np.array(tau, dtype=float)) for (t0, tau), t1 in zip(rows, ends)
                if t1 > t0]

    def sample_times(self) -> np.ndarray:
        """Times (s) at which errors are measured: every SAMPLE_SPACING up to t_end."""
        n = int(round(self.t_end / SAMPLE_SPACING))
        return SAMPLE_SPACING * np.arange(1, n + 1)

    def initial_speed(self) -> float:
        """|omega(0)| (rad/s)."""
        return float(np.linalg.norm(self.omega0_body))


def diagonal(i1: float, i2: float, i3: float) -> tuple:
    return ((i1, 0.0, 0.0), (0.0, i2, 0.0), (0.0, 0.0, i3))


def torque_schedule(t_end: float) -> tuple:
    """A torque (N m, world) that jumps every SEGMENT seconds, deterministic."""
    n = int(round(t_end / SEGMENT))
    return tuple((SEGMENT * k, (0.3 * math.sin(k + 1.0), 0.2 * math.cos(2.0 * k),
                                0.25 * (-1) ** k)) for k in range(n))


def work_precision_scenes(quick: bool = False) -> list[Scene]:
    """The four work-precision scenes (half as long in quick mode)."""
    scale = 0.5 if quick else 1.0
    tilt = (0.3, -0.5, 0.8)  # R0: a general orientation, so that frame mix-ups show
    full_inertia = ((0.2, 0.01, 0.0), (0.01, 0.3, 0.02), (0.0, 0.02, 0.45))
    return [
        Scene('tumble', diagonal(1.0, 2.0, 3.0), (1.0, 0.0, 1.5), 2.0 * scale, tilt,
              reference='elliptic'),
        Scene('symmetric top', diagonal(1.0, 1.0, 1.8), (0.4, -0.3, 2.0), 2.0 * scale, tilt,
              reference='top'),
        Scene('torque every 0.1 s', full_inertia, (0.3, 1.0, -0.2), 1.0 * scale, tilt,
              torque_schedule(1.0 * scale)),
        Scene('fast spin', diagonal(1.0, 2.0, 3.0), (5.0, 0.0, 30.0), 0.5 * scale, tilt,
              reference='elliptic'),
    ]
