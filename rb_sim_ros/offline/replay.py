# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""replay: verify, recover or republish a recording of the simulator.

    replay --verify run.mcap          re-simulate offline, compare, exit 1 on any difference
    replay --recover run.mcap out.mcap  finalise a killed recording (rosbags/ros2 bag open it)
    replay run.mcap [--rate 2]        republish pose/twist/odom with /clock, in sim-time order
    replay --plot run.mcap [--out plots/] [--bodies a,b]   PNGs: states, energy, wrench, events
    replay --render run.mcap out.gif|out.mp4 [--view iso|top|side] [--follow body] [--fps 25]

--verify needs no ROS graph: it rebuilds the run from the recording's definition (body, dt,
integrator, initial state) and its inputs at the steps they took effect, fills the output
messages as the node does, and compares them with the recorded ones, field by field and bit
by bit, as it reads them (memory does not grow with the length). Expected: identical. The
definition is the file's 'rb_sim_ros' metadata record, or, in a bag converted by tools that
drop metadata (rosbags-convert, ros2 bag convert), the same on /rb_sim/run_definition.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
import itertools
import json
import math
import re
import struct
import sys
import time

from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.offline.progress import Progress
from rb_sim_ros.pictures import plots, render
from rb_sim_ros.recording import (message_class, ReaderError, RecordingReader, recover,
                                  WriterError)
from rb_sim_ros.recording.errors import interrupt_in
from rb_sim_ros.recording.qos import POLICIES
from rb_sim_ros.recording.schemas import type_name_of
from rb_sim_ros.ros import node_params, node_recorder, output_kinds, ros_arguments
from rb_sim_ros.ros.ros_messages import (fill_tf, OutputMessages, TF, tf_message, tf_qos,
                                         TF_STATIC, time_msg)
from rb_sim_ros.sim.imu import ImuSensor
from rb_sim_ros.sim.simulation import Config, Delete, Simulation, Spawn

QUANTITIES = ('position', 'orientation', 'linear_velocity', 'angular_velocity',
              'linear_acceleration', 'angular_acceleration')
# Everything in a file is untrusted; these bound the work a file can ask for.
MAX_JSON_DEPTH = 16  # the metadata nests 5 deep (config, bodies, a body, colliders, a collider)
MAX_STEPS_PER_OUTPUT = 1_000_000  # physics steps between two published states (as the node)
MAX_REBUILT_BODIES = 5_000_000  # bodies of all the worlds spawns and deletes build (~6 min)
GAP_ALLOWANCE = 2  # a damaged chunk may hide outputs: allow twice the steps the outputs imply
MIN_RATE, MAX_RATE = 1e-6, 1e9  # --rate: sim time per wall time (0: as fast as possible)
MAX_WAIT_S = 1e6
# A publish the DDS history has no room for (keep_all: the subscribers have not taken what was
# sent) is tried again until it goes out, for at most this long without progress.
MAX_BLOCKED_S = 60.0
# A full topic name as rmw_validate_full_topic_name accepts it: absolute, tokens of letters,
# digits and '_' not starting with a digit, no empty token or trailing '/', at most 247 chars.
TOPIC_NAME = re.compile(r'(?:/[A-Za-z_][A-Za-z0-9_]*)+')
MAX_TOPIC_NAME = 247  # RMW_TOPIC_MAX_NAME_LENGTH
MAX_QOS_TEXT = 100_000  # offered_qos_profiles of one channel (a profile is ~400 characters)
MAX_DEFINITION_TEXT = 1 << 26  # the run definition message (a config of 5000 bodies: ~5 MB)
RUN_DEFINITION = node_recorder.RUN_DEFINITION
DEFAULT_DEPTH = 10  # the QoS of a republished topic whose recording keeps none (as before)
INPUT_TYPES = {kind: type_name_of(cls) for kind, cls in node_recorder.INPUTS.items()}
OUTPUT_TYPES = {kind: type_name_of(cls) for kind, cls in node_recorder.OUTPUTS.items()}
# Parameters replay itself uses, with their defaults (a recording holds all of them).
IMU_DEFAULTS = {'imu_gyro_noise': 0.0, 'imu_accel_noise': 0.0, 'imu_gyro_bias_walk': 0.0,
                'imu_accel_bias_walk': 0.0, 'imu_seed': 0, 'imu_gyro_bias': [0.0] * 3,
                'imu_accel_bias': [0.0] * 3}
FRAME_PARAMS = {'world_frame': 'odom', 'body_frame': 'base_link', 'twist_frame': 'body'}


@dataclass
class Verification:
    """Largest difference per quantity over all recorded outputs, and what was compared.

    Identical only if every recorded output message was compared (``outputs == recorded``),
    none differs and none holds a non-finite value."""

    outputs: int = 0  # output messages compared
    recorded: int = 0  # output messages in the file
    inputs: int = 0
    mismatched_messages: int = 0
    non_finite: int = 0  # recorded output messages with a nan or inf
    max_difference: dict = field(default_factory=lambda: dict.fromkeys(QUANTITIES, 0.0))
    per_topic: dict = field(default_factory=dict)  # topic -> [compared, recorded]
    first_mismatch: str = ''
    truncated: bool = False
    last_time_ns: int = 0
    integration_error: str = ''  # the run went non-finite (the node paused there too)
    lockstep_notes: list = field(default_factory=list)  # (step, JSON): timeouts, inputs gone

    @property
    def identical(self) -> bool:
        return (self.outputs > 0 and self.outputs == self.recorded
                and self.mismatched_messages == 0 and self.non_finite == 0)


@dataclass
class Recording:
    """A recording read back and checked: what re-simulates it and what it recorded."""

    config: Config
    parameters: dict
    inputs: list  # (step, event, topic), sorted by step
    outputs: 'Outputs'  # (step, body, kind, topic, msg, log_time_ns), in step order, read
    # from the file each time it is iterated; /tf and /tf_static with body '' and kind 'tf'
    # or 'tf_static'
    truncated: bool
    path: str = ''
    recorded_per_topic: dict = field(default_factory=dict)  # output topic -> messages in file
    qos: dict = field(default_factory=dict)  # output topic -> recorded_qos(...) of its channel
    types: dict = field(default_factory=dict)  # output topic -> 'pkg/msg/Type'
    last_output_ns: int = 0  # log time of the last recorded output
    lockstep_notes: list = field(default_factory=list)  # (step, JSON) of /rb_sim/lockstep

    def frames(self, body: str, spawned: bool = False) -> tuple[str, str]:
        """(world frame, body frame) the node stamped ``body``'s outputs with (a spawned body
        is named as a scene's, even beside the single body)."""
        p = {**FRAME_PARAMS, **self.parameters}
        return p['world_frame'], node_params.body_frame(
            p, body, not p.get('scene_file') and not spawned)

    def tf_bodies(self, kind: str) -> list[str]:
        """The bodies of a /tf ('tf': the moving ones with topics) or /tf_static message
        ('tf_static': the static ones with topics), in the node's order."""
        limit = self.parameters.get('max_body_topics', len(self.config.bodies))
        if not self.parameters.get('scene_file'):
            limit = 1
        return [b.name for b in self.config.bodies[:limit] if b.static == (kind == 'tf_static')]


