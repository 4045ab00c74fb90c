# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Contact response: impulses with restitution and Coulomb friction, then position correction.

The derivation is docs/collisions.md ("Proof 2"); in short, for a contact at point p with unit
normal n from body a to body b, r_a = p - x_a, r_b = p - x_b (world frame), and the world
inverse inertias I^-1 = R I_body^-1 R^T:

    v_rel . n = n . (v_b + w_b x r_b - v_a - w_a x r_a)
    K = 1/m_a + 1/m_b + n . ((I_a^-1 (r_a x n)) x r_a + (I_b^-1 (r_b x n)) x r_b)
    j = -(1 + e) v_rel . n / K        (one contact alone; +j n on b, -j n on a, at p)

Every impulse is applied equal and opposite at one point, so linear momentum and angular
momentum about any fixed point are conserved exactly (up to rounding) by the velocity solve.
Several contacts are solved by projected Gauss-Seidel (sequential impulses) on the
accumulated impulse of each: the normal one clamped to >= 0, the tangent one (a 2-vector, each
step along -v_t scaled by the largest eigenvalue of the 2x2 tangent effective mass, so that a
sliding contact's impulse converges to the direction opposite its slip) projected onto the
Coulomb disc |lambda_t| <= mu lambda_n. Targets of
the normal velocity: -e (v_rel . n before) for an impact (approach faster than the bounce
threshold, e > 0), 0 for a resting or sliding contact, and -gap/dt for a speculative one (a
gap that the bodies may close in one step, but not more: no tunnelling); never above
-(v_rel . n before),
so a contact that was separating does no positive work. A step with an impact first passes
it from pair to pair of bodies as the sequence of ideal pairwise collisions would (the
impact pass, ``solver_kernels._impacts``; docs/collisions.md, "Impacts"): a chain of touching
bodies transmits it, and a contact pushed there keeps its bounce as its target.

Energy: the velocity pass never adds kinetic energy. Where Newton's law with friction (Kane's
paradox), simultaneous contacts or an unfinished warm start would, the result is blended with
the plastic solve to the largest restitution that keeps the energy (``_largest_step`` of
``solver_kernels``; docs/collisions.md, "Energy").

Rolling resistance (``rolling_resistance`` mu_r, a length in m, 0 by default): after the
velocity iterations, each pressed contact gets a couple in the tangent plane (equal and
opposite angular impulses, so momentum and angular momentum are kept) against the part w_t of
the relative angular velocity w_b - w_a along the surface: the one that stops it,
K_t^-1 w_t with K_t the 2x2 block of I_a^-1 + I_b^-1 on the tangents, scaled down to at most
mu_r lambda_n (the resisting moment mu_r N of a normal force acting a distance mu_r ahead of
the contact point). w_t then shrinks by that scale and never turns back. Torsional friction
(``torsional_friction`` mu_t, m) does the same for the spin about the normal, w_n: a couple
along n of at most mu_t lambda_n, bounded by what stops w_n.

Position correction is split from the velocities (split impulse / non-linear projection): a
second Gauss-Seidel pass on pseudo-velocities that are displacements, with the same rows,
moves the bodies apart by ``position_fraction`` of the penetration beyond ``slop``. It never
changes v or omega (the collision world turns omega with R, keeping 1/2 w . I w), so the
velocity impulses keep momentum exactly and add no energy.

One compiled kernel does all of it (``solver_kernels.solve_arrays``, on arrays; ``solve``
below is its Python face). The contacts are coloured in contact order (greedily while a body
has few; in O(contacts) however many: ``solver_kernels._colour``) so that no
moving body is in two contacts of one colour, and Gauss-Seidel visits them colour by colour,
one after the other: the order, and so the result, depends only on the inputs. Its arithmetic
is plain float64 in a written order (no BLAS), so the compiled and the interpreted path
(``NUMBA_DISABLE_JIT=1``) give the same bits (test_collisions checks it).
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from rb_sim_ros.contact import solver_kernels as kernels

# Relative gain of kinetic energy above which a velocity solve is taken to have created energy
# and is blended with the plastic one (rounding of the solve is ~1e-15 relative).
ENERGY_TOLERANCE = kernels.ENERGY_TOLERANCE


# The largest iteration count (the kernel's settings are floats; 2^31 - 1 converts exactly).
MAX_COUNT = 2 ** 31 - 1


