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
import re
from typing import Any, Callable

from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import Frame
from rb_sim_ros.ros import output_kinds
from rb_sim_ros.sim.imu import ImuNoise, MAX_SIGMA


# The work of one publish period is bounded: at most this many physics steps. A period is
# stepped with the node's lock held (inputs take effect between periods, never inside one), so
# a pause, a service or a parameter change waits up to one period: 10^5 steps of one body are
# 0.1 to 0.5 s (10^6, dt 1e-9 at 1 kHz, made a pause wait 4 to 10 s). Longer periods: raise
# publish_rate or dt.
MAX_STEPS_PER_PERIOD = 100_000
# A real_time_factor below this would make one period last longer than 10^4 times its sim time.
MIN_REAL_TIME_FACTOR = 1e-4
MAX_CATCHUP = 10_000


def _number(name: str, v: Any) -> float:
    """A finite int or float (never a bool), as a float; ValueError naming ``name``."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f'{name} must be a number, got {type(v).__name__} {v!r}')
    try:
        f = float(v)
    except OverflowError:
        raise ValueError(f'{name} must be a finite number, got {v!r}') from None
    if not math.isfinite(f):
        raise ValueError(f'{name} must be a finite number, got {v!r}')
    return f


def _positive(name: str, v: Any) -> None:
    if _number(name, v) <= 0.0:
        raise ValueError(f'{name} must be a finite number > 0, got {v!r}')


def _within(low: float, high: float, text: str):
    """A check for a number from ``low`` to ``high``, ``text`` saying so in the refusal."""
    def check(name: str, v: Any) -> None:
        if not low <= _number(name, v) <= high:
            raise ValueError(f'{name} must be between {text}, got {v!r}')
    return check


def _integer(low: int, high: int):
    """A check for an int (not a bool) from ``low`` to ``high``."""
    def check(name: str, v: Any) -> None:
        if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
            raise ValueError(f'{name} must be an integer from {low} to {high}, got {v!r}')
    return check


def _real_time_factor(name: str, v: Any) -> None:
    f = _number(name, v)
    if f != 0.0 and not MIN_REAL_TIME_FACTOR <= f <= 1e9:
        raise ValueError(f'{name} must be 0 (as fast as possible) or between '
                         f'{MIN_REAL_TIME_FACTOR:g} and 1e9, got {v!r}')


def _bool(name: str, v: Any) -> None:
    if not isinstance(v, bool):
        raise ValueError(f'{name} must be true or false, got {v!r}')


def _string(name: str, v: Any) -> None:
    if not isinstance(v, str):
        raise ValueError(f'{name} must be a string, got {type(v).__name__} {v!r}')
    if '\0' in v or len(v) > 4096:
        raise ValueError(f'{name} must be a path or name of at most 4096 characters without '
                         f'NUL, got {v[:40]!r}...')


def _vector(*sizes: int):
    def check(name: str, v: Any) -> None:
        if isinstance(v, (str, bytes)) or not hasattr(v, '__len__') or len(v) not in sizes:
            want = ' or '.join(str(n) for n in sizes)
            raise ValueError(f'{name} must be a list of {want} numbers, got {v!r}')
        for c in v:
            _number(name, c)
    return check


def covariance36(v: Any) -> tuple[float, ...]:
    """The 36 row-major entries of a 6x6 covariance given as 6 variances (its diagonal) or all
    36 (symmetric, variances >= 0): the form of nav_msgs/Odometry's covariance fields."""
    values = [float(c) for c in v]
    if len(values) == 6:
        full = [0.0] * 36
        for k in range(6):
            full[7 * k] = values[k]
        return tuple(full)
    return tuple(values)


def _covariance(name: str, v: Any) -> None:
    _vector(6, 36)(name, v)
    full = covariance36(v)
    if any(full[7 * k] < 0.0 for k in range(6)):
        raise ValueError(f'{name}: variances (the diagonal) must be >= 0, got '
                         f'{[full[7 * k] for k in range(6)]}')
    if any(full[6 * i + j] != full[6 * j + i] for i in range(6) for j in range(i)):
        raise ValueError(f'{name}: a 6x6 covariance must be symmetric')