class Outputs:
    """The recorded outputs of a checked recording, read and deserialised from the file each
    time they are iterated (never all held): (step, body, kind, topic, msg, log_time_ns) in
    step order. ``len`` is how many the file holds."""

    def __init__(self, reader: RecordingReader, by_topic: dict, dt_ns: float,
                 count: int) -> None:
        self._reader, self._by_topic, self._dt_ns, self._count = reader, by_topic, dt_ns, count
        self._topics = sorted(t for t in by_topic if t in reader.topics)

    def __len__(self) -> int:
        return self._count

    def __iter__(self):
        if not self._topics:
            return
        by_topic, dt_ns, n = self._by_topic, self._dt_ns, 0
        for topic, msg, log_time, _publish_time, _sequence in self._reader.messages(
                self._topics):
            n += 1
            if n > self._count:
                break
            yield (round(log_time / dt_ns), *by_topic[topic], topic, msg, log_time)
        if n != self._count:
            raise ReaderError(f'{self._reader.path}: changed while being read ({n} output '
                              f'messages, {self._count} when it was checked)')


METADATA_LABEL = f'bad {node_recorder.METADATA!r} metadata'
DEFINITION_LABEL = f'bad run definition on {RUN_DEFINITION}'


def _bad(path: str, what: str) -> ReaderError:
    # one line, whatever the recording's keys hold (a newline is shown as \n)
    line = f'{path}: {METADATA_LABEL}: {what}'
    return ReaderError(''.join(c if c.isprintable() else repr(c)[1:-1] for c in line))


def json_depth(text: str) -> int:
    """How deep arrays and objects nest in JSON ``text`` (brackets inside strings ignored)."""
    depth = deepest = 0
    for bracket in re.findall(r'[\[\]{}]', re.sub(r'"(?:[^"\\]|\\.)*"', '', text)):
        depth += 1 if bracket in '[{' else -1
        deepest = max(deepest, depth)
    return deepest


def _json(meta: dict, key: str, path: str):
    text = meta.get(key)
    if not isinstance(text, str):
        raise _bad(path, f'no {key!r}')
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise _bad(path, f'{key} nests {depth} levels deep (at most {MAX_JSON_DEPTH})')
    try:
        value = json.loads(text)
    except ValueError as e:
        raise _bad(path, f'{key} is not JSON: {e}') from None
    _check_plain(value, key, path)
    return value


def _check_plain(value, where: str, path: str) -> None:
    """JSON values only, every number finite and within float range."""
    if isinstance(value, dict):
        for k, v in value.items():
            _check_plain(v, f'{where}.{k}', path)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_plain(v, f'{where}[{i}]', path)
    elif isinstance(value, float) and not math.isfinite(value):
        raise _bad(path, f'{where} is {value!r}, not a finite number')
    elif isinstance(value, int) and not isinstance(value, bool) and abs(value) > 2 ** 63:
        raise _bad(path, f'{where} is an integer beyond 2**63')


