# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The simulator node's parameters: names, defaults, descriptions and validation.

Kept apart from the node so that ``simulator --help`` can list them without starting ROS, and
so that the checks are plain functions. Physics parameters are read-only once the node runs
(changing them would need a new run); the others may be set at any time and are validated by
the node's on-set callback, which refuses a bad value with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Callable

from rb_sim_ros import multistep
from rb_sim_ros.rigid_body import Frame


def _positive(name: str, v: Any) -> None:
    if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
        raise ValueError(f'{name} must be a finite number > 0, got {v!r}')


def _non_negative(name: str, v: Any) -> None:
    if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
        raise ValueError(f'{name} must be a finite number >= 0, got {v!r}')


def _frame(name: str, v: Any) -> None:
    Frame.parse(v)


def _frame_id(name: str, v: Any) -> None:
    if not isinstance(v, str) or not v or v.startswith('/'):
        raise ValueError(f'{name} must be a non-empty frame id without a leading /, got {v!r}')


def _integrator(name: str, v: Any) -> None:
    multistep.method_by_name(v)


def _any(name: str, v: Any) -> None:
    pass


@dataclass(frozen=True)
class Param:
    name: str
    default: Any
    description: str
    read_only: bool = False
    check: Callable[[str, Any], None] = _any


PARAMS = (
    Param('dt', 0.001, 'Physics step (s). Simulated time is always step_count * dt.', True,
          _positive),
    Param('publish_rate', 100.0, 'Rate (Hz, sim time) of pose/twist/odom/clock. 1/(rate*dt) '
          'must be a whole number of physics steps.', True, _positive),
    Param('integrator', multistep.EQ27.name,
          f'Integration method: one of {sorted(multistep.METHODS)}.', True, _integrator),
    Param('mass', 1.0, 'Body mass (kg).', True, _positive),
    Param('inertia', [0.1, 0.1, 0.1], 'Body-frame inertia about the centre of mass (kg m^2): '
          '3 principal moments, or 9 row-major components of a symmetric tensor.', True),
    Param('initial_position', [0.0, 0.0, 0.0], 'Initial position (m) in world_frame; also '
          'the reset pose.'),
    Param('initial_orientation', [0.0, 0.0, 0.0, 1.0],
          'Initial orientation quaternion x, y, z, w in world_frame.'),
    Param('initial_linear_velocity', [0.0, 0.0, 0.0], 'Initial velocity (m/s), world frame.'),
    Param('initial_angular_velocity', [0.0, 0.0, 0.0],
          'Initial angular velocity (rad/s), world frame.'),
    Param('world_frame', 'odom', 'Fixed frame (REP-105) of pose and odom headers.', True,
          _frame_id),
    Param('body_frame', 'base_link', 'Body frame (REP-105): odom child_frame_id.', True,
          _frame_id),
    Param('wrench_frame', 'world', "Frame of wrenches on the 'wrench' topic: 'world' (fixed) "
          "or 'body' (turns with the body).", False, _frame),
    Param('twist_frame', 'body', "Frame of the 'twist' topic and of 'set_twist': 'body' (as "
          "in odom) or 'world'.", True, _frame),
    Param('command_timeout', 1.0, 'Sim-time seconds after the last wrench command at which '
          'the wrench is set to zero; 0 holds the last command forever.', False, _non_negative),
    Param('max_wrench', 1.0e6, 'Largest accepted force norm (N) and torque norm (N m); '
          'larger or non-finite commands are rejected.', False, _positive),
    Param('real_time_factor', 1.0, 'Sim time per wall time: 1.0 follows the wall clock, 2.0 '
          'runs twice as fast, 0 runs as fast as possible (follow /clock with use_sim_time).',
          False, _non_negative),
    Param('max_catchup', 10, 'Most publish periods stepped in one tick to catch up after a '
          'late tick; beyond that, real time is dropped (counted in diagnostics).', False,
          _positive),
    Param('start_paused', False, 'Start paused at step 0. While paused, inputs take effect '
          'as they arrive (at the step the next step call takes), so a script of inputs and '
          'step calls gives the same run every time.', True),
    Param('publish_clock', True, 'Publish /clock (rosgraph_msgs/Clock, best-effort) with sim '
          'time.', True),
    Param('scene_file', '', 'A YAML scene (several bodies, gravity, damping; see '
          'rb_sim_ros/scene.py). Empty: one body from the parameters above. Each scene body '
          'has its own topics <name>/wrench, <name>/pose, ...', True),
    Param('record', '', 'Path of an MCAP file to record the run to; empty: no recording.', True),
    Param('record_overwrite', False, 'Overwrite an existing recording file.', True),
)

BY_NAME = {p.name: p for p in PARAMS}


def help_text() -> str:
    lines = ['Parameters (set with --ros-args -p name:=value or --params-file FILE):', '']
    for p in PARAMS:
        ro = ' [read-only once running]' if p.read_only else ''
        lines.append(f'  {p.name} (default {p.default!r}){ro}')
        lines.append(f'      {p.description}')
    return '\n'.join(lines)


def check(name: str, value: Any) -> None:
    """Raise ValueError with the reason if ``value`` is not valid for parameter ``name``."""
    BY_NAME[name].check(name, value)
