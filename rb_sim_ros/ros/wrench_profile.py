# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A wrench profile: a CSV of times and wrenches (``t,fx,fy,fz,tx,ty,tz[,frame]``), read and
checked as the simulator would take each wrench. No ROS: ``send_wrench`` plays one to a live
node, ``sweep`` applies one offline."""

from __future__ import annotations

import csv
import math

FIELDS = ('t', 'fx', 'fy', 'fz', 'tx', 'ty', 'tz')
MAX_WRENCH = 1.0e6  # the simulator's max_wrench parameter's default (N, N m)
MAX_SECONDS = 1e9  # profile times (and send_wrench's --duration, --wait): ~31 years


def check_wrench(values, max_wrench: float, where: str) -> None:
    """ValueError (naming ``where``) unless force and torque (6 values) are finite with norms
    (math.hypot: no overflow) of at most ``max_wrench``, as the simulator requires."""
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f'{where}: non-finite wrench {list(values)}')
    for name, vec in (('force', values[:3]), ('torque', values[3:])):
        norm = math.hypot(*vec)
        if not norm <= max_wrench:
            raise ValueError(f'{where}: {name} norm {norm:.6g} exceeds --max-wrench '
                             f'{max_wrench:.6g}')


def load_profile(path: str, max_wrench: float = MAX_WRENCH
                 ) -> list[tuple[float, tuple[float, ...], str | None]]:
    """Rows (t, (fx, fy, fz, tx, ty, tz), frame or None) sorted by t; ValueError names the line."""
    rows = []
    line = 1
    try:
        with open(path, newline='') as f:
            reader = csv.DictReader(f)
            missing = [c for c in FIELDS if c not in (reader.fieldnames or [])]
            if missing:
                raise ValueError(f'{path}: missing columns {missing} (need {",".join(FIELDS)})')
            for line, row in enumerate(reader, start=2):
                rows.append(_row(path, line, row, max_wrench))
    except csv.Error as e:  # a field over csv's size limit, a NUL byte...
        raise ValueError(f'{path}:{line + 1}: not a CSV profile: {e}') from None
    except UnicodeDecodeError as e:
        raise ValueError(f'{path}: not a text file ({e.reason} at byte {e.start})') from None
    if not rows:
        raise ValueError(f'{path}: no rows')
    if any(b[0] < a[0] for a, b in zip(rows, rows[1:])):
        raise ValueError(f'{path}: times must not decrease')
    return rows


def _row(path: str, line: int, row: dict, max_wrench: float):
    try:
        values = tuple(float(row[c]) for c in FIELDS)
    except (TypeError, ValueError):
        raise ValueError(f'{path}:{line}: not a number in {_short(row)}') from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f'{path}:{line}: non-finite value in {_short(row)}')
    if not 0 <= values[0] <= MAX_SECONDS:
        raise ValueError(f'{path}:{line}: t must be from 0 to {MAX_SECONDS:g} s, '
                         f'got {values[0]!r}')
    check_wrench(values[1:], max_wrench, f'{path}:{line}')
    frame = row.get('frame')
    frame = (frame.strip() if isinstance(frame, str) else '') or None
    if frame not in (None, 'world', 'body'):
        raise ValueError(f"{path}:{line}: frame must be world or body, got '{frame[:40]}'")
    return values[0], values[1:], frame


def _short(row: dict) -> str:
    text = str(row)
    return text if len(text) <= 200 else text[:200] + '...'