def _is_number(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _mapping(value, where: str, path: str) -> dict:
    if not isinstance(value, dict):
        raise _bad(path, f'{where} must be a mapping, got {type(value).__name__}')
    return value


def _list_of_mappings(value, where: str, path: str) -> list:
    if not isinstance(value, list):
        raise _bad(path, f'{where} must be a list, got {type(value).__name__}')
    for i, item in enumerate(value):
        _mapping(item, f'{where}[{i}]', path)
    return value


def _flat(value, where: str, path: str) -> None:
    """A scalar or a list of scalars: what a parameter or a body field is."""
    items = value if isinstance(value, list) else [value]
    for item in items:
        if isinstance(item, (dict, list)):
            raise _bad(path, f'{where} must be a value or a list of values, not nested')


def _config(data, path: str) -> Config:
    _mapping(data, 'config', path)
    for key, value in data.items():
        if key == 'bodies':
            for i, body in enumerate(_list_of_mappings(value, 'config.bodies', path)):
                for k, v in body.items():
                    if k == 'colliders':
                        for j, c in enumerate(_list_of_mappings(
                                v, f'config.bodies[{i}].colliders', path)):
                            for ck, cv in c.items():
                                where = f'config.bodies[{i}].colliders[{j}].{ck}'
                                if ck == 'points' and isinstance(cv, list):  # a hull's
                                    for m, point in enumerate(cv):
                                        _flat(point, f'{where}[{m}]', path)
                                else:
                                    _flat(cv, where, path)
                    elif k == 'points':  # [[name, [x, y, z]], ...]
                        where = f'config.bodies[{i}].points'
                        if not isinstance(v, list):
                            raise _bad(path, f'{where} must be a list, got {type(v).__name__}')
                        for j, pair in enumerate(v):
                            if not (isinstance(pair, list) and len(pair) == 2
                                    and isinstance(pair[0], str)):
                                raise _bad(path, f'{where}[{j}] must be [name, [x, y, z]]')
                            _flat(pair[1], f'{where}[{j}]', path)
                    else:
                        _flat(v, f'config.bodies[{i}].{k}', path)
        elif key == 'contact':
            for k, v in _mapping(value, 'config.contact', path).items():
                _flat(v, f'config.contact.{k}', path)
        else:
            _flat(value, f'config.{key}', path)
    try:
        config = Config.from_dict(data)
    except (ValueError, TypeError) as e:  # the scene's validators: wrong values and types
        raise _bad(path, f'config: {e}') from None
    if config.steps_per_publish > MAX_STEPS_PER_OUTPUT:
        raise _bad(path, f'config: steps_per_publish {config.steps_per_publish} is more than '
                   f'{MAX_STEPS_PER_OUTPUT} physics steps per output')
    return config


def _parameters(data, config: Config, path: str) -> dict:
    _mapping(data, 'parameters', path)
    for name, value in data.items():
        _flat(value, f'parameters.{name}', path)
        if name in node_params.BY_NAME:
            try:
                node_params.check(name, value)
            except (ValueError, TypeError) as e:
                raise _bad(path, f'parameters: {e}') from None
    for name in FRAME_PARAMS:  # also checked above, if the node's checks know them
        value = data.get(name, FRAME_PARAMS[name])
        if not isinstance(value, str) or not value:
            raise _bad(path, f'parameters: {name} must be a non-empty string, got {value!r}')
    try:
        OutputMessages(data.get('world_frame', 'odom'), data.get('body_frame', 'base_link'),
                       data.get('twist_frame', 'body'))
    except ValueError as e:
        raise _bad(path, f'parameters: twist_frame: {e}') from None
    if not isinstance(data.get('scene_file', ''), str):
        raise _bad(path, f'parameters: scene_file must be a string, got '
                   f'{data["scene_file"]!r}')
    dt, rate = data.get('dt'), data.get('publish_rate')
    if dt is not None and not (_is_number(dt) and float(dt) == config.dt):
        raise _bad(path, f'parameters: dt {dt!r} is not dt {config.dt!r} of the config')
    if dt is not None and rate is not None:
        product = rate * dt if _is_number(rate) else 0.0
        steps = 1.0 / product if product > 0 else math.inf
        if not math.isfinite(steps) or round(steps) != config.steps_per_publish:
            raise _bad(path, f'parameters: publish_rate {data["publish_rate"]!r} Hz and dt '
                       f'{data["dt"]!r} s do not give steps_per_publish of the config '
                       f'{config.steps_per_publish}')
    return data


def _kinds_problem(topics: dict, parameters: dict) -> str:
    """What is wrong with the output kinds recorded of a body, or '': only those
    record_outputs names (all, in a recording from before it), and of them every required
    one (the others came later)."""
    kinds = sorted(topics)
    if not set(kinds) <= set(OUTPUT_TYPES):
        return f'has {kinds[:10]}: outputs are only {sorted(OUTPUT_TYPES)}'
    named = node_params.record_outputs(parameters.get('record_outputs', OUTPUT_TYPES))
    if not set(kinds) <= set(named):
        return f'has {kinds}, but record_outputs names only {named}'
    needed = [kind for kind in node_recorder.REQUIRED_OUTPUTS if kind in named]
    if not set(needed) <= set(kinds):
        return f'has {kinds}: it needs {needed}'
    return ''


def _output_topics(data, config: Config, parameters: dict, path: str) -> dict:
    _mapping(data, 'output_topics', path)
    # The node gives own topics (and so recorded outputs) to the first max_body_topics bodies
    # of a scene; recordings made before that parameter existed have all of them.
    limit = parameters.get('max_body_topics', len(config.bodies))
    moving = [b.name for b in config.bodies[:limit] if not b.static]
    if sorted(data) != sorted(moving):
        raise _bad(path, f'output_topics are for bodies {sorted(data)}, but the moving bodies '
                   f'of the config are {sorted(moving)}')
    seen = set()
    for body, topics in data.items():
        _mapping(topics, f'output_topics.{body}', path)
        problem = _kinds_problem(topics, parameters)
        if problem:
            raise _bad(path, f'output_topics.{body} {problem}')
        for kind, topic in topics.items():
            if (not isinstance(topic, str) or not topic.startswith('/') or len(topic) < 2
                    or topic.startswith(node_recorder.INPUT_PREFIX) or topic in seen
                    or topic == RUN_DEFINITION):
                raise _bad(path, f'output_topics.{body}.{kind} {topic!r} is not a topic name '
                           'of its own (absolute, not an input or the run definition, not '
                           'used twice)')
            problem = topic_name_problem(topic)
            if problem:
                raise _bad(path, f'output_topics.{body}.{kind} {topic[:300]!r} {problem}')
            seen.add(topic)
    return data


def topic_name_problem(topic: str) -> str:
    """Why ``topic`` is not a valid full ROS topic name (rclpy would refuse to publish on it),
    or ''."""
    if len(topic) > MAX_TOPIC_NAME:
        return f'is not a valid ROS topic name (longer than {MAX_TOPIC_NAME} characters)'
    if not TOPIC_NAME.fullmatch(topic):
        return ('is not a valid ROS topic name (absolute; letters, digits and _ between single '
                "'/'; no part starting with a digit)")
    return ''


def recorded_qos(text: str) -> dict | None:
    """The QoS to republish a topic with, from its channel's ``offered_qos_profiles`` (YAML, as
    rosbag2 and qos.py write it), as ``ros2 bag play`` adapts the recorded offers: reliable
    if every offer is, transient local if every offer is, the longest history offered.
    Returns {history, depth, reliability, durability} (qos.py's names), or None if the text
    holds no profile, or one this cannot read (the file is untrusted: no YAML parser)."""
    if not text or len(text) > MAX_QOS_TEXT:
        return None
    profiles = []
    for item in re.split(r'^- ', text, flags=re.MULTILINE)[1:]:
        found = re.findall(r'^ *(history|depth|reliability|durability): *(\w+) *$', item,
                           re.MULTILINE)
        p = dict(found)
        if len(found) != 4 or len(p) != 4 or not re.fullmatch(r'[0-9]{1,10}', p['depth']) or any(
                p[name] not in allowed for name, allowed in POLICIES.items() if name in p):
            return None
        profiles.append(p)
    if not profiles:
        return None
    keep_all = any(p['history'] == 'keep_all' for p in profiles)
    depth = max(int(p['depth']) for p in profiles)
    if not keep_all and not 1 <= depth < 2 ** 31:
        return None
    return {'history': 'keep_all' if keep_all else 'keep_last',
            'depth': min(depth, 2 ** 31 - 1),
            'reliability': ('reliable' if all(p['reliability'] == 'reliable' for p in profiles)
                            else 'best_effort'),
            'durability': ('transient_local' if all(p['durability'] == 'transient_local'
                                                    for p in profiles) else 'volatile')}


def _tf_topics(meta: dict, path: str) -> list:
    """The tf topics a recording holds (none before they existed)."""
    if 'tf_topics' not in meta:
        return []
    data = _json(meta, 'tf_topics', path)
    if not isinstance(data, list) or not all(isinstance(t, str) for t in data) or \
            not set(data) <= {TF, TF_STATIC} or len(set(data)) != len(data):
        raise _bad(path, f'tf_topics must list {TF!r} and/or {TF_STATIC!r}, got {data!r}')
    return data


def _spawned_topics(body: str, topics: dict, by_topic: dict, types: dict,
                    parameters: dict) -> None:
    """Add the output topics of a body spawned in the run; ValueError if they are not its
    own (a body spawned again after a delete has the same ones)."""
    problem = _kinds_problem(topics, parameters) if topics else ''
    if problem:
        raise ValueError(f'output_topics {problem}')
    for kind, topic in topics.items():
        if (not topic.startswith('/') or len(topic) < 2
                or topic.startswith(node_recorder.INPUT_PREFIX) or topic == RUN_DEFINITION
                or by_topic.get(topic, (body, kind)) != (body, kind)):
            raise ValueError(f'output topic {topic[:100]!r} is not one of its own (absolute, '
                             'not an input or the run definition, not another output)')
        problem = topic_name_problem(topic)
        if problem:
            raise ValueError(f'output topic {topic[:300]!r} {problem}')
        by_topic[topic] = (body, kind)
        types[topic] = OUTPUT_TYPES[kind]


def _definition_message(reader: RecordingReader, path: str) -> dict | None:
    """The run definition recorded as a message (a JSON object of strings, as the metadata
    record), or None if the file has none; ReaderError if it is not one message at the first
    time stamp of the file, or not such an object."""
    info = reader.topics.get(RUN_DEFINITION)
    if info is None or info.message_count == 0:
        return None
    if info.type_name != node_recorder.RUN_DEFINITION_TYPE:
        raise ReaderError(f'{path}: topic {RUN_DEFINITION} has type {info.type_name}, not '
                          f'{node_recorder.RUN_DEFINITION_TYPE}')
    if info.message_count != 1:
        raise ReaderError(f'{path}: {RUN_DEFINITION} holds {info.message_count} messages; a '
                          'recording has one, at its first time stamp')
    _topic, msg, log_time, _publish_time, _sequence = next(reader.messages(RUN_DEFINITION))
    if log_time != reader.start_time_ns:
        raise ReaderError(f'{path}: the run definition on {RUN_DEFINITION} is at {log_time} '
                          f'ns, not at the first time stamp of the file '
                          f'({reader.start_time_ns} ns)')
    text = msg.data
    if len(text) > MAX_DEFINITION_TEXT:
        raise ReaderError(f'{path}: {DEFINITION_LABEL}: longer than {MAX_DEFINITION_TEXT} '
                          'characters')
    what = 'must be a JSON object of strings (as the metadata record)'
    if json_depth(text) != 1:
        raise ReaderError(f'{path}: {DEFINITION_LABEL}: {what}')
    try:
        data = json.loads(text)
    except ValueError as e:
        raise ReaderError(f'{path}: {DEFINITION_LABEL}: not JSON: {e}') from None
    if not isinstance(data, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in data.items()):
        raise ReaderError(f'{path}: {DEFINITION_LABEL}: {what}')
    return data


def _run_definition(reader: RecordingReader, path: str) -> tuple[dict, bool]:
    """(the run's definition, whether it is the message): the metadata record, else the
    message; ReaderError if there is neither, or both and they differ."""
    meta = reader.metadata.get(node_recorder.METADATA)
    message = _definition_message(reader, path)
    if meta is None and message is None:
        raise ReaderError(f'{path}: no {node_recorder.METADATA!r} metadata and no '
                          f'{RUN_DEFINITION} message: not a recording of the rb_sim_ros '
                          'simulator')
    if meta is not None and message is not None and meta != message:
        keys = sorted(k for k in set(meta) | set(message) if meta.get(k) != message.get(k))
        raise ReaderError(f'{path}: the run definition on {RUN_DEFINITION} and the '
                          f'{node_recorder.METADATA!r} metadata differ (in '
                          f'{", ".join(k[:40] for k in keys[:5])}): refusing to choose')
    if meta is not None:
        return meta, False
    assert message is not None  # (neither: refused above)
    return message, True


def load(path: str) -> Recording:
    """Read a recording of the simulator and check all of it; ReaderError (one line: the file
    and what is wrong) if it is not a recording this replay can re-simulate.

    Reads the file once to check it, keeping the inputs and counting the outputs; the
    outputs (``Recording.outputs``) are read and deserialised each time they are iterated
    (bytes that do not deserialise: ReaderError then)."""
    reader = RecordingReader(path)
    meta, from_message = _run_definition(reader, path)
    try:
        if meta.get('format') != str(node_recorder.FORMAT):
            raise _bad(path, f'format {meta.get("format")!r}; this replay reads format '
                       f'{node_recorder.FORMAT!r} only')
        config = _config(_json(meta, 'config', path), path)
        parameters = _parameters(_json(meta, 'parameters', path), config, path)
        output_topics = _output_topics(_json(meta, 'output_topics', path), config,
                                       parameters, path)
        tf_topics = _tf_topics(meta, path)
    except ReaderError as e:
        if from_message:  # say where the bad definition is
            raise ReaderError(str(e).replace(METADATA_LABEL, DEFINITION_LABEL, 1)) from None
        raise
    by_topic = {topic: (body, kind) for body, topics in output_topics.items()
                for kind, topic in topics.items()}
    types = {topic: OUTPUT_TYPES[kind] for topic, (_, kind) in by_topic.items()}
    for topic in tf_topics:
        if topic in by_topic:
            raise _bad(path, f'{topic} is both a body output and a tf topic')
        by_topic[topic] = ('', 'tf' if topic == TF else 'tf_static')
        types[topic] = node_recorder.TF_TYPE
    later = {}  # channels of bodies spawned in the run: known once their spawn is read
    for topic, type_name in reader.channels.items():
        parsed = node_recorder.parse_input_topic(topic)
        if topic == RUN_DEFINITION:
            continue  # its type: checked with it
        if topic == node_recorder.LOCKSTEP:  # notes of a lockstep run (no input)
            if type_name != 'std_msgs/msg/String':
                raise ReaderError(f'{path}: topic {topic} has type {type_name}, not '
                                  'std_msgs/msg/String')
            continue
        if parsed is not None:
            want = INPUT_TYPES[parsed[1]]
        elif topic in by_topic:
            want = types[topic]
        else:
            later[topic] = type_name
            continue
        if type_name != want:
            raise ReaderError(f'{path}: topic {topic} has type {type_name}, not {want}')
    inputs = []
    dt_ns = config.dt * 1e9
    read = dict.fromkeys(reader.channels, 0)
    # Sequence numbers hold step mod 2^32, or are all 0: bag tools (rosbag2's SQLite3 storage)
    # keep none. The first message that has one, and the first without one.
    sequenced = unsequenced = None
    outputs, published, last_output_ns = 0, 0, 0
    last_step: int | None = None
    lockstep_notes: list = []  # (step, JSON text) of /rb_sim/lockstep
    # Outputs are checked here as bytes (their time stamps, counts and channels) and
    # deserialised when iterated; inputs are deserialised and kept.
    for raw in reader.raw_messages():
        topic, log_time, sequence = raw.topic, raw.log_time_ns, raw.sequence
        read[topic] += 1
        steps = log_time / dt_ns  # log time is step * dt; sequence holds step mod 2^32
        if not steps < 2 ** 62:
            raise ReaderError(f'{path}: {topic} at {log_time} ns is step {steps:.3g} of dt = '
                              f'{config.dt!r} s: too many steps to re-simulate')
        step = round(steps)
        if step % 2 ** 32 != sequence:
            if sequence != 0:
                raise ReaderError(f'{path}: {topic} at {log_time} ns has sequence {sequence}, '
                                  f'not its step {step}')
            unsequenced = unsequenced or (topic, log_time, step)
        elif sequence:
            sequenced = True
        if sequenced and unsequenced:
            topic0, log_time0, step0 = unsequenced
            raise ReaderError(f'{path}: {topic0} at {log_time0} ns has sequence 0, not its '
                              f'step {step0}')
        if topic == RUN_DEFINITION:
            continue
        if topic == node_recorder.LOCKSTEP:
            lockstep_notes.append((step, reader.deserialize(raw).message.data))
            continue
        parsed = node_recorder.parse_input_topic(topic)
        if parsed is None:  # an output: checked and counted now, read again when iterated
            outputs += 1
            if step != last_step:
                published += 1
                last_step = step
            last_output_ns = log_time
            continue
        msg = reader.deserialize(raw).message
        try:
            if parsed[1] == 'spawn':
                event, topics = node_recorder.spawn_from_message(parsed[0], msg)
                _spawned_topics(parsed[0], topics, by_topic, types, parameters)
            else:
                event = node_recorder.event_from_message(*parsed, msg)
        except ValueError as e:
            raise ReaderError(f'{path}: the input on {topic} at step {step} is invalid: '
                              f'{e}') from None
        inputs.append((step, event, topic))
    for topic, type_name in later.items():
        if topic not in by_topic:
            raise ReaderError(f'{path}: topic {topic} is neither an output named in the '
                              'metadata or a spawn nor an input')
        if type_name != types[topic]:
            raise ReaderError(f'{path}: topic {topic} has type {type_name}, not '
                              f'{types[topic]}')
    for topic, n in read.items():
        if n != reader.topics[topic].message_count:
            raise ReaderError(f'{path}: {topic} holds {n} messages, but the file says '
                              f'{reader.topics[topic].message_count}')
    inputs.sort(key=lambda e: e[0])
    # Each spawn or delete rebuilds the world around all its bodies: bound the work a file
    # can ask for that way (as the steps are bounded below).
    bodies, rebuilt, changes = len(config.bodies), 0, 0
    for _, event, _ in inputs:
        if isinstance(event, (Spawn, Delete)):
            bodies += 1 if isinstance(event, Spawn) else -1
            rebuilt += max(bodies, 1)
            changes += 1
    if rebuilt > MAX_REBUILT_BODIES:
        raise ReaderError(f'{path}: its {changes} spawns and deletes rebuild the world over '
                          f'{rebuilt} bodies in all, more than {MAX_REBUILT_BODIES}: refusing '
                          'to re-simulate that')
    if outputs:
        implied = GAP_ALLOWANCE * config.steps_per_publish * published
        if last_step is not None and last_step > implied:
            raise ReaderError(
                f'{path}: its last output is at step {last_step} of dt = {config.dt!r} s, '
                f'but {published} outputs every {config.steps_per_publish} steps imply at most '
                f'{implied}: log times and metadata disagree; refusing to simulate that long')
    recorded = {t: read.get(t, 0) for t in by_topic}
    qos = {t: recorded_qos(reader.topics[t].offered_qos_profiles)
           for t in by_topic if t in reader.topics}
    return Recording(config, parameters, inputs, Outputs(reader, by_topic, dt_ns, outputs),
                     reader.truncated, path, recorded, qos, types, last_output_ns,
                     lockstep_notes)


def _vectors(kind: str, msg):
    """The quantities an output message carries, as tuples of floats (``output_kinds``;
    /tf and /tf_static: every transform's)."""
    if kind in ('tf', 'tf_static'):
        ts = [t.transform for t in msg.transforms]
        return {'position': sum((output_kinds.xyz(t.translation) for t in ts), ()),
                'orientation': sum((output_kinds.xyzw(t.rotation) for t in ts), ())}
    return output_kinds.BY_NAME[kind].quantities(msg)


def identical(kind: str, a, b) -> bool:
    """Every field equal, and every float the same bits (so 0.0 and -0.0 differ).

    Not the serialised bytes: rclpy's CDR leaves alignment padding uninitialised, so two
    serialisations of one message can differ there (seen here)."""
    if a != b:
        return False
    va, vb = _vectors(kind, a), _vectors(kind, b)
    return all(struct.pack(f'<{len(va[q])}d', *va[q]) == struct.pack(f'<{len(vb[q])}d', *vb[q])
               for q in va)


def _finite_message(kind: str, msg) -> bool:
    return all(math.isfinite(c) for v in _vectors(kind, msg).values() for c in v)


def resimulate(rec: Recording, errors: list | None = None):
    """Re-run a recording: yields (step, kind, topic, recorded message, re-simulated message,
    log time) for every recorded output, in step order.

    As in the node, a run that goes non-finite stays at its last finite state while the step
    count goes on (the node pauses there and publishes that state); the first error's text is
    appended to ``errors``. ReaderError if an input cannot be applied (a file that was not
    recorded from a run). Reads the outputs as it goes (``rec.outputs``): what it holds does
    not grow with the length of the run."""
    try:
        sim = Simulation(rec.config)
    except ValueError as e:
        raise _bad(rec.path, f'config: {e}') from None
    twist_frame = rec.parameters.get('twist_frame', 'body')
    covariances = [node_params.covariance36(rec.parameters.get(name, [0.0] * 6))
                   for name in ('odom_pose_covariance', 'odom_twist_covariance')]
    try:
        noise = node_params.imu_noise({**IMU_DEFAULTS, **rec.parameters})
    except (ValueError, TypeError) as e:
        raise _bad(rec.path, f'parameters: {e}') from None

    def outputs_of(name, spawned=False):
        return OutputMessages(*rec.frames(name, spawned), twist_frame, *covariances, noise)
    outs = {b.name: outputs_of(b.name) for b in rec.config.bodies}
    sensors = {b.name: ImuSensor(noise, i) for i, b in enumerate(rec.config.bodies)}
    streams = len(rec.config.bodies)  # a spawned body's noise stream: after them, in order
    ported = set(rec.tf_bodies('tf') + rec.tf_bodies('tf_static'))  # bodies with topics
    spawned = set()
    offsets: dict = {}
    motion_filled: dict = {}
    events = rec.inputs
    i = 0
    filled: dict = {}
    for step, body, kind, topic, msg, log_time in rec.outputs:
        while sim.step_count < step:
            while i < len(events) and events[i][0] <= sim.step_count:
                at, event, where = events[i]
                if at < sim.step_count:
                    raise ReaderError(f'{rec.path}: the input on {where} at step {at} is in '
                                      f'the past of the run (now at step {sim.step_count})')
                try:
                    sim.apply(event)
                except ValueError as e:
                    raise ReaderError(f'{rec.path}: the input on {where} at step {at} cannot '
                                      f'be applied: {e}') from None
                if isinstance(event, Spawn):  # as the node: topics, frames, a noise stream
                    outs[event.body] = outputs_of(event.body, True)
                    sensors[event.body] = ImuSensor(noise, streams)
                    streams += 1
                    ported.add(event.body)
                    spawned.add(event.body)
                elif isinstance(event, Delete):
                    ported.discard(event.body)
                    spawned.discard(event.body)
                i += 1
            due = events[i][0] if i < len(events) else step
            before = sim.step_count
            try:
                sim.run(min(due, step) - before)
            except IntegrationError as e:
                if errors is not None and not errors:  # the first says why; not one a step
                    errors.append(str(e))
            if sim.step_count <= before:
                raise ReaderError(f'{rec.path}: the run does not advance past step {before}')
        if i < len(events) and events[i][0] < sim.step_count:
            raise ReaderError(f'{rec.path}: the input on {events[i][2]} at step '
                              f'{events[i][0]} is in the past of the run (now at step '
                              f'{sim.step_count})')
        if kind in ('tf', 'tf_static'):
            yield step, kind, topic, msg, _tf_message(rec, sim, kind, type(msg), ported,
                                                      spawned), \
                log_time
            continue
        if not sim.is_moving(body):
            raise ReaderError(f'{rec.path}: an output of {body!r} on {topic} at step {step}, '
                              'when the run has no such moving body')
        out = outs[body]
        if filled.get(body) != step:  # a publish: as the node, the IMU's noise drawn first
            offsets[body] = sensors[body].sample(sim.time_ns)
            out.fill(sim.time_ns, *sim.pose_twist(body))
            filled[body] = step
        if output_kinds.needs_motion(kind) and motion_filled.get(body) != step:
            _, q, _, w = sim.pose_twist(body)
            a, b = sim.accelerations(body)
            out.fill_motion(sim.time_ns, q, w, a, b, rec.config.gravity, offsets[body])
            motion_filled[body] = step
        yield step, kind, topic, msg, getattr(out, kind), log_time


def _tf_message(rec: Recording, sim: Simulation, kind: str, msg_type, ported: set,
                spawned: set):
    """The /tf (or /tf_static) message the node would publish now: the bodies with topics
    (``ported``), moving or static, in the run's order."""
    bodies = [b.name for b in sim.config.bodies
              if b.name in ported and b.static == (kind == 'tf_static')]
    world = {**FRAME_PARAMS, **rec.parameters}['world_frame']
    mine = tf_message(msg_type, world, [rec.frames(b, b in spawned)[1] for b in bodies])
    fill_tf(mine, sim.time_ns, [sim.pose_twist(b)[:2] for b in bodies])
    return mine


def verify(path: str) -> Verification:
    """Re-simulate ``path`` offline and compare every recorded output with the re-run, each
    as it is read (memory bounded whatever the length)."""
    rec = load(path)
    result = Verification(inputs=len(rec.inputs), truncated=rec.truncated,
                          recorded=len(rec.outputs), lockstep_notes=rec.lockstep_notes,
                          per_topic={t: [0, n] for t, n in rec.recorded_per_topic.items()})
    errors: list[str] = []
    for step, kind, topic, msg, mine, log_time in resimulate(rec, errors):
        result.outputs += 1
        result.per_topic[topic][0] += 1
        result.last_time_ns = log_time
        if not _finite_message(kind, msg):
            result.non_finite += 1
        theirs_v, mine_v = _vectors(kind, msg), _vectors(kind, mine)
        for q, v in theirs_v.items():  # an empty TFMessage (every body deleted): nothing
            d = max((abs(a - b) for a, b in zip(v, mine_v[q])), default=0.0)
            if not d <= result.max_difference[q]:  # also catches nan
                result.max_difference[q] = d if not math.isnan(d) else math.inf
        if not identical(kind, msg, mine):
            result.mismatched_messages += 1
            if not result.first_mismatch:
                result.first_mismatch = f'{topic} at step {step} (t = {log_time * 1e-9:.9f} s)'
    result.integration_error = errors[0] if errors else ''
    return result


def play(path: str, rate: float, clock: bool = True, wait: float = 0.0) -> int:
    """Republish the recorded outputs in sim-time order with /clock, ``rate`` x sim time
    (0: as fast as possible); first wait up to ``wait`` seconds for a subscriber on one of
    them. Ctrl-C raises KeyboardInterrupt (rclpy's signal handler is not installed)."""
    import rclpy
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from rosgraph_msgs.msg import Clock

    recording = load(path)
    # (topic, msg, log time), in log-time order (log time is step * dt), read from the file
    # while playing. Not the run definition (or the inputs): the node never publishes it.
    outputs = ((o[3], o[4], o[5]) for o in recording.outputs)
    types = {topic: message_class(name) for topic, name in recording.types.items()
             if recording.recorded_per_topic.get(topic)}
    qos = {}
    for topic, q in recording.qos.items():
        if q is not None:
            qos[topic] = QoSProfile(
                history=HistoryPolicy[q['history'].upper()], depth=q['depth'],
                reliability=ReliabilityPolicy[q['reliability'].upper()],
                durability=DurabilityPolicy[q['durability'].upper()])
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('rb_sim_replay')  # on the ROS graph of the environment
        try:
            _publish(rclpy, node, outputs, rate, wait, Clock if clock else None,
                     QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT), qos,
                     types, recording.last_output_ns)
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return 0


