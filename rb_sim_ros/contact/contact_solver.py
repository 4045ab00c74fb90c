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
so a contact that was separating does no positive work.

Energy: the velocity pass never adds kinetic energy. Where Newton's law with friction (Kane's
paradox), simultaneous contacts or an unfinished warm start would, the result is blended with
the plastic solve to the largest restitution that keeps the energy (``_within_energy``;
docs/collisions.md, "Energy").

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

Two kernels run the iterations, with the same arithmetic in the same order: plain floats for
few contacts, numpy over batches of contacts for many. The contacts are coloured so that no
moving body is in two contacts of one colour; each colour is then a batch that numpy can update
at once, and the float kernel visits contacts colour by colour in the same order, so both give
the same bits (test_collisions checks it) and the result does not depend on which ran.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np


@dataclass(frozen=True)
class SolverSettings:
    """restitution e in [0, 1]; friction mu >= 0; dt (s); iterations of each Gauss-Seidel
    pass; slop (m): penetration left uncorrected (keeps resting contacts alive);
    position_fraction in (0, 1]: share of the rest corrected per step; bounce_threshold
    (m/s): slower approaches do not bounce; tolerance (m/s): a pass stops after an iteration
    that changed no contact's velocity by more (the position pass: by more than tolerance dt,
    in m); batch_threshold: contacts from which the numpy kernel runs; rolling_resistance
    (m): the lever arm of the moment resisting rolling, mu_r (0: none); torsional_friction
    (m): that of the moment resisting spin about the normal, mu_t (0: none)."""

    restitution: float = 0.0
    friction: float = 0.5
    dt: float = 1e-3
    velocity_iterations: int = 10
    position_iterations: int = 4
    slop: float = 1e-4
    position_fraction: float = 0.8
    bounce_threshold: float = 0.1
    tolerance: float = 1e-6
    batch_threshold: int = 48
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
        for name in ('velocity_iterations', 'position_iterations', 'batch_threshold'):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise ValueError(f'{name} must be an int >= 0, got {value!r}')


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


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a x b of (M, 3) arrays (np.cross costs several times more on small arrays)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def tangent_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit t1, t2 (M, 3) with (t1, t2, n) right-handed: t1 = n x e / |n x e| for the world
    axis e least aligned with n (the first on a tie), t2 = n x t1. Depends on n only."""
    axis = np.argmin(np.abs(normal), axis=1)
    e = np.eye(3)[axis]
    t1 = cross(normal, e)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, cross(normal, t1)


class _Rows:
    """Per contact, for its 3 rows (normal n, tangents t1, t2): the Jacobian J (M, 12) =
    (linear, angular of body a; linear, angular of body b), so that J . (v_a, w_a, v_b, w_b)
    is the relative velocity of the contact points along the row, and M^-1 J^T (M, 12), the
    change of (v_a, w_a, v_b, w_b) per unit impulse; the effective masses K = J M^-1 J^T."""

    def __init__(self, contacts: ContactArrays, bodies: Bodies) -> None:
        a, b = contacts.body_a, contacts.body_b
        count = len(a)
        n = contacts.normal
        t1, t2 = tangent_basis(n)
        d = np.concatenate([n, t1, t2])                          # (3M, 3): the 3 rows
        ra = np.tile(contacts.point - bodies.position[a], (3, 1))
        rb = np.tile(contacts.point - bodies.position[b], (3, 1))
        ang_a, ang_b = -cross(ra, d), cross(rb, d)              # -(r_a x d), r_b x d
        ma = np.tile(bodies.inverse_mass[a], 3)[:, None]
        mb = np.tile(bodies.inverse_mass[b], 3)[:, None]
        ia = np.tile(bodies.inverse_inertia[a], (3, 1, 1))
        ib = np.tile(bodies.inverse_inertia[b], (3, 1, 1))
        j = np.concatenate([-d, ang_a, d, ang_b], axis=1)
        w = np.concatenate([-ma * d, np.einsum('mij,mj->mi', ia, ang_a), mb * d,
                            np.einsum('mij,mj->mi', ib, ang_b)], axis=1)
        self.j = [j[:count], j[count:2 * count], j[2 * count:]]
        self.w = [w[:count], w[count:2 * count], w[2 * count:]]
        self.t1, self.t2 = t1, t2

        def k(p, q):
            return np.einsum('mi,mi->m', self.j[p], self.w[q])
        self.k_normal = k(0, 0)
        self.inverse_k = 1.0 / self.k_normal
        # Friction steps along -v_t with the largest eigenvalue of the 2x2 tangent block K_t:
        # a sliding contact's impulse then ends opposite its slip (see docs/collisions.md).
        k11, k12, k22 = k(1, 1), k(1, 2), k(2, 2)
        half_trace, half_diff = 0.5 * (k11 + k22), 0.5 * (k11 - k22)
        self.k_tangent = half_trace + np.sqrt(half_diff * half_diff + k12 * k12)
        self.inverse_kt = 1.0 / self.k_tangent
        self.a, self.b = a, b

    def normal_velocity(self, u: np.ndarray) -> np.ndarray:
        return np.einsum('mi,mi->m', self.j[0], np.concatenate([u[self.a], u[self.b]], axis=1))


def colour(body_a: np.ndarray, body_b: np.ndarray, moving: np.ndarray) -> np.ndarray:
    """Greedy colouring in contact order: each contact gets the lowest colour that neither of
    its moving bodies has yet (static bodies may repeat within a colour; they never move)."""
    masks = [0] * len(moving)
    moving = moving.tolist()
    out = []
    for a, b in zip(body_a.tolist(), body_b.tolist()):
        used = (masks[a] if moving[a] else 0) | (masks[b] if moving[b] else 0)
        bit = ~used & (used + 1)
        out.append(bit.bit_length() - 1)
        if moving[a]:
            masks[a] |= bit
        if moving[b]:
            masks[b] |= bit
    return np.array(out, dtype=np.int64)


def solve(contacts: ContactArrays, bodies: Bodies, settings: SolverSettings,
          warm_normal: np.ndarray | None = None,
          warm_tangent: np.ndarray | None = None,
          restitution: np.ndarray | None = None,
          friction: np.ndarray | None = None) -> SolveResult:
    """Impulses and position correction for ``contacts`` between ``bodies``.

    ``warm_normal`` (M,) and ``warm_tangent`` (M, 3, world) are accumulated impulses carried
    over from the previous step (0 for a new contact); they are applied first and the
    iterations refine them. ``restitution`` and ``friction`` (M,), when given, replace the
    settings' for each contact (the shapes' materials). The bodies' arrays are not
    modified."""
    count = len(contacts)
    body_count = len(bodies.inverse_mass)
    u0 = np.concatenate([bodies.velocity, bodies.angular_velocity], axis=1).astype(float)
    zero = np.zeros((body_count, 3))
    if count == 0:
        return SolveResult(bodies.velocity.copy(), bodies.angular_velocity.copy(), zero,
                           zero.copy(), np.zeros(0), np.zeros((0, 3)), np.zeros(0),
                           np.zeros(body_count, dtype=bool), 0, 0, 0)
    rows = _Rows(contacts, bodies)
    moving = bodies.inverse_mass > 0.0
    colours = colour(contacts.body_a, contacts.body_b, moving)
    order = np.argsort(colours, kind='stable')
    bounds = np.flatnonzero(np.diff(colours[order])) + 1
    batches = np.split(order, bounds)

    # Targets of the normal velocity (see the module doc), from the velocities before.
    vn0 = rows.normal_velocity(u0)
    depth = contacts.depth
    dt = settings.dt
    # A contact that was separating (vn0 > 0) may be pressed back at most at -vn0: its impulse
    # then does no positive work (docs/collisions.md, "Energy").
    plastic = np.minimum(np.where(depth < 0.0, depth / dt, 0.0), -vn0)
    e = settings.restitution if restitution is None else restitution
    # Without restitution there is nothing to bounce: the target stays the plastic one, so a
    # fast body closes a speculative gap and stops on the surface, not where the gap began (a
    # ball at 20 m/s with no gravity used to hover 13 mm off the ground for ever).
    bounce = (vn0 < -settings.bounce_threshold) & (vn0 < plastic) & (np.asarray(e) > 0.0)
    target = np.where(bounce, -e * vn0, plastic)
    mu = np.full(count, float(settings.friction)) if friction is None else friction
    with_friction = bool(np.any(mu > 0.0))
    kernel = _batched if count >= settings.batch_threshold else _scalar
    u, lam, v_done = _velocities(contacts, bodies, settings, rows, u0, target, mu, batches,
                                 with_friction, kernel, warm_normal, warm_tangent)
    # Newton's law with friction or with simultaneous contacts (Kane's paradox), or a warm
    # start the iterations did not undo, can create energy: then the impulses are scaled back
    # just enough (docs/collisions.md, "Energy").
    u, lam, v_more = _within_energy(contacts, bodies, settings, rows, u0, u, lam, plastic, mu,
                                    batches, with_friction, kernel)
    v_done += v_more

    # Position correction on pseudo-velocities (displacements), normal rows only.
    q = np.zeros((body_count, 6))
    p_lam = np.zeros((count, 3))
    p_done = 0
    if settings.position_iterations:
        p_target = settings.position_fraction * (depth - settings.slop)
        if np.any(p_target > 0.0):
            q, p_lam, p_done = kernel(rows, q, p_lam, p_target, mu, batches,
                                      settings.position_iterations, False,
                                      settings.tolerance * dt)
    touched = np.any(u != u0, axis=1) | np.any(q != 0.0, axis=1)
    tangent = lam[:, 1:2] * rows.t1 + lam[:, 2:3] * rows.t2
    return SolveResult(u[:, :3], u[:, 3:], q[:, :3], q[:, 3:], lam[:, 0], tangent,
                       p_lam[:, 0], touched, int(colours.max()) + 1, v_done, p_done)


def kinetic_energies(bodies: Bodies, u: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Kinetic energy (J) of each moving body ``which`` (indices) at velocities ``u`` (N, 6):
    1/2 m v.v + 1/2 w . I w, with I w solved from the world inverse inertia."""
    v, w = u[which, :3], u[which, 3:6]
    iw = np.linalg.solve(bodies.inverse_inertia[which], w[:, :, None])[:, :, 0]
    return 0.5 * (np.einsum('ni,ni->n', v, v) / bodies.inverse_mass[which]
                  + np.einsum('ni,ni->n', w, iw))


