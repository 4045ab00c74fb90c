# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Run time against error: every integrator on every scene, over a sweep of dt.

Two phases, so that nothing is timed before everything is known to be right:

1. ``accuracy``: each runner on each scene at each dt (DOP853: each rtol), errors against the
   scene's reference at the sample times. ``check_orders`` then fits the slope of log(error)
   against log(dt) over the asymptotic range (the finest steps whose error is still well above
   the reference's own, ~1e-13) for the orientation and the angular velocity, and raises
   ``OrderError`` naming every method whose slope is off its order by more than 0.3.
2. ``timing``: wall time per simulated second of every (runner, dt) that did not diverge,
   the minimum of several runs.
"""

from __future__ import annotations

import math

import numpy as np

from bench import peers, references, scenes as sc

# dt = SEGMENT / n: these divide the sample spacing and every torque segment.
FULL_STEPS = (2, 4, 10, 20, 40, 100, 200, 400, 1000, 2000)
QUICK_STEPS = (2, 4, 10, 20, 40, 100, 200, 400)
FULL_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)
QUICK_RTOLS = (1e-6, 1e-8, 1e-10)
# The fitted slope must be within this of the method's order.
ORDER_TOLERANCE = 0.3
# Errors below FLOOR (rad; for omega, rad/s per rad/s of |omega0|) are near the references'
# own accuracy and rounding; above ASYMPTOTIC the method is not yet in its asymptotic range.
FLOOR = 1e-11
ASYMPTOTIC = 0.1
# A method whose errors are all below EXACT at every dt swept (the flow methods on a
# torque-free scene: exact at any step, their error the rounding of up to 4e4 steps, which
# grows as dt falls) has no order to fit and passes as exact.
EXACT = 1e-10
# The fit uses the finest FIT_POINTS points between those bounds (at least 3).
FIT_POINTS = 4


class OrderError(AssertionError):
    """A method's error did not fall at its order: nothing is timed."""


def dts(quick: bool) -> list[float]:
    return [sc.SEGMENT / n for n in (QUICK_STEPS if quick else FULL_STEPS)]


def rtols(quick: bool) -> tuple[float, ...]:
    return QUICK_RTOLS if quick else FULL_RTOLS


def count(quick: bool) -> int:
    """Number of (scene, runner, dt or rtol) runs, for progress bars."""
    per_scene = len(peers.steppers()) * len(dts(quick)) + len(rtols(quick))
    return per_scene * len(sc.work_precision_scenes(quick))


def _measure(runner, scene, step, ref) -> dict:
    try:
        return peers.errors(runner.run(scene, step), ref)
    except peers.Diverged as e:
        return {'diverged': str(e)[:200]}


def accuracy(quick: bool, progress=None) -> dict:
    """{scene name: {'scene': ..., 'reference_check': ..., 'methods': {name: {'kind',
    'expected_order', 'points': [{'dt' or 'rtol', errors...}]}}}} (phase 1, untimed)."""
    out = {}
    for scene in sc.work_precision_scenes(quick):
        check = references.self_check(scene)
        if not check['ok']:
            raise OrderError(f'{scene.name}: the references disagree: {check}')
        ref = references.reference(scene, scene.sample_times())
        methods = {}
        for runner in peers.steppers():
            points = []
            for dt in dts(quick):
                points.append({'dt': dt, **_measure(runner, scene, dt, ref)})
                if progress:
                    progress.update()
            methods[runner.name] = {'kind': runner.kind, 'expected_order': runner.order,
                                    'points': points}
        points = []
        for rtol in rtols(quick):
            points.append({'rtol': rtol, **_measure(peers.Dop853, scene, rtol, ref)})
            if progress:
                progress.update()
        methods[peers.Dop853.name] = {'kind': peers.Dop853.kind, 'expected_order': None,
                                      'points': points}
        out[scene.name] = {'scene': {'key': scene.key, 't_end': scene.t_end,
                                     'omega0': scene.initial_speed(),
                                     'reference': scene.reference,
                                     'moments': np.linalg.eigvalsh(scene.inertia_body).tolist()},
                           'reference_check': check, 'methods': methods}
    return out


def fit_order(points: list[dict], key: str, scale: float = 1.0) -> dict:
    """Slope of log(error) against log(dt) over the asymptotic range of ``points``.

    ``key`` is 'angle_final' (rad) or 'omega_final' (rad/s; divided by ``scale``, |omega0|).
    Uses the finest FIT_POINTS points with FLOOR < error < ASYMPTOTIC; {'order': None} if
    fewer than 3 qualify."""
    usable = [(p['dt'], p[key] / scale) for p in points
              if 'diverged' not in p and FLOOR < p[key] / scale < ASYMPTOTIC]
    usable = sorted(usable, reverse=True)[-FIT_POINTS:]
    if len(usable) < 3:
        return {'order': None, 'dts': [d for d, _ in usable]}
    x, y = np.log([d for d, _ in usable]), np.log([e for _, e in usable])
    return {'order': float(np.polyfit(x, y, 1)[0]), 'dts': [d for d, _ in usable]}


def check_orders(results: dict) -> list[str]:
    """Fit and store each fixed-step method's orders ('order_angle', 'order_omega'); return
    the failures (empty if every slope is within ORDER_TOLERANCE of the method's order, or
    every error below EXACT). A DOP853 sweep must reach 1e-9 rad at its tightest
    tolerance."""
    failures = []
    for scene_name, scene in results.items():
        speed = scene['scene']['omega0']
        for name, data in scene['methods'].items():
            if data['expected_order'] is None:
                best = min(p.get('angle_final', math.inf) for p in data['points'])
                data['ok'] = best < 1e-9
                if not data['ok']:
                    failures.append(f'{scene_name}: {name} reaches only {best:.2e} rad')
                continue
            fits = {'angle': fit_order(data['points'], 'angle_final'),
                    'omega': fit_order(data['points'], 'omega_final', speed)}
            data['ok'] = True
            for what, fit in fits.items():
                data[f'order_{what}'] = fit['order']
                data[f'fit_dts_{what}'] = fit['dts']
                errors = [p.get(f'{what}_final', math.inf) / (speed if what == 'omega' else 1)
                          for p in data['points']]
                if all(e <= EXACT for e in errors):
                    data[f'exact_{what}'] = True  # the flow methods on a torque-free scene
                    continue
                if fit['order'] is None or abs(fit['order'] - data['expected_order']) > \
                        ORDER_TOLERANCE:
                    data['ok'] = False
                    shown = 'n/a' if fit['order'] is None else f'{fit["order"]:.2f}'
                    errs = [f'{p["dt"]:.2g}: {p.get(what + "_final", math.nan):.2e}'
                            for p in data['points']]
                    failures.append(f'{scene_name}: {name} {what} error falls at order '
                                    f'{shown}, expected {data["expected_order"]} '
                                    f'(dt: error {", ".join(errs)})')
    return failures


def timing(results: dict, quick: bool, progress=None) -> None:
    """Add 'seconds_per_sim_second' to every point that did not diverge (phase 2)."""
    repeats = 2 if quick else 5
    runners = {r.name: r for r in peers.steppers()}
    runners[peers.Dop853.name] = peers.Dop853
    for scene in sc.work_precision_scenes(quick):
        for name, data in results[scene.name]['methods'].items():
            for p in data['points']:
                if 'diverged' not in p:
                    step = p['dt'] if 'dt' in p else p['rtol']
                    p['seconds_per_sim_second'] = runners[name].seconds_per_sim_second(
                        scene, step, repeats)
                if progress:
                    progress.update()


def cheapest(points: list[dict], target: float, key: str = 'angle_final') -> float | None:
    """Least measured wall time per simulated second among points with error <= target."""
    ok = [p['seconds_per_sim_second'] for p in points
          if 'seconds_per_sim_second' in p and p[key] <= target]
    return min(ok) if ok else None


def plot(name: str, scene: dict, path) -> None:
    """Two log-log panels: final orientation error and final omega error against wall time
    per simulated second. Points that diverged or whose error exceeds 1 rad are left out."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    lines = {'rb_sim_ros': '-', 'mujoco': '--', 'scipy': ':'}
    markers = 'oDvsPX^'
    for i, (method, data) in enumerate(scene['methods'].items()):
        line, marker = lines[data['kind']], markers[i % len(markers)]
        pts = [p for p in data['points'] if 'seconds_per_sim_second' in p
               and 0 < p['angle_final'] < 1.0]
        for ax, key in zip(axes, ('angle_final', 'omega_final')):
            x = [p['seconds_per_sim_second'] for p in pts]
            y = [max(p[key], 1e-16) for p in pts]
            (handle,) = ax.loglog(x, y, line, marker=marker, label=method, markersize=4,
                                  color=f'C{i}', alpha=0.85)
            ring = [(xi, yi) for xi, yi, p in zip(x, y, pts)
                    if abs(p.get('dt', 0.0) - 1e-3) < 1e-12]
            if ring:
                ax.loglog(*zip(*ring), 'o', markersize=11, markerfacecolor='none',
                          color=handle.get_color())
    axes[0].set_ylabel('orientation error at the final time (rad)')
    axes[1].set_ylabel('angular velocity error at the final time (rad/s)')
    for ax in axes:
        ax.set_xlabel('wall time per simulated second (s)')
        ax.grid(True, which='both', alpha=0.3)
    axes[0].legend(fontsize=8, title='ring: dt = 1 ms', title_fontsize=8)
    info = scene['scene']
    fig.suptitle(f'Work-precision: {name} ({info["t_end"]:g} s, |omega0| = '
                 f'{info["omega0"]:.3g} rad/s, reference: {info["reference"]})')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
