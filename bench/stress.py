# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Numerical stress: the Dzhanibekov flip, extreme inertia, fast spin, long runs, blow-ups.

Each function returns plain data (for summary.json and the report); none of them times
anything. Energies are 1/2 omega_b . I omega_b (J), angular momenta R I omega_b (kg m^2/s,
world frame); drifts are relative to their initial values.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from bench import peers, references, scenes as sc
from rb_sim_ros import IntegrationError, METHODS, RigidBody, State, Stepper
from rb_sim_ros.core import so3

TILT = (0.3, -0.5, 0.8)  # R0 of every stress scene (rotation vector, rad)


def invariants(scene: sc.Scene, rot: np.ndarray, omega: np.ndarray) -> tuple[float, np.ndarray]:
    """(kinetic energy (J), angular momentum world (kg m^2/s)) of (R, omega world)."""
    w_body = rot.T @ omega
    momentum = scene.inertia_body @ w_body
    return 0.5 * float(w_body @ momentum), rot @ momentum


def drifts(scene: sc.Scene, states) -> dict:
    """Largest relative energy and angular momentum drift over ``states`` [(R, omega)]."""
    e0, l0 = invariants(scene, scene.rotation0, scene.omega0_world)
    de, dl = 0.0, 0.0
    for rot, w in states:
        e, mom = invariants(scene, so3.orthonormalize(rot), w)
        de = max(de, abs(e - e0) / e0)
        dl = max(dl, float(np.linalg.norm(mom - l0) / np.linalg.norm(l0)))
    return {'energy_drift': de, 'momentum_drift': dl}


# -- Dzhanibekov flip ---------------------------------------------------------------------

def _crossings(values, dt):
    """Times (s) at which a sequence sampled every dt changes sign, interpolated linearly."""
    out = []
    for k in range(1, len(values)):
        a, b = values[k - 1], values[k]
        if (a > 0.0) != (b > 0.0):
            out.append(dt * (k - 1 + a / (a - b)))
    return out


def _omega_body_2_ours(stepper: Stepper) -> float:
    """omega_2 in the body frame, (R e2) . omega, from the cheap read of the stepper."""
    _, (x, y, z, w), _, (wx, wy, wz) = stepper.pose_twist()
    return (2.0 * (x * y - z * w) * wx + (1.0 - 2.0 * (x * x + z * z)) * wy
            + 2.0 * (y * z + x * w) * wz)


def flip_series(runner, scene: sc.Scene, dt: float) -> list[float]:
    """omega_2 (body, rad/s) at every step of the run (one step at a time)."""
    n = round(scene.t_end / dt)
    if isinstance(runner, peers.Ours):
        s = runner.stepper(scene, dt)
        out = [float(scene.omega0_body[1])]
        for _ in range(n):
            s.step(1)
            out.append(_omega_body_2_ours(s))
        return out
    m, d = runner.model(scene, dt)
    out = [float(d.qvel[4])]
    for _ in range(n):
        mujoco.mj_step(m, d)
        out.append(float(d.qvel[4]))
    if runner.flagged(d):
        raise peers.Diverged(f'MuJoCo: {runner.flagged(d)} (simulation reset)')
    return out


def dzhanibekov_runs(quick: bool) -> list:
    """(runner, dt (s)): every integrator at 1 ms; in full mode eq27 also at 2 and 0.5 ms."""
    runs = [(r, 1e-3) for r in peers.steppers()]
    if not quick:
        runs += [(peers.Ours('eq27'), 2e-3), (peers.Ours('eq27'), 5e-4)]
    return runs


def dzhanibekov(quick: bool, progress=None) -> dict:
    """A T-handle spun about its middle axis: the measured period of the body-frame motion
    (two flips) at dt = 1 ms against the elliptic oracle 4 K(k) / rate."""
    moments, omega0 = (1.0, 2.0, 3.0), (0.01, 2.0, 0.01)
    expected = references.flip_period(moments, omega0)
    periods = 1 if quick else 3
    # omega_2 starts at its largest and first crosses 0 about a quarter period in.
    scene = sc.Scene('Dzhanibekov', sc.diagonal(*moments), omega0, (periods + 0.5) * expected,
                     TILT)
    rows = []
    for runner, dt in dzhanibekov_runs(quick):
        row = {'method': runner.name, 'dt': dt}
        try:
            cross = _crossings(flip_series(runner, scene, dt), dt)
        except peers.Diverged as e:
            cross, row['diverged'] = [], str(e)
        if len(cross) >= 3:
            full = [cross[k + 2] - cross[k] for k in range(0, len(cross) - 2, 2)]
            row.update(periods=len(full), period_s=sum(full) / len(full),
                       first_period_s=full[0], last_period_s=full[-1],
                       relative_error=sum(full) / len(full) / expected - 1.0)
        rows.append(row)
        if progress:
            progress.update()
    return {'moments': moments, 'omega0_body': omega0, 'expected_period_s': expected,
            'rows': rows}