def kinetic_energy(bodies: Bodies, u: np.ndarray, which: np.ndarray) -> float:
    """The total of ``kinetic_energies`` (J)."""
    return float(np.sum(kinetic_energies(bodies, u, which)))


# Relative gain of kinetic energy above which a velocity solve is taken to have created energy
# (rounding of the solve is ~1e-15 relative).
ENERGY_TOLERANCE = 1e-9


def _within_energy(contacts, bodies, settings, rows, u0, u, lam, plastic, mu, batches,
                   with_friction, kernel):
    """(u, lam, extra iterations): the solve ``u``, ``lam`` if it has no more kinetic energy
    than ``u0`` (to ENERGY_TOLERANCE); else a blend that has none. The base is the plastic solve
    (every target the one without restitution, no warm start), or if even that gained, the
    blend of u0 towards it that keeps the energy; then from the base towards ``u`` by the
    largest s in [0, 1] that keeps the energy. Every candidate is a set of equal and opposite
    impulses with lambda_n >= 0 inside the friction cones, and so is a blend of them (the
    constraints are convex): momentum is kept, and s scales the restitution down."""
    moving = bodies.inverse_mass > 0.0
    which = np.unique(np.concatenate([contacts.body_a, contacts.body_b]))
    which = which[moving[which]]
    e0 = kinetic_energy(bodies, u0, which)
    if not kinetic_energy(bodies, u, which) > e0 * (1.0 + ENERGY_TOLERANCE):
        return u, lam, 0  # (a non-finite one too: the collision world's check says so)
    base, base_lam, done = _velocities(contacts, bodies, settings, rows, u0, plastic, mu,
                                       batches, with_friction, kernel, None, None)
    s = _largest_step(bodies, which, u0, base, e0)
    base, base_lam = u0 + s * (base - u0), s * base_lam
    s = _largest_step(bodies, which, base, u, e0)
    return base + s * (u - base), base_lam + s * (lam - base_lam), done


