# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Benchmark scenes and their references: closed forms, the elliptic oracle, DOP853 at 1e-13.

Every scene is one body, zero gravity, with a torque schedule in the world frame (held, so
that MuJoCo can apply it once per segment), run from t = 0 to ``t_end``. A reference gives
R(t) and omega(t) (world frame) at any sample time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import ellipj, ellipk

from rb_sim_ros import so3


@dataclass
class Scene:
    name: str
    moments: tuple[float, float, float]  # principal moments (kg m^2), body = principal frame
    omega0: tuple[float, float, float]  # initial angular velocity, world (= body at t = 0)
    t_end: float
    schedule: list = field(default_factory=list)  # [(t_start, torque world (N m))]
    reference: str = 'dop853'  # 'elliptic', 'top' or 'dop853'
    samples: int = 20  # trajectory samples for the max error

    def torque_segments(self):
        rows = self.schedule or [(0.0, (0.0, 0.0, 0.0))]
        ends = [r[0] for r in rows[1:]] + [self.t_end]
        return [(t0, t1, np.array(tau, dtype=float)) for (t0, tau), t1 in zip(rows, ends)]

    def sample_times(self):
        return np.linspace(self.t_end / self.samples, self.t_end, self.samples)


def _rhs(moments, torque):
    inertia = np.diag(moments)

    def f(_t, y):
        rot = y[:9].reshape(3, 3)
        w = y[9:]
        i_w = rot @ inertia @ rot.T
        beta = np.linalg.solve(i_w, torque - np.cross(w, i_w @ w))
        return np.concatenate([(so3.hat(w) @ rot).reshape(9), beta])
    return f


def dop853(scene: Scene, times, rtol=1e-13, atol=1e-14):
    """(R, omega) at ``times`` by DOP853, integrated segment by segment."""
    y = np.concatenate([np.eye(3).reshape(9), scene.omega0])
    out = {}
    for t0, t1, tau in scene.torque_segments():
        grid = sorted({float(t) for t in times if t0 < t <= t1 + 1e-12} | {t1})
        sol = solve_ivp(_rhs(scene.moments, tau), (t0, t1), y, method='DOP853', rtol=rtol,
                        atol=atol, t_eval=grid)
        for k, t in enumerate(grid):
            out[round(t, 12)] = (sol.y[:9, k].reshape(3, 3), sol.y[9:, k].copy())
        y = sol.y[:, -1]
    return [out[round(float(t), 12)] for t in times]


def elliptic_omega(scene: Scene, t):
    """Body-frame omega of a torque-free asymmetric body (Jacobi elliptic functions).

    Landau & Lifshitz section 37, for I1 < I2 < I3, omega_2(0) = 0, omega_1(0), omega_3(0) > 0
    and M^2 > 2 E I2 (rotation about the axis of I3 in the mean)."""
    i1, i2, i3 = scene.moments
    w1, w2, w3 = scene.omega0
    e2 = i1 * w1 * w1 + i2 * w2 * w2 + i3 * w3 * w3  # 2E
    m2 = (i1 * w1) ** 2 + (i2 * w2) ** 2 + (i3 * w3) ** 2
    rate = math.sqrt((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3))
    k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1))
    sn, cn, dn, _ = ellipj(rate * np.asarray(t), k2)
    return np.stack([math.sqrt((e2 * i3 - m2) / (i1 * (i3 - i1))) * cn,
                     math.sqrt((e2 * i3 - m2) / (i2 * (i3 - i2))) * sn,
                     math.sqrt((m2 - e2 * i1) / (i3 * (i3 - i1))) * dn], axis=-1)


def flip_period(moments, omega0) -> float:
    """Full period (s) of the body-frame motion, 4 K(k) / rate, for the elliptic case above
    with the roles of axes 1 and 3 swapped when M^2 < 2 E I2 (a flip about the middle axis)."""
    i1, i2, i3 = moments
    w = np.asarray(omega0, dtype=float)
    e2 = float(np.dot(moments, w * w))
    m2 = float(np.dot(np.square(moments), w * w))
    if m2 < e2 * i2:
        i1, i3 = i3, i1
    rate = math.sqrt(abs((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3)))
    k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1))
    return 4.0 * float(ellipk(k2)) / rate


def top(scene: Scene, t):
    """(R, omega world) of a torque-free symmetric top (I1 = I2) from R(0) = I."""
    i_t, _, i_3 = scene.moments
    w_body = np.asarray(scene.omega0, dtype=float)
    angular_momentum = np.diag(scene.moments) @ w_body
    lam = (1.0 - i_3 / i_t) * w_body[2]
    rot = so3.exp(t * angular_momentum / i_t) @ so3.exp([0.0, 0.0, lam * t])
    e3 = rot[:, 2]
    omega = angular_momentum / i_t + (1.0 / i_3 - 1.0 / i_t) * (angular_momentum @ e3) * e3
    return rot, omega


def reference(scene: Scene, times):
    """[(R, omega world)] at ``times``: the scene's oracle, DOP853 where it has none."""
    if scene.reference == 'top':
        return [top(scene, float(t)) for t in times]
    states = dop853(scene, times)
    if scene.reference == 'elliptic':
        # omega from the elliptic functions (in the body frame, turned by the DOP853 R).
        w_body = elliptic_omega(scene, np.asarray(times))
        states = [(rot, rot @ wb) for (rot, _), wb in zip(states, w_body)]
    return states


def scenes(quick: bool = False) -> list[Scene]:
    t = 0.5 if quick else 1.0
    schedule = [(0.1 * k, (0.3 * math.sin(k), 0.2 * math.cos(2 * k), 0.25 * (-1) ** k))
                for k in range(int(round(t / 0.1)))]
    return [
        Scene('tumble', (1.0, 2.0, 3.0), (1.0, 0.0, 1.5), 2 * t, reference='elliptic'),
        Scene('symmetric top', (1.0, 1.0, 1.8), (0.4, -0.3, 2.0), 2 * t, reference='top'),
        Scene('torque every 0.1 s', (0.2, 0.3, 0.45), (0.3, 1.0, -0.2), t, schedule),
        Scene('fast spin', (1.0, 2.0, 3.0), (5.0, 0.0, 30.0), t / 2, reference='elliptic'),
    ]