# -- Extreme inertia ----------------------------------------------------------------------

def extreme_cases(quick: bool) -> list[sc.Scene]:
    """Thin rods (moment ratios 1e2 and 1e4, one given as a rotated full tensor) and the
    body of mujoco#3553, each spun about its long axis and tumbled end over end."""
    t_end = 2.0 if quick else 10.0
    q = so3.exp((0.3, 0.4, 0.5))
    rod4 = np.diag([1e-4, 0.99996, 1.00004])
    rotated = q @ rod4 @ q.T
    issue = sc.diagonal(1.7231e-4, 6.58e-6, 1.7243e-4)
    cases = [
        ('rod 1:1e2, long-axis spin', sc.diagonal(0.01, 1.0, 1.005), (20.0, 0.3, 0.2), 1.0),
        ('rod 1:1e2, end over end', sc.diagonal(0.01, 1.0, 1.005), (0.5, 0.2, 3.0), 1.0),
        ('rod 1:1e4, long-axis spin', sc.diagonal(*np.diag(rod4)), (20.0, 0.3, 0.2), 1.0),
        ('rod 1:1e4, end over end', sc.diagonal(*np.diag(rod4)), (0.5, 0.2, 3.0), 1.0),
        ('rod 1:1e4 as a rotated full tensor, long-axis spin',
         tuple(map(tuple, rotated)), tuple(q @ (20.0, 0.3, 0.2)), 1.0),
        ('mujoco#3553 body, long-axis spin', issue, (1.0, 50.0, 0.5), 0.12),
        ('mujoco#3553 body, tumble', issue, (0.5, 3.0, 20.0), 0.12),
    ]
    return [sc.Scene(name, inertia, omega, t_end, TILT, mass=mass)
            for name, inertia, omega, mass in cases]


def _extreme_runners(scene: sc.Scene) -> list:
    runners = peers.steppers()
    if scene.name.startswith('mujoco#3553'):
        runners.append(peers.MuJoCo('implicitfast', nested=True))
    return runners


def extreme_count(quick: bool) -> int:
    return sum(len(_extreme_runners(scene)) for scene in extreme_cases(quick))


def extreme_inertia(quick: bool, progress=None) -> list[dict]:
    """Torque-free runs at dt = 1 ms of the extreme cases: orientation and omega error against
    DOP853 (rtol 1e-13), energy and momentum drift, and whether the run stayed finite; ours
    and MuJoCo's on the same body (and, for mujoco#3553, MuJoCo with the nested inertia)."""
    rows = []
    for scene in extreme_cases(quick):
        times = scene.sample_times()
        ref = references.reference(scene, times)
        runners = _extreme_runners(scene)
        row = {'case': scene.name, 'moments': np.linalg.eigvalsh(scene.inertia_body).tolist(),
               'omega0': scene.initial_speed(), 't_end': scene.t_end, 'results': {}}
        for runner in runners:
            try:
                states = runner.run(scene, 1e-3)
                e = peers.errors(states, ref)
                result = {'angle_final': e['angle_final'], 'angle_max': e['angle_max'],
                          'omega_max_relative': e['omega_max'] / scene.initial_speed(),
                          **drifts(scene, states), 'finite': True}
            except peers.Diverged as e:
                result = {'diverged': str(e)[:200], 'step': e.step, 'finite': False}
            row['results'][runner.name] = result
            if progress:
                progress.update()
        rows.append(row)
    return rows


# -- Fast spin ----------------------------------------------------------------------------

FULL_SPINS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0)
QUICK_SPINS = (0.01, 0.1, 0.5, 1.0, 2.0)
ACCURATE = 1e-2  # rad, worst orientation error over the first 10 revolutions
UNBOUNDED = 1.0  # relative energy change over the run that counts as a blow-up