def _largest_step(bodies, which, start, end, limit) -> float:
    """The largest s in [0, 1] with kinetic energy at start + s (end - start) <= ``limit``,
    given that of ``start`` is (0 if it is not)."""
    e_start = kinetic_energy(bodies, start, which)
    e_end = kinetic_energy(bodies, end, which)
    if e_end <= limit:
        return 1.0
    if not e_start <= limit:
        return 0.0
    # E(s) = e_start + b s + a s^2; the root of E(s) = limit in [0, 1).
    a = kinetic_energy(bodies, end - start, which)
    b = e_end - e_start - a
    if not a > 0.0:
        return 0.0
    s = (-b + math.sqrt(max(b * b + 4.0 * a * (limit - e_start), 0.0))) / (2.0 * a)
    return min(max(s, 0.0), 1.0) * (1.0 - 1e-12)


def _velocities(contacts, bodies, settings, rows, u0, target, mu, batches, with_friction,
                kernel, warm_normal, warm_tangent):
    """The velocity pass (warm start, Gauss-Seidel, rolling and torsional couples) towards
    ``target``: (u, lam, iterations)."""
    count = len(contacts)
    lam = np.zeros((count, 3))
    u = u0.copy()
    if warm_normal is not None:
        lam[:, 0] = np.maximum(warm_normal, 0.0)
        if warm_tangent is not None and with_friction:
            l1 = np.einsum('mi,mi->m', warm_tangent, rows.t1)
            l2 = np.einsum('mi,mi->m', warm_tangent, rows.t2)
            limit = mu * lam[:, 0]
            norm = np.sqrt(l1 * l1 + l2 * l2)
            scale = np.where(norm > limit, limit / np.where(norm > 0.0, norm, 1.0), 1.0)
            lam[:, 1], lam[:, 2] = l1 * scale, l2 * scale
        impulse = (lam[:, 0:1] * rows.w[0] + lam[:, 1:2] * rows.w[1]) + lam[:, 2:3] * rows.w[2]
        np.add.at(u, rows.a, impulse[:, :6])
        np.add.at(u, rows.b, impulse[:, 6:])
    u, lam, done = kernel(rows, u, lam, target, mu, batches, settings.velocity_iterations,
                          with_friction, settings.tolerance)
    if settings.rolling_resistance > 0.0 or settings.torsional_friction > 0.0:
        u = _resist_rolling(contacts, bodies, rows, u, lam[:, 0], settings.rolling_resistance,
                            settings.torsional_friction, batches, kernel is _batched)
    return u, lam, done


