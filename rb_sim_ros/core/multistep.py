# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Proof 3 of the report: the multistep update of v, omega, x and R.

With a_n, beta_n the accelerations at step n and a_{n-1}, beta_{n-1} those of the step before:

    v_{n+1}     = v_n + (3 a_n - a_{n-1}) / 2 dt                                      (11)
    omega_{n+1} = omega_n + (3 beta_n - beta_{n-1}) / 2 dt                            (12)
    x_{n+1}     = x_n + v_n dt + (4 a_n - a_{n-1}) / 6 dt^2                           (13)
    R_{n+1}     = exp([omega_n + (4 beta_n - beta_{n-1}) / 6 dt
                       + (beta_n x omega_n) dt^2 / 12] dt) R_n          (27, last line)

Eq. (14) of the report, as printed, has the wrong sign and symmetry in its dt^3 term and is
not used (see ../shared/seed/NOTES.md): with eq. (27) the local error of R is O(dt^4).
Local errors are O(dt^3) for v and omega and O(dt^4) for x and R; globally the method is
second order.

The method is data: a ``Multistep`` holds the coefficients of a_n and a_{n-1} in each update,
so another explicit method of this family is another table, not another function.
"""

from __future__ import annotations

from dataclasses import dataclass

from rb_sim_ros.core import so3, step_kernel


@dataclass(frozen=True)
class Multistep:
    """Coefficients of one explicit two-step method of the form above.

    velocity_now, velocity_prev: weights of a_n, a_{n-1} (and beta) in v and omega, times dt.
    position_now, position_prev: weights of a_n, a_{n-1} in x, times dt^2.
    rotation_now, rotation_prev: weights of beta_n, beta_{n-1} in the rotation vector, times dt^2.
    rotation_cross: weight of beta_n x omega_n in the rotation vector, times dt^3.
    order: global order of accuracy; local_orders: (v and omega, x and R) one-step orders.
    """

    name: str
    order: int
    local_orders: tuple[int, int]
    velocity_now: float
    velocity_prev: float
    position_now: float
    position_prev: float
    rotation_now: float
    rotation_prev: float
    rotation_cross: float
    description: str = ''


# The report's method: eq. (11), (12), (13) and the last line of eq. (27).
EQ27 = Multistep(
    name='eq27', order=2, local_orders=(3, 4),
    velocity_now=1.5, velocity_prev=-0.5,
    position_now=4.0 / 6.0, position_prev=-1.0 / 6.0,
    rotation_now=4.0 / 6.0, rotation_prev=-1.0 / 6.0, rotation_cross=1.0 / 12.0,
    description='Adams-Bashforth 2 for v, omega; eq. (13) for x; eq. (27) exponential for R')

# Eq. (27) without its dt^2 correction: what the NOTES measured as local order 3 for R.
# Kept to show (in the tests and benchmarks) what the correction buys; not a default.
EQ27_NO_CROSS = Multistep(
    name='eq27-no-cross', order=2, local_orders=(3, 3),
    velocity_now=1.5, velocity_prev=-0.5,
    position_now=4.0 / 6.0, position_prev=-1.0 / 6.0,
    rotation_now=4.0 / 6.0, rotation_prev=-1.0 / 6.0, rotation_cross=0.0,
    description='eq27 without the (beta x omega) dt^2/12 term')

# One-step Taylor method (no history): v += a dt, x += v dt + a dt^2/2, R = exp((w + b dt/2) dt) R.
# First order globally; the cheap baseline of the benchmarks.
TAYLOR1 = Multistep(
    name='taylor1', order=1, local_orders=(2, 3),
    velocity_now=1.0, velocity_prev=0.0,
    position_now=0.5, position_prev=0.0,
    rotation_now=0.5, rotation_prev=0.0, rotation_cross=0.0,
    description='single-step Taylor: explicit Euler for v, omega; second order terms for x, R')

METHODS = {m.name: m for m in (EQ27, EQ27_NO_CROSS, TAYLOR1)}


def method_by_name(name: str) -> Multistep:
    """The method called ``name``; ValueError lists the known ones."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(
            f'integrator must be one of {sorted(METHODS)}, got {name!r}') from None


def make_step(method: Multistep, dt, rotate: bool = True):
    """One step of ``method`` with a fixed dt (s), as a function of components:

        step(x, v, r, w, a, b, a_prev, b_prev) -> (x, v, r, w) at t + dt

    x (m), v (m/s), w (rad/s) are world-frame 3-tuples of floats and r the 9 row-major
    components of R; a, b are the linear (m/s^2) and angular (rad/s^2) accelerations at t,
    a_prev and b_prev those at t - dt, all world frame. It is the step kernel's own update
    (``step_kernel.multistep_step``), called on one body: tests check the method through it.

    ``rotate=False`` builds a step that leaves R and omega as they are, for a body that does
    not turn (omega = beta = beta_prev = 0 under no torque), where the full update would give
    them back (omega bit for bit, R up to the sign of a zero entry) at four times the cost.
    """
    coefficients = step_kernel.method_coefficients(method, float(dt))
    tiny = so3.TINY_ANGLE_SQ

    def step(x, v, r, w, a, b, a_prev, b_prev):
        out = step_kernel.multistep_step(*coefficients, tiny, rotate, *x, *v, *r, *w, *a, *b,
                                         *a_prev, *b_prev)
        return out[0:3], out[3:6], out[6:15], out[15:18]
    return step
