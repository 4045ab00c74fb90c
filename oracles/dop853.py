# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The DOP853 reference of the tests and the benchmarks: eq. (10) integrated by scipy's DOP853
at rtol 1e-13, piece by piece so that no step straddles a jump of the held wrench.

Nothing here uses rb_sim_ros's integrator or its principal-axes dynamics: the right-hand sides
form I = R I_body R^T and solve with numpy, as Thm 1 is printed (``rhs``,
``rhs_world_matrix``), or take Euler's equations in the body frame on a quaternion
(``rhs_body_quaternion``, the second formulation the benchmarks check the first against). Of
rb_sim_ros only ``State`` (``solve``'s states) and ``so3``'s quaternion conversions are used.

* ``solve``: a body (mass, inertia) and a ``State``, under a schedule of wrenches (force and
  torque, each in the world or the body frame); the states at the times asked (the tests).
* ``integrate``: a benchmark scene (bench/scenes.py: rotation only, world-frame torques);
  (R, omega world) at the times asked (the benchmarks).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from rb_sim_ros import State
from rb_sim_ros.core import so3

RTOL, ATOL = 1e-13, 1e-14


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rhs(inertia_body, mass, force, torque, frame, gravity=None, linear_damping=0.0,
        angular_damping=0.0):
    """d/dt of y = (x, v, R row-major, omega), world frame; wrench constant in ``frame``
    ('world' or 'body'). With ``gravity`` (m/s^2, world) given, a = F/m + g - c v and
    beta = I^-1 (tau - omega x I omega) - d omega (c, d: the linear and angular damping)."""
    inertia_body = np.asarray(inertia_body, dtype=float)
    force = np.asarray(force, dtype=float)
    torque = np.asarray(torque, dtype=float)
    damped = gravity is not None

    def f(_t, y):
        v = y[3:6]
        rot = y[6:15].reshape(3, 3)
        w = y[15:18]
        fw, tw = (rot @ force, rot @ torque) if frame == 'body' else (force, torque)
        inertia = rot @ inertia_body @ rot.T
        beta = np.linalg.solve(inertia, tw - np.cross(w, inertia @ w))
        if damped:
            beta = beta - angular_damping * w
            return np.concatenate([v, fw / mass + gravity - linear_damping * v,
                                   (_hat(w) @ rot).reshape(9), beta])
        return np.concatenate([v, fw / mass, (_hat(w) @ rot).reshape(9), beta])

    return f


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


def pack(state: State) -> np.ndarray:
    """``rhs``'s y of ``state``: (x, v, R row-major, omega)."""
    return np.concatenate([state.position, state.linear_velocity, state.rotation.reshape(9),
                           state.angular_velocity])


def unpack(y: np.ndarray) -> State:
    """The ``State`` of ``rhs``'s y, R projected onto SO(3) (by its SVD)."""
    rot = y[6:15].reshape(3, 3)
    u, _, vt = np.linalg.svd(rot)
    return State(y[0:3], u @ vt, y[3:6], y[15:18])


def piecewise(pieces, y, times, rtol: float = RTOL, atol: float = ATOL,
              what: str = '') -> dict:
    """DOP853 piece by piece from y at the first piece's start: ``pieces`` [(t0, t1, f)] in
    order, f the right-hand side on [t0, t1]. {t: y(t)} for every t of ``times`` that a piece
    holds (a t on a boundary from the piece that ends there): the dense output of the step
    that holds it, never a step across a boundary."""
    out = {}
    wanted = set(times)
    for t0, t1, f in pieces:
        grid = sorted({t for t in wanted if t0 <= t <= t1} | {t1})
        sol = solve_ivp(f, (t0, t1), y, method='DOP853', rtol=rtol, atol=atol, t_eval=grid)
        if not sol.success:
            raise RuntimeError(f'DOP853 failed{what}: {sol.message}')
        for i, t in enumerate(grid):
            if t in wanted:
                out.setdefault(t, sol.y[:, i].copy())
        y = sol.y[:, -1]
    return out


def solve(body, state: State, schedule, t_end: float, times=None, rtol=RTOL, atol=ATOL,
          gravity=None, linear_damping=0.0, angular_damping=0.0) -> list[State]:
    """Reference states of ``body`` (``mass``, ``inertia`` body frame) from ``state`` at t = 0,
    at ``times`` (sorted, within [0, t_end]; default [t_end]).

    schedule: list of (t_start, force, torque, frame), sorted, first at 0; each wrench is held
    until the next starts. ``gravity``, ``linear_damping``, ``angular_damping``: as ``rhs``.
    """
    times = [t_end] if times is None else list(times)
    bounds = [s[0] for s in schedule[1:]] + [t_end]
    pieces = [(t0, t1, rhs(body.inertia, body.mass, force, torque, frame, gravity,
                           linear_damping, angular_damping))
              for (t0, force, torque, frame), t1 in zip(schedule, bounds) if t1 > t0]
    out = piecewise(pieces, pack(state), times, rtol, atol)
    return [unpack(out[t]) for t in times]


def integrate(scene, times, rtol: float = RTOL, atol: float = ATOL,
              formulation: str = 'matrix') -> list[tuple[np.ndarray, np.ndarray]]:
    """[(R, omega world (rad/s))] of a benchmark scene (bench/scenes.py's ``Scene``: its
    ``inertia_body``, ``rotation0``, ``omega0_world`` / ``omega0_body`` and world-frame torque
    ``segments()``) at ``times`` (s, sorted, in (0, t_end]). ``formulation`` 'matrix' (world
    frame, R) or 'quaternion' (body frame, q)."""
    times = [float(t) for t in times]
    if formulation == 'matrix':
        y = np.concatenate([scene.rotation0.reshape(9), scene.omega0_world])
        rhs_of = rhs_world_matrix
    else:
        y = np.concatenate([quaternion_wxyz(scene.rotation0), scene.omega0_body])
        rhs_of = rhs_body_quaternion
    pieces = [(t0, t1, rhs_of(scene.inertia_body, tau)) for t0, t1, tau in scene.segments()]
    out = piecewise(pieces, y, times, rtol, atol, f' on {scene.name}')
    states = []
    for t in times:
        yk = out[t]
        if formulation == 'matrix':
            states.append((yk[:9].reshape(3, 3), yk[9:]))
        else:
            rot = matrix_from_wxyz(yk[:4])
            states.append((rot, rot @ yk[4:]))
    return states