def _scalar(rows: _Rows, u: np.ndarray, lam: np.ndarray, target: np.ndarray, mu: np.ndarray,
            batches, iterations: int, friction: bool, tolerance: float):
    """The Gauss-Seidel iterations on plain floats, contacts in colour order. Written out
    term by term: the same operations, in the same order, as ``_batched`` (not ``sum()``,
    which compensates its rounding from Python 3.12 on). Stops after an iteration in which
    no row changed its velocity by more than ``tolerance``; returns (u, lam, iterations)."""
    us = [tuple(row) for row in u.tolist()]
    lams = lam.tolist()
    order = np.concatenate(batches)
    records = list(zip(order.tolist(), rows.a[order].tolist(), rows.b[order].tolist(),
                       *(x[order].tolist() for x in (*rows.j, *rows.w)),
                       *(x[order].tolist() for x in (rows.inverse_k, rows.k_normal,
                                                     rows.inverse_kt, rows.k_tangent,
                                                     target, mu))))
    sqrt = math.sqrt
    done = 0
    while done < iterations:
        done += 1
        change = 0.0
        for k, ia, ib, jn, j1, j2, wn, w1, w2, inv_k, kn, ikt, kt, tgt, m in records:
            a0, a1, a2, a3, a4, a5 = us[ia]
            b0, b1, b2, b3, b4, b5 = us[ib]
            lk = lams[k]
            if friction:
                v1 = (j1[0] * a0 + j1[1] * a1 + j1[2] * a2 + j1[3] * a3 + j1[4] * a4
                      + j1[5] * a5 + j1[6] * b0 + j1[7] * b1 + j1[8] * b2 + j1[9] * b3
                      + j1[10] * b4 + j1[11] * b5)
                v2 = (j2[0] * a0 + j2[1] * a1 + j2[2] * a2 + j2[3] * a3 + j2[4] * a4
                      + j2[5] * a5 + j2[6] * b0 + j2[7] * b1 + j2[8] * b2 + j2[9] * b3
                      + j2[10] * b4 + j2[11] * b5)
                l1 = lk[1] - v1 * ikt
                l2 = lk[2] - v2 * ikt
                limit = m * lk[0]
                s2 = l1 * l1 + l2 * l2
                if s2 > limit * limit:
                    f = limit / sqrt(s2)
                    l1, l2 = l1 * f, l2 * f
                d1, d2 = l1 - lk[1], l2 - lk[2]
                lk[1], lk[2] = l1, l2
                c = (abs(d1) + abs(d2)) * kt         # bounds the change of |v_t|
                if c > change:
                    change = c
                a0, a1, a2 = (a0 + d1 * w1[0] + d2 * w2[0], a1 + d1 * w1[1] + d2 * w2[1],
                              a2 + d1 * w1[2] + d2 * w2[2])
                a3, a4, a5 = (a3 + d1 * w1[3] + d2 * w2[3], a4 + d1 * w1[4] + d2 * w2[4],
                              a5 + d1 * w1[5] + d2 * w2[5])
                b0, b1, b2 = (b0 + d1 * w1[6] + d2 * w2[6], b1 + d1 * w1[7] + d2 * w2[7],
                              b2 + d1 * w1[8] + d2 * w2[8])
                b3, b4, b5 = (b3 + d1 * w1[9] + d2 * w2[9], b4 + d1 * w1[10] + d2 * w2[10],
                              b5 + d1 * w1[11] + d2 * w2[11])
            vn = (jn[0] * a0 + jn[1] * a1 + jn[2] * a2 + jn[3] * a3 + jn[4] * a4 + jn[5] * a5
                  + jn[6] * b0 + jn[7] * b1 + jn[8] * b2 + jn[9] * b3 + jn[10] * b4
                  + jn[11] * b5)
            ln = lk[0] + (tgt - vn) * inv_k
            if ln < 0.0:
                ln = 0.0
            dn = ln - lk[0]
            lk[0] = ln
            c = abs(dn) * kn
            if c > change:
                change = c
            us[ia] = (a0 + dn * wn[0], a1 + dn * wn[1], a2 + dn * wn[2], a3 + dn * wn[3],
                      a4 + dn * wn[4], a5 + dn * wn[5])
            us[ib] = (b0 + dn * wn[6], b1 + dn * wn[7], b2 + dn * wn[8], b3 + dn * wn[9],
                      b4 + dn * wn[10], b5 + dn * wn[11])
        if change <= tolerance:
            break
    return np.array(us, dtype=float).reshape(u.shape), np.array(lams, dtype=float), done


