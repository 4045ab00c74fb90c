# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What a recording of the simulator holds, written by the node and read back by ``replay``.

One MCAP file (profile ros2, cdr, ros2msg schemas; see ``recording/``):

* metadata ``rb_sim_ros``: ``config`` (JSON of ``simulation.Config``: the bodies, gravity, dt,
  integrator, initial states), ``parameters`` (JSON of every node parameter), ``version``,
  ``format``, ``output_topics``, ``tf_topics`` (the run's definition);
* the same definition as a message, where bag tools keep it (``rosbags-convert`` and ``ros2
  bag convert`` drop MCAP metadata records but keep every message): one std_msgs/String on
  ``/rb_sim/run_definition`` at step 0 (log time 0, the run's first time stamp), holding the
  metadata record as a JSON object of strings, on a transient local channel (as a latched
  topic: a late reader of a bag gets it);
* inputs, each at the step it took effect (MCAP ``sequence`` = step, log time = step * dt), on
  ``/rb_sim/input/<body>/wrench`` (WrenchStamped, frame_id 'world' or 'body', as received),
  ``.../set_pose`` (PoseStamped, world), ``.../set_twist`` (TwistStamped, world) and
  ``.../reset`` (nav_msgs/Odometry: the state reset to, world frame), ``.../spawn``
  (std_msgs/String: JSON ``{"body": the body as in config, "output_topics": {kind: topic}}``;
  the body appears at its initial state, and its outputs are on those topics from then on)
  and ``.../delete`` (std_msgs/String ``{}``);
* outputs at every publish: each moving body's ``pose``, ``twist``, ``odom``, ``imu`` and
  ``accel`` on the topics the node published them on (``output_topics`` in the metadata;
  recordings made before imu and accel existed have the first three), log time = sim time;
  with publish_tf, ``/tf`` (tf2_msgs/TFMessage) at every publish and ``/tf_static`` once at
  step 0 (``tf_topics`` in the metadata);
* in lockstep, ``/rb_sim/lockstep`` (std_msgs/String, JSON ``{"event": "timeout" or "left",
  "inputs": [bodies]}``) at the step where a controller's answer was not waited for.

Inputs are everything that changed the run; with ``config`` they re-simulate it bit for bit,
and the outputs are what to compare against.
"""

from __future__ import annotations

import json
import os
import struct

from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from mcap.writer import LIBRARY_IDENTIFIER
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from rb_sim_ros import __version__
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.recording import RecordingWriter, WriterError
from rb_sim_ros.recording.cdr import encoder, HEADER
from rb_sim_ros.recording.compare import difference
from rb_sim_ros.ros import node_params, output_kinds
from rb_sim_ros.ros.ros_messages import set_stamp, tf_qos, time_msg
from rb_sim_ros.sim.simulation import (body_from_dict, body_to_dict, Config, Delete, Reset,
                                       SetPose, SetTwist, SetWrench, Spawn)

METADATA = 'rb_sim_ros'
# The writer named in the file's header (as rosbag2 names itself there).
LIBRARY = f'rb_sim_ros/{__version__} {LIBRARY_IDENTIFIER}'
FORMAT = 1
INPUT_PREFIX = '/rb_sim/input/'
INPUTS = {'wrench': WrenchStamped, 'set_pose': PoseStamped, 'set_twist': TwistStamped,
          'reset': Odometry, 'spawn': String, 'delete': String}
STATE_INPUTS = ('wrench', 'set_pose', 'set_twist', 'reset')
# The most text a spawn's JSON may hold (a body with many colliders is a few kB).
MAX_SPAWN_TEXT = 1 << 20
OUTPUTS = {k.name: k.msg_type for k in output_kinds.KINDS}
# What every recording has of a body (imu and accel came later).
REQUIRED_OUTPUTS = output_kinds.REQUIRED
# tf2's topics and their type (tf2_msgs, built into a PyPI venv by tools/build_msgs.sh).
TF_TYPE = 'tf2_msgs/msg/TFMessage'
# The run's definition as a message at step 0 (beside the metadata record, which bag tools
# drop): latched, as a late subscriber or a bag reader wants it.
RUN_DEFINITION = '/rb_sim/run_definition'
RUN_DEFINITION_TYPE = 'std_msgs/msg/String'
# What happened to lockstep's inputs (timeouts, controllers gone), at its step: a JSON object
# {"event": "timeout" or "left", "inputs": [bodies]}.
LOCKSTEP = '/rb_sim/lockstep'
RUN_DEFINITION_QOS = {'history': 'keep_last', 'depth': 1, 'reliability': 'reliable',
                      'durability': 'transient_local'}


def run_definition(config: Config, parameters: dict, output_topics: dict,
                   tf_topics) -> dict[str, str]:
    """The run's definition: the ``rb_sim_ros`` metadata record (string keys and values) that
    replay rebuilds the run from; also recorded, as JSON, on ``RUN_DEFINITION``."""
    return {'format': str(FORMAT), 'version': __version__,
            'config': json.dumps(config.to_dict()),
            'parameters': json.dumps(parameters, sort_keys=True),
            'output_topics': json.dumps(output_topics, sort_keys=True),
            'tf_topics': json.dumps(sorted(tf_topics))}


# A metadata record of where a run came from (offline/campaign: the campaign, the run's
# number, seed, drawn values and controller parameters).
PROVENANCE = 'rb_sim_ros_campaign'
# Parameters that change how a run is made, not what it is: two recordings of one run may
# differ in them (the file, the pace, how long lockstep waits).
# scene_file too: the scene is in the recorded config (the bodies, gravity, contact) and
# spawns are recorded whole, so the file's name is where it came from, not what ran (a
# campaign's run over DDS reads its dispersed scene from a file of its own).
RUN_NEUTRAL = ('record', 'record_overwrite', 'real_time_factor', 'max_catchup',
               'compile_in_background', 'lockstep_timeout', 'lockstep_on_timeout',
               'scene_file')


def same_run(a: str, b: str) -> str:
    """'' if recordings ``a`` and ``b`` are the same run, bit for bit, else the first
    difference (recording.compare.difference): every message and metadata record, but for the
    RUN_NEUTRAL parameters, the files' own names and the PROVENANCE record (what made the run,
    not what it is: a run of a campaign and the same run made by the node are one run)."""
    def definition(text: str) -> str:
        data = json.loads(text)
        params = json.loads(data.get('parameters', '{}'))
        data['parameters'] = json.dumps({k: v for k, v in params.items()
                                         if k not in RUN_NEUTRAL}, sort_keys=True)
        return json.dumps(data, sort_keys=True)

    def metadata(path, name, record):
        if name == PROVENANCE:
            return None
        if name == METADATA:
            return json.loads(definition(json.dumps(record)))
        # rosbag2's record names the file itself
        return {k: v.replace(os.path.basename(path), '<file>') for k, v in record.items()}

    def message(path, topic, msg):
        return String(data=definition(msg.data)) if topic == RUN_DEFINITION else msg
    return difference(a, b, metadata, message)


def input_topic(body: str, kind: str) -> str:
    return f'{INPUT_PREFIX}{body}/{kind}'


def parse_input_topic(topic: str) -> tuple[str, str] | None:
    """(body, kind) of an input topic, or None for any other topic."""
    if not topic.startswith(INPUT_PREFIX):
        return None
    body, _, kind = topic[len(INPUT_PREFIX):].rpartition('/')
    return (body, kind) if kind in INPUTS and body else None


def wrench_message(event: SetWrench, time_ns: int, msg: WrenchStamped) -> WrenchStamped:
    """``msg`` filled in place with the wrench input ``event`` took effect with at
    ``time_ns``."""
    set_stamp(msg.header.stamp, time_ns)
    msg.header.frame_id = event.wrench.frame.value
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z = map(float, event.wrench.force)
    t.x, t.y, t.z = map(float, event.wrench.torque)
    return msg


_STAMP = struct.Struct('<iI')  # a header's stamp (sec, nanosec)
_SIX = struct.Struct('<6d')
_frame_ids: dict[str, bytes] = {}


def wrench_bytes(event: SetWrench, time_ns: int) -> bytes:
    """The CDR bytes of ``wrench_message(event, time_ns, ...)`` (what its serialiser gives),
    packed from the numbers: a closed-loop run records a wrench input every period."""
    wrench = event.wrench
    frame = wrench.frame.value
    tail = _frame_ids.get(frame)
    if tail is None:  # its length, the UTF-8 and a NUL, padded to the doubles' alignment
        text = frame.encode() + b'\0'
        tail = struct.pack('<I', len(text)) + text
        tail = _frame_ids[frame] = tail + bytes(-(8 + len(tail)) % 8)
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return HEADER + _STAMP.pack(sec, nanosec) + tail + _SIX.pack(*wrench.components)


_POSE = struct.Struct('<7d')  # position, orientation; then a covariance
_TWIST = struct.Struct('<6d')  # odom's body-frame twist; then its covariance
_ODOM_TAIL = (7 + 36 + 6 + 36) * 8  # the bytes after the frame ids: doubles only
_odom_parts: dict[tuple, tuple[bytes, bytes, bytes]] = {}


def odom_bytes(out) -> bytes:
    """The CDR bytes of the Odometry ``out`` (ros_messages.OutputMessages) would hold after
    its last fill, packed from its numbers (``out.last``) whether it filled odom or not (a
    campaign's run records odom every period, and its law may read the IMU only): what the
    generic serialiser gives for the filled message. Its frame ids and covariances are
    ``out.odom``'s, which a fill does not change."""
    odom = out.odom
    pose_cov, twist_cov = odom.pose.covariance, odom.twist.covariance
    key = (odom.header.frame_id, odom.child_frame_id, bytes(memoryview(pose_cov)),
           bytes(memoryview(twist_cov)))
    parts = _odom_parts.get(key)
    if parts is None:  # the constant bytes, cut from the serialiser's own output
        template = Odometry()
        template.header.frame_id, template.child_frame_id = key[0], key[1]
        template.pose.covariance, template.twist.covariance = pose_cov, twist_cov
        data = encoder(Odometry)(template)
        end = len(data) - _ODOM_TAIL
        parts = (data[12:end], data[end + 56:end + 56 + 288], data[len(data) - 288:])
        if len(_odom_parts) < 64:
            _odom_parts[key] = parts
    head, pose_cov_bytes, twist_cov_bytes = parts
    time_ns, p, q, lin, ang = out.last
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return (HEADER + _STAMP.pack(sec, nanosec) + head + _POSE.pack(*p, *q)
            + pose_cov_bytes + _TWIST.pack(*lin, *ang) + twist_cov_bytes)


def event_message(event, time_ns: int, output_topics: dict | None = None):
    """(kind, message) recording ``event`` that took effect at ``time_ns``; a Spawn's names
    the ``output_topics`` of the new body ({} for one without)."""
    if isinstance(event, Spawn):
        return 'spawn', String(data=json.dumps(
            {'body': body_to_dict(event.spec), 'output_topics': output_topics or {}},
            sort_keys=True))
    if isinstance(event, Delete):
        return 'delete', String(data='{}')
    if isinstance(event, SetWrench):
        return 'wrench', wrench_message(event, time_ns, WrenchStamped())
    stamp = time_msg(time_ns)
    if isinstance(event, SetPose):
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, 'world'
        p, o = msg.pose.position, msg.pose.orientation
        p.x, p.y, p.z = event.position
        o.x, o.y, o.z, o.w = event.orientation_xyzw
        return 'set_pose', msg
    if isinstance(event, SetTwist):
        msg = TwistStamped()
        msg.header.stamp, msg.header.frame_id = stamp, 'world'
        lin, ang = msg.twist.linear, msg.twist.angular
        lin.x, lin.y, lin.z = event.linear
        ang.x, ang.y, ang.z = event.angular
        return 'set_twist', msg
    if isinstance(event, Reset):
        if event.position is None:
            raise ValueError('a recorded Reset must name its state (Reset.to_initial)')
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, 'world', 'world'
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        p.x, p.y, p.z = event.position
        o.x, o.y, o.z, o.w = event.orientation_xyzw
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        lin.x, lin.y, lin.z = event.linear
        ang.x, ang.y, ang.z = event.angular
        return 'reset', msg
    raise ValueError(f'not an event: {event!r}')


def spawn_from_message(body: str, msg) -> tuple[Spawn, dict]:
    """(the Spawn, its body's output topics) of a recorded spawn on ``body``'s topic;
    ValueError saying what is wrong with it."""
    text = msg.data
    if len(text) > MAX_SPAWN_TEXT:
        raise ValueError(f'its JSON is longer than {MAX_SPAWN_TEXT} characters')
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as e:
        raise ValueError(f'not JSON: {e}') from None
    if not isinstance(data, dict) or set(data) != {'body', 'output_topics'}:
        raise ValueError('must be a JSON object of body and output_topics')
    try:
        spec = body_from_dict(data['body'])
    except (ValueError, TypeError, KeyError, AttributeError, ArithmeticError) as e:
        raise ValueError(f'not a body: {e}') from None
    if spec.name != body:
        raise ValueError(f"spawns '{spec.name}' on the topic of '{body}'")
    topics = data['output_topics']
    if not isinstance(topics, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in topics.items()):
        raise ValueError('output_topics must map output kinds to topic names')
    return Spawn(spec), topics


def event_from_message(body: str, kind: str, msg):
    """The simulation event a recorded input message stands for (inverse of event_message)."""
    if kind == 'spawn':
        return spawn_from_message(body, msg)[0]
    if kind == 'delete':
        if msg.data != '{}':
            raise ValueError(f'a delete holds {{}}, not {msg.data[:40]!r}')
        return Delete(body)
    if kind == 'wrench':
        f, t = msg.wrench.force, msg.wrench.torque
        return SetWrench(Wrench((f.x, f.y, f.z), (t.x, t.y, t.z), msg.header.frame_id), body)
    if kind == 'set_pose':
        p, o = msg.pose.position, msg.pose.orientation
        return SetPose((p.x, p.y, p.z), (o.x, o.y, o.z, o.w), body)
    if kind == 'set_twist':
        lin, ang = msg.twist.linear, msg.twist.angular
        return SetTwist((lin.x, lin.y, lin.z), (ang.x, ang.y, ang.z), body)
    if kind == 'reset':
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        return Reset((p.x, p.y, p.z), (o.x, o.y, o.z, o.w), (lin.x, lin.y, lin.z),
                     (ang.x, ang.y, ang.z), body)
    raise ValueError(f'{kind} is not an input')


class NodeRecorder:
    """Records a node's run; every call returns quickly (file I/O is on the writer's thread).

    ``output_topics`` maps each body name to its {'pose': topic, 'twist': ..., 'odom': ...}.

    A file that cannot be created (missing directory, existing file without ``overwrite``,
    read-only file system...) raises WriterError, a ValueError, with one line naming the path
    and the reason. A write that fails later (disk full, I/O error) never raises: the recording
    stops, ``failed`` holds the reason (poll it, e.g. for a diagnostics error), ``event`` and
    ``output`` cost nothing from then on, ``close`` does not raise, and the file keeps what was
    written before the failure (``replay --recover`` finalises it).
    """

    def __init__(self, path: str, config: Config, parameters: dict,
                 output_topics: dict[str, dict[str, str]], overwrite: bool = False,
                 tf_topics=(), max_chunk_age_s: float | None = 1.0,
                 background: bool = True) -> None:
        try:
            self._writer = RecordingWriter(path, overwrite=overwrite, library=LIBRARY,
                                           max_chunk_age_s=max_chunk_age_s,
                                           background=background)
        except WriterError as e:
            hint = ('; set record_overwrite:=true to replace it'
                    if not overwrite and os.path.isfile(path) else '')
            raise WriterError(f'cannot record to {e}{hint}') from None
        self._closed_error: str | None = None
        self._first = config.bodies[0].name
        # the outputs recorded: those record_outputs names (all, for a caller without it)
        self._kinds = frozenset(node_params.record_outputs(
            parameters.get('record_outputs', OUTPUTS)))
        output_topics = {body: self._recorded(topics) for body, topics in output_topics.items()}
        self._outputs = dict(output_topics)
        self._registered: set[str] = set()
        for spec in config.bodies:
            if spec.static:
                continue
            for kind in STATE_INPUTS:  # spawn and delete: when one happens
                self._register(input_topic(spec.name, kind), INPUTS[kind])
        for topics in output_topics.values():
            for kind, topic in topics.items():
                self._register(topic, OUTPUTS[kind])
        tf_topics = sorted(tf_topics)
        if tf_topics:
            from tf2_msgs.msg import TFMessage  # only when the node has it: publish_tf
            for topic in tf_topics:
                self._writer.register_topic(topic, TFMessage, tf_qos(topic))
        definition = run_definition(config, parameters, output_topics, tf_topics)
        self._writer.write_metadata(METADATA, definition)
        self._writer.register_topic(RUN_DEFINITION, String, RUN_DEFINITION_QOS)
        self._writer.write(RUN_DEFINITION, String(data=json.dumps(definition, sort_keys=True)),
                           0, sequence=0)

    @property
    def failed(self) -> str | None:
        """Why recording stopped (the file and the reason, one line), or None while it works."""
        return self._writer.failed or self._closed_error

    @property
    def pending(self) -> int:
        """Messages handed over and not yet written (the writer's queue)."""
        return self._writer.pending

    def metadata(self, name: str, record: dict[str, str]) -> None:
        """A metadata record of the recording's maker (not the node's: ``same_run`` compares
        the node's records only), e.g. the campaign a run belongs to (PROVENANCE)."""
        if name == METADATA:
            raise ValueError(f"metadata '{name}' is the run's definition")
        self._writer.write_metadata(name, record)

    def event(self, step: int, time_ns: int, event) -> None:
        if self._writer.error is not None:
            return
        if type(event) is SetWrench:  # (the most frequent: packed from its numbers)
            topic = input_topic(event.body or self._first, 'wrench')
            if topic not in self._registered and not self._registered_now(topic, 'wrench'):
                return
            self._writer.write_serialized(topic, wrench_bytes(event, time_ns), WrenchStamped,
                                          time_ns, sequence=step)
            return
        kind, msg = event_message(event, time_ns)
        topic = input_topic(event.body or self._first, kind)
        if not self._registered_now(topic, kind):
            return
        self._writer.write(topic, msg, time_ns, sequence=step)

    def _registered_now(self, topic: str, kind: str) -> bool:
        """Input ``topic`` of ``kind`` registered (once); False if it cannot be (said at the
        close)."""
        try:
            self._register(topic, INPUTS[kind])
        except WriterError as e:
            self._closed_error = self._closed_error or str(e)
            return False
        return True

    def _recorded(self, topics: dict[str, str]) -> dict[str, str]:
        """Of a body's output topics, those recorded (record_outputs)."""
        return {kind: topic for kind, topic in topics.items() if kind in self._kinds}

    def _register(self, topic: str, msg_type) -> None:
        """Declare ``topic`` once (a body deleted and spawned again keeps its topics)."""
        if topic not in self._registered:
            self._writer.register_topic(topic, msg_type)
            self._registered.add(topic)

    def spawned(self, step: int, time_ns: int, event: Spawn, output_topics: dict) -> None:
        """A body spawned at ``step``: its inputs and outputs (``output_topics``, {} for a
        static one) are recorded from now on; the spawn itself is an input."""
        if self._writer.error is not None:
            return
        name = event.spec.name
        output_topics = self._recorded(output_topics)
        try:
            for kind, msg_type in INPUTS.items():
                if kind != 'delete':
                    self._register(input_topic(name, kind), msg_type)
            for kind, topic in output_topics.items():
                self._register(topic, OUTPUTS[kind])
        except WriterError as e:  # a topic of a deleted body with another kind's type
            self._closed_error = self._closed_error or str(e)
            return
        if output_topics:
            self._outputs[name] = dict(output_topics)
        kind, msg = event_message(event, time_ns, output_topics)
        self._writer.write(input_topic(name, kind), msg, time_ns, sequence=step)

    def deleted(self, step: int, time_ns: int, name: str) -> None:
        """Body ``name`` deleted at ``step`` (an input; its outputs stop)."""
        self._outputs.pop(name, None)
        self.event(step, time_ns, Delete(name))

    def output(self, body: str, step: int, time_ns: int, out) -> None:
        """``body``'s outputs recorded of ``out`` (ros_messages.OutputMessages) just filled
        (odom packed from its numbers if it was not filled: ``odom_bytes``)."""
        w = self._writer
        if w.error is not None:
            return
        for kind, topic in self._outputs[body].items():
            if kind == 'odom' and 'odom' not in out.kinds:
                w.write_serialized(topic, odom_bytes(out), Odometry, time_ns, sequence=step)
            else:
                w.write(topic, getattr(out, kind), time_ns, sequence=step)

    def lockstep(self, step: int, time_ns: int, what: str, bodies: list) -> None:
        """What happened to lockstep's inputs at ``step`` (a timeout, one that left), on
        LOCKSTEP: not an input (the wrenches held are what they were), but part of the run."""
        if self._writer.error is not None:
            return
        try:
            self._register(LOCKSTEP, String)
        except WriterError as e:
            self._closed_error = self._closed_error or str(e)
            return
        self._writer.write(LOCKSTEP, String(data=json.dumps(
            {'event': what, 'inputs': list(bodies)}, sort_keys=True)), time_ns, sequence=step)

    def tf(self, topic: str, step: int, time_ns: int, msg) -> None:
        """A TFMessage the node published on ``topic`` (/tf or /tf_static)."""
        if self._writer.error is None:
            self._writer.write(topic, msg, time_ns, sequence=step)

    def close(self) -> None:
        """Finish the file (idempotent). Never raises for a failed write: see ``failed``."""
        try:
            self._writer.finish()
        except WriterError as e:
            self._closed_error = self._closed_error or str(e)
