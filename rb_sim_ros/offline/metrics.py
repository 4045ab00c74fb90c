# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What a GNC engineer measures of one closed-loop run, from its recording.

``attitude(path, body, target)`` reads the body's odom and its wrench inputs and gives:

* ``initial_error_rad``, ``final_error_rad``: the angle from the target attitude (rad) at the
  first and the last recorded state (theta = 2 atan2(|e_v|, |e_w|), e = target^-1 q);
* ``settling_s``: the first time after which the angle stays within ``band`` (default 2 %) of
  its initial value, as a step response's settling time (0 if it starts there; the run's end
  if it never settles: then ``settled`` is 0);
* ``overshoot``: how far the error goes past the target, as a fraction of the initial error,
  along the initial error's axis (the error's rotation vector projected on it: a second-order
  response's exp(-pi zeta / sqrt(1 - zeta^2))); 0 if it never crosses;
* ``peak_s``: when that projection is most negative (the first peak's time, pi / omega_d, for
  a second-order response); NaN if it never crosses;
* ``peak_torque``, ``rms_torque`` (N m): the largest norm of the torque commanded, and its
  root mean square over the run, each wrench held from its step to the next.

A user's own metric is a function ``f(path, run_info) -> {name: number}`` given by import
path (``module:function``): ``run_info`` holds the run's number, seed, drawn values, the
body and the target.
"""

from __future__ import annotations

import importlib
import json
import math
from typing import Callable

import numpy as np

from rb_sim_ros.recording.reader import RecordingReader
from rb_sim_ros.ros import node_recorder

BAND = 0.02


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple:
    """x, y, z, w of R = Rz(yaw) Ry(pitch) Rx(roll) (REP-103 fixed axes)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def error_vectors(q: np.ndarray, target) -> np.ndarray:
    """The rotation vectors (rad) of target^-1 q for each row x, y, z, w of ``q``, the
    shorter way round."""
    tx, ty, tz, tw = -target[0], -target[1], -target[2], target[3]
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    e = np.stack([tw * x + tx * w + ty * z - tz * y, tw * y - tx * z + ty * w + tz * x,
                  tw * z + tx * y - ty * x + tz * w], axis=1)
    ew = tw * w - tx * x - ty * y - tz * z
    e = np.where((ew < 0.0)[:, None], -e, e)
    norm = np.linalg.norm(e, axis=1)
    angle = 2.0 * np.arctan2(norm, np.abs(ew))
    with np.errstate(invalid='ignore', divide='ignore'):
        scale = np.where(norm > 0.0, angle / norm, 2.0)
    return e * scale[:, None]


def series(path: str, body: str = '', target=(0.0, 0.0, 0.0, 1.0)):
    """(t s, error rotation vectors (n, 3) rad, wrench input steps' times s, torques (m, 3),
    dt s) of ``body``'s recorded run ('' : the single body)."""
    reader = RecordingReader(path)
    outputs = json.loads(reader.metadata[node_recorder.METADATA]['output_topics'])
    name = body or next(iter(outputs))
    if name not in outputs:
        raise ValueError(f"{path}: no body '{name}' recorded (bodies: {', '.join(outputs)})")
    topic = outputs[name].get('odom')
    if topic is None:
        raise ValueError(f"{path}: body '{name}' has no odom recorded (record_outputs)")
    wrench_topic = node_recorder.input_topic(name, 'wrench')
    t, q, tw, torque = [], [], [], []
    for m in reader.messages(topics=[topic, wrench_topic]):
        if m.topic == topic:
            o = m.message.pose.pose.orientation
            t.append(m.log_time_ns * 1e-9)
            q.append((o.x, o.y, o.z, o.w))
        else:
            tq = m.message.wrench.torque
            tw.append(m.log_time_ns * 1e-9)
            torque.append((tq.x, tq.y, tq.z))
    return (np.array(t), error_vectors(np.array(q, dtype=float).reshape(-1, 4), target),
            np.array(tw), np.array(torque, dtype=float).reshape(-1, 3))


def attitude(path: str, body: str = '', target=(0.0, 0.0, 0.0, 1.0),
             band: float = BAND) -> dict:
    """The attitude metrics of the module's doc, of ``body`` towards ``target`` (x, y, z,
    w)."""
    t, r, tw, torque = series(path, body, target)
    return response(t, r, tw, torque, band)


def response(t: np.ndarray, r: np.ndarray, tw: np.ndarray, torque: np.ndarray,
             band: float = BAND) -> dict:
    """The metrics of an error series (times ``t``, rotation vectors ``r``) and the torques
    commanded at times ``tw``."""
    angle = np.linalg.norm(r, axis=1)
    out = {'initial_error_rad': float(angle[0]), 'final_error_rad': float(angle[-1])}
    outside = np.flatnonzero(angle > band * angle[0])
    if angle[0] == 0.0 or not len(outside):
        out.update(settling_s=0.0, settled=1)
    elif outside[-1] == len(t) - 1:
        out.update(settling_s=float(t[-1] - t[0]), settled=0)
    else:
        out.update(settling_s=float(t[outside[-1] + 1] - t[0]), settled=1)
    if angle[0] > 0.0:
        along = r @ (r[0] / angle[0])
        k = int(np.argmin(along))
        crossed = along[k] < 0.0
        out['overshoot'] = float(-along[k] / angle[0]) if crossed else 0.0
        out['peak_s'] = float(t[k] - t[0]) if crossed else math.nan
    else:
        out['overshoot'], out['peak_s'] = 0.0, math.nan
    norms = np.linalg.norm(torque, axis=1) if len(torque) else np.zeros(0)
    out['peak_torque'] = float(norms.max()) if len(norms) else 0.0
    span = t[-1] - t[0]
    if len(norms) and span > 0.0:
        held = np.diff(np.append(np.clip(tw, t[0], t[-1]), t[-1]))
        out['rms_torque'] = float(math.sqrt(float(np.sum(norms ** 2 * held)) / span))
    else:
        out['rms_torque'] = 0.0
    return out


def user_metric(where: str) -> Callable:
    """The function named ``module:function``; ValueError naming what is wrong."""
    module, sep, name = where.partition(':')
    if not sep or not module or not name:
        raise ValueError(f'--metric {where}: give it as module:function')
    try:
        fn = getattr(importlib.import_module(module), name)
    except Exception as e:  # noqa: B902 - whatever the user's module raised on import
        raise ValueError(f'--metric {where}: {type(e).__name__}: '
                         f'{str(e).splitlines()[0] if str(e) else ""}') from None
    if not callable(fn):
        raise ValueError(f'--metric {where}: not a function')
    return fn