def _resist_rolling(contacts: ContactArrays, bodies: Bodies, rows: _Rows, u: np.ndarray,
                    normal_impulse: np.ndarray, mu_r: float, mu_t: float, batches,
                    batched: bool) -> np.ndarray:
    """One pass of rolling resistance and torsional friction couples over the pressed
    contacts, colour by colour (the module doc; docs/collisions.md (36), (37)); returns the
    new (N, 6) velocities. What depends only on the contacts is computed once with numpy; the
    sequential part runs on floats or, ``batched``, with numpy a colour at a time, with the
    same operations in the same order, so both give the same bits."""
    order = np.concatenate(batches)
    order = order[normal_impulse[order] > 0.0]
    if not len(order):
        return u
    ii = bodies.inverse_inertia
    a, b, n = contacts.body_a[order], contacts.body_b[order], contacts.normal[order]
    t1, t2 = rows.t1[order], rows.t2[order]
    ia, ib = ii[a], ii[b]
    ia_t1, ia_t2 = np.einsum('mij,mj->mi', ia, t1), np.einsum('mij,mj->mi', ia, t2)
    ib_t1, ib_t2 = np.einsum('mij,mj->mi', ib, t1), np.einsum('mij,mj->mi', ib, t2)
    ia_n, ib_n = np.einsum('mij,mj->mi', ia, n), np.einsum('mij,mj->mi', ib, n)
    k11 = np.einsum('mi,mi->m', t1, ia_t1 + ib_t1)
    k12 = np.einsum('mi,mi->m', t1, ia_t2 + ib_t2)
    k22 = np.einsum('mi,mi->m', t2, ia_t2 + ib_t2)
    det = k11 * k22 - k12 * k12
    k_n = np.einsum('mi,mi->m', n, ia_n + ib_n)
    budget_r = mu_r * normal_impulse[order]
    budget_t = mu_t * normal_impulse[order]
    columns = (t1, t2, n, ia_t1, ia_t2, ib_t1, ib_t2, ia_n, ib_n)
    scalars = (k11, k12, k22, det, k_n, budget_r, budget_t)
    if batched:
        return _couples_batched(u, a, b, order, batches, normal_impulse, columns, scalars,
                                mu_r > 0.0, mu_t > 0.0)
    return _couples_scalar(u, a, b, columns, scalars, mu_r > 0.0, mu_t > 0.0)


