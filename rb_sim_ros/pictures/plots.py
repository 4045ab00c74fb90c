# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Plots of a recording, for people who would rather look than read (``replay --plot``).

One PNG per body: position; orientation as roll, pitch, yaw (REP-103: about the fixed x, y, z
axes, z-y-x order) and as the quaternion; linear and angular velocity (world frame); kinetic
energy and angular momentum about the centre of mass (world frame); the applied force (N) and
torque (N m), each in its own panel, as the steps they were held. The quaternion is drawn
sign-continuous (q and -q are one rotation: each sample on the hemisphere of the one before).
Events are marked on every time axis: teleports (set_pose, set_twist), resets, wrench
changes, spawns and deletes. With colliders, one more PNG: the contacts of the
last step of every publish, from a re-simulation of the run (the recording holds states, not
contacts; the re-simulation is the run, bit for bit, as ``--verify`` shows).

The states are the recorded ``odom`` messages (pose in the world frame, twist in the body
frame), so the plot shows what the node published. matplotlib renders without a display.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
import os

import numpy as np

from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.sim.simulation import Delete, Reset, SetPose, SetTwist, SetWrench, Simulation, \
    Spawn

# How each kind of event is marked: colour and line style.
EVENT_STYLE = {'wrench': ('tab:orange', ':'), 'teleport': ('tab:red', '--'),
               'reset': ('tab:purple', '-.'), 'spawn': ('tab:green', '--'),
               'delete': ('tab:gray', '--')}
# More wrench changes than this (a controller commanding every period) are not marked.
MAX_WRENCH_MARKS = 40
# A line of more samples than this is drawn as its envelope: the first, least and greatest
# sample of each of MAX_LINE_POINTS / 3 runs of samples (a panel is about 500 pixels wide:
# nothing visible is lost, and matplotlib's memory does not grow with the run's length).
MAX_LINE_POINTS = 3000
# Values beyond this magnitude (and non-finite ones) are left out of a panel, which says so: an
# axis cannot span them (matplotlib fails on ticks or transforms near the float range).
MAX_VALUE = 1e100


@dataclass
class BodySeries:
    """What was recorded of one body, as arrays over its publishes."""

    name: str
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))  # s
    position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    quaternion: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # x y z w
    linear: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # world, m/s
    angular: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # world, rad/s
    energy: np.ndarray = field(default_factory=lambda: np.zeros(0))  # J
    momentum: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # world, kg m^2/s


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations (body to world) of (n, 4) quaternions x, y, z, w (normalised)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
        axis=1)


def roll_pitch_yaw(q: np.ndarray) -> np.ndarray:
    """(n, 3) roll, pitch, yaw (rad) of (n, 4) quaternions x, y, z, w: R = Rz(yaw) Ry(pitch)
    Rx(roll), the fixed-axes convention of REP-103; yaw and roll unwrapped over time."""
    r = rotation_matrices(q)
    pitch = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    yaw = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    return np.stack([np.unwrap(roll), pitch, np.unwrap(yaw)], axis=1)