def _non_negative(name: str, v: Any) -> None:
    if _number(name, v) < 0.0:
        raise ValueError(f'{name} must be a finite number >= 0, got {v!r}')


def _sigma(name: str, v: Any) -> None:
    """An IMU standard deviation: from 0 to imu.MAX_SIGMA, so that its square stays finite."""
    if not 0.0 <= _number(name, v) <= MAX_SIGMA:
        raise ValueError(f'{name} must be a number from 0 to {MAX_SIGMA:g}, got {v!r}')


def _bias(name: str, v: Any) -> None:
    """An IMU's initial bias: 3 numbers, each within +-imu.MAX_SIGMA."""
    _vector(3)(name, v)
    if any(abs(float(c)) > MAX_SIGMA for c in v):
        raise ValueError(f'{name} must be 3 numbers from -{MAX_SIGMA:g} to {MAX_SIGMA:g}, got '
                         f'{v!r}')


def _prefix(name: str, v: Any) -> None:
    """'' or what makes a frame id of any body frame after it ('sim1/', 'sim1_')."""
    if not isinstance(v, str) or len(v) > 256 or (v and not _FRAME.fullmatch(v + 'x')):
        raise ValueError(f'{name} must be empty or a frame id prefix (at most 256 characters: '
                         'names of letters, digits and _, not starting with a digit, each '
                         f"followed by one / or by the body frame, e.g. 'sim1/'), got {v!r}")


def imu_noise(values: dict):
    """The sim.imu.ImuNoise of the node's parameters ``values``."""
    return ImuNoise(float(values['imu_gyro_noise']), float(values['imu_accel_noise']),
                    float(values['imu_gyro_bias_walk']), float(values['imu_accel_bias_walk']),
                    int(values['imu_seed']),
                    tuple(float(c) for c in values.get('imu_gyro_bias', (0.0,) * 3)),
                    tuple(float(c) for c in values.get('imu_accel_bias', (0.0,) * 3)))


def body_frame(values: dict, name: str, single: bool) -> str:
    """The frame id of body ``name`` under the parameters ``values``: frame_prefix +
    body_frame for the single body, frame_prefix + its name for a scene's. ValueError if it
    is world_frame (/tf would say world_frame -> world_frame)."""
    frame = values.get('frame_prefix', '') + (values['body_frame'] if single else name)
    if frame == values.get('world_frame'):
        raise ValueError(f"body '{name}': its frame '{frame}' is world_frame: rename the body "
                         'or change frame_prefix, body_frame or world_frame')
    return frame


def _orientation(name: str, v: Any) -> None:
    _vector(4)(name, v)
    if not any(v):
        raise ValueError(f'{name} must be a non-zero quaternion x, y, z, w, got {list(v)}')


def _frame(name: str, v: Any) -> None:
    if not isinstance(v, str):
        raise ValueError(f"{name} must be 'world' or 'body', got {v!r}")
    Frame.parse(v)


# A frame id as a ROS name relative to nothing (tf2 ids have no leading /): tokens of letters,
# digits and _, not starting with a digit, separated by single slashes.
_FRAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*(?:/[A-Za-z_][A-Za-z0-9_]*)*')


def _frame_id(name: str, v: Any) -> None:
    if not isinstance(v, str) or len(v) > 256 or not _FRAME.fullmatch(v):
        raise ValueError(f'{name} must be a frame id (at most 256 characters: names of '
                         'letters, digits and _, not starting with a digit, separated by '
                         f"single /, no leading or trailing /, e.g. 'base_link'), got {v!r}")


def _integrator(name: str, v: Any) -> None:
    if not isinstance(v, str) or (v and v not in multistep.METHODS):
        raise ValueError(f'{name} must be one of {sorted(multistep.METHODS)} or empty, '
                         f'got {v!r}')


def _one_of(choices: tuple):
    def check(name: str, v: Any) -> None:
        if v not in choices:
            raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}, "
                             f'got {v!r}')
    return check