def _couples_scalar(u, a, b, columns, scalars, rolling, spinning):
    us = [tuple(row) for row in u.tolist()]
    records = zip(a.tolist(), b.tolist(), *(c.tolist() for c in columns),
                  *(x.tolist() for x in scalars))
    sqrt = math.sqrt
    for (ia, ib, t1, t2, n, pa1, pa2, pb1, pb2, pan, pbn, k11, k12, k22, det, k_n, br,
         bt) in records:
        a0, a1, a2, a3, a4, a5 = us[ia]
        b0, b1, b2, b3, b4, b5 = us[ib]
        if rolling:
            r0, r1, r2 = b3 - a3, b4 - a4, b5 - a5
            w1 = r0 * t1[0] + r1 * t1[1] + r2 * t1[2]
            w2 = r0 * t2[0] + r1 * t2[1] + r2 * t2[2]
            if w1 != 0.0 or w2 != 0.0:
                l1 = (k22 * w1 - k12 * w2) / det
                l2 = (k11 * w2 - k12 * w1) / det
                size = sqrt(l1 * l1 + l2 * l2)
                if size > br:
                    f = br / size
                    l1, l2 = l1 * f, l2 * f
                a3, a4, a5 = (a3 + (l1 * pa1[0] + l2 * pa2[0]), a4 + (l1 * pa1[1] + l2 * pa2[1]),
                              a5 + (l1 * pa1[2] + l2 * pa2[2]))
                b3, b4, b5 = (b3 - (l1 * pb1[0] + l2 * pb2[0]), b4 - (l1 * pb1[1] + l2 * pb2[1]),
                              b5 - (l1 * pb1[2] + l2 * pb2[2]))
        if spinning:
            w_n = (b3 - a3) * n[0] + (b4 - a4) * n[1] + (b5 - a5) * n[2]
            if w_n != 0.0:
                c = w_n / k_n
                if abs(c) > bt:
                    c = math.copysign(bt, c)
                a3, a4, a5 = a3 + c * pan[0], a4 + c * pan[1], a5 + c * pan[2]
                b3, b4, b5 = b3 - c * pbn[0], b4 - c * pbn[1], b5 - c * pbn[2]
        us[ia] = (a0, a1, a2, a3, a4, a5)
        us[ib] = (b0, b1, b2, b3, b4, b5)
    return np.array(us, dtype=float).reshape(u.shape)