def _sleep_until(deadline: float) -> None:
    """Sleep until time.monotonic() reaches ``deadline``, in slices time.sleep accepts."""
    while True:
        left = deadline - time.monotonic()
        if not left > 0:
            return
        time.sleep(min(left, 1.0))


def _publish(rclpy, node, outputs, rate: float, wait: float, clock_type, clock_qos,
             qos=None, types=None, end=None) -> None:
    """Publish ``outputs`` ((topic, msg, log time), in log-time order) on one publisher per
    topic, created first: /tf and /tf_static with tf_qos, the others with ``qos[topic]`` (the
    recorded QoS) or, without it, depth 10. ``types`` (topic -> message class) and ``end``
    (the last log time) let ``outputs`` be an iterator, read while publishing; without them
    it is a list."""
    qos = qos or {}
    if types is None:
        types = {}
        for topic, msg, _ in outputs:
            types.setdefault(topic, type(msg))
        end = outputs[-1][2] if outputs else 0
    pubs = {topic: node.create_publisher(
        msg_type, topic,
        tf_qos(topic) if topic in (TF, TF_STATIC) else qos.get(topic, DEFAULT_DEPTH))
        for topic, msg_type in types.items()}
    clock_pub = (node.create_publisher(clock_type, '/clock', clock_qos)
                 if clock_type is not None else None)
    outputs = iter(outputs)
    first = next(outputs, None)
    if first is None:
        return
    end_wait = time.monotonic() + wait
    while time.monotonic() < end_wait and not any(
            p.get_subscription_count() for p in pubs.values()):
        rclpy.spin_once(node, timeout_sec=0.05)
    t0_sim, t0_wall = first[2], time.monotonic()
    send = _Sender(t for t in types if _keeps_all(qos.get(t)))
    progress = Progress(round((end - t0_sim) * 1e-9, 3), 'replay', 's of sim time')
    started = None
    for topic, msg, log_time in itertools.chain([first], outputs):
        if rate > 0:
            _sleep_until(t0_wall + (log_time - t0_sim) * 1e-9 / rate)
        if clock_pub is not None:
            clock_pub.publish(clock_type(clock=time_msg(log_time)))
        send(pubs[topic], topic, msg)
        if started is None:  # said once the first message is out
            started = True
            print(f'replay: publishing {len(pubs)} topics, sim time {t0_sim * 1e-9:.3f} to '
                  f'{end * 1e-9:.3f} s', file=sys.stderr, flush=True)
        progress(round((log_time - t0_sim) * 1e-9, 3))
    progress.close()
    # What DDS still holds for the subscribers (a keep_all history, the last messages of a
    # reliable topic) is lost if the process ends now: wait until they have it (at most
    # MAX_BLOCKED_S in all).
    # In slices: the wait is in C, and Ctrl-C is acted on only between two calls.
    from rclpy.duration import Duration
    start = time.monotonic()
    deadline = start + MAX_BLOCKED_S
    behind = []
    for topic, pub in pubs.items():
        wait_acked = getattr(pub, 'wait_for_all_acked', None)
        if wait_acked is None:
            continue
        while not wait_acked(Duration(nanoseconds=200_000_000)):
            if time.monotonic() >= deadline:
                behind.append(topic)
                break
    if behind:
        print(f'replay: the subscribers of {", ".join(behind)} had not acknowledged every '
              f'message after {time.monotonic() - start:.0f} s; some may not have arrived',
              file=sys.stderr)


