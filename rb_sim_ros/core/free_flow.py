# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The exact torque-free motion of a rigid body, for any step: Jacobi elliptic functions for
the body-frame angular momentum, Carlson's elliptic integrals for the attitude.

``free_flow`` takes (R, omega) of a body with principal moments I (R of the principal frame,
omega world frame) through time h of torque-free motion. Derivation in
docs/integrators.md ("The exact free flow"); in short:

* the body-frame angular momentum m = I (R^T omega) keeps |m|^2 = G^2 and m . I^-1 m = H.
  With the axes ordered (p, q, r) so that m_r never changes sign (r the axis of largest
  moment if G^2 >= H I_mid, else of the smallest), m_p = a cn(u), m_q = b sn(u),
  m_r = c dn(u), u = u0 + lambda t (Landau-Lifshitz section 37), parameter k^2 < 1;
* R(t) m(t) = L, the world angular momentum, for all t: R(t) = R(0) P^T B(0)^T Rz(dphi)
  B(t) P, B(t) the rotation taking m(t) to G e_z (two Euler angles of m), P the axes'
  order, dphi the precession about L, dphi = G / (I_p lambda) [Phi(u1) - Phi(u0)],
  Phi(u) = F(am u) + (n + gamma) J(am u) by Carlson's R_F and R_J. L is kept to rounding
  whatever dphi's error;
* a symmetric body (two moments equal) has the closed form exp(h [L] / I_t) R exp(h nu
  [e_s]); a steady rotation about a principal axis, exp(h [omega]) R.