def names_list(v: Any) -> list[str]:
    """The entries of a list of names given as a list of strings or one comma-separated
    string (empty entries dropped)."""
    items = v.split(',') if isinstance(v, str) else list(v)
    return [item.strip() for item in items if item.strip()]


def _names(name: str, v: Any) -> None:
    if not (isinstance(v, str) or (isinstance(v, (list, tuple)) and
                                   all(isinstance(c, str) for c in v))):
        raise ValueError(f'{name} must be a list of names or a comma-separated string, '
                         f'got {v!r}')
    if len(v) > 100_000 or any(len(c) > 1024 for c in names_list(v)):
        raise ValueError(f'{name}: too long')


def record_outputs(v: Any) -> list[str]:
    """The output kinds ``record_outputs`` names, in the order of output_kinds.NAMES."""
    named = set(names_list(v))
    return [kind for kind in output_kinds.NAMES if kind in named]


def _record_outputs(name: str, v: Any) -> None:
    _names(name, v)
    named = names_list(v)
    unknown = sorted(set(named) - set(output_kinds.NAMES))
    if unknown or not named or len(set(named)) != len(named):
        raise ValueError(f'{name} must name one or more of {", ".join(output_kinds.NAMES)}, '
                         f'each once, got {v!r}')


@dataclass(frozen=True)
class Param:
    name: str
    default: Any
    description: str
    read_only: bool = False
    check: Callable[[str, Any], None] | None = None  # every parameter has one (checked below)


