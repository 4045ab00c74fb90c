# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Independent references for the tests: eq. (10) in the world frame integrated by DOP853.

Nothing here uses rb_sim_ros's integrator or its principal-axes dynamics: the right-hand side
forms I = R I_body R^T and solves with numpy, as Thm 1 is printed.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from rb_sim_ros import State


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rhs(inertia_body, mass, force, torque, frame):
    """d/dt of y = (x, v, R row-major, omega), world frame; wrench constant in ``frame``."""
    inertia_body = np.asarray(inertia_body, dtype=float)
    force = np.asarray(force, dtype=float)
    torque = np.asarray(torque, dtype=float)

    def f(_t, y):
        v = y[3:6]
        rot = y[6:15].reshape(3, 3)
        w = y[15:18]
        fw, tw = (rot @ force, rot @ torque) if frame == 'body' else (force, torque)
        inertia = rot @ inertia_body @ rot.T
        beta = np.linalg.solve(inertia, tw - np.cross(w, inertia @ w))
        return np.concatenate([v, fw / mass, (_hat(w) @ rot).reshape(9), beta])

    return f


def pack(state: State) -> np.ndarray:
    return np.concatenate([state.position, state.linear_velocity, state.rotation.reshape(9),
                           state.angular_velocity])


def unpack(y: np.ndarray) -> State:
    rot = y[6:15].reshape(3, 3)
    u, _, vt = np.linalg.svd(rot)
    return State(y[0:3], u @ vt, y[3:6], y[15:18])


def solve(body, state: State, schedule, t_end: float, times=None, rtol=1e-13, atol=1e-14):
    """Reference states at ``times`` (sorted, within [0, t_end]).

    schedule: list of (t_start, force, torque, frame), sorted, first at 0; each wrench is held
    until the next starts. Integrated segment by segment so that no step straddles a jump.
    """
    times = [t_end] if times is None else list(times)
    out = {}
    y = pack(state)
    bounds = [s[0] for s in schedule[1:]] + [t_end]
    for (t0, force, torque, frame), t1 in zip(schedule, bounds):
        if t1 <= t0:
            continue
        grid = sorted({t for t in times if t0 <= t <= t1} | {t1})
        sol = solve_ivp(rhs(body.inertia, body.mass, force, torque, frame), (t0, t1), y,
                        method='DOP853', rtol=rtol, atol=atol, t_eval=grid)
        for i, t in enumerate(grid):
            if t in times:
                out.setdefault(t, unpack(sol.y[:, i]))
        y = sol.y[:, -1]
    return [out[t] for t in times]