class _Sender:
    """Publishes a message, waiting while DDS has no room for it: a keep_all topic (as
    recorded) whose subscribers have not yet taken what was sent makes the publish fail (an
    RCLError after the RMW's blocking time) instead of dropping a message; at ``--rate 0``
    that is the normal case. Tried again until it goes out; ValueError (one line) after
    MAX_BLOCKED_S without progress."""

    def __init__(self, keep_all=()) -> None:
        self._keep_all = set(keep_all)  # the topics published keep_all
        try:
            from rclpy._rclpy_pybind11 import RCLError
        except ImportError:  # not this rclpy: nothing to wait for
            RCLError = ()  # noqa: N806 (an exception class, or none)
        self._full = RCLError
        self._told = False

    def __call__(self, pub, topic: str, msg) -> None:
        end = None
        while True:
            try:
                pub.publish(msg)
                return
            except TypeError as e:  # Ctrl-C while rclpy converted the message
                stop = interrupt_in(e)
                if stop is None:
                    raise
                raise stop from None
            except self._full as e:
                why = ' '.join(str(e).split())[:120]
                if topic not in self._keep_all:  # not a full keep_all history: failed
                    raise ValueError(f'{topic}: publishing failed ({why})') from None
                now = time.monotonic()
                if end is None:
                    end = now + MAX_BLOCKED_S
                    if not self._told:
                        self._told = True
                        print(f'replay: {topic}: its subscribers are behind (keep_all: '
                              'nothing is dropped); waiting for them', file=sys.stderr,
                              flush=True)
                elif now > end:
                    raise ValueError(f'{topic}: no room to publish for {MAX_BLOCKED_S:g} s '
                                     '(a keep_all subscriber takes no messages): stopped '
                                     f'({why})') from None
                time.sleep(0.005)


