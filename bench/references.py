# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""References for the benchmark scenes, and the checks that they agree with one another.

* Torque-free asymmetric body: omega in the body frame from Jacobi's elliptic functions
  (Landau & Lifshitz, section 37); R from DOP853 at rtol 1e-13, checked against the invariant
  R I omega_body = L0 (world angular momentum), which pins two of its three degrees of freedom.
* Torque-free symmetric top (I1 = I2 = I_t): R(t) = exp(t [L]/I_t) R0 exp(t lambda [e3]) with
  lambda = (1 - I3/I_t) omega_b3 and L the (constant) world angular momentum.
* Anything else: DOP853 at rtol 1e-13, segment by segment (no step straddles a torque jump),
  on Thm 1 in the world frame (R and omega world, I = R I_body R^T solved with numpy). It is
  checked against a second formulation (unit quaternion, Euler's equations in the body frame).

The oracles themselves are the tests' too (oracles/, at the top of the checkout): the closed
forms in ``oracles.free_rotation``, DOP853 in ``oracles.dop853``. This module picks a scene's
and checks them against each other; the bench modules also call the oracles through it
(``references.integrate``, ``references.flip_period``, ...: ``__all__``).
"""

from __future__ import annotations

import numpy as np

from bench.scenes import Scene
from oracles.dop853 import integrate, matrix_from_wxyz, quaternion_wxyz, rhs_body_quaternion
from oracles.free_rotation import elliptic_omega_body, flip_period, symmetric_top
from rb_sim_ros.core import so3

__all__ = ['AGREEMENT', 'flip_period', 'integrate', 'matrix_from_wxyz', 'quaternion_wxyz',
           'reference', 'rhs_body_quaternion', 'self_check', 'top']

# References must agree with each other to this (rad, and rad/s relative to |omega0|).
AGREEMENT = 1e-9


def top(scene: Scene, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, omega world) of the torque-free symmetric top of ``scene`` at time t (s)."""
    i_t, i_t2, i_3 = np.diag(scene.inertia_body)
    assert i_t == i_t2, 'the closed form needs I1 = I2'
    return symmetric_top(t, i_t, i_3, scene.omega0_body, scene.rotation0)


def reference(scene: Scene, times) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(R, omega world)] at ``times``: the scene's oracle, DOP853 where it has none."""
    if scene.reference == 'top':
        return [top(scene, float(t)) for t in times]
    states = integrate(scene, times)
    if scene.reference == 'elliptic':
        moments = np.diag(scene.inertia_body)
        w_body = elliptic_omega_body(moments, scene.omega0_body, times)
        states = [(rot, rot @ wb) for (rot, _), wb in zip(states, w_body)]
    return states


def self_check(scene: Scene) -> dict:
    """How well the references of ``scene`` agree with each other and its invariants.

    'angle' (rad) and 'omega' (relative to |omega0|) are the largest disagreements over the
    sample times between the scene's reference and an independent second one: DOP853 on
    quaternions with Euler's equations in the body frame (against the elliptic omega and the
    world-frame DOP853 R, or against the world-frame DOP853), or for the top, DOP853 in the world
    frame against the closed form.
    'momentum' is max |R I omega_body - L0| / |L0| of the reference (torque-free only).
    """
    times = scene.sample_times()
    ref = reference(scene, times)
    if scene.reference == 'top':
        other, what = integrate(scene, times), 'DOP853, world-frame R'
    else:
        other, what = integrate(scene, times, formulation='quaternion'), 'DOP853, quaternion'
    speed = scene.initial_speed()
    result = {'against': what,
              'angle': max(so3.angle_between(r1, r2) for (r1, _), (r2, _) in zip(ref, other)),
              'omega': max(float(np.linalg.norm(w1 - w2)) / speed
                           for (_, w1), (_, w2) in zip(ref, other))}
    if scene.torque_free:
        momentum0 = scene.rotation0 @ scene.inertia_body @ np.asarray(scene.omega0_body)
        result['momentum'] = max(
            float(np.linalg.norm(rot @ scene.inertia_body @ (rot.T @ w) - momentum0)
                  / np.linalg.norm(momentum0)) for rot, w in ref)
    result['ok'] = all(v <= AGREEMENT for k, v in result.items() if k != 'against')
    return result
