# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Closed forms of a torque-free rigid body's rotation, for the tests and the benchmarks.

* Symmetric top (I1 = I2 = I_t): R(t) = exp(t [L]/I_t) R0 exp(t lambda [e3]) with
  lambda = (1 - I3/I_t) omega_b3 and L the (constant) world angular momentum.
* Asymmetric body (I1 < I2 < I3): omega in the body frame from Jacobi's elliptic functions
  (Landau & Lifshitz, section 37), and the period of its body-frame motion 4 K(k) / rate.

Nothing here uses rb_sim_ros's integrator or its principal-axes dynamics; only ``so3.exp``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipj, ellipk

from rb_sim_ros.core import so3


def symmetric_top(t, i_t, i_3, w_body, rot0) -> tuple[np.ndarray, np.ndarray]:
    """R(t) and omega(t) (world) of a torque-free symmetric top (I1 = I2 = i_t, I3 = i_3,
    principal axes) that starts at R0 = ``rot0`` spinning at ``w_body`` (body frame)."""
    w_body = np.asarray(w_body, dtype=float)
    angular_momentum = rot0 @ (np.diag([i_t, i_t, i_3]) @ w_body)
    lam = (1.0 - i_3 / i_t) * w_body[2]
    rot = so3.exp(t * angular_momentum / i_t) @ rot0 @ so3.exp([0.0, 0.0, lam * t])
    e3 = rot[:, 2]
    omega = angular_momentum / i_t + (1.0 / i_3 - 1.0 / i_t) * (angular_momentum @ e3) * e3
    return rot, omega


def _elliptic_parameters(moments, omega0_body):
    """(rate (rad/s), k^2, amplitudes of omega_1, omega_2, omega_3 (rad/s)) for the elliptic
    solution with I1 < I2 < I3, omega_2(0) = 0, omega_1(0), omega_3(0) > 0, M^2 > 2 E I2."""
    i1, i2, i3 = moments
    w1, w2, w3 = omega0_body
    e2 = i1 * w1 * w1 + i2 * w2 * w2 + i3 * w3 * w3  # 2E
    m2 = (i1 * w1) ** 2 + (i2 * w2) ** 2 + (i3 * w3) ** 2  # |L|^2
    if not (i1 < i2 < i3 and w2 == 0.0 and w1 > 0.0 and w3 > 0.0 and m2 > e2 * i2):
        raise ValueError('the elliptic oracle needs I1 < I2 < I3, omega_2(0) = 0, '
                         'omega_1(0), omega_3(0) > 0 and M^2 > 2 E I2')
    rate = math.sqrt((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3))
    k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1))
    amplitudes = (math.sqrt((e2 * i3 - m2) / (i1 * (i3 - i1))),
                  math.sqrt((e2 * i3 - m2) / (i2 * (i3 - i2))),
                  math.sqrt((m2 - e2 * i1) / (i3 * (i3 - i1))))
    return rate, k2, amplitudes


def elliptic_omega_body(moments, omega0_body, t) -> np.ndarray:
    """omega (rad/s, body frame) at times t (s) of a torque-free asymmetric body:
    (A1 cn, A2 sn, A3 dn)(rate t | k^2); shape (len(t), 3)."""
    rate, k2, (a1, a2, a3) = _elliptic_parameters(moments, omega0_body)
    sn, cn, dn, _ = ellipj(rate * np.asarray(t, dtype=float), k2)
    return np.stack([a1 * cn, a2 * sn, a3 * dn], axis=-1)


def flip_period(moments, omega0_body) -> float:
    """Period (s) of the body-frame motion of a torque-free body, 4 K(k) / rate.

    For a spin near the middle axis (M^2 < 2 E I2, the Dzhanibekov flip) the roles of axes 1
    and 3 swap; omega_2 is then rate-scaled sn and changes sign twice per period (two flips).
    """
    i1, i2, i3 = moments
    w = np.asarray(omega0_body, dtype=float)
    e2 = float(np.dot(moments, w * w))
    m2 = float(np.dot(np.square(moments), w * w))
    if m2 < e2 * i2:
        i1, i3 = i3, i1
    rate = math.sqrt((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3))
    k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1))
    return 4.0 * float(ellipk(k2)) / rate
