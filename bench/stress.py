# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Numerical stress: the Dzhanibekov flip, extreme inertia, fast spin, long runs, blow-ups."""

from __future__ import annotations

import math

import numpy as np

import peers
from rb_sim_ros import IntegrationError, RigidBody, so3, State, Stepper
import scenes as sc


def _invariants(body: RigidBody, state: State):
    return state.kinetic_energy(body), state.angular_momentum(body)


def dzhanibekov(quick: bool) -> dict:
    """Flip period of a T-handle spun near its middle axis, dt = 1 ms, against 4K(k)/rate."""
    moments, omega0 = (1.0, 2.0, 3.0), (0.01, 2.0, 0.01)
    expected = sc.flip_period(moments, omega0)
    body = RigidBody(1.0, list(moments))
    s = Stepper(body, 1e-3, State(angular_velocity=omega0))
    # omega_2 (body) changes sign twice per period: time the zero crossings.
    crossings, last = [], 2.0
    periods = 1 if quick else 3
    while len(crossings) < 2 * periods + 1 and s.time < 4 * periods * expected:
        s.step(1)
        w2 = float(s.state.angular_velocity_body[1])
        if last > 0 >= w2 or last < 0 <= w2:
            crossings.append(s.time)
        last = w2
    measured = (crossings[-1] - crossings[0]) / periods
    return {'expected_period_s': expected, 'measured_period_s': measured,
            'relative_error': abs(measured - expected) / expected}


def extreme_inertia(quick: bool) -> list[dict]:
    """Torque-free spin of very unequal bodies for 10 s (2 s quick) at dt = 1 ms: energy and
    momentum drift, ours and MuJoCo's (RK4, Euler) on the same body."""
    t_end = 2.0 if quick else 10.0
    cases = [('1 : 100 : 100', (1.0, 100.0, 100.0), (10.0, 0.1, 0.05)),
             ('1 : 1e4 : 1e4', (1.0, 1e4, 1e4), (10.0, 0.01, 0.005)),
             ('mujoco#3553', (1.7231e-4, 6.58e-6, 1.7243e-4), (0.5, 3.0, 0.2))]
    out = []
    for name, moments, omega0 in cases:
        scene = sc.Scene(name, moments, omega0, t_end, samples=10)
        body = RigidBody(1.0, list(moments))
        e0, l0 = _invariants(body, State(angular_velocity=omega0))
        row = {'case': name, 'moments': moments}
        for runner in (peers.Ours('eq27'), peers.MuJoCo('RK4'), peers.MuJoCo('Euler')):
            rot, w = runner.run(scene, 1e-3)[-1]
            st = State(rotation=so3.orthonormalize(rot), angular_velocity=w)
            e, l_vec = _invariants(body, st)
            row[runner.name] = {'energy_drift': abs(e - e0) / e0,
                                'momentum_drift': float(np.linalg.norm(l_vec - l0)
                                                        / np.linalg.norm(l0)),
                                'finite': bool(np.all(np.isfinite(w)))}
        out.append(row)
    return out


def fast_spin(quick: bool) -> list[dict]:
    """Error after 100 steps as omega*dt grows from 0.01 to 1: where each method stops being
    accurate (error < 1e-2 rad) or stable (bounded energy)."""
    moments = (1.0, 2.0, 3.0)
    rows = []
    for wdt in ([0.01, 0.1, 1.0] if quick else [0.01, 0.03, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0]):
        omega0 = (0.3, 0.0, 1.0)
        norm = math.sqrt(0.09 + 1.0)
        dt = 0.01
        scale = wdt / (norm * dt)
        scene = sc.Scene(f'w dt = {wdt}', moments, tuple(scale * c for c in omega0),
                         100 * dt, reference='elliptic', samples=4)
        ref = sc.reference(scene, scene.sample_times())
        row = {'omega_dt': wdt}
        for runner in (peers.Ours('eq27'), peers.Ours('taylor1'), peers.MuJoCo('Euler'),
                       peers.MuJoCo('implicitfast'), peers.MuJoCo('RK4')):
            try:
                e = peers.errors(runner.run(scene, dt), ref)
                row[runner.name] = e['angle_max']
            except (IntegrationError, ValueError, FloatingPointError):
                row[runner.name] = math.inf
        rows.append(row)
    return rows


def long_run(quick: bool, progress=None) -> dict:
    """1e7 steps (1e5 quick) torque-free at dt = 1 ms: energy and world angular momentum drift
    over time, and the worst orthonormality error of R."""
    steps = 100_000 if quick else 10_000_000
    body = RigidBody(1.0, [1.0, 2.0, 3.0])
    s = Stepper(body, 1e-3, State(angular_velocity=(1.0, 0.1, 1.5)))
    e0, l0 = _invariants(body, s.state)
    chunk = steps // 200
    t, energy, momentum, ortho = [], [], [], 0.0
    for _ in range(200):
        s.step(chunk)
        st = s.state
        e, l_vec = _invariants(body, st)
        t.append(s.time)
        energy.append((e - e0) / e0)
        momentum.append(float(np.linalg.norm(l_vec - l0) / np.linalg.norm(l0)))
        ortho = max(ortho, so3.orthonormality_error(st.rotation))
        if progress:
            progress.update()
    return {'steps': steps, 'time': t, 'energy_drift': energy, 'momentum_drift': momentum,
            'max_orthonormality_error': ortho}


def blow_up() -> dict:
    """A state that overflows: the stepper raises IntegrationError naming the step."""
    s = Stepper(RigidBody(1.0, [1.0, 2.0, 3.0]), 1e-3,
                State(angular_velocity=(1e150, 2e150, 1.0)))
    try:
        s.step(1000)
    except IntegrationError as e:
        return {'raised': True, 'step': e.step, 'message': str(e),
                'state_finite': bool(np.all(np.isfinite(s.state.angular_velocity)))}
    return {'raised': False}


def plot_long_run(result: dict, path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(result['time'], np.abs(result['energy_drift']), label='|energy drift| (relative)')
    ax.plot(result['time'], result['momentum_drift'], label='|L - L0| / |L0| (world)')
    ax.set_yscale('log')
    ax.set_xlabel('simulated time (s), dt = 1 ms')
    ax.set_title(f'Torque-free tumble, {result["steps"]:.0e} steps (eq27)')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
