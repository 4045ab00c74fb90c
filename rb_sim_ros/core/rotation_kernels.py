# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Rotations as 9 row-major floats, written out (no BLAS): the exponential of a rotation
vector, a product, and the orthonormalisation. The step kernel and the free flow share them
(``step_kernel`` re-exports them)."""

from __future__ import annotations

import math

from rb_sim_ros.core.jit import kernel


# Below this squared angle exp_so3 takes A and B from their Taylor series in t^2 (``small_angle``):
# t <= 0.25 rad, where the series below leaves out less than 3e-21 of either; no sqrt, sin, cos
# or division, so a block of bodies (``step_kernel.advance``) steps in SIMD lanes.
SMALL_ANGLE_SQ = 0.0625
# sin(t)/t = sum (-t^2)^k / (2k+1)!, (1 - cos t)/t^2 = sum (-t^2)^k / (2k+2)!, k = 0 .. 6.
_A1, _A2, _A3 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0
_A4, _A5, _A6 = 1.0 / 362880.0, -1.0 / 39916800.0, 1.0 / 6227020800.0
_B1, _B2, _B3 = -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0
_B4, _B5, _B6 = 1.0 / 3628800.0, -1.0 / 479001600.0, 1.0 / 87178291200.0


@kernel
def small_angle(t2):
    """(A, B) = (sin(t)/t, (1 - cos t)/t^2) for t^2 < SMALL_ANGLE_SQ, by Horner in t^2."""
    a = 1.0 + t2 * (_A1 + t2 * (_A2 + t2 * (_A3 + t2 * (_A4 + t2 * (_A5 + t2 * _A6)))))
    b = 0.5 + t2 * (_B1 + t2 * (_B2 + t2 * (_B3 + t2 * (_B4 + t2 * (_B5 + t2 * _B6)))))
    return a, b


@kernel
def _rodrigues(px, py, pz, xx2, yy2, zz2, ca, cb):
    """I + A [p] + B [p]^2 as 9 row-major floats, with p's squares."""
    bxy, bxz, byz = cb * px * py, cb * px * pz, cb * py * pz
    ax_, ay_, az_ = ca * px, ca * py, ca * pz
    return (1.0 - cb * (yy2 + zz2), bxy - az_, bxz + ay_,
            bxy + az_, 1.0 - cb * (xx2 + zz2), byz - ax_,
            bxz - ay_, byz + ax_, 1.0 - cb * (xx2 + yy2))


@kernel
def exp_so3(px, py, pz, tiny):
    """exp([p]) as 9 row-major floats: I + A [p] + B [p]^2 (Rodrigues) with A = sin(t)/t and
    B = (1 - cos t)/t^2: from their series below SMALL_ANGLE_SQ (``small_angle``), else in
    half-angle form with t^2 lifted by ``tiny`` (so3.TINY_ANGLE_SQ). A non-finite angle gives
    nan (Python's sin would raise; numba's gives nan)."""
    xx2, yy2, zz2 = px * px, py * py, pz * pz
    t2 = xx2 + yy2 + zz2
    if t2 < SMALL_ANGLE_SQ:
        ca, cb = small_angle(t2)
        return _rodrigues(px, py, pz, xx2, yy2, zz2, ca, cb)
    t2 = t2 + tiny
    if t2 <= 1.7976931348623157e308:
        t = math.sqrt(t2)
        s = math.sin(0.5 * t)
        ca = 2.0 * s * math.cos(0.5 * t) / t
        cb = 2.0 * s * s / t2
    else:
        ca = cb = math.nan
    return _rodrigues(px, py, pz, xx2, yy2, zz2, ca, cb)


@kernel
def exp_so3_small(px, py, pz):
    """``exp_so3`` of a p the caller knows to be below SMALL_ANGLE_SQ: no branch, no call
    (SIMD lanes); the same bits as exp_so3 there."""
    xx2, yy2, zz2 = px * px, py * py, pz * pz
    ca, cb = small_angle(xx2 + yy2 + zz2)
    return _rodrigues(px, py, pz, xx2, yy2, zz2, ca, cb)


@kernel
def orthonormalize(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """One Newton step of the polar decomposition, R (3 I - R^T R) / 2: from a matrix within
    ~1e-8 of SO(3) to within ~1e-16. (so3.orthonormalize_components, written out.)"""
    s00 = r00 * r00 + r10 * r10 + r20 * r20
    s11 = r01 * r01 + r11 * r11 + r21 * r21
    s22 = r02 * r02 + r12 * r12 + r22 * r22
    s01 = r00 * r01 + r10 * r11 + r20 * r21
    s02 = r00 * r02 + r10 * r12 + r20 * r22
    s12 = r01 * r02 + r11 * r12 + r21 * r22
    m00, m11, m22 = 0.5 * (3.0 - s00), 0.5 * (3.0 - s11), 0.5 * (3.0 - s22)
    m01, m02, m12 = -0.5 * s01, -0.5 * s02, -0.5 * s12
    return mul33(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                 m00, m01, m02, m01, m11, m12, m02, m12, m22)


@kernel
def mul33(a00, a01, a02, a10, a11, a12, a20, a21, a22,
          b00, b01, b02, b10, b11, b12, b20, b21, b22):
    """A B of two 3x3 matrices given as 9 row-major floats each, written out (no BLAS):
    (A B)_ij = a_i0 b_0j + a_i1 b_1j + a_i2 b_2j, summed left to right."""
    return (a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21,
            a00 * b02 + a01 * b12 + a02 * b22,
            a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21,
            a10 * b02 + a11 * b12 + a12 * b22,
            a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21,
            a20 * b02 + a21 * b12 + a22 * b22)