@dataclass(frozen=True)
class SolverSettings:
    """restitution e in [0, 1]; friction mu >= 0; dt (s); iterations of each Gauss-Seidel
    pass; slop (m): penetration left uncorrected (keeps resting contacts alive);
    position_fraction in (0, 1]: share of the rest corrected per step; bounce_threshold
    (m/s): slower approaches do not bounce; tolerance (m/s): a pass stops after an iteration
    that changed no contact's velocity by more (the position pass: by more than tolerance dt,
    in m); rolling_resistance (m): the lever arm of the moment resisting rolling, mu_r (0:
    none); torsional_friction (m): that of the moment resisting spin about the normal, mu_t
    (0: none)."""

    restitution: float = 0.0
    friction: float = 0.5
    dt: float = 1e-3
    velocity_iterations: int = 10
    position_iterations: int = 4
    slop: float = 1e-4
    position_fraction: float = 0.8
    bounce_threshold: float = 0.1
    tolerance: float = 1e-6
    rolling_resistance: float = 0.0
    torsional_friction: float = 0.0

    def __post_init__(self) -> None:
        _number('restitution', self.restitution, 0.0, 1.0)
        _number('friction', self.friction, 0.0, math.inf)
        _number('dt', self.dt, 0.0, math.inf, open_low=True)
        _number('slop', self.slop, 0.0, math.inf)
        _number('position_fraction', self.position_fraction, 0.0, 1.0, open_low=True)
        _number('bounce_threshold', self.bounce_threshold, 0.0, math.inf)
        _number('tolerance', self.tolerance, 0.0, math.inf)
        _number('rolling_resistance', self.rolling_resistance, 0.0, math.inf)
        _number('torsional_friction', self.torsional_friction, 0.0, math.inf)
        for name in ('velocity_iterations', 'position_iterations'):
            value = getattr(self, name)
            # (at most 2^31 - 1: the kernel reads the counts back from floats)
            if (not isinstance(value, int) or isinstance(value, bool) or value < 0
                    or value > MAX_COUNT):
                raise ValueError(f'{name} must be an int in [0, {MAX_COUNT}], got {value!r}')


def _number(name, value, low, high, open_low=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f'{name} must be a number, got {value!r}')
    value = float(value)
    bad = not math.isfinite(value) or value > high or value < low or (open_low and value == low)
    if bad:
        bound = f'in {"(" if open_low else "["}{low}, {high}]'
        raise ValueError(f'{name} must be finite and {bound}, got {value!r}')


@dataclass
class Bodies:
    """N bodies as arrays, world frame: position (N, 3) m, velocity (N, 3) m/s,
    angular_velocity (N, 3) rad/s, inverse_mass (N,) 1/kg, inverse_inertia (N, 3, 3)
    (R I_body^-1 R^T, 1/(kg m^2)). A static body (or plane) has inverse mass and inertia 0."""

    position: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    inverse_mass: np.ndarray
    inverse_inertia: np.ndarray


@dataclass
class ContactArrays:
    """M contacts: body indices a, b (M,), point (M, 3) m, normal (M, 3) unit from a to b,
    depth (M,) m (> 0 penetrating), world frame."""

    body_a: np.ndarray
    body_b: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray

    def __len__(self) -> int:
        return len(self.depth)


@dataclass
class SolveResult:
    """velocity, angular_velocity (N, 3) after the impulses; displacement (N, 3) m and
    rotation (N, 3) rad (a rotation vector, applied as R <- exp([rotation]) R) of the position
    correction; normal_impulse (M,) N s, tangent_impulse (M, 3) N s (world vector),
    position_impulse (M,) (kg m); touched (N,) bodies whose state changed; colours used;
    iterations run by each pass."""

    velocity: np.ndarray
    angular_velocity: np.ndarray
    displacement: np.ndarray
    rotation: np.ndarray
    normal_impulse: np.ndarray
    tangent_impulse: np.ndarray
    position_impulse: np.ndarray
    touched: np.ndarray
    colours: int
    velocity_iterations: int
    position_iterations: int


def inverse_inertia_world(rotation: np.ndarray, inverse_inertia_body: np.ndarray) -> np.ndarray:
    """R I_body^-1 R^T for (N, 3, 3) rotations and body-frame inverse inertias (Lemma 1)."""
    return rotation @ inverse_inertia_body @ np.swapaxes(rotation, -1, -2)


