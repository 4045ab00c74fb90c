# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Run time against error: every method on every scene, over a sweep of dt.

First each stepping method's final-time orientation error must fall at its order over the
sweep (the slope of log error against log dt, fitted on the finest steps); only then is
anything timed. Wall time is per simulated second, the minimum of several runs.
"""

from __future__ import annotations

import math

import numpy as np

import peers
import scenes as sc

# The asymptotic slope must be within this of the method's order.
ORDER_TOLERANCE = 0.3


class OrderError(AssertionError):
    """A method's error did not fall at its order: nothing is timed."""


def fitted_order(dts, errs) -> float:
    """Slope of log(err) against log(dt) over the three finest steps."""
    x, y = np.log(dts[-3:]), np.log(errs[-3:])
    return float(np.polyfit(x, y, 1)[0])


def steppers():
    return [peers.Ours('eq27'), peers.Ours('eq27-no-cross'), peers.Ours('taylor1'),
            peers.MuJoCo('Euler'), peers.MuJoCo('implicitfast'), peers.MuJoCo('RK4')]


def sweep(scene: sc.Scene, quick: bool, progress=None) -> dict:
    """{method name: {'order': fitted, 'points': [{dt, errors..., seconds}]}} for one scene."""
    ref = sc.reference(scene, scene.sample_times())
    spacing = scene.t_end / scene.samples
    ks = range(3, 6) if quick else range(1, 8)
    result = {}
    for runner in steppers():
        dts = [spacing / 2 ** k for k in ks]
        errs = [peers.errors(runner.run(scene, dt), ref) for dt in dts]
        finals = [e['angle_final'] for e in errs]
        # Fit where the error is well above the reference's own (~1e-13).
        usable = [(d, e) for d, e in zip(dts, finals) if e > 1e-10]
        if len(usable) < 3:
            usable = list(zip(dts, finals))[:3]
        order = fitted_order(*zip(*usable))
        if not abs(order - runner.order) <= ORDER_TOLERANCE:
            raise OrderError(f'{scene.name}: {runner.name} converges at order {order:.2f}, '
                             f'expected {runner.order}: errors {finals} at dt {dts}')
        points = []
        for dt, e in zip(dts, errs):
            points.append({'dt': dt, **e, 'seconds_per_sim_second':
                           runner.seconds_per_sim_second(scene, dt, 2 if quick else 3)})
            if progress:
                progress.update()
        result[runner.name] = {'order': order, 'expected_order': runner.order,
                               'points': points}
    tols = [1e-6, 1e-9] if quick else [1e-5, 1e-7, 1e-9, 1e-11, 1e-13]
    dop = peers.Dop853()
    points = []
    for rtol in tols:
        e = peers.errors(dop.run(scene, rtol), ref)
        points.append({'rtol': rtol, **e, 'seconds_per_sim_second':
                       dop.seconds_per_sim_second(scene, rtol, 2 if quick else 3)})
        if progress:
            progress.update()
    result[dop.name] = {'order': None, 'expected_order': None, 'points': points}
    return result


def count(quick: bool) -> int:
    """Number of progress steps of a full sweep (for the progress bar)."""
    per_scene = len(steppers()) * (3 if quick else 7) + (2 if quick else 5)
    return per_scene * len(sc.scenes(quick))


def plot(name: str, result: dict, path) -> None:
    """Log-log plot of final orientation error against wall time per simulated second."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 5))
    for method, data in result.items():
        pts = [p for p in data['points'] if p['angle_final'] > 0]
        style = ('-o' if method.startswith('rb_sim_ros')
                 else '--s' if 'MuJoCo' in method else ':^')
        ax.loglog([p['seconds_per_sim_second'] for p in pts], [p['angle_final'] for p in pts],
                  style, label=method, markersize=4)
    ax.set_xlabel('wall time per simulated second (s)')
    ax.set_ylabel('orientation error at the final time (rad)')
    ax.set_title(f'Work-precision: {name}')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def cheapest_at(result: dict, target: float) -> dict:
    """Per method, the least wall time per simulated second reaching ``target`` rad."""
    out = {}
    for method, data in result.items():
        ok = [p['seconds_per_sim_second'] for p in data['points'] if p['angle_final'] <= target]
        out[method] = min(ok) if ok else math.inf
    return out
