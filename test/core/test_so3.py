# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""SO(3) helpers: the group's axioms, and agreement of the two independent exp forms."""

import math

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from rb_sim_ros.core import multistep, so3

finite = st.floats(-10.0, 10.0, allow_nan=False)
vectors = st.tuples(finite, finite, finite).map(np.array)


def _rodrigues(phi):
    """exp([phi]) as the integrator computes it: one step with w = phi/dt, no acceleration."""
    dt = 0.5
    step = multistep.make_step(multistep.EQ27, dt)
    zero = (0.0, 0.0, 0.0)
    eye = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    _, _, r, _ = step(zero, zero, eye, tuple(phi / dt), zero, zero, zero, zero)
    return np.array(r).reshape(3, 3)


def _same_rotation_quaternions(q1, q2):
    return min(np.max(np.abs(q1 - q2)), np.max(np.abs(q1 + q2)))


@given(vectors)
def test_hat_is_cross_product(v):
    u = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(so3.hat(v) @ u, np.cross(v, u), atol=1e-12)
    np.testing.assert_array_equal(so3.vee(so3.hat(v)), v)


@given(vectors)
def test_exp_is_a_rotation(phi):
    r = so3.exp(phi)
    assert so3.orthonormality_error(r) < 1e-14
    assert not np.any(np.isnan(r))


@given(vectors)
def test_integrator_rodrigues_matches_quaternion_exp(phi):
    np.testing.assert_allclose(_rodrigues(phi), so3.exp(phi), atol=1e-14)


def _exp_series(phi, terms=40):
    """exp([phi]) summed from its power series, with each entry's bound on the error.

    The series sum_n K^n / n!, K = [phi], is summed to ``terms`` terms. An entry of K^n is at
    most |K|_2^n = angle^n, so the tail left off is at most angle^N / N! e^angle (Lagrange) in
    every entry, and the rounding of the sum at most a few ulps of the sum of the terms' absolute
    values (entrywise), which is 1 on the diagonal and about the entry itself off it: the bound
    scales with the entry, so it stays meaningful at 1e-300 rad as at 3 rad.
    """
    k = so3.hat(phi)
    angle = float(np.linalg.norm(phi))
    term, total, size = np.eye(3), np.eye(3), np.eye(3)
    for n in range(1, terms):
        term = term @ k / n
        total = total + term
        size = size + np.abs(term)
    tail = angle ** terms / math.factorial(terms) * math.exp(angle)
    return total, tail + 4.0 * np.finfo(float).eps * size


@pytest.mark.parametrize('angle', [0.0, 1e-300, 1e-160, 1e-20, 1e-9, 1e-5, 1e-3, 0.1,
                                   0.25 - 1e-12, 0.25, 0.25 + 1e-12, 1.0, 3.0,
                                   math.pi - 1e-3])
def test_exp_agrees_with_the_power_series_at_every_angle(angle):
    """Both sides of the step kernel's switch from the series of sin(t)/t and
    (1 - cos t)/t^2 to sin and cos at t = 0.25 (SMALL_ANGLE_SQ) included."""
    axis = np.array([2.0, -3.0, 6.0]) / 7.0
    phi = angle * axis
    series, bound = _exp_series(phi)
    assert np.all(bound < 1e-13)  # the oracle is tight: a wrong term anywhere shows
    for name, r in (('rodrigues', _rodrigues(phi)), ('so3.exp', so3.exp(phi))):
        err = np.abs(r - series)
        assert np.all(err <= bound), f'{name} at {angle} rad: error / bound {np.max(err / bound)}'


@given(vectors)
def test_log_exp_bijective(phi):
    angle = np.linalg.norm(phi)
    if angle >= math.pi - 1e-6:
        phi = phi / angle * math.fmod(angle, math.pi - 1e-6)
    np.testing.assert_allclose(so3.log(so3.exp(phi)), phi, atol=1e-9)


@given(vectors)
def test_exp_log_bijective(phi):
    r = so3.exp(phi)
    np.testing.assert_allclose(so3.exp(so3.log(r)), r, atol=1e-13)


@given(vectors)
def test_inverse_is_exp_of_minus(phi):
    np.testing.assert_allclose(so3.exp(phi) @ so3.exp(-phi), np.eye(3), atol=1e-14)


@given(vectors)
def test_quaternion_round_trip(phi):
    r = so3.exp(phi)
    q = so3.quaternion_xyzw_from_matrix(r)
    assert abs(np.linalg.norm(q) - 1.0) < 1e-15
    assert q[3] >= 0.0
    np.testing.assert_allclose(so3.matrix_from_quaternion_xyzw(q), r, atol=1e-14)


