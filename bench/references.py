# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""References for the benchmark scenes, and the checks that they agree with one another.

* Torque-free asymmetric body: omega in the body frame from Jacobi's elliptic functions
  (Landau & Lifshitz, section 37); R from DOP853 at rtol 1e-13, checked against the invariant
  R I omega_body = L0 (world angular momentum), which pins two of its three degrees of freedom.
* Torque-free symmetric top (I1 = I2 = I_t): R(t) = exp(t [L]/I_t) R0 exp(t lambda [e3]) with
  lambda = (1 - I3/I_t) omega_b3 and L the (constant) world angular momentum.
* Anything else: DOP853 at rtol 1e-13, segment by segment (no step straddles a torque jump),
  on Thm 1 in the world frame (R and omega world, I = R I_body R^T solved with numpy). It is
  checked against a second formulation (unit quaternion, Euler's equations in the body frame).

Nothing here uses rb_sim_ros's integrator or its principal-axes dynamics; only ``so3.exp``,
``log`` and the quaternion conversions.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import ellipj, ellipk

from rb_sim_ros.core import so3
from scenes import Scene

RTOL, ATOL = 1e-13, 1e-14
# References must agree with each other to this (rad, and rad/s relative to |omega0|).
AGREEMENT = 1e-9


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rhs_world_matrix(inertia_body: np.ndarray, torque_world: np.ndarray):
    """d/dt of y = (R row-major (9), omega world (3)) under a constant world torque (N m):
    dR/dt = [omega] R, domega/dt = I^-1 (tau - omega x I omega), I = R I_body R^T (eq. (10))."""
    inertia_body = np.asarray(inertia_body, dtype=float)
    torque_world = np.asarray(torque_world, dtype=float)

    def f(_t, y):
        rot = y[:9].reshape(3, 3)
        w = y[9:]
        inertia = rot @ inertia_body @ rot.T
        beta = np.linalg.solve(inertia, torque_world - np.cross(w, inertia @ w))
        return np.concatenate([(_hat(w) @ rot).reshape(9), beta])
    return f


def rhs_body_quaternion(inertia_body: np.ndarray, torque: np.ndarray, frame: str = 'world'):
    """d/dt of y = (q = (w, x, y, z) body to world (4), omega body (3)) under a constant torque
    (N m) in ``frame`` ('world' or 'body'): dq/dt = q (0, omega_b) / 2,
    I_b domega_b/dt = tau_b - omega_b x I_b omega_b with tau_b = R^T tau for a world torque."""
    inertia_body = np.asarray(inertia_body, dtype=float)
    inverse = np.linalg.inv(inertia_body)
    tx, ty, tz = (float(c) for c in torque)
    in_body = frame == 'body'

    def f(_t, y):
        qw, qx, qy, qz, wx, wy, wz = y
        # R^T tau with R from the (not necessarily unit) quaternion: rotate by its conjugate.
        n2 = qw * qw + qx * qx + qy * qy + qz * qz
        rt = np.array([
            [1 - 2 * (qy * qy + qz * qz) / n2, 2 * (qx * qy + qz * qw) / n2,
             2 * (qx * qz - qy * qw) / n2],
            [2 * (qx * qy - qz * qw) / n2, 1 - 2 * (qx * qx + qz * qz) / n2,
             2 * (qy * qz + qx * qw) / n2],
            [2 * (qx * qz + qy * qw) / n2, 2 * (qy * qz - qx * qw) / n2,
             1 - 2 * (qx * qx + qy * qy) / n2]])
        w = np.array([wx, wy, wz])
        tau_b = np.array([tx, ty, tz]) if in_body else rt @ np.array([tx, ty, tz])
        dw = inverse @ (tau_b - np.cross(w, inertia_body @ w))
        return np.array([0.5 * (-qx * wx - qy * wy - qz * wz),
                         0.5 * (qw * wx + qy * wz - qz * wy),
                         0.5 * (qw * wy + qz * wx - qx * wz),
                         0.5 * (qw * wz + qx * wy - qy * wx), *dw])
    return f


def quaternion_wxyz(rot: np.ndarray) -> np.ndarray:
    x, y, z, w = so3.quaternion_xyzw_from_matrix(rot)
    return np.array([w, x, y, z])


def matrix_from_wxyz(q) -> np.ndarray:
    w, x, y, z = q
    return so3.matrix_from_quaternion_xyzw((x, y, z, w))


def integrate(scene: Scene, times, rtol: float = RTOL, atol: float = ATOL,
              formulation: str = 'matrix') -> list[tuple[np.ndarray, np.ndarray]]:
    """[(R, omega world (rad/s))] at ``times`` (s, sorted, in (0, t_end]) by DOP853, segment
    by segment. ``formulation`` 'matrix' (world frame, R) or 'quaternion' (body frame, q)."""
    times = [float(t) for t in times]
    if formulation == 'matrix':
        y = np.concatenate([scene.rotation0.reshape(9), scene.omega0_world])
        rhs = rhs_world_matrix
    else:
        y = np.concatenate([quaternion_wxyz(scene.rotation0), scene.omega0_body])
        rhs = rhs_body_quaternion
    out = {}
    for t0, t1, tau in scene.segments():
        grid = sorted({t for t in times if t0 < t <= t1 + 1e-12} | {t1})
        sol = solve_ivp(rhs(scene.inertia_body, tau), (t0, t1), y, method='DOP853',
                        rtol=rtol, atol=atol, t_eval=grid)
        if not sol.success:
            raise RuntimeError(f'DOP853 failed on {scene.name}: {sol.message}')
        for k, t in enumerate(grid):
            out[round(t, 9)] = sol.y[:, k].copy()
        y = sol.y[:, -1]
    states = []
    for t in times:
        yk = out[round(t, 9)]
        if formulation == 'matrix':
            states.append((yk[:9].reshape(3, 3), yk[9:]))
        else:
            rot = matrix_from_wxyz(yk[:4])
            states.append((rot, rot @ yk[4:]))
    return states


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


def top(scene: Scene, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, omega world) of the torque-free symmetric top of ``scene`` at time t (s)."""
    i_t, i_t2, i_3 = np.diag(scene.inertia_body)
    assert i_t == i_t2, 'the closed form needs I1 = I2'
    w_body = np.asarray(scene.omega0_body, dtype=float)
    momentum = scene.rotation0 @ (scene.inertia_body @ w_body)  # L, world, constant
    lam = (1.0 - i_3 / i_t) * w_body[2]
    rot = so3.exp(t * momentum / i_t) @ scene.rotation0 @ so3.exp([0.0, 0.0, lam * t])
    return rot, momentum / i_t + lam * rot[:, 2]


def reference(scene: Scene, times) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(R, omega world)] at ``times``: the scene's oracle, DOP853 where it has none."""
    if scene.reference == 'top':
        return [top(scene, float(t)) for t in times]
    states = integrate(scene, times)
    if scene.reference == 'elliptic':
        moments = np.diag(scene.inertia_body)
        w_body = elliptic_omega_body(moments, scene.omega0_body, times)
        states = [(rot, rot @ wb) for (rot, _), wb in zip(states, w_body)]
    return states


def self_check(scene: Scene) -> dict:
    """How well the references of ``scene`` agree with each other and its invariants.

    'angle' (rad) and 'omega' (relative to |omega0|) are the largest disagreements over the
    sample times between the scene's reference and an independent second one: DOP853 on
    quaternions with Euler's equations in the body frame (against the elliptic omega and the
    world-frame DOP853 R, or against the world-frame DOP853), or for the top, DOP853 in the world
    frame against the closed form.
    'momentum' is max |R I omega_body - L0| / |L0| of the reference (torque-free only).
    """
    times = scene.sample_times()
    ref = reference(scene, times)
    if scene.reference == 'top':
        other, what = integrate(scene, times), 'DOP853, world-frame R'
    else:
        other, what = integrate(scene, times, formulation='quaternion'), 'DOP853, quaternion'
    speed = scene.initial_speed()
    result = {'against': what,
              'angle': max(so3.angle_between(r1, r2) for (r1, _), (r2, _) in zip(ref, other)),
              'omega': max(float(np.linalg.norm(w1 - w2)) / speed
                           for (_, w1), (_, w2) in zip(ref, other))}
    if scene.torque_free:
        momentum0 = scene.rotation0 @ scene.inertia_body @ np.asarray(scene.omega0_body)
        result['momentum'] = max(
            float(np.linalg.norm(rot @ scene.inertia_body @ (rot.T @ w) - momentum0)
                  / np.linalg.norm(momentum0)) for rot, w in ref)
    result['ok'] = all(v <= AGREEMENT for k, v in result.items() if k != 'against')
    return result