PARAMS = (
    Param('dt', 0.001, 'Physics step (s), 1e-9 to 10. Simulated time is always step_count * dt.',
          True, _within(1e-9, 10.0, '1e-9 and 10 s')),
    Param('publish_rate', 100.0, 'Rate (Hz, sim time) of the published states (pose, twist, '
          'odom, imu, accel, /tf) and /clock. 1/(rate*dt) must be a whole number of physics '
          'steps.', True, _positive),
    Param('integrator', '',
          f'Integration method: one of {sorted(multistep.METHODS)}; empty: the scene '
          f"file's integrator, else {multistep.EQ27.name} (docs/integrators.md).", True,
          _integrator),
    Param('mass', 1.0, 'Body mass (kg).', True, _positive),
    Param('inertia', [0.1, 0.1, 0.1], 'Body-frame inertia about the centre of mass (kg m^2): '
          '3 principal moments, or 9 row-major components of a symmetric tensor.', True,
          _vector(3, 9)),
    Param('initial_position', [0.0, 0.0, 0.0], 'Initial position (m) in world_frame; also '
          'the reset pose.', False, _vector(3)),
    Param('initial_orientation', [0.0, 0.0, 0.0, 1.0],
          'Initial orientation quaternion x, y, z, w in world_frame.', False, _orientation),
    Param('initial_linear_velocity', [0.0, 0.0, 0.0], 'Initial velocity (m/s), world frame.',
          False, _vector(3)),
    Param('initial_angular_velocity', [0.0, 0.0, 0.0],
          'Initial angular velocity (rad/s), world frame.', False, _vector(3)),
    Param('world_frame', 'world', 'Fixed frame of pose and odom headers. Ground truth, and '
          'set_pose teleports: a world or map frame, not odom (REP-105 forbids jumps in '
          'odom).', True, _frame_id),
    Param('body_frame', 'base_link', 'Body frame (REP-105): odom child_frame_id.', True,
          _frame_id),
    Param('frame_prefix', '', 'Prepended to every body frame id the node uses (odom child, '
          '/tf child, imu header, wrench_stamped frame), so that several simulators share one '
          "graph and one world_frame (e.g. 'sim1/'). Empty: none.", True, _prefix),
    Param('publish_tf', True, 'Publish each moving body as world_frame -> body frame on /tf '
          'every publish period, and static bodies once on /tf_static (transient local), as '
          'tf2_ros broadcasters do.', True, _bool),
    Param('imu_gyro_noise', 0.0, "Gyroscope white noise of '<body>/imu': standard deviation "
          'per sample and axis (rad/s); its variance fills angular_velocity_covariance.', True,
          _sigma),
    Param('imu_accel_noise', 0.0, 'Accelerometer white noise: standard deviation per sample '
          'and axis (m/s^2); its variance fills linear_acceleration_covariance.', True,
          _sigma),
    Param('imu_gyro_bias_walk', 0.0, 'Gyroscope bias random walk per axis (rad/s/sqrt(s)); '
          'the bias starts at imu_gyro_bias.', True, _sigma),
    Param('imu_accel_bias_walk', 0.0, 'Accelerometer bias random walk per axis '
          '(m/s^2/sqrt(s)); the bias starts at imu_accel_bias.', True, _sigma),
    Param('imu_gyro_bias', [0.0, 0.0, 0.0], 'Gyroscope bias at the first sample, per body '
          'axis (rad/s): a turn-on bias, constant but for imu_gyro_bias_walk.', True,
          _bias),
    Param('imu_accel_bias', [0.0, 0.0, 0.0], 'Accelerometer bias at the first sample, per '
          'body axis (m/s^2), constant but for imu_accel_bias_walk.', True, _bias),
    Param('imu_seed', 0, 'Seed of the IMU noise (0 to 2^63 - 1); each body draws its own '
          'stream from it, so a run and its replay get the same noise.', True,
          _integer(0, 2 ** 63 - 1)),
    Param('odom_pose_covariance', [0.0] * 6, "Covariance of odom's pose: 6 variances "
          '(x, y, z in m^2; rotation about x, y, z in rad^2) or the 36 row-major entries. '
          'The simulator knows its pose exactly (0); set what the consumer of a real odometry '
          'source would get.', True, _covariance),
    Param('odom_twist_covariance', [0.0] * 6, "Covariance of odom's twist: 6 variances "
          '((m/s)^2, (rad/s)^2) or the 36 row-major entries.', True, _covariance),
    Param('wrench_frame', 'world', "Frame of wrenches on the 'wrench' topic: 'world' (fixed) "
          "or 'body' (turns with the body).", False, _frame),
    Param('twist_frame', 'body', "Frame of the 'twist' topic and of 'set_twist': 'body' (as "
          "in odom) or 'world'.", True, _frame),
    Param('command_timeout', 1.0, 'Sim-time seconds (0 to 1e9) after the last wrench command '
          'at which the wrench is set to zero; 0 holds the last command forever.', False,
          _within(0.0, 1e9, '0 and 1e9 s')),
    Param('max_wrench', 1.0e6, 'Largest accepted force norm (N) and torque norm (N m); '
          'larger or non-finite commands are rejected.', False, _positive),
    Param('real_time_factor', 1.0, 'Sim time per wall time: 1.0 follows the wall clock, 2.0 '
          'runs twice as fast, 0 runs as fast as possible (follow /clock with use_sim_time); '
          f'otherwise {MIN_REAL_TIME_FACTOR:g} to 1e9.', False, _real_time_factor),
    Param('max_catchup', 10, 'Most publish periods stepped in one tick to catch up after a '
          'late tick (1 to 10000); beyond that, real time is dropped (counted in diagnostics).',
          False, _integer(1, MAX_CATCHUP)),
    Param('start_paused', False, 'Start paused at step 0. While paused, inputs take effect '
          'as they arrive (at the step the next step call takes), so a script of inputs and '
          'step calls gives the same run every time.', True, _bool),
    Param('compile_in_background', True, 'When the compiled kernels are not in the cache yet '
          '(a first start from a source checkout; colcon build compiles them), step in the '
          'interpreter, bit for bit as compiled but about 100x slower, while a child process '
          'compiles them (a minute or two on 2 cores), then go on compiled: the first poses '
          'come at once. '
          'false: compile before the first step.', True, _bool),
    Param('publish_clock', True, 'Publish /clock (rosgraph_msgs/Clock, best-effort) with sim '
          'time.', True, _bool),
    Param('scene_file', '', 'A YAML scene (several bodies, gravity, damping; see '
          'rb_sim_ros/sim/scene.py), an MJCF model (a name ending in .xml or .mjcf: its free '
          'bodies) or a URDF (.urdf: its fixed-jointed links, one body; docs/scenes.md). '
          'Empty: one body from the parameters above. Each scene body has its own topics '
          '<name>/wrench, <name>/pose, ...', True, _string),
    Param('max_body_topics', 100, 'How many bodies of a scene (in file order) get their own '
          'topics <name>/wrench, <name>/pose, ... (0 to 100000). Each topic is a DDS endpoint, '
          'and endpoints cost time and memory to create: the rest are simulated, recorded '
          "only through their effect on the others, and published together on 'poses'.",
          True, _integer(0, 100_000)),
    Param('lockstep', False, 'Lockstep with controllers: after each publish the node waits '
          'until every lockstep input has answered the state with a WrenchStamped stamped as '
          "that state (frame_id 'hold': no change), applies the answers at the next step and "
          'only then steps on, so a closed-loop run is the same on any machine, under any '
          'load, at any real_time_factor (docs/recording.md, "Lockstep").', True, _bool),
    Param('lockstep_inputs', '', 'The lockstep inputs: bodies or their wrench_stamped topics, '
          "as a list or comma-separated ('ball, box/wrench_stamped'); step 0 waits for every "
          "one. Empty: every body's wrench_stamped that has a publisher when step 0 is taken "
          '(then a controller that joins later is in from its first answer).', True,
          _names),
    Param('lockstep_delay', 0, 'Periods (0 to 1000) between a state and the step its answers '
          'take effect at, after the first step after it: a controller latency, '
          'deterministic.', True, _integer(0, 1000)),
    Param('lockstep_timeout', 0.0, 'Wall seconds (0 to 1e6) to wait for the answers to a '
          'state; 0 waits for ever. Then lockstep_on_timeout says what happens, and the '
          'recording notes it.', False, _within(0.0, 1e6, '0 and 1e6 s')),
    Param('lockstep_on_timeout', 'error', "After lockstep_timeout: 'error' pauses the node "
          'with an ERROR in /diagnostics (and ends a run with stop_after, exit code 3); '
          "'hold' steps on with the wrenches of the inputs that did not answer held.",
          False, _one_of(('error', 'hold'))),
    Param('stop_after', 0.0, 'Sim seconds (0 to 1e9) after which the node stops by itself: '
          'it steps to that time, publishes, finishes the recording and exits 0 (a run for '
          'CI). 0: never.', True, _within(0.0, 1e9, '0 and 1e9 s')),
    Param('record', '', 'Path of an MCAP file to record the run to; empty: no recording.', True,
          _string),
    Param('record_overwrite', False, 'Overwrite an existing recording file.', True, _bool),
    Param('record_outputs', list(output_kinds.NAMES), 'The outputs of each body a recording '
          f"holds: any of {', '.join(output_kinds.NAMES)}, as a list or comma-separated. "
          'Fewer make a smaller recording, written faster (a campaign records odom); replay '
          'regenerates every output and compares those recorded. Published: all of them, '
          'whatever this is.', True, _record_outputs),
)

BY_NAME = {p.name: p for p in PARAMS}
_unchecked = [p.name for p in PARAMS if p.check is None]
if _unchecked:  # pragma: no cover - a programming error, caught by importing the module
    raise RuntimeError(f'parameters without a check: {_unchecked}')


def help_text() -> str:
    lines = ['Parameters (set with --ros-args -p name:=value or --params-file FILE):', '']
    for p in PARAMS:
        ro = ' [read-only once running]' if p.read_only else ''
        lines.append(f'  {p.name} (default {p.default!r}){ro}')
        lines.append(f'      {p.description}')
    return '\n'.join(lines)


def check(name: str, value: Any) -> None:
    """Raise ValueError with the reason, naming the parameter, if ``value`` is not valid for
    parameter ``name``."""
    try:
        BY_NAME[name].check(name, value)
    except ValueError as e:
        if not str(e).startswith(name):
            raise ValueError(f'{name}: {e}') from None
        raise