def fast_spin(quick: bool, progress=None) -> dict:
    """An asymmetric body (1, 2, 3) tumbling near its major axis at |omega0| = 1 rad/s, at
    dt = omega*dt / |omega0|: the worst orientation error over the first 10 revolutions
    (against DOP853 at 1e-13) and the energy and momentum drift over 100 (10 quick). A method
    is 'accurate' while that error is below ACCURATE, 'diverged' if the state stops being
    finite (or MuJoCo resets it) or the energy changes by more than UNBOUNDED, else
    'bounded'."""
    direction = np.array([0.3, 0.0, 1.0]) / math.hypot(0.3, 1.0)
    revolutions = 10 if quick else 100
    rows = []
    spins = QUICK_SPINS if quick else FULL_SPINS
    for wdt in spins:
        dt = wdt
        n_acc = int(math.ceil(10 * 2 * math.pi / dt))
        n_all = int(math.ceil(revolutions * 2 * math.pi / dt))
        stride = max(1, n_acc // 50)
        acc_steps = list(range(stride, n_acc + 1, stride))
        drift_steps = sorted({max(1, round(n_all * k / 20)) for k in range(1, 21)})
        all_steps = sorted(set(acc_steps) | set(drift_steps))
        scene = sc.Scene(f'omega dt = {wdt}', sc.diagonal(1.0, 2.0, 3.0), tuple(direction),
                         n_all * dt, TILT)
        ref = references.integrate(scene, [k * dt for k in acc_steps])
        row = {'omega_dt': wdt, 'steps': n_all, 'results': {}}
        for runner in peers.steppers():
            try:
                states = dict(zip(all_steps, runner.run(scene, dt, [k * dt for k in all_steps])))
                e = peers.errors([states[k] for k in acc_steps], ref)
                d = drifts(scene, [states[k] for k in drift_steps])
                finite = all(np.all(np.isfinite(r)) and np.all(np.isfinite(w))
                             for r, w in states.values())
                status = ('diverged' if not finite or d['energy_drift'] > UNBOUNDED
                          else 'accurate' if e['angle_max'] <= ACCURATE else 'bounded')
                result = {'angle_max': e['angle_max'], **d, 'status': status}
            except peers.Diverged as e:
                result = {'status': 'diverged', 'step': e.step, 'message': str(e)[:200]}
            row['results'][runner.name] = result
            if progress:
                progress.update()
        rows.append(row)
    limits = {}
    for runner in peers.steppers():
        statuses = [(r['omega_dt'], r['results'][runner.name]['status']) for r in rows]
        last_ok = None
        for w, st in statuses:
            if st != 'accurate':
                break
            last_ok = w
        diverged = [w for w, st in statuses if st == 'diverged']
        limits[runner.name] = {'accurate_up_to': last_ok,
                               'first_diverged': min(diverged) if diverged else None,
                               'tested_up_to': max(spins)}
    return {'revolutions': revolutions, 'rows': rows, 'limits': limits}


def plot_fast_spin(result: dict, path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    names = list(result['rows'][0]['results'])
    markers = 'oDvsPX'
    for i, name in enumerate(names):
        line = '-' if name.startswith('rb_sim_ros') else '--'
        for ax, key in zip(axes, ('angle_max', 'energy_drift')):
            results = [(r['omega_dt'], r['results'][name]) for r in result['rows']]
            ok = [(w, max(r[key], 1e-17)) for w, r in results if r['status'] != 'diverged']
            if ok:
                ax.loglog(*zip(*ok), line, marker=markers[i % len(markers)], color=f'C{i}',
                          label=name, markersize=4)
            bad = [w for w, r in results if r['status'] == 'diverged']
            if bad:  # one row of crosses per method, above the data
                top = (10.0 if key == 'angle_max' else 1e3) * 2.0 ** i
                ax.loglog(bad, [top] * len(bad), 'x', color=f'C{i}', markersize=8,
                          label=None if ok else name)
    axes[0].axhline(ACCURATE, color='grey', lw=0.8)
    axes[0].set_ylabel('worst orientation error, first 10 revolutions (rad)')
    axes[1].set_ylabel(f'|energy drift| (relative), {result["revolutions"]} revolutions')
    for ax in axes:
        ax.set_xlabel('omega * dt (rad)')
        ax.grid(True, which='both', alpha=0.3)
    axes[0].legend(fontsize=8, title='x: diverged', title_fontsize=8)
    fig.suptitle('Fast spin: torque-free body (1, 2, 3) near its major axis')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -- Long run -----------------------------------------------------------------------------

def long_run_steps(quick: bool) -> int:
    return 20_000 if quick else 10_000_000


def long_run(quick: bool, progress=None) -> dict:
    """1e7 steps (2e4 quick) torque-free at dt = 1 ms, for each method and MuJoCo: relative
    energy and world angular momentum drift at log-spaced times, and for rb_sim_ros the worst
    orthonormality error of the R it integrates (read raw: ``State`` would orthonormalize)."""
    steps = long_run_steps(quick)
    dt = 1e-3
    scene = sc.Scene('long run', sc.diagonal(1.0, 2.0, 3.0), (1.0, 0.1, 1.5), steps * dt, TILT)
    marks = sorted({int(round(k)) for k in np.geomspace(100, steps, 120)} | {steps})
    e0, l0 = invariants(scene, scene.rotation0, scene.omega0_world)
    out = {'steps': steps, 'dt': dt, 'times': [k * dt for k in marks], 'methods': {}}
    for runner in peers.steppers():
        energy, momentum, ortho, done = [], [], 0.0, 0
        diverged = None
        if isinstance(runner, peers.Ours):
            s = runner.stepper(scene, dt)
        else:
            m, d = runner.model(scene, dt)
        for k in marks:
            try:
                if isinstance(runner, peers.Ours):
                    s.step(k - done)
                    raw = s.rotation()  # the integrated R, not re-orthonormalized
                    ortho = max(ortho, so3.orthonormality_error(raw))
                    st = s.state
                    rot, w = st.rotation, st.angular_velocity
                else:
                    runner.advance(m, d, k - done, done)
                    rot, w = runner.state(d)
            except (IntegrationError, peers.Diverged) as error:
                diverged = f'step {error.step}: {str(error)[:150]}'
                break
            if progress:
                progress.update(k - done)
            done = k
            e_now, mom = invariants(scene, rot, w)
            energy.append((e_now - e0) / e0)
            momentum.append(float(np.linalg.norm(mom - l0) / np.linalg.norm(l0)))
        if progress:
            progress.update(steps - done)
        out['methods'][runner.name] = {
            'energy_drift': energy, 'momentum_drift': momentum, 'diverged': diverged,
            'max_orthonormality_error': ortho if isinstance(runner, peers.Ours) else None}
    return out


def plot_long_run(result: dict, path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for i, (name, data) in enumerate(result['methods'].items()):
        style = '-' if name.startswith('rb_sim_ros') else '--'
        t = result['times'][:len(data['energy_drift'])]
        for ax, key in zip(axes, ('energy_drift', 'momentum_drift')):
            y = [max(abs(v), 1e-17) for v in data[key]]
            ax.loglog(t, y, style, color=f'C{i}', label=name)
    axes[0].set_ylabel('|E - E0| / E0')
    axes[1].set_ylabel('|L - L0| / |L0| (world frame)')
    for ax in axes:
        ax.set_xlabel(f'simulated time (s), dt = {result["dt"] * 1e3:g} ms')
        ax.grid(True, which='both', alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f'Long run: torque-free tumble, {result["steps"]:.0e} steps')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -- Blow-up ------------------------------------------------------------------------------

def blow_up() -> list[dict]:
    """A spin far past every method's limit (omega*dt = 1.5, body (1, 2, 3)) must end in
    IntegrationError naming the step, never in a non-finite state returned silently. The step
    it names is checked by stepping a second stepper one step at a time. The flows have no
    limit: they must run through, finite, keeping the energy."""
    rows = []
    body = RigidBody(1.0, [1.0, 2.0, 3.0])
    omega = so3.exp(TILT) @ (np.array([0.3, 0.0, 1.0]) * 1.5 / math.hypot(0.3, 1.0))
    start = State(rotation=so3.exp(TILT), angular_velocity=omega)
    for method in METHODS:
        s = Stepper(body, 1.0, start, method=method)
        # The flows (steps == 1) have no limit: exact torque-free at any rate, they must stay
        # finite and keep the energy.
        row = {'method': method, 'omega_dt': 1.5, 'exact_flow': METHODS[method].steps == 1}
        try:
            s.step(1000)
            st = s.state
            e0, _ = invariants(sc.Scene('blow-up', np.diag([1.0, 2.0, 3.0]), (0.0, 0.0, 1.0),
                                        1.0, TILT), start.rotation, start.angular_velocity)
            e1, _ = invariants(sc.Scene('blow-up', np.diag([1.0, 2.0, 3.0]), (0.0, 0.0, 1.0),
                                        1.0, TILT), st.rotation, st.angular_velocity)
            row.update(raised=False, finite=bool(np.all(np.isfinite(st.angular_velocity))),
                       energy_drift=float((e1 - e0) / e0))
        except IntegrationError as e:
            st = s.state
            row.update(raised=True, step=e.step, message=str(e)[:160],
                       step_count_after=s.step_count,
                       state_finite=bool(np.all(np.isfinite(st.angular_velocity))
                                         and np.all(np.isfinite(st.rotation))))
            # One at a time: the first step that raises must be the one named.
            one = Stepper(body, 1.0, start, method=method)
            first_bad = None
            for k in range(1000):
                try:
                    one.step(1)
                except IntegrationError as e1:
                    first_bad = (k, e1.step)
                    break
            row['one_by_one'] = first_bad
            row['consistent'] = first_bad is not None and first_bad[1] == e.step == k
        rows.append(row)
    return rows