def test_quaternion_compares_up_to_sign_near_pi():
    r = so3.exp(np.array([0.0, 0.0, math.pi]))
    q = so3.quaternion_xyzw_from_matrix(r)
    assert _same_rotation_quaternions(q, np.array([0.0, 0.0, 1.0, 0.0])) < 1e-15


def test_zero_quaternion_is_refused():
    with pytest.raises(ValueError, match='quaternion'):
        so3.matrix_from_quaternion_xyzw((0, 0, 0, 0))


@settings(max_examples=50)
@given(vectors, st.floats(1e-9, 1e-4))
def test_orthonormalize_components_squares_the_error(phi, eps):
    r = so3.exp(phi)
    bent = r + eps * np.array([[0.3, -0.2, 0.5], [0.1, 0.4, -0.7], [-0.6, 0.2, 0.1]])
    fixed = np.array(so3.orthonormalize_components(*bent.reshape(9))).reshape(3, 3)
    assert so3.orthonormality_error(fixed) < 10 * eps * eps + 1e-15


# -- plain-float linear algebra: the same bits whatever BLAS kernel the machine picks --------
@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9),
       st.floats(1e-3, 1e3), st.sampled_from([0, 1, 2]))
def test_symmetric_eigen_diagonalises(entries, scale, degenerate):
    from rb_sim_ros.core.euler_dynamics import symmetric_eigen
    a = np.array(entries).reshape(3, 3)
    inertia = scale * (a @ a.T + 0.1 * np.eye(3))
    if degenerate:  # two equal moments (a symmetric top), turned
        rot = so3.exp(np.array(entries[:3]) * 3.0)
        inertia = rot @ np.diag([1.0, 1.0, 1.0 + degenerate]) @ rot.T * scale
    values, vec = symmetric_eigen(inertia.tolist())
    v = np.array(vec)
    assert list(values) == sorted(values)
    np.testing.assert_allclose(values, np.linalg.eigvalsh(inertia), rtol=1e-12,
                               atol=1e-14 * scale)
    np.testing.assert_allclose(v.T @ v, np.eye(3), atol=1e-14)
    assert np.linalg.det(v) > 0.0
    np.testing.assert_allclose(v @ np.diag(values) @ v.T, inertia, atol=1e-13 * scale)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
       st.lists(st.floats(-1e-4, 1e-4), min_size=9, max_size=9))
def test_orthonormalize_is_the_polar_factor(phi, noise):
    rot = so3.exp(np.array(phi)) + np.array(noise).reshape(3, 3)
    u, _, vt = np.linalg.svd(rot)  # the reference: the polar factor from the SVD
    out = so3.orthonormalize(rot)
    np.testing.assert_allclose(out, u @ vt, atol=1e-14)
    assert so3.orthonormality_error(out) < 1e-15


def test_orthonormalize_refuses_reflections_and_non_finite():
    with pytest.raises(ValueError, match='det > 0'):
        so3.orthonormalize(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match='finite'):
        so3.orthonormalize(np.full((3, 3), np.nan))
    assert so3.orthonormality_error(np.full((3, 3), np.nan)) == math.inf


def test_mul9_matches_matrix_products():
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    v = rng.normal(size=3)
    np.testing.assert_allclose(np.array(so3.mul9(a.reshape(9), b.reshape(9))).reshape(3, 3),
                               a @ b, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(np.array(so3.mul9(a.reshape(9), b.reshape(9), True)).reshape(
        3, 3), a @ b.T, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(so3.mul9_vec(a.reshape(9), v), a @ v, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(so3.mul9_vec(a.reshape(9), v, True), a.T @ v, rtol=1e-15,
                               atol=1e-15)


@pytest.mark.parametrize('scale', [1e-50, 1e-3, 7.0, 1e100, 1e200])
def test_orthonormalize_of_a_scaled_rotation_is_the_rotation(scale):
    """The polar factor of s R is R for any s > 0 (the iteration is scaled first; without it
    1e-50 R or 1e200 R came back far off SO(3) or NaN)."""
    rot = so3.exp(np.array([0.3, -1.2, 2.0]))
    np.testing.assert_allclose(so3.orthonormalize(scale * rot), rot, atol=1e-15)


@pytest.mark.parametrize('scale', [1e-300, 1.0, 4e306])
def test_symmetric_eigen_at_any_scale(scale):
    """Eigenvalues of s A are s times those of A, up to 1e307 (a sum of entries overflowed
    there and the iteration stopped before any rotation) and down to 1e-300."""
    from rb_sim_ros.core.euler_dynamics import symmetric_eigen
    a = np.array([[2.0, 0.5, -0.3], [0.5, 1.0, 0.2], [-0.3, 0.2, 3.0]])
    values, _vec = symmetric_eigen((scale * a).tolist())
    np.testing.assert_allclose(np.array(values) / scale, np.linalg.eigvalsh(a), rtol=1e-14)