def recorded_odom(rec, bodies=None, keep: bool = True
                  ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """One pass over the recorded outputs (which may be read from the file as they are
    iterated): ({body: (n, 14) t s, position, quaternion x y z w, body-frame linear and
    angular velocity}, the steps of the publishes); with ``keep`` False, the steps only.
    Only these floats are kept, not the messages: 112 bytes a publish of a body."""
    rows: dict[str, array] = {}
    steps, last = array('q'), None
    for step, body, kind, _topic, msg, log_time in rec.outputs:
        if step != last:
            steps.append(step)
            last = step
        if not keep or kind != 'odom' or (bodies and body not in bodies):
            continue
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        v, w = msg.twist.twist.linear, msg.twist.twist.angular
        row = rows.get(body)
        if row is None:
            row = rows[body] = array('d')
        row.extend((log_time * 1e-9, p.x, p.y, p.z, o.x, o.y, o.z, o.w, v.x, v.y, v.z, w.x,
                    w.y, w.z))
    return ({name: np.frombuffer(row, dtype=float).reshape(-1, 14)
             for name, row in rows.items()},
            np.unique(np.frombuffer(steps, dtype=np.int64)))


def body_series(rec, bodies=None, odom=None) -> dict[str, BodySeries]:
    """The recorded odom of each body (all moving ones, or those named in ``bodies``), with
    energy and momentum from the body's mass and inertia in the recording's config; ``odom``
    is recorded_odom(rec, bodies)[0] if already read."""
    lives = lifetimes(rec)
    if odom is None:
        odom = recorded_odom(rec, bodies)[0]
    out = {}
    for name, a in odom.items():
        # Each publish with the body of its lifetime (a name deleted and spawned again may
        # be another body): the last spawn strictly before it (a spawn follows the publish
        # of its step).
        starts = [start for start, _ in lives[name]]
        which = np.maximum(np.searchsorted(starts, a[:, 0], side='left') - 1, 0)
        mass = np.array([spec.mass for _, spec in lives[name]])[which]
        inertia = np.array([_tensor(spec) for _, spec in lives[name]])[which]
        r = rotation_matrices(a[:, 4:8])
        v_body, w_body = a[:, 8:11], a[:, 11:14]
        spin = np.einsum('nij,nj->ni', inertia, w_body)  # I w, body frame
        out[name] = BodySeries(
            name, a[:, 0], a[:, 1:4], a[:, 4:8],
            np.einsum('nij,nj->ni', r, v_body), np.einsum('nij,nj->ni', r, w_body),
            0.5 * mass * np.sum(v_body * v_body, axis=1) + 0.5 * np.sum(w_body * spin, axis=1),
            np.einsum('nij,nj->ni', r, spin))
    return out


def lifetimes(rec) -> dict[str, list]:
    """Each body's [(start s, BodySpec)]: the config's from the start (-inf), then every spawn
    of that name."""
    out = {b.name: [(-np.inf, b)] for b in rec.config.bodies}
    for step, event, _ in rec.inputs:
        if isinstance(event, Spawn):
            out.setdefault(event.spec.name, []).append((step * rec.config.dt, event.spec))
    return out


def _tensor(spec) -> np.ndarray:
    inertia = np.array(spec.inertia, dtype=float)
    return np.diag(inertia) if inertia.size == 3 else inertia.reshape(3, 3)


def events(rec) -> list[tuple[float, str, str]]:
    """(time s, kind, body) of every input: 'wrench', 'teleport', 'reset', 'spawn',
    'delete'."""
    kinds = {SetWrench: 'wrench', SetPose: 'teleport', SetTwist: 'teleport', Reset: 'reset',
             Spawn: 'spawn', Delete: 'delete'}
    dt = rec.config.dt
    return [(step * dt, kinds[type(e)], e.body or rec.config.bodies[0].name)
            for step, e, _ in rec.inputs]


def wrench_steps(rec, name: str, t_end: float):
    """(times, forces (n, 3), torques (n, 3), frames) of the wrench held on ``name``: zero at
    the start, each change where it took effect (a reset zeroes it), held to ``t_end``."""
    dt = rec.config.dt
    times, forces, torques, frames = [0.0], [(0.0,) * 3], [(0.0,) * 3], ['world']
    for step, e, _ in rec.inputs:
        if (e.body or rec.config.bodies[0].name) != name:
            continue
        if isinstance(e, SetWrench):
            times.append(step * dt)
            forces.append(tuple(e.wrench.force))
            torques.append(tuple(e.wrench.torque))
            frames.append(e.wrench.frame.value)
        elif isinstance(e, (Reset, Spawn, Delete)):
            times.append(step * dt)
            forces.append((0.0,) * 3)
            torques.append((0.0,) * 3)
            frames.append('world')
    times.append(max(t_end, times[-1]))
    forces.append(forces[-1])
    torques.append(torques[-1])
    return np.array(times), np.array(forces), np.array(torques), frames


def contact_counts(rec, progress=None, steps=None):
    """(times s, contacts) after the last step of every publish (``steps``, if already read:
    recorded_odom's), from a re-simulation; None when no moving body of the run has
    colliders (no collision world steps it).
    Stops at the first non-finite step."""
    collides = rec.config.collides or any(
        isinstance(e, Spawn) and e.spec.colliders and not e.spec.static
        for _, e, _ in rec.inputs)
    if not collides:
        return None
    sim = Simulation(rec.config)
    if steps is None:
        steps = recorded_odom(rec, keep=False)[1]
    steps = [int(step) for step in steps]
    pending = [(s, e) for s, e, _ in rec.inputs]
    times, counts = [], []
    for k, step in enumerate(steps):
        try:
            pending = sim.run_until(step, pending)
        except (IntegrationError, ValueError):
            break
        stats = sim.contact_stats()
        times.append(step * rec.config.dt)
        counts.append(stats.contacts if stats is not None else 0)
        if progress is not None:
            progress(k + 1, len(steps))
    return np.array(times), np.array(counts)


def _mark(ax, marks) -> None:
    for t, kind, _ in marks:
        colour, style = EVENT_STYLE[kind]
        ax.axvline(t, color=colour, linestyle=style, linewidth=0.8, alpha=0.8)


def _legend_for_events(fig, marks) -> None:
    from matplotlib.lines import Line2D
    kinds = sorted({k for _, k, _ in marks})
    if kinds:
        fig.legend([Line2D([0], [0], color=EVENT_STYLE[k][0], linestyle=EVENT_STYLE[k][1])
                    for k in kinds], kinds, loc='upper right', title='events', fontsize=8)


def drawable(values: np.ndarray) -> tuple[np.ndarray, int]:
    """``values`` with those non-finite or beyond MAX_VALUE as NaN (not drawn), and how many
    were."""
    values = np.array(values, dtype=float)
    with np.errstate(invalid='ignore'):
        bad = ~(np.abs(values) <= MAX_VALUE)
    values[bad] = np.nan
    return values, int(bad.sum())


def envelope(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) of at most MAX_LINE_POINTS samples: all if there are no more, else of each of
    MAX_LINE_POINTS // 3 runs of consecutive samples its first, least and greatest (a NaN,
    not drawn, is neither), and the last sample, in time order."""
    n = len(t)
    if n <= MAX_LINE_POINTS:
        return t, y
    runs = MAX_LINE_POINTS // 3 - 1
    edges = np.linspace(0, n, runs + 1).astype(np.int64)
    run = np.repeat(np.arange(runs), np.diff(edges))
    picks = [edges[:-1], [n - 1]]
    nan = np.isnan(y)
    for reduce, blank in ((np.minimum, np.inf), (np.maximum, -np.inf)):
        z = np.where(nan, blank, y)
        extreme = reduce.reduceat(z, edges[:-1])
        at = np.flatnonzero(z == extreme[run])
        _, first = np.unique(run[at], return_index=True)
        picks.append(at[first])
    pick = np.unique(np.concatenate(picks))
    return t[pick], y[pick]


def _left_out(count: int) -> str:
    return f'; {count} values not finite or beyond {MAX_VALUE:g}: not drawn' if count else ''


def plot(rec, out_dir: str, bodies=None, progress=None) -> list[str]:
    """Write the PNGs of ``rec`` (a replay.Recording) into ``out_dir``; their paths.
    ValueError, one line naming the body, if one cannot be drawn."""
    try:
        with np.errstate(all='ignore'):
            return _plot(rec, out_dir, bodies, progress)
    except (OverflowError, FloatingPointError) as e:
        raise ValueError(f'the plots cannot be drawn: {e}') from None


def _plot(rec, out_dir: str, bodies=None, progress=None) -> list[str]:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    odom, steps = recorded_odom(rec, bodies)
    series = body_series(rec, bodies, odom)
    del odom
    if bodies:
        missing = sorted(set(bodies) - set(series))
        if missing:
            raise ValueError(f'no recorded outputs of {missing} (have '
                             f'{sorted(recorded_odom(rec)[0])})')
    all_marks = events(rec)
    written = []
    t_end = max((s.t[-1] for s in series.values() if len(s.t)), default=0.0)
    for name, s in series.items():
        try:
            written.append(_plot_body(rec, out_dir, plt, name, s, all_marks, t_end))
        except (ValueError, OverflowError, FloatingPointError) as e:
            plt.close('all')
            raise ValueError(f'body {name!r}: its plots cannot be drawn: {e}') from None
    counts = contact_counts(rec, progress, steps)
    if counts is not None:
        fig, ax = plt.subplots(figsize=(10, 3.5))
        ax.step(*envelope(counts[0], counts[1].astype(float)), where='post', color='k',
                linewidth=1.0)
        ax.set_xlabel('sim time (s)')
        ax.set_ylabel('contacts')
        ax.set_title('contacts of the last step of each publish (re-simulated)')
        ax.grid(True, alpha=0.3)
        wrenches = sum(1 for k in all_marks if k[1] == 'wrench')
        shown = [m for m in all_marks if m[1] != 'wrench' or wrenches <= MAX_WRENCH_MARKS]
        _mark(ax, shown)
        _legend_for_events(fig, shown)
        fig.tight_layout(rect=(0, 0, 0.88, 1))
        path = os.path.join(out_dir, 'contacts.png')
        fig.savefig(path, dpi=80)
        plt.close(fig)
        written.append(path)
    return written


def _plot_body(rec, out_dir, plt, name, s, all_marks, t_end) -> str:
    """The PNG of one body's series ``s``; its path."""
    fig = body_figure(rec, plt, name, s, all_marks, t_end)
    path = os.path.join(out_dir, f'{name}.png')
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def continuous_quaternions(q: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions with each sample's sign chosen so that it is on the hemisphere of
    the one before (q and -q are one rotation): the series has no jump where the recorded one
    crosses w = 0. A sample that is not finite leaves the sign as it was."""
    q = np.array(q, dtype=float)
    if len(q) < 2:
        return q
    with np.errstate(invalid='ignore'):
        flip = np.sum(q[1:] * q[:-1], axis=1) < 0.0  # against the recorded one before
    sign = np.concatenate([[1.0], np.cumprod(np.where(flip, -1.0, 1.0))])
    return q * sign[:, None]


# The panels of a body's figure, rows of two: their keys.
BODY_PANELS = [['position', 'rpy'], ['quaternion', 'linear'], ['angular', 'momentum'],
               ['energy', 'energy'], ['force', 'torque']]


def body_figure(rec, plt, name, s, all_marks, t_end):
    """The matplotlib figure of one body's series ``s``: a panel a quantity, with its unit."""
    marks = [m for m in all_marks if m[2] == name]
    wrenches = sum(1 for m in marks if m[1] == 'wrench')
    if wrenches > MAX_WRENCH_MARKS:  # a controller's stream: the wrench panels show it
        marks = [m for m in marks if m[1] != 'wrench']
    fig, axes = plt.subplot_mosaic(BODY_PANELS, figsize=(13, 14), sharex=True)
    fig.suptitle(f'{name}  ({os.path.basename(rec.path)})')
    panels = [
        ('position', 'position (m, world)', s.position, ('x', 'y', 'z')),
        ('rpy', 'roll, pitch, yaw (rad)', roll_pitch_yaw(s.quaternion),
         ('roll', 'pitch', 'yaw')),
        ('quaternion', 'quaternion (sign continuous: q and -q are one rotation)',
         continuous_quaternions(s.quaternion), ('x', 'y', 'z', 'w')),
        ('linear', 'linear velocity (m/s, world)', s.linear, ('x', 'y', 'z')),
        ('angular', 'angular velocity (rad/s, world)', s.angular, ('x', 'y', 'z')),
        ('momentum', 'angular momentum (kg m^2/s, world, about the CoM)', s.momentum,
         ('x', 'y', 'z')),
    ]
    for key, title, values, labels in panels:
        ax = axes[key]
        values, hidden = drawable(values)
        title += _left_out(hidden)
        for k, label in enumerate(labels):
            ax.plot(*envelope(s.t, values[:, k]), label=label, linewidth=1.0)
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8, loc='best')
        ax.grid(True, alpha=0.3)
    ax = axes['energy']
    energy, hidden = drawable(s.energy)
    ax.plot(*envelope(s.t, energy), color='k', linewidth=1.0)
    ax.set_title('kinetic energy (J)' + _left_out(hidden), fontsize=10)
    ax.set_ylabel('J')
    ax.grid(True, alpha=0.3)
    times, forces, torques, _ = wrench_steps(rec, name, t_end)
    changes = f'; {wrenches} changes, not marked' if wrenches > MAX_WRENCH_MARKS else ''
    for key, what, unit, values in (('force', 'force', 'N', forces),
                                    ('torque', 'torque', 'N m', torques)):
        ax = axes[key]
        values, hidden = drawable(values)
        for k, label in enumerate('xyz'):
            ax.step(times, values[:, k], where='post', label=label, linewidth=1.0)
        ax.set_title(f'applied {what} ({unit}, as sent: world or body frame){changes}'
                     + _left_out(hidden), fontsize=10)
        ax.set_ylabel(unit)
        ax.legend(fontsize=8, loc='best')
        ax.grid(True, alpha=0.3)
    for ax in axes.values():
        _mark(ax, marks)
    for key in BODY_PANELS[-1]:
        axes[key].set_xlabel('sim time (s)')
    _legend_for_events(fig, marks)
    fig.tight_layout(rect=(0, 0, 0.93, 0.97))
    return fig