def _keeps_all(qos) -> bool:
    """Whether a publisher of ``qos`` (a QoSProfile, or a depth) keeps all (where a full
    queue fails a publish)."""
    from rclpy.qos import HistoryPolicy
    return getattr(qos, 'history', None) == HistoryPolicy.KEEP_ALL


_Parser = ros_arguments.OneLineParser


def _check_options(opts) -> str:
    """What is wrong with the options, or ''."""
    if not (opts.rate == 0 or MIN_RATE <= opts.rate <= MAX_RATE):
        return (f'--rate must be 0 (as fast as possible) or from {MIN_RATE:g} to '
                f'{MAX_RATE:g}, got {opts.rate!r}')
    if not 0 <= opts.wait <= MAX_WAIT_S:
        return f'--wait must be from 0 to {MAX_WAIT_S:g} s, got {opts.wait!r}'
    if (opts.recover or opts.render) and not opts.out:
        return f'--{"recover" if opts.recover else "render"} needs FILE and OUT'
    if opts.out and not (opts.recover or opts.render):
        return 'OUT is only for --recover and --render'
    if opts.out_dir is not None and not opts.plot:
        return '--out is only for --plot (with --render, OUT is the second argument)'
    if opts.bodies is not None and not opts.plot:
        return '--bodies is only for --plot'
    if (opts.view != 'iso' or opts.follow is not None or opts.fps is not None
            or opts.size != '640x480') and not opts.render:
        return '--view, --follow, --fps and --size are only for --render'
    if not re.fullmatch(r'\d{2,4}x\d{2,4}', opts.size):
        return f'--size must be WIDTHxHEIGHT in pixels (e.g. 640x480), got {opts.size!r}'
    return ''