def _couples_batched(u, a, b, order, batches, normal_impulse, columns, scalars, rolling,
                     spinning):
    u = u.copy()
    t1, t2, n, pa1, pa2, pb1, pb2, pan, pbn = columns
    k11, k12, k22, det, k_n, br, bt = scalars
    start = 0
    for batch in batches:
        count = int(np.count_nonzero(normal_impulse[batch] > 0.0))
        if not count:
            continue
        k = slice(start, start + count)
        start += count
        ia, ib = a[k], b[k]
        wa, wb = u[ia, 3:], u[ib, 3:]
        if rolling:
            r = wb - wa
            w1 = r[:, 0] * t1[k, 0] + r[:, 1] * t1[k, 1] + r[:, 2] * t1[k, 2]
            w2 = r[:, 0] * t2[k, 0] + r[:, 1] * t2[k, 1] + r[:, 2] * t2[k, 2]
            go = (w1 != 0.0) | (w2 != 0.0)
            l1 = (k22[k] * w1 - k12[k] * w2) / det[k]
            l2 = (k11[k] * w2 - k12[k] * w1) / det[k]
            size = np.sqrt(l1 * l1 + l2 * l2)
            over = size > br[k]
            f = br[k] / np.where(over, size, 1.0)
            l1 = np.where(over, l1 * f, l1)[:, None]
            l2 = np.where(over, l2 * f, l2)[:, None]
            go = go[:, None]
            wa = np.where(go, wa + (l1 * pa1[k] + l2 * pa2[k]), wa)
            wb = np.where(go, wb - (l1 * pb1[k] + l2 * pb2[k]), wb)
        if spinning:
            d = wb - wa
            w_n = d[:, 0] * n[k, 0] + d[:, 1] * n[k, 1] + d[:, 2] * n[k, 2]
            c = w_n / k_n[k]
            c = np.where(np.abs(c) > bt[k], np.copysign(bt[k], c), c)
            go = (w_n != 0.0)[:, None]
            c = c[:, None]
            wa = np.where(go, wa + c * pan[k], wa)
            wb = np.where(go, wb - c * pbn[k], wb)
        u[ia, 3:] = wa
        u[ib, 3:] = wb
    return u


def _dot12(j, ua, ub):
    """Row-wise J . (u_a, u_b), summed left to right as the float kernel does."""
    return (j[:, 0] * ua[:, 0] + j[:, 1] * ua[:, 1] + j[:, 2] * ua[:, 2]
            + j[:, 3] * ua[:, 3] + j[:, 4] * ua[:, 4] + j[:, 5] * ua[:, 5]
            + j[:, 6] * ub[:, 0] + j[:, 7] * ub[:, 1] + j[:, 8] * ub[:, 2]
            + j[:, 9] * ub[:, 3] + j[:, 10] * ub[:, 4] + j[:, 11] * ub[:, 5])


def _batched(rows: _Rows, u: np.ndarray, lam: np.ndarray, target: np.ndarray, mu: np.ndarray,
             batches, iterations: int, friction: bool, tolerance: float):
    """The same iterations with numpy, one colour (no shared moving body) at a time."""
    u = u.copy()
    lam = lam.copy()
    pre = [(idx, rows.a[idx], rows.b[idx], [x[idx] for x in rows.j],
            [x[idx][:, :6] for x in rows.w], [x[idx][:, 6:] for x in rows.w],
            rows.inverse_k[idx], rows.k_normal[idx], rows.inverse_kt[idx],
            rows.k_tangent[idx], target[idx], mu[idx]) for idx in batches]
    done = 0
    while done < iterations:
        done += 1
        change = 0.0
        for idx, a, b, j, wa, wb, inv_k, kn, ikt, kt, tgt, m in pre:
            ua, ub = u[a], u[b]
            lk = lam[idx]
            if friction:
                v1 = _dot12(j[1], ua, ub)
                v2 = _dot12(j[2], ua, ub)
                l1 = lk[:, 1] - v1 * ikt
                l2 = lk[:, 2] - v2 * ikt
                limit = m * lk[:, 0]
                s2 = l1 * l1 + l2 * l2
                over = s2 > limit * limit
                if np.any(over):
                    f = limit / np.sqrt(np.where(over, s2, 1.0))
                    l1 = np.where(over, l1 * f, l1)
                    l2 = np.where(over, l2 * f, l2)
                d1, d2 = l1 - lk[:, 1], l2 - lk[:, 2]
                lk[:, 1], lk[:, 2] = l1, l2
                change = max(change, float(np.max((np.abs(d1) + np.abs(d2)) * kt)))
                d1, d2 = d1[:, None], d2[:, None]
                ua = ua + d1 * wa[1] + d2 * wa[2]
                ub = ub + d1 * wb[1] + d2 * wb[2]
            vn = _dot12(j[0], ua, ub)
            ln = lk[:, 0] + (tgt - vn) * inv_k
            ln = np.where(ln < 0.0, 0.0, ln)
            dn = ln - lk[:, 0]
            lk[:, 0] = ln
            change = max(change, float(np.max(np.abs(dn) * kn)))
            dn = dn[:, None]
            u[a] = ua + dn * wa[0]
            u[b] = ub + dn * wb[0]
            lam[idx] = lk
        if change <= tolerance:
            break
    return u, lam, done