Plain + - * / sqrt sin cos on float64 in a data-dependent but deterministic number of
iterations: compiled and interpreted give the same bits.
"""

from __future__ import annotations

import math

import numpy as np

from rb_sim_ros.core.jit import kernel
from rb_sim_ros.core.rotation_kernels import exp_so3, mul33

# Carlson's duplication stops when the arguments agree to these; the series after it then
# has an error below 1e-16 (Carlson 1995; Numerical Recipes 3rd ed., 6.12).
_RF_TOL, _RJ_TOL, _RC_TOL = 0.0025, 0.0015, 0.0012
_MAX_DUPLICATIONS = 60
# The AGM of sncndn stops when a and b agree to this (its error is about its square).
_SNCNDN_TOL = 1e-8


@kernel
def carlson_rf(x, y, z):
    """R_F(x, y, z), x, y, z >= 0, at most one 0 (DLMF 19.16.1)."""
    mu, dx, dy, dz = 1.0, 0.0, 0.0, 0.0
    for _ in range(_MAX_DUPLICATIONS):
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
        mu = (x + y + z) / 3.0
        dx, dy, dz = (mu - x) / mu, (mu - y) / mu, (mu - z) / mu
        if max(abs(dx), abs(dy), abs(dz)) < _RF_TOL:
            break
    e2 = dx * dy - dz * dz
    e3 = dx * dy * dz
    return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / math.sqrt(mu)


@kernel
def carlson_rc(x, y):
    """R_C(x, y) = R_F(x, y, y), x >= 0, y > 0 (DLMF 19.2.17)."""
    ave, s = 1.0, 0.0
    for _ in range(_MAX_DUPLICATIONS):
        lam = 2.0 * math.sqrt(x) * math.sqrt(y) + y
        x, y = 0.25 * (x + lam), 0.25 * (y + lam)
        ave = (x + y + y) / 3.0
        s = (y - ave) / ave
        if abs(s) <= _RC_TOL:
            break
    return (1.0 + s * s * (0.3 + s * (1.0 / 7.0 + s * (0.375 + s * 9.0 / 22.0)))) / (
        math.sqrt(ave))


@kernel
def carlson_rj(x, y, z, p):
    """R_J(x, y, z, p), x, y, z >= 0 (at most one 0), p > 0 (DLMF 19.16.2)."""
    c1, c2, c3, c4 = 3.0 / 14.0, 1.0 / 3.0, 3.0 / 22.0, 3.0 / 26.0
    c5, c6, c7, c8 = 0.75 * c3, 1.5 * c4, 0.5 * c2, c3 + c3
    total, fac = 0.0, 1.0
    ave, dx, dy, dz, dp = 1.0, 0.0, 0.0, 0.0, 0.0
    for _ in range(_MAX_DUPLICATIONS):
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        alpha = p * (sx + sy + sz) + sx * sy * sz
        alpha = alpha * alpha
        beta = p * (p + lam) * (p + lam)
        total += fac * carlson_rc(alpha, beta)
        fac *= 0.25
        x, y, z, p = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam), 0.25 * (p + lam)
        ave = 0.2 * (x + y + z + p + p)
        dx, dy, dz, dp = (ave - x) / ave, (ave - y) / ave, (ave - z) / ave, (ave - p) / ave
        if max(abs(dx), abs(dy), abs(dz), abs(dp)) <= _RJ_TOL:
            break
    ea = dx * (dy + dz) + dy * dz
    eb = dx * dy * dz
    ec = dp * dp
    ed = ea - 3.0 * ec
    ee = eb + 2.0 * dp * (ea - ec)
    return 3.0 * total + fac * (1.0 + ed * (-c1 + c5 * ed - c6 * ee) + eb * (c7 + dp * (
        -c8 + dp * c4)) + dp * ea * (c2 - dp * c3) - c2 * dp * ec) / (ave * math.sqrt(ave))


@kernel
def sncndn(u, mc):
    """Jacobi sn, cn, dn of u for parameter m = 1 - mc, 0 <= mc <= 1, by the descending
    Landen (AGM) transformation (Numerical Recipes 3rd ed., 6.12)."""
    if mc == 0.0:
        cn = 1.0 / math.cosh(u)
        return math.tanh(u), cn, cn
    em = np.empty(16)
    en = np.empty(16)
    a, dn, c = 1.0, 1.0, 1.0
    emc = mc
    last = 0
    for i in range(16):
        last = i
        em[i] = a
        emc = math.sqrt(emc)
        en[i] = emc
        c = 0.5 * (a + emc)
        if abs(a - emc) <= _SNCNDN_TOL * a:
            break
        emc *= a
        a = c
    u *= c
    sn, cn = math.sin(u), math.cos(u)
    if sn != 0.0:
        a = cn / sn
        c *= a
        for ii in range(last, -1, -1):
            b = em[ii]
            a *= c
            c *= dn
            dn = (en[ii] + a) / (b + a)
            a = c / b
        a = 1.0 / math.sqrt(c * c + 1.0)
        sn = a if sn >= 0.0 else -a
        cn = c * sn
    return sn, cn, dn


@kernel
def _phi(s, c, d, n, ng):
    """F(phi) + ng J(phi) at sin(phi) = s (sn), cos(phi) = c >= 0 (cn), Delta = d (dn),
    |phi| <= pi/2: the integral of (1 + gamma sn^2) / (1 - n sn^2) du from 0 to the u of
    amplitude phi (ng = n + gamma), J(phi) = integral of sin^2 / ((1 - n sin^2) Delta)
    = s^3 R_J(c^2, d^2, 1, 1 - n s^2) / 3. cn and dn are taken as given, not as
    sqrt(1 - s^2): near the middle axis they are small and only they are accurate; and
    1 - n s^2 is c^2 + (1 - n) s^2, which does not cancel."""
    f = s * carlson_rf(c * c, d * d, 1.0)
    if ng == 0.0 or s == 0.0:
        return f
    return f + ng * s * s * s * carlson_rj(c * c, d * d, 1.0, c * c + (1.0 - n) * s * s) / 3.0


@kernel
def _steady(r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, h, tiny):
    """A body whose omega stays put (steady rotation, or isotropic): exp(h [omega]) R."""
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = exp_so3(wx * h, wy * h, wz * h, tiny)
    q = mul33(e00, e01, e02, e10, e11, e12, e20, e21, e22,
              r00, r01, r02, r10, r11, r12, r20, r21, r22)
    return q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], wx, wy, wz


@kernel
def _from_body(q00, q01, q02, q10, q11, q12, q20, q21, q22, mx, my, mz, ix, iy, iz):
    """omega in the world frame from R (principal) and the body-frame momentum: R (m / I)."""
    bx, by, bz = mx / ix, my / iy, mz / iz
    return (q00 * bx + q01 * by + q02 * bz, q10 * bx + q11 * by + q12 * bz,
            q20 * bx + q21 * by + q22 * bz)


@kernel
def _symmetric(ix, iy, iz, axis, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz,
               mx, my, mz, h, tiny):
    """Two moments equal, ``axis`` the other one (0, 1, 2): R(h) = exp(h [L] / I_t) R
    exp(h nu [e_s]), nu = m_s (1 / I_s - 1 / I_t); m(h) = exp(-h nu [e_s]) m."""
    if axis == 0:
        i_s, i_t, m_s = ix, iy, mx
    elif axis == 1:
        i_s, i_t, m_s = iy, iz, my
    else:
        i_s, i_t, m_s = iz, ix, mz
    nu = m_s * (1.0 / i_s - 1.0 / i_t)
    lx = r00 * mx + r01 * my + r02 * mz
    ly = r10 * mx + r11 * my + r12 * mz
    lz = r20 * mx + r21 * my + r22 * mz
    g = h / i_t
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = exp_so3(lx * g, ly * g, lz * g, tiny)
    a = mul33(e00, e01, e02, e10, e11, e12, e20, e21, e22,
              r00, r01, r02, r10, r11, r12, r20, r21, r22)
    sx = h * nu if axis == 0 else 0.0
    sy = h * nu if axis == 1 else 0.0
    sz = h * nu if axis == 2 else 0.0
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = exp_so3(sx, sy, sz, tiny)
    q = mul33(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8],
              f00, f01, f02, f10, f11, f12, f20, f21, f22)
    # m(h) = exp(-h nu [e_s]) m = F^T m
    nx = f00 * mx + f10 * my + f20 * mz
    ny = f01 * mx + f11 * my + f21 * mz
    nz = f02 * mx + f12 * my + f22 * mz
    w0, w1, w2 = _from_body(q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8],
                            nx, ny, nz, ix, iy, iz)
    return q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], w0, w1, w2


@kernel
def _euler_b(mp, mq, mr):
    """B, 9 row-major floats: the rotation Rx(theta) Rz(psi) taking (m_p, m_q, m_r) to
    (0, 0, |m|): cos(theta) = m_r / |m|, sin(psi) = m_p / rho, cos(psi) = m_q / rho."""
    rho = math.sqrt(mp * mp + mq * mq)
    g = math.sqrt(rho * rho + mr * mr)  # its own norm: B is a rotation to rounding
    st, ct = rho / g, mr / g
    sp, cp = mp / rho, mq / rho
    return cp, -sp, 0.0, ct * sp, ct * cp, -st, st * sp, st * cp, ct


@kernel
def _extremes(ix, iy, iz):
    """The axes of the smallest and the largest moment, and the other one."""
    m3 = (ix, iy, iz)
    lo = 0
    hi = 0
    for k in range(1, 3):
        if m3[k] < m3[lo]:
            lo = k
        if m3[k] > m3[hi]:
            hi = k
    return lo, hi, 3 - lo - hi


@kernel
def invariants(ix, iy, iz, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz):
    """The two invariants of torque-free motion the flow keeps, each a sum of terms of one
    sign (no cancellation): E_lo = G^2 - H I_lo = sum m_i^2 (1 - I_lo / I_i) and
    E_hi = H I_hi - G^2 = sum m_i^2 (I_hi / I_i - 1), m = I R^T omega, G^2 = |m|^2,
    H = m . I^-1 m (twice the kinetic energy)."""
    mx = ix * (r00 * wx + r10 * wy + r20 * wz)
    my = iy * (r01 * wx + r11 * wy + r21 * wz)
    mz = iz * (r02 * wx + r12 * wy + r22 * wz)
    lo, hi, _ = _extremes(ix, iy, iz)
    m3 = (ix, iy, iz)
    i_lo, i_hi = m3[lo], m3[hi]
    e_lo = mx * mx * (1.0 - i_lo / ix) + my * my * (1.0 - i_lo / iy) + mz * mz * (
        1.0 - i_lo / iz)
    e_hi = mx * mx * (i_hi / ix - 1.0) + my * my * (i_hi / iy - 1.0) + mz * mz * (
        i_hi / iz - 1.0)
    return e_lo, e_hi


@kernel
def _constants(ix, iy, iz, e_lo, e_hi):
    """The polhode of the invariants (e_lo, e_hi): ok (False: no elliptic form, at a steady
    rotation about a principal axis), the axes p, q, r and q's sign, the moments I_p, I_q,
    I_r, the amplitudes a, b, |c|, k^2, |lambda|, n, n + gamma, 1 - k^2, the u of a half
    period of the amplitude (2K), Phi over it, and G."""
    lo, hi, mid = _extremes(ix, iy, iz)
    m3 = (ix, iy, iz)
    i_lo, i_mid, i_hi = m3[lo], m3[mid], m3[hi]
    # G^2 - H I_mid, by its sign: about the axis of the largest moment, or of the smallest
    if e_lo * (i_hi - i_mid) >= e_hi * (i_mid - i_lo):
        p_ax, r_ax = lo, hi
        d_r, d_p = e_hi, e_lo  # H I_r - G^2, G^2 - H I_p
    else:
        p_ax, r_ax = hi, lo
        d_r, d_p = -e_lo, -e_hi
    q_ax = mid
    # (p, q, r) right-handed: if not a cyclic order of (0, 1, 2), flip q.
    sign_q = 1.0 if (q_ax - p_ax) % 3 == 1 else -1.0
    ip, iq, ir = m3[p_ax], m3[q_ax], m3[r_ax]
    hh = (e_lo + e_hi) / (i_hi - i_lo)
    g = math.sqrt(e_lo + hh * i_lo)
    a2 = ip * d_r / (ir - ip)
    b2 = iq * d_r / (ir - iq)
    c2 = ir * d_p / (ir - ip)
    k2 = (iq - ip) * d_r / ((ir - iq) * d_p)
    # The case chosen above makes k^2 <= 1 (= 1 on the separatrix); rounding may not.
    k2 = min(k2, 1.0)
    ok = a2 > 0.0 and b2 > 0.0 and c2 > 0.0
    if not ok:
        return (False, p_ax, q_ax, r_ax, sign_q, ip, iq, ir, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                0.0, 1.0, 1.0, 0.0, g)
    k2 = max(k2, 0.0)
    lam = math.sqrt((ir - iq) * d_p / (ip * iq * ir))
    n = 1.0 - b2 / a2
    ng = b2 * (ip - iq) / (a2 * iq)
    mc = 1.0 - k2
    if mc == 0.0:  # on the separatrix: one approach to the middle axis, no period
        return (True, p_ax, q_ax, r_ax, sign_q, ip, iq, ir, math.sqrt(a2), math.sqrt(b2),
                math.sqrt(c2), k2, lam, n, ng, mc, math.inf, math.inf, g)
    kk = carlson_rf(0.0, mc, 1.0)  # K(k)
    phi_c = 2.0 * kk
    if ng != 0.0:
        phi_c += 2.0 * ng * carlson_rj(0.0, mc, 1.0, 1.0 - n) / 3.0
    return (True, p_ax, q_ax, r_ax, sign_q, ip, iq, ir, math.sqrt(a2), math.sqrt(b2),
            math.sqrt(c2), k2, lam, n, ng, mc, 2.0 * kk, phi_c, g)


@kernel
def _at(u, a, b, c, k2, n, ng, mc, half, phi_c):
    """m_p, m_q, m_r at u and Phi(u) (the integral of the precession rate's shape), with u
    counted in half periods of the amplitude from the one where cn >= 0 (on the separatrix,
    k = 1, there is one: sn = tanh, cn = dn = sech)."""
    if mc == 0.0:
        sn, cn, dn = sncndn(u, mc)
        return a * cn, b * sn, c * dn, _phi(sn, cn, dn, n, ng)
    j = math.floor(u / half + 0.5)
    r = u - j * half
    sn, cn, dn = sncndn(r, mc)
    sign = 1.0 if j % 2 == 0 else -1.0
    return a * sign * cn, b * sign * sn, c * dn, j * phi_c + _phi(sn, cn, dn, n, ng)


@kernel
def _frame_r(q00, q01, q02, q10, q11, q12, q20, q21, q22, phi, mp, mq, mr, p_ax, q_ax,
             r_ax, sign_q):
    """R = Q Rz(phi) B(m) P, 9 row-major floats, in the principal axes."""
    b1 = _euler_b(mp, mq, mr)
    cz, sz = math.cos(phi), math.sin(phi)
    t = np.empty(9)  # Rz(phi) B, in the (p, q, r) frame
    for col in range(3):
        t[col] = cz * b1[col] - sz * b1[3 + col]
        t[3 + col] = sz * b1[col] + cz * b1[3 + col]
        t[6 + col] = b1[6 + col]
    # (Rz B) P: column j of the (p, q, r) frame is principal axis perm[j], sign sgn[j]
    perm = (p_ax, q_ax, r_ax)
    sgn = (1.0, sign_q, 1.0)
    w = np.zeros(9)
    for row in range(3):
        for col in range(3):
            w[3 * row + perm[col]] = sgn[col] * t[3 * row + col]
    return mul33(q00, q01, q02, q10, q11, q12, q20, q21, q22,
                 w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8])


@kernel
def flow_start(ix, iy, iz, e_lo, e_hi, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy,
               wz):
    """Where a body's torque-free motion is on its polhode: (elliptic, sign of m_r, u, Q)
    with R = Q Rz(0) B(m) P now (Q = R P^T B(m)^T: its third column is L / |L|).
    elliptic is False where ``free_flow``'s special cases apply (equal moments, a steady
    rotation about a principal axis): then step with ``free_flow``. On the separatrix
    (k = 1) u runs over the one approach to the middle axis."""
    mx = ix * (r00 * wx + r10 * wy + r20 * wz)
    my = iy * (r01 * wx + r11 * wy + r21 * wz)
    mz = iz * (r02 * wx + r12 * wy + r22 * wz)
    zeros = (1 if mx == 0.0 else 0) + (1 if my == 0.0 else 0) + (1 if mz == 0.0 else 0)
    none = (False, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    if ix == iy or iy == iz or ix == iz or zeros >= 2:
        return none
    (ok, p_ax, q_ax, r_ax, sign_q, ip, iq, ir, a, b, c, k2, lam, n, ng, mc, half, phi_c,
     g) = _constants(ix, iy, iz, e_lo, e_hi)
    if not ok:
        return none
    mv = (mx, my, mz)
    mp, mq, mr = mv[p_ax], sign_q * mv[q_ax], mv[r_ax]
    sign_r = -1.0 if mr < 0.0 else 1.0
    # u from (sn, cn, dn) = (m_q / b, m_p / a, |m_r| / c), each from its own component (near
    # the middle axis cn and dn are small, and only they fix u); half periods counted from
    # cn >= 0.
    s0, c0, d0 = mq / b, mp / a, abs(mr) / c
    j0 = 0
    branch = 1.0
    if c0 < 0.0:
        s0, c0, j0 = -s0, -c0, 1
        if mc == 0.0:  # no half period to shift by: (m_p, m_q) -> -(m_p, m_q) is a symmetry
            branch, j0 = -1.0, 0
    s0 = min(max(s0, -1.0), 1.0)
    c0, d0 = min(c0, 1.0), min(d0, 1.0)
    if c0 == 0.0 and d0 == 0.0:  # at the middle axis itself: steady
        return none
    u0 = s0 * carlson_rf(c0 * c0, d0 * d0, 1.0)
    if j0:
        u0 += half
    # Q = R P^T B^T: R times the transpose of (B P)
    bp = _frame_r(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, mp, mq, mr, p_ax, q_ax,
                  r_ax, sign_q)
    q = mul33(r00, r01, r02, r10, r11, r12, r20, r21, r22,
              bp[0], bp[3], bp[6], bp[1], bp[4], bp[7], bp[2], bp[5], bp[8])
    # sign_r carries the separatrix's branch too: |sign_r| = 2 for (m_p, m_q) negated.
    return (True, sign_r * (2.0 if branch < 0.0 else 1.0), u0, q[0], q[1], q[2], q[3], q[4],
            q[5], q[6], q[7], q[8])


@kernel
def flow_advance(ix, iy, iz, e_lo, e_hi, sign_r, u, phi, q00, q01, q02, q10, q11, q12, q20,
                 q21, q22, h):
    """Time h along the polhode from (u, phi) with the frame Q of ``flow_start``: (u, phi,
    R, omega) after it, 14 floats. u is kept within a period (4K), phi within 2 pi."""
    (ok, p_ax, q_ax, r_ax, sign_q, ip, iq, ir, a, b, c, k2, lam, n, ng, mc, half, phi_c,
     g) = _constants(ix, iy, iz, e_lo, e_hi)
    if abs(sign_r) > 1.5:  # the separatrix's other branch: (m_p, m_q) negated
        a, b = -a, -b
    c = c if sign_r > 0.0 else -c
    if (c < 0.0) != (1.0 / iq - 1.0 / ir < 0.0):
        lam = -lam
    _, _, _, big0 = _at(u, a, b, c, k2, n, ng, mc, half, phi_c)
    u1 = u + lam * h
    mp, mq, mr, big1 = _at(u1, a, b, c, k2, n, ng, mc, half, phi_c)
    phi1 = phi + g / (ip * lam) * (big1 - big0)
    two_pi = 2.0 * math.pi
    phi1 -= two_pi * math.floor(phi1 / two_pi + 0.5)
    if mc != 0.0:
        u1 -= 2.0 * half * math.floor(u1 / (2.0 * half) + 0.5)
    r = _frame_r(q00, q01, q02, q10, q11, q12, q20, q21, q22, phi1, mp, mq, mr, p_ax, q_ax,
                 r_ax, sign_q)
    nb = np.empty(3)
    nb[p_ax], nb[q_ax], nb[r_ax] = mp, sign_q * mq, mr
    w0, w1, w2 = _from_body(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8],
                            nb[0], nb[1], nb[2], ix, iy, iz)
    return (u1, phi1, r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], w0, w1, w2)


@kernel
def free_flow(ix, iy, iz, e_lo, e_hi, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy,
              wz, h, tiny):
    """(R, omega) after time h (s, any sign) of torque-free motion of a body with principal
    moments (ix, iy, iz), from R (its principal frame, body to world), omega (world) and
    the motion's ``invariants`` (e_lo, e_hi): 12 floats, exact up to rounding (see the
    module): ``flow_start`` then ``flow_advance``, or the special cases."""
    (elliptic, sign_r, u0, q00, q01, q02, q10, q11, q12, q20, q21, q22) = flow_start(
        ix, iy, iz, e_lo, e_hi, r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz)
    if elliptic:
        out = flow_advance(ix, iy, iz, e_lo, e_hi, sign_r, u0, 0.0, q00, q01, q02, q10, q11,
                           q12, q20, q21, q22, h)
        return (out[2], out[3], out[4], out[5], out[6], out[7], out[8], out[9], out[10],
                out[11], out[12], out[13])
    mx = ix * (r00 * wx + r10 * wy + r20 * wz)
    my = iy * (r01 * wx + r11 * wy + r21 * wz)
    mz = iz * (r02 * wx + r12 * wy + r22 * wz)
    if ix == iy and iy == iz:
        return _steady(r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, h, tiny)
    if ix == iy or iy == iz or ix == iz:
        axis = 2 if ix == iy else (0 if iy == iz else 1)
        return _symmetric(ix, iy, iz, axis, r00, r01, r02, r10, r11, r12, r20, r21, r22,
                          wx, wy, wz, mx, my, mz, h, tiny)
    # about a principal axis (the middle one too), or rounding at a steady rotation
    return _steady(r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz, h, tiny)