def main(args=None) -> int:
    argv = sys.argv if args is None else args
    parser = _Parser(prog='replay', description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('file', help='a recording (.mcap) made with the record parameter')
    parser.add_argument('out', nargs='?', help='with --recover: the finalised copy to write')
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument('--verify', action='store_true', help='re-simulate and compare')
    mode.add_argument('--recover', action='store_true', help='finalise a killed recording')
    mode.add_argument('--plot', action='store_true',
                      help='write PNGs of every body (matplotlib) into --out')
    mode.add_argument('--render', action='store_true',
                      help='write an animation to OUT (.gif; .mp4 with imageio-ffmpeg)')
    parser.add_argument('--out', dest='out_dir', metavar='DIR',
                        help='with --plot: the directory (default: FILE without .mcap)')
    parser.add_argument('--bodies', help='with --plot: the bodies, comma-separated (default: '
                        'all that were recorded)')
    parser.add_argument('--view', default='iso', choices=('iso', 'top', 'side'),
                        help='with --render: the camera (orthographic)')
    parser.add_argument('--follow', metavar='BODY', help='with --render: keep BODY centred')
    parser.add_argument('--fps', type=float, help='with --render: frames per second of sim '
                        'time (default: one frame per recorded publish)')
    parser.add_argument('--size', default='640x480', help='with --render: WIDTHxHEIGHT')
    parser.add_argument('--rate', type=float, default=1.0,
                        help=f'playback speed (sim time per wall time, {MIN_RATE:g} to '
                        f'{MAX_RATE:g}; 0: as fast as possible)')
    parser.add_argument('--no-clock', action='store_true', help='do not publish /clock')
    parser.add_argument('--wait', type=float, default=0.0,
                        help='seconds to wait for a subscriber before playing')
    parser.add_argument('--overwrite', action='store_true', help='with --recover')
    opts = parser.parse_args(ros_arguments.non_ros_args(argv, 'replay'))
    problem = _check_options(opts)
    if problem:
        parser.error(problem)
    try:
        if opts.verify:
            return _print_verification(opts.file, verify(opts.file))
        if opts.recover:
            counts = recover(opts.file, opts.out, overwrite=opts.overwrite)
            print(f'replay: recovered {counts} into {opts.out}')
            return 0
        if opts.plot:
            return _plot(opts)
        if opts.render:
            return _render(opts)
        return play(opts.file, opts.rate, clock=not opts.no_clock, wait=opts.wait)
    except (ReaderError, WriterError, OSError, ValueError, OverflowError) as e:
        print(f'replay: {e}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('replay: interrupted', file=sys.stderr)
        return 130


def _progress(what: str):
    """A progress callback ``show(done, total)`` for plots and renders (``Progress``: a tqdm bar
    on a terminal, else whole lines), closed at the last of ``total``."""
    bar: list = []

    def show(done: int, total: int) -> None:
        if not bar:
            bar.append(Progress(total, f'replay: {what}'))
        bar[0](done)
        if done >= total:
            bar[0].close()
    return show


def _needs(module: str, what: str) -> None:
    try:
        __import__(module)
    except ImportError:
        raise ValueError(f'{what} needs {module} (pip install -r requirements-viz.txt; on a '
                         'ROS install: apt install python3-matplotlib)') from None


def _plot(opts) -> int:
    _needs('matplotlib', '--plot')
    rec = load(opts.file)
    out = opts.out_dir or re.sub(r'\.mcap$', '', opts.file) + '_plots'
    bodies = [b for b in opts.bodies.split(',') if b] if opts.bodies else None
    files = plots.plot(rec, out, bodies, progress=_progress('re-simulating contacts'))
    for f in files:
        print(f)
    return 0


def _render(opts) -> int:
    _needs('PIL', '--render')
    rec = load(opts.file)
    size = tuple(int(c) for c in opts.size.split('x'))
    count = render.render(rec, opts.out, opts.view, opts.fps, opts.follow, size,
                          progress=_progress('rendering frame'))
    print(f'replay: {count} frames written to {opts.out}')
    return 0


def _print_verification(path: str, r: Verification) -> int:
    note = ' (truncated recording: compared what it holds)' if r.truncated else ''
    print(f'{path}: {r.inputs} inputs, {r.outputs} of {r.recorded} recorded output messages '
          f'compared, up to t = {r.last_time_ns * 1e-9:.6f} s{note}')
    for topic, (compared, recorded) in sorted(r.per_topic.items()):
        print(f'  {topic:<24} {compared} of {recorded} compared')
    for q in QUANTITIES:
        print(f'  largest difference in {q:<17} {r.max_difference[q]:.3g}')
    if r.integration_error:
        print(f'  the run went non-finite, as the node did (it paused there): '
              f'{r.integration_error}')
    for step, text in r.lockstep_notes[:10]:  # what the run did without an answer
        print(f'  lockstep at step {step}: {text[:200]}')
    if len(r.lockstep_notes) > 10:
        print(f'  ... and {len(r.lockstep_notes) - 10} more lockstep notes')
    if r.identical:
        print('identical: every output message re-simulated bit for bit')
        return 0
    problems = []
    if r.mismatched_messages:
        problems.append(f'{r.mismatched_messages} of {r.outputs} messages differ'
                        + (f', first {r.first_mismatch}' if r.first_mismatch else ''))
    if r.outputs != r.recorded:
        problems.append(f'{r.recorded - r.outputs} of {r.recorded} recorded output messages '
                        'were not compared')
    if r.non_finite:
        problems.append(f'{r.non_finite} recorded output messages hold non-finite values')
    if not r.recorded:
        problems.append('no output messages to compare')
    print('MISMATCH: ' + '; '.join(problems))
    return 1


if __name__ == '__main__':
    sys.exit(main())
