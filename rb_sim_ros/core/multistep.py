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

The method is data: a ``Multistep`` holds the weights of a_n, a_{n-1}, ... in each update, so
another explicit method of this family is another table, not another function. ``lie3`` and
``lie4`` are its members of orders 3 and 4 (k = 3, 4 accelerations; derivation, start-up and
stability in docs/integrators.md): Adams-Bashforth of order k for v and omega, the matching
position formula for x, and R by the exponential of a rotation vector that keeps the Magnus
commutator terms order k needs, (dt^3/12) beta x omega (eq. (27)'s) and (dt^4/24) beta' x omega.
"""

from __future__ import annotations

from dataclasses import dataclass

from rb_sim_ros.core import so3, step_kernel


@dataclass(frozen=True)
class Multistep:
    """Coefficients of one explicit method of the family above, with k = ``steps`` >= 2
    accelerations (a_n, a_{n-1}, ..., a_{n-k+1}; beta likewise), each a tuple of k weights:

    velocity: of a_{n-j} (and beta_{n-j}) in v and omega, times dt.
    position: of a_{n-j} in x, times dt^2.
    rotation: of beta_{n-j} in the rotation vector, times dt^2.
    cross: of beta_{n-j} in (sum_j cross_j beta_{n-j}) x omega_n in the rotation vector, times
        dt^3 (the commutator term of the Magnus expansion and, from k = 3, its derivative).
    order: global order of accuracy; local_orders: (v and omega, x and R) one-step orders.
    """

    name: str
    order: int
    local_orders: tuple[int, int]
    velocity: tuple[float, ...]
    position: tuple[float, ...]
    rotation: tuple[float, ...]
    cross: tuple[float, ...]
    description: str = ''

    @property
    def steps(self) -> int:
        """How many accelerations a step takes (the history is steps - 1 states)."""
        return len(self.velocity)


# The report's method: eq. (11), (12), (13) and the last line of eq. (27).
EQ27 = Multistep(
    name='eq27', order=2, local_orders=(3, 4),
    velocity=(1.5, -0.5), position=(4.0 / 6.0, -1.0 / 6.0), rotation=(4.0 / 6.0, -1.0 / 6.0),
    cross=(1.0 / 12.0, 0.0),
    description='Adams-Bashforth 2 for v, omega; eq. (13) for x; eq. (27) exponential for R')

# Eq. (27) without its dt^2 correction: what the NOTES measured as local order 3 for R.
# Kept to show (in the tests and benchmarks) what the correction buys; not a default.
EQ27_NO_CROSS = Multistep(
    name='eq27-no-cross', order=2, local_orders=(3, 3),
    velocity=(1.5, -0.5), position=(4.0 / 6.0, -1.0 / 6.0), rotation=(4.0 / 6.0, -1.0 / 6.0),
    cross=(0.0, 0.0),
    description='eq27 without the (beta x omega) dt^2/12 term')

# One-step Taylor method (no history): v += a dt, x += v dt + a dt^2/2, R = exp((w + b dt/2) dt) R.
# First order globally; the cheap baseline of the benchmarks.
TAYLOR1 = Multistep(
    name='taylor1', order=1, local_orders=(2, 3),
    velocity=(1.0, 0.0), position=(0.5, 0.0), rotation=(0.5, 0.0), cross=(0.0, 0.0),
    description='single-step Taylor: explicit Euler for v, omega; second order terms for x, R')

# Orders 3 and 4 (docs/integrators.md): Adams-Bashforth of order k for v and omega; for x and
# the rotation vector the integral of the interpolated a (beta) against (1 - s); the Magnus
# commutator (dt^3/12) beta_n x omega_n + (dt^4/24) beta_n' x omega_n, beta_n' by differences.
LIE3 = Multistep(
    name='lie3', order=3, local_orders=(4, 5),
    velocity=(23.0 / 12.0, -16.0 / 12.0, 5.0 / 12.0),
    position=(19.0 / 24.0, -10.0 / 24.0, 3.0 / 24.0),
    rotation=(19.0 / 24.0, -10.0 / 24.0, 3.0 / 24.0),
    cross=(7.0 / 48.0, -4.0 / 48.0, 1.0 / 48.0),
    description='Lie Adams-Bashforth 3: AB3 for v, omega; exponential of a Magnus rotation '
                'vector for R')

LIE4 = Multistep(
    name='lie4', order=4, local_orders=(5, 5),
    velocity=(55.0 / 24.0, -59.0 / 24.0, 37.0 / 24.0, -9.0 / 24.0),
    position=(323.0 / 360.0, -264.0 / 360.0, 159.0 / 360.0, -38.0 / 360.0),
    rotation=(323.0 / 360.0, -264.0 / 360.0, 159.0 / 360.0, -38.0 / 360.0),
    cross=(23.0 / 144.0, -18.0 / 144.0, 9.0 / 144.0, -2.0 / 144.0),
    description='Lie Adams-Bashforth 4: AB4 for v, omega; exponential of a Magnus rotation '
                'vector for R')


@dataclass(frozen=True)
class Splitting:
    """The exact torque-free flow (``free_flow``) composed with kicks of the wrench: one
    step of dt is, for each weight w in turn, a kick of w dt / 2, the free flow of w dt
    (and x += v w dt), a kick of w dt / 2 (Strang). A kick holds R and changes v and the
    angular momentum by the wrench, damping solved exactly. No history: ``steps`` is 1.
    weights: (1,) is Strang, order 2; the triple jump (w1, w0, w1) is order 4."""

    name: str
    order: int
    weights: tuple[float, ...]
    description: str = ''

    @property
    def steps(self) -> int:
        return 1


# Strang splitting: exact for a torque-free body at any dt (energy and |L| to rounding).
FLOW2 = Splitting(
    name='flow2', order=2, weights=(1.0,),
    description='exact torque-free flow between half kicks of the wrench (Strang)')

_CBRT2 = 2.0 ** (1.0 / 3.0)
# Yoshida's triple jump of Strang steps: order 4, still exact torque-free.
FLOW4 = Splitting(
    name='flow4', order=4,
    weights=(1.0 / (2.0 - _CBRT2), -_CBRT2 / (2.0 - _CBRT2), 1.0 / (2.0 - _CBRT2)),
    description='exact torque-free flow and kicks, composed to order 4 (triple jump)')

METHODS = {m.name: m for m in (EQ27, EQ27_NO_CROSS, TAYLOR1, LIE3, LIE4, FLOW2, FLOW4)}


def method_by_name(name: str) -> Multistep | Splitting:
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
        out = step_kernel.multistep_step(*coefficients, tiny, False, rotate, *x, *v, *r, *w,
                                         *a, *b, *a_prev, *b_prev)
        return out[0:3], out[3:6], out[6:15], out[15:18]
    return step
