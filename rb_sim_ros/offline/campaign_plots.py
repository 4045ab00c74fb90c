# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The pictures of a campaign (``campaign --plot DIR``), from its summary and recordings:

* ``envelope.png``: every run's attitude error over time (each run a thin line, up to 300 of
  them), the 5th-95th percentile band and the largest error at each time, the worst runs
  (by final error) drawn and named (run, seed) in the legend;
* ``histograms.png``: a histogram of each metric over the runs that did not fail;
* ``against_<key>.png``: each metric against each dispersed value, one dot a run.
"""

from __future__ import annotations

import csv
import math
import os

import numpy as np

from rb_sim_ros.offline import metrics
from rb_sim_ros.offline.progress import Progress

METRICS = ('settling_s', 'overshoot', 'peak_torque', 'rms_torque', 'final_error_rad',
           'contact_s')
MAX_LINES = 300
WORST = 3


def _rows(out_dir: str) -> list:
    try:
        with open(os.path.join(out_dir, 'summary.csv'), newline='') as f:
            return list(csv.DictReader(f))
    except (OSError, ValueError, csv.Error) as e:
        raise ValueError(f'{out_dir}: not a finished campaign ({e})') from None


def _number(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def plot(out_dir: str, spec: dict, progress: bool = True) -> list[str]:
    """Draw the pictures of the campaign in ``out_dir`` (``spec``: its campaign.json, read and
    checked) into it; their paths."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    rows = _rows(out_dir)
    good = [r for r in rows if not r.get('error') and r.get('file')]
    if not good:
        raise ValueError(f'{out_dir}: no run finished without an error: nothing to draw')
    written = [_envelope(plt, out_dir, spec, good, progress)]
    names = [m for m in METRICS if m in good[0]]
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.2), squeeze=False)
    for ax, name in zip(axes[0], names):
        values = np.array([_number(r[name]) for r in good])
        ax.hist(values[np.isfinite(values)], bins=min(50, max(5, len(good) // 10)))
        ax.set_xlabel(name)
        ax.set_ylabel('runs')
    fig.suptitle(f'{len(good)} runs of {len(rows)}')
    fig.tight_layout()
    written.append(os.path.join(out_dir, 'histograms.png'))
    fig.savefig(written[-1], dpi=100)
    plt.close(fig)
    for key, _ in spec['vary']:
        x = np.array([_number(r.get(key)) for r in good])
        fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.2),
                                 squeeze=False)
        for ax, name in zip(axes[0], names):
            ax.plot(x, [_number(r[name]) for r in good], '.', markersize=3)
            ax.set_xlabel(key)
            ax.set_ylabel(name)
        fig.tight_layout()
        written.append(os.path.join(out_dir, f'against_{key.replace("/", "_")}.png'))
        fig.savefig(written[-1], dpi=100)
        plt.close(fig)
    return written


def _envelope(plt, out_dir: str, spec: dict, good: list, progress: bool) -> str:
    target = spec['controller_params'].get('target_rpy') or (0.0, 0.0, 0.0)
    try:
        q = metrics.quaternion_from_rpy(*(float(c) for c in target))
    except (TypeError, ValueError):
        raise ValueError(f'campaign.json: target_rpy {target!r} is not 3 angles') from None
    fig, ax = plt.subplots(figsize=(9, 5))
    worst = sorted(good, key=lambda r: -_number(r.get('final_error_rad')))[:WORST]
    curves = []
    show = Progress(len(good), 'campaign --plot', 'runs') if progress else None
    for k, row in enumerate(good):
        t, r, _, _ = metrics.series(os.path.join(out_dir, row['file']), spec.get('body', ''),
                                    q)
        angle = np.degrees(np.linalg.norm(r, axis=1))
        curves.append((t, angle))
        if k < MAX_LINES:
            ax.plot(t, angle, color='0.75', linewidth=0.5)
        if show is not None:
            show(k + 1)
    if show is not None:
        show.close()
    n = min(len(t) for t, _ in curves)
    stack = np.array([a[:n] for _, a in curves])
    t = curves[0][0][:n]
    ax.fill_between(t, np.percentile(stack, 5, axis=0), np.percentile(stack, 95, axis=0),
                    color='tab:blue', alpha=0.3, label='5th to 95th percentile')
    ax.plot(t, stack.max(axis=0), color='tab:blue', linewidth=1.0, label='largest')
    index = {row['run']: k for k, row in enumerate(good)}
    for row, color in zip(worst, ('tab:red', 'tab:orange', 'tab:purple')):
        tw, a = curves[index[row['run']]]
        ax.plot(tw, a, color=color, linewidth=1.2,
                label=f"run {row['run']} (seed {row['seed']}): final "
                      f"{math.degrees(_number(row['final_error_rad'])):.3g} deg")
    ax.set_yscale('symlog', linthresh=0.1)
    ax.set_xlabel('t (s)')
    ax.set_ylabel('attitude error (deg)')
    ax.set_title(f'{len(good)} runs' + (f' ({MAX_LINES} drawn)' if len(good) > MAX_LINES
                                        else ''))
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(out_dir, 'envelope.png')
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
