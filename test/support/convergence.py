# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The order tests' body, start and wrenches, and how they measure (test_convergence for eq27,
test_high_order for lie3, lie4 and the flows): errors against the DOP853 reference at 1e-13
(oracles/dop853.py), and the orders measured between consecutive halvings of dt."""

import math

import numpy as np

from oracles import dop853
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

BODY = RigidBody(1.3, [[1.2, 0.1, 0.05], [0.1, 2.0, -0.1], [0.05, -0.1, 2.6]])
START = State(position=[0.1, -0.2, 0.3], rotation=so3.exp([0.3, -0.5, 0.2]),
              linear_velocity=[0.5, -0.1, 0.2], angular_velocity=[0.8, -1.5, 1.1])
FORCE, TORQUE = [0.3, -0.2, 0.6], [0.2, 0.4, -0.3]
# A wrench in either frame that changes every 0.125 s (16 of them, 2 s).
SCHEDULE = [(k * 0.125, [0.5 * math.sin(k), 0.3 * math.cos(3 * k), 0.2 * (-1) ** k],
             [0.4 * math.cos(2 * k), 0.3 * (-1) ** k, 0.5 * math.sin(k + 1)],
             'body' if k % 2 else 'world') for k in range(16)]


def state_errors(state, ref):
    return {
        'x': float(np.linalg.norm(state.position - ref.position)),
        'v': float(np.linalg.norm(state.linear_velocity - ref.linear_velocity)),
        'w': float(np.linalg.norm(state.angular_velocity - ref.angular_velocity)),
        'R': so3.angle_between(state.rotation, ref.rotation),
    }


def orders_of(errors):
    """Per quantity, the orders measured between consecutive halvings of dt."""
    return {q: [math.log2(a[q] / b[q]) for a, b in zip(errors, errors[1:])] for q in errors[0]}


def global_errors(schedule, t_end, dts, tamper=None, method='eq27'):
    ref = dop853.solve(BODY, START, schedule, t_end)[0]
    errors = []
    for dt in dts:
        s = Stepper(BODY, dt, START, method=method)
        bounds = [row[0] for row in schedule[1:]] + [t_end]
        for (t0, force, torque, frame), t1 in zip(schedule, bounds):
            s.set_wrench(Wrench(force, torque, frame))
            if tamper:
                tamper(s)
            s.step(round((t1 - t0) / dt))
        errors.append(state_errors(s.state, ref))
    return errors