def tangent_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit t1, t2 (M, 3) with (t1, t2, n) right-handed for unit normals n (M, 3): t1 =
    n x e / |n x e| for the world axis e least aligned with n (the first on a tie), t2 =
    n x t1. Depends on n only; the solver's own (``solver_kernels.tangent_basis``), row by
    row."""
    out = np.array([kernels.tangent_basis(float(n[0]), float(n[1]), float(n[2]))
                    for n in np.asarray(normal, dtype=float).reshape(-1, 3)]).reshape(-1, 6)
    return out[:, :3], out[:, 3:]


def settings_array(settings: SolverSettings) -> np.ndarray:
    """``settings`` as the float64 array of ``solver_kernels.solve_arrays`` (indices
    ``solver_kernels.RESTITUTION`` ... ``TORSIONAL_FRICTION``; iteration counts as
    floats)."""
    out = np.zeros(kernels.SETTINGS_WIDTH)
    out[kernels.RESTITUTION] = settings.restitution
    out[kernels.FRICTION] = settings.friction
    out[kernels.DT] = settings.dt
    out[kernels.VELOCITY_ITERATIONS] = settings.velocity_iterations
    out[kernels.POSITION_ITERATIONS] = settings.position_iterations
    out[kernels.SLOP] = settings.slop
    out[kernels.POSITION_FRACTION] = settings.position_fraction
    out[kernels.BOUNCE_THRESHOLD] = settings.bounce_threshold
    out[kernels.TOLERANCE] = settings.tolerance
    out[kernels.ROLLING_RESISTANCE] = settings.rolling_resistance
    out[kernels.TORSIONAL_FRICTION] = settings.torsional_friction
    return out


def _floats(values, shape: tuple) -> np.ndarray:
    """``values`` as a C-contiguous, writable float64 array of ``shape`` (broadcast, copied
    if need be): numba compiles a kernel once for each layout and writability of its array
    arguments, so every call passes the same."""
    out = np.asarray(values, dtype=np.float64)
    if out.shape != shape:
        out = np.broadcast_to(out, shape)
    if not (out.flags.c_contiguous and out.flags.writeable):
        out = np.array(out, order='C')
    return out


def _indices(values, count: int) -> np.ndarray:
    """``values`` as a C-contiguous, writable int64 array of ``count`` (as ``_floats``)."""
    out = np.asarray(values, dtype=np.int64).reshape(count)
    if not (out.flags.c_contiguous and out.flags.writeable):
        out = np.array(out, order='C')
    return out


def solve(contacts: ContactArrays, bodies: Bodies, settings: SolverSettings,
          warm_normal: np.ndarray | None = None,
          warm_tangent: np.ndarray | None = None,
          restitution: np.ndarray | None = None,
          friction: np.ndarray | None = None) -> SolveResult:
    """Impulses and position correction for ``contacts`` between ``bodies``.

    ``warm_normal`` (M,) and ``warm_tangent`` (M, 3, world) are accumulated impulses carried
    over from the previous step (0 for a new contact); they are applied first and the
    iterations refine them (``warm_tangent`` without ``warm_normal`` is ignored).
    ``restitution`` and ``friction`` (M,), when given, replace the settings' for each contact
    (the shapes' materials). The bodies' arrays are not modified. One call of the compiled
    ``solver_kernels.solve_arrays``."""
    count = len(contacts)
    body_count = len(bodies.inverse_mass)
    if count == 0:
        zero = np.zeros((body_count, 3))
        return SolveResult(bodies.velocity.copy(), bodies.angular_velocity.copy(), zero,
                           zero.copy(), np.zeros(0), np.zeros((0, 3)), np.zeros(0),
                           np.zeros(body_count, dtype=bool), 0, 0, 0)
    use_warm = warm_normal is not None
    out = SolveResult(np.empty((body_count, 3)), np.empty((body_count, 3)),
                      np.empty((body_count, 3)), np.empty((body_count, 3)), np.empty(count),
                      np.empty((count, 3)), np.empty(count),
                      np.empty(body_count, dtype=np.bool_), 0, 0, 0)
    out.colours, out.velocity_iterations, out.position_iterations = (
        int(x) for x in kernels.solve_arrays(
            _indices(contacts.body_a, count), _indices(contacts.body_b, count),
            _floats(contacts.point, (count, 3)), _floats(contacts.normal, (count, 3)),
            _floats(contacts.depth, (count,)), _floats(bodies.position, (body_count, 3)),
            _floats(bodies.velocity, (body_count, 3)),
            _floats(bodies.angular_velocity, (body_count, 3)),
            _floats(bodies.inverse_mass, (body_count,)),
            _floats(bodies.inverse_inertia, (body_count, 3, 3)).reshape(body_count, 9),
            settings_array(settings),
            _floats(warm_normal if use_warm else 0.0, (count,)),
            _floats(warm_tangent if use_warm and warm_tangent is not None else 0.0,
                    (count, 3)),
            use_warm,
            _floats(settings.restitution if restitution is None else restitution, (count,)),
            _floats(settings.friction if friction is None else friction, (count,)),
            out.velocity, out.angular_velocity, out.displacement, out.rotation,
            out.normal_impulse, out.tangent_impulse, out.position_impulse, out.touched))
    return out


def kinetic_energies(bodies: Bodies, u: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Kinetic energy (J) of each moving body ``which`` (indices) at velocities ``u`` (N, 6):
    1/2 m v.v + 1/2 w . I w, with I w solved from the world inverse inertia. (numpy, for the
    collision world's check; the solver's guard measures it in its kernel.)"""
    v, w = u[which, :3], u[which, 3:6]
    iw = np.linalg.solve(bodies.inverse_inertia[which], w[:, :, None])[:, :, 0]
    return 0.5 * (np.einsum('ni,ni->n', v, v) / bodies.inverse_mass[which]
                  + np.einsum('ni,ni->n', w, iw))


def kinetic_energy(bodies: Bodies, u: np.ndarray, which: np.ndarray) -> float:
    """The total of ``kinetic_energies`` (J)."""
    return float(np.sum(kinetic_energies(bodies, u, which)))
