# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The simulator node: steps a Simulation at a fixed rate, takes wrenches, publishes state.

Bodies. Without ``scene_file``, one body built from the node's parameters, on topics at the
node's namespace (``wrench``, ``pose``, ...). With it, every body of the scene on its own topics
(``<name>/wrench``, ``<name>/pose``, ...), with ``<name>`` as its frame id.

Timing. Sim time is step_count * dt. A step-loop thread wakes on the steady clock once per
publish period (divided by real_time_factor) and steps as many whole publish periods as are due
(a late tick catches up by stepping, at most max_catchup periods, and is counted), publishing
pose, twist, odom and /clock after each. The executor thread only queues inputs and answers
services, so it sleeps while nothing arrives: rclpy's executor rebuilds its wait set on every
wake-up (ros2/design#305), which at 1 kHz would cost most of a core if it also drove the steps.
Inputs take effect at the start of the next period (at once while paused); what a run does
depends only on the inputs and the step at which each took effect, never on scheduling. In
lockstep (ros/lockstep.py) the step loop also waits, after each publish, for every
controller's answer to the state it published, and takes those answers itself
(ros/taken_inputs.py): a closed loop then depends on what the controllers answered, never on
when.

Collisions. When a body of the scene has colliders the Simulation steps a CollisionWorld, and
``collision_markers`` (visualization_msgs/MarkerArray: the colliders and the last step's
contact points) is published each period to whoever subscribes.
"""

from __future__ import annotations

import argparse
import collections
from dataclasses import replace
import math
import os
import signal
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Pose, PoseArray
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import InvalidQosOverridesError
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Empty, SetBool, Trigger
from visualization_msgs.msg import MarkerArray

try:  # not among ROS 2 Jazzy's PyPI wheels: tools/build_msgs.sh builds it into the venv
    from tf2_msgs.msg import TFMessage
except ImportError:  # then no /tf, said once at start
    TFMessage = None
try:  # the same
    import rb_sim_ros.ros.sim_interfaces as sim_interfaces
    from rb_sim_ros.ros.sim_interfaces import EntityStateInput, SimulationInterfaces
except ImportError:  # then no simulation_interfaces services, said once at start
    SimulationInterfaces = sim_interfaces = None

    class EntityStateInput:  # never made without them
        pass

from rb_sim_ros.core import jit
from rb_sim_ros.core.rigid_body import ZERO_WRENCH
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.ros import body_ports, node_params, ros_arguments, ros_messages
from rb_sim_ros.ros.body_ports import APPLIED_QOS, BodyPorts, OVERRIDABLE, TwistInput
from rb_sim_ros.ros.collision_markers import CollisionMarkers
from rb_sim_ros.ros.diagnostics import Diagnostics
from rb_sim_ros.ros.lockstep import HOLD, Lockstep
from rb_sim_ros.ros.node_config import config_from, stop_step, timeout_steps
from rb_sim_ros.ros.ros_messages import TF, TF_STATIC
from rb_sim_ros.ros.taken_inputs import TakenInputs
from rb_sim_ros.sim import precompile
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import (BodySpec, config_after, contact_tests, Delete,
                                       kernels_after, Reset, SetTwist, SetWrench, Simulation,
                                       Spawn, warm_up_bodies, warm_up_contacts)

__all__ = ['APPLIED_QOS', 'SimulatorNode', 'main']

# The node's own topics and services: (name, type, when it has it ('' always), what). The node
# creates them with the types of these tables (``_own``), and ``simulator --help`` lists them
# from the same, with body_ports' tables of a body's topics and sim_interfaces' services.
TOPICS = (
    ('/clock', ClockMsg, 'publish_clock', 'sim time (best effort)'),
    ('/diagnostics', DiagnosticArray, '', 'step cost, ticks, rejections, errors, every second'),
    ('poses', PoseArray, '', "every body's pose in world_frame, in scene order"),
    (TF, TFMessage or 'tf2_msgs/msg/TFMessage', 'publish_tf and a moving body',
     'world_frame -> each moving body with topics'),
    (TF_STATIC, TFMessage or 'tf2_msgs/msg/TFMessage', 'publish_tf and a static body',
     'world_frame -> each static body (transient local)'),
    ('collision_markers', MarkerArray, 'a body with colliders',
     "the colliders and the last step's contact points"),
)
SERVICES = (
    ('reset', Empty, '', 'every moving body back to its initial state'),
    ('pause', SetBool, '', 'data true pauses, false runs'),
    ('step', Trigger, '', 'one publish period, while paused'),
)
_TYPES = {name: t for name, t, _, _ in TOPICS + SERVICES}

# Most steps run between two looks at the stop flag: shutdown never waits for a long period.
_CHUNK_STEPS = 1000
# ... and about the wall time a chunk may take: where a step is slow (a heap of contacts), the
# chunks shrink to what runs in this time (one step at least, which nothing can interrupt).
_CHUNK_WALL_S = 0.05


def next_chunk(steps: int, seconds: float) -> int:
    """Steps of the next chunk after one of ``steps`` took ``seconds`` of wall time."""
    if steps <= 0 or not seconds > 0.0:
        return _CHUNK_STEPS
    return max(1, min(_CHUNK_STEPS, int(_CHUNK_WALL_S * steps / seconds)))


def describe_bodies(bodies, with_topics: int, shown: int = 10) -> str:
    """The start-up line's bodies: a moving body with its mass, a static one without (it has
    none that means anything: infinite in contacts); the first ``shown``, then a count."""
    text = ', '.join(f'{b.name} (static)' if b.static else f'{b.name} ({b.mass:g} kg)'
                     for b in bodies[:shown])
    if len(bodies) > shown:
        text += (f' and {len(bodies) - shown} more ({with_topics} with topics of their own, '
                 "all on 'poses')")
    return text


# Messages the recording's writer may have queued before the step loop waits for it.
MAX_BACKLOG = 10_000


class SimulatorNode(Node):
    """Rigid bodies on ROS topics; see docs/interface.md for topics, services and parameters."""

    def __init__(self, **kwargs) -> None:
        super().__init__('rb_sim', **kwargs)
        self._thread = self._recorder = self._lockstep = self._taken = None
        self._stop = threading.Event()
        self.done = threading.Event()  # the run ended by itself (stop_after, or its error)
        self.exit_code = 0
        # For run_summary (close() may run on a node that did not finish starting): when the
        # first period began, the periods then, the time spent in periods.
        self._first_period, self._first_periods, self._work_s = None, 0, 0.0
        self._periods = self._stop_step = 0
        self._chunk = _CHUNK_STEPS  # steps between two looks at the stop flag (next_chunk)
        try:
            self._start()
        except BaseException:  # a bad value or a signal while starting: leave nothing open
            self.close()
            raise

    # Topics take QoS overrides from parameters (body_ports.OVERRIDABLE); a bad one is the
    # user's input: refused in one line naming the topic, not a traceback.
    def create_publisher(self, msg_type, topic, *args, **kwargs):
        return self._endpoint(super().create_publisher, msg_type, topic, *args, **kwargs)

    def create_subscription(self, msg_type, topic, *args, **kwargs):
        return self._endpoint(super().create_subscription, msg_type, topic, *args, **kwargs)

    def _own(self, topic: str, *args, **kwargs):
        """A publisher of one of the node's TOPICS, of the type the table gives it."""
        return self.create_publisher(_TYPES[topic], topic, *args, **kwargs)

    @staticmethod
    def _endpoint(create, msg_type, topic, *args, **kwargs):
        try:
            return create(msg_type, topic, *args, **kwargs)
        except InvalidQosOverridesError as e:  # body_ports.OVERRIDABLE's check: its reason
            why = str(e).partition('are not valid: ')[2] or str(e)
        except (RuntimeError, TypeError, ParameterException) as e:
            # (RuntimeError: rcl refused it; TypeError: a value the C profile cannot hold.) A
            # first line that does not end a sentence is not a reason: the type then.
            lines = str(e).strip().splitlines()
            why = lines[0] if lines and not lines[0].endswith(':') else \
                f'{type(e).__name__}: its QoS profile was refused'
        raise ValueError(f"cannot create the endpoint of '{topic}' (check its "
                         f'qos_overrides parameters): {why}')

    def _start(self) -> None:
        for p in node_params.PARAMS:
            self.declare_parameter(p.name, p.default, ParameterDescriptor(
                description=p.description, read_only=p.read_only, dynamic_typing=True))
        values = {p.name: self.get_parameter(p.name).value for p in node_params.PARAMS}
        for name, value in values.items():
            node_params.check(name, value)
        self._scene = None
        if values['scene_file']:
            # Said first: a large scene takes seconds to read and check (the file is named
            # once, by the start-up line or by the refusal).
            self.get_logger().info('reading the scene (scene_file)')
            self._scene = load_scene(values['scene_file'])
        self.config = config_from(values, self._scene)
        self.diagnostics = Diagnostics()
        self._compiling = None
        # A first start (the kernels this scene steps with not in a writable cache yet): a
        # child compiles them while this process steps in the interpreter.
        parts = precompile.parts_of(self.config)
        first = (values['compile_in_background'] and jit.compiling() and
                 jit.cache_directory() is not None and not jit.precompiled(parts))
        if first:
            jit.run_interpreted()
        self.sim = Simulation(self.config)
        if first:
            self._compiling = precompile.Background(parts)
            self.diagnostics.compiling = f'process {self._compiling.pid} compiles them'
            self.get_logger().info(
                'the kernels are not compiled yet: stepping in the interpreter (the same bits, '
                f'slower) while process {self._compiling.pid} compiles {", ".join(parts)} '
                '(seconds to a minute, once)')
        # Compiles (or loads) the kernels: before the clock, not in a period. Interpreted:
        # nothing to do.
        self.sim.warm_up()
        self._v = values
        self._pending: collections.deque = collections.deque()
        self._lock = threading.Lock()  # the step loop against service and parameter callbacks
        self._wake = threading.Event()
        self._error_paused = False  # paused by an error (not by a user): reset resumes
        self._failures = 0
        self._paused = bool(values['start_paused'])
        self._timeout_steps = 0
        self._stop_step = stop_step(values, self.config)
        self._lockstep = Lockstep(None, values['lockstep_delay']) if values['lockstep'] \
            else None
        self._resent = 0.0  # when a state was last sent again to a controller not heard yet
        self._polled = 0  # when lockstep_poll last ran (monotonic ns)
        self._crowded: dict[str, int] = {}  # inputs with more than one publisher, said
        # In lockstep the step loop takes the answers itself, not the executor.
        self._taken = TakenInputs(self.context, self._callback_failed) \
            if self._lockstep is not None else None
        self.ports: dict[str, BodyPorts] = {}
        single = self._scene is None
        self._noise = node_params.imu_noise(values)
        # A spawned body's IMU noise stream: after those of the scene's bodies, in order.
        self._next_stream = len(self.config.bodies)
        for index, spec in enumerate(
                self.config.bodies[:values['max_body_topics'] if not single else 1]):
            self._add_ports(spec, '' if single else spec.name + '/', single, index)
        self._apply_settings()
        if self._lockstep is not None:
            self._declare_inputs(values['lockstep_inputs'])
            self.diagnostics.lockstep = self._lockstep
        self._tf = self._tf_msg = self._tf_static = self._pub_tf_static = None
        self._tf_filled = False  # the last publish filled /tf (a re-send may send it)
        self._tf_static_frames: list = []
        self._tf_static_due = False
        self._tf_on = bool(values['publish_tf'])
        if self._tf_on and TFMessage is None:
            self._tf_on = False
            self.get_logger().warning(
                'publish_tf: tf2_msgs is not installed, so no /tf (on a ROS install: '
                'ros-jazzy-tf2-msgs; in the PyPI venv tools/build_msgs.sh builds it)')
        over = {'qos_overriding_options': OVERRIDABLE}
        self._pub_clock = (self._own('/clock', QoSProfile(
            depth=1, reliability=ReliabilityPolicy.BEST_EFFORT), **over)
            if values['publish_clock'] else None)
        self._clock_msg = ClockMsg()
        self.diagnostics.create_publisher(self)
        self._pub_poses = self._own('poses', 10, **over)
        self._poses_msg = PoseArray()
        self._poses_msg.header.frame_id = values['world_frame']
        self._pub_markers = None
        self._bodies_changed()  # moving bodies, tf, poses, collision markers
        self.interfaces = None
        if SimulationInterfaces is not None:
            self.interfaces = SimulationInterfaces(self)
        else:
            self.get_logger().warning(
                'simulation_interfaces is not installed, so no standard simulator services (on '
                'a ROS install: ros-jazzy-simulation-interfaces; in the PyPI venv '
                'tools/build_msgs.sh builds it)')
        for name, callback in (('reset', self._on_reset), ('pause', self._on_pause),
                               ('step', self._on_step)):
            self.create_service(_TYPES[name], name, callback)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # Last, once every endpoint exists: a start refused for a bad value (a QoS override of
        # /clock, /tf, poses, ...) never creates, nor truncates, the file.
        self._recorder = _open_recorder(self, values)
        self._set_rate()
        if self._lockstep is not None:
            self._lockstep.expect(self.sim.time_ns)
        self._publish()
        self._thread = threading.Thread(target=self._loop, name='rb_sim_step_loop', daemon=True)
        self._thread.start()
        self.get_logger().info(
            f'simulating {describe_bodies(self.config.bodies, len(self.ports))}; '
            f'dt {self.config.dt} s, publishing every {self.config.steps_per_publish} steps, '
            f'real_time_factor '
            f'{values["real_time_factor"]}')
        if self._recorder is not None:
            self.get_logger().info(f"recording to '{os.path.abspath(values['record'])}'")
        if self._lockstep is not None:
            declared = self._lockstep.declared
            self.get_logger().info(
                'lockstep: each state waits for the answers of ' +
                (', '.join(f"'{self.ports[b].answers.topic_name}'" for b in declared)
                 if declared else 'every wrench_stamped with a publisher at step 0') +
                (f' ({values["lockstep_delay"]} periods of delay)'
                 if values['lockstep_delay'] else ''))
        if self._stop_step:
            self.get_logger().info(f'stopping at t = {self._stop_step * self.config.dt:.9g} s '
                                   '(stop_after)')

    def _declare_inputs(self, value) -> None:
        """lockstep_inputs: body names or their wrench_stamped topics (relative to the
        node's namespace, or absolute); ValueError naming an entry that is neither."""
        names = node_params.names_list(value)
        if not names:
            return
        topics = {port.answers.topic_name: body for body, port in self.ports.items()
                  if port.answers is not None}
        bodies = []
        for name in names:
            body = name if name in self.ports else None
            if body is None:
                try:
                    body = topics.get(self.resolve_topic_name(name))
                except Exception:  # noqa: B902 - rcl's error for a name that is not one
                    body = None
            if body is None:
                raise ValueError(
                    f"lockstep_inputs: '{name}' is neither a body with topics nor its "
                    f"wrench_stamped (there are {', '.join(sorted(topics)) or 'none'})")
            if not self.sim.is_moving(body):
                raise ValueError(f"lockstep_inputs: '{name}' is a static body: nothing to "
                                 'command')
            bodies.append(body)
        self._lockstep.declared = sorted(set(bodies))
        self._lockstep.join(self._lockstep.declared)

    def _add_ports(self, spec: BodySpec, prefix: str, single: bool, stream: int,
                   moving: bool | None = None) -> None:
        v = self._v
        moving = self.sim.is_moving(spec.name) if moving is None else moving
        self.ports[spec.name] = BodyPorts(
            self, spec.name, prefix, v['world_frame'],
            node_params.body_frame(v, spec.name, single), v['twist_frame'], _Settings(self),
            self._queue, self._reject, spec.points, moving, self._noise, stream,
            answer=self._answer if self._lockstep is not None else None,
            answers_group=self._taken.group if self._taken is not None else None)
        if self._taken is not None:
            self._taken.add(self.ports[spec.name].answers)

    @property
    def templates(self) -> tuple:
        """The scene's templates of bodies to spawn (BodySpec)."""
        return self._scene.templates if self._scene is not None else ()

    def _update_tf(self) -> None:
        """/tf for the moving bodies with topics, every period; /tf_static for the static
        ones (transient local, depth 1: what tf2_ros's static broadcaster offers), sent at the
        next publish whenever that set changes (at start, and after a spawn or a delete)."""
        if not self._tf_on:
            return
        over = {'qos_overriding_options': OVERRIDABLE}
        world = self._v['world_frame']
        self._tf_msg = ros_messages.tf_message(TFMessage, world,
                                               [p.body_frame for p in self._moving])
        self._tf_filled = False  # (not sent again before a publish fills it)
        if self._moving and self._tf is None:
            self._tf = self._own(TF, ros_messages.tf_qos(TF), **over)
        static = [p for p in self.ports.values() if not self.sim.is_moving(p.name)]
        frames = [p.body_frame for p in static]
        if frames == self._tf_static_frames:
            return
        self._tf_static_frames = frames
        self._tf_static = ros_messages.tf_message(TFMessage, world, frames)
        self._tf_static_poses = [self.sim.pose_twist(p.name)[:2] for p in static]
        if self._pub_tf_static is None:
            self._pub_tf_static = self._own(TF_STATIC, ros_messages.tf_qos(TF_STATIC),
                                            **over)
        self._tf_static_due = True

    # -- spawning and deleting -------------------------------------------------------------
    def change_bodies(self, event, place=None) -> str:
        """Apply a Spawn or a Delete now, at the current step (after the inputs queued before
        it): the body's topics come or go with it, and the recording has it as an input.
        ``place``: for a spawn, a function of its BodySpec giving the spec to spawn, called
        under the lock after the queued inputs (a pose relative to another body is resolved
        against that body's state then); its ValueError propagates and nothing changes.
        Returns '' or why it was refused (then nothing changed)."""
        index, why, placing = self.change_all([(event, place)])
        if placing:
            raise ValueError(why)
        return why

    def change_all(self, changes) -> tuple[int, str, bool]:
        """Apply every (event, place) of ``changes`` as change_bodies does, all at the same
        step, or none: (-1, '', False) when all were applied, else (the index of the one
        refused, why, whether its ``place`` refused it with a ValueError), the ones before it
        taken back (each spawn then deleted at the same step: both recorded)."""
        # The first moving collider of the run, or the last one deleted: the kernels that
        # then step the bodies compiled (or loaded) now, before the lock, not while the step
        # loop waits (a scene's start compiled the kernels of its own kind only).
        kinds = [kernels_after(self.sim, event) for event, _ in changes]
        if 'contact' in kinds:  # the world's step with the tests the bodies then need
            after = self.config
            for event, _ in changes:
                after = config_after(after, event)
            warm_up_contacts(after, contact_tests(after, self.sim.world))
        elif any(k is not None for k in kinds):
            warm_up_bodies(self.config, blocks='blocks' in kinds)
        with self._lock:
            if not self._guarded(self._drain):
                return 0, self.diagnostics.error, False
            done = []
            for index, (event, place) in enumerate(changes):
                placing = False
                try:
                    if place is not None:
                        event = Spawn(place(event.spec))
                except ValueError as e:
                    why, placing = str(e), True
                else:
                    why = self._change(event)
                if why:
                    for spawned in reversed(done):  # taken back: none of them
                        self._change(Delete(spawned))
                    return index, why, placing
                if isinstance(event, Spawn):
                    done.append(event.spec.name)
        return -1, '', False

    def _change(self, event) -> str:
        """change_bodies' work, the lock held: '' or why nothing changed."""
        spawn = event.spec if isinstance(event, Spawn) else None
        if spawn is not None:
            if any(b.name == spawn.name for b in self.config.bodies):
                return f"there is a body named '{spawn.name}' already"
            try:  # its topics first: a bad QoS override refuses the spawn whole
                self._add_ports(spawn, spawn.name + '/', False, self._next_stream,
                                moving=not spawn.static)
            except ValueError as e:
                return str(e)
        try:
            self.sim.apply(event)
        except (ValueError, IntegrationError) as e:
            if spawn is not None:
                self._drop_ports(spawn.name)
            return str(e)
        self.config = self.sim.config
        step, t_ns = self.sim.step_count, self.sim.time_ns
        if spawn is not None:
            self._next_stream += 1
            if self._recorder is not None:
                topics = self.ports[spawn.name].topics() if not spawn.static else {}
                self._recorder.spawned(step, t_ns, event, topics)
        else:
            self._drop_ports(event.body)
            if self._lockstep is not None and self._lockstep.leave(event.body, deleted=True):
                self.get_logger().info(f"lockstep: '{event.body}' deleted: its answers "
                                       'are not waited for any more')
            if self._recorder is not None:
                self._recorder.deleted(step, t_ns, event.body)
        self._bodies_changed()
        return ''

    def _drop_ports(self, name: str) -> None:
        port = self.ports.pop(name, None)
        if port is not None:
            if self._taken is not None:
                self._taken.remove(port.answers)
            port.destroy(self)

    def _bodies_changed(self) -> None:
        """What follows the set of bodies: tf, poses, collision markers."""
        self._moving = [p for p in self.ports.values() if self.sim.is_moving(p.name)]
        self._update_tf()
        self._poses_msg.poses = [Pose() for _ in self.config.bodies]
        self._markers = None
        if self.config.has_colliders:
            self._markers = CollisionMarkers(self.config, self._v['world_frame'])
            if self._pub_markers is None:
                self._pub_markers = self._own('collision_markers', 1,
                                              qos_overriding_options=OVERRIDABLE)

    # -- inputs (callbacks only queue; the step loop applies) ------------------------------
    def _queue(self, event) -> None:
        """Queue an input for the start of the next period; while paused that is now."""
        self._pending.append(event)
        if self._paused:
            with self._lock:
                self._guarded(self._drain)

    def _drain(self) -> None:
        while self._pending:
            self._apply(self._pending.popleft())

    def _guarded(self, work) -> bool:
        """Run ``work`` (the lock held); an unexpected error pauses the node with ERROR, as in
        the step loop, instead of escaping a callback. False if it failed."""
        try:
            work()
            return True
        except Exception as e:  # noqa: B902 - a bug must not leave a client unanswered
            self._fail(f'{type(e).__name__}: {e}')
            return False

    def _reject(self, what: str, error: Exception) -> None:
        self.diagnostics.rejected += 1
        self.get_logger().warning(f'rejected {what}: {error}', throttle_duration_sec=1.0)

    def reset_events(self) -> list:
        """A reset of every moving body (applied together: at the same step)."""
        return [Reset(body=spec.name) for spec in self.config.bodies if not spec.static]

    def _on_reset(self, request, response):
        self.reset_all()
        return response

    def reset_all(self) -> bool:
        """Every moving body back to its initial state, all at the same step (now if paused,
        else at the next period); an error pause is cleared and the run goes on. False if
        applying it failed (the reason in diagnostics)."""
        resets = self.reset_events()
        if self.interfaces is not None:
            self.interfaces._epoch += 1  # a stepping call under way stops at its next period
        with self._lock:
            self._pending.extend(resets)
            ok = self._guarded(self._drain) if self._paused else True
            if ok:
                self.diagnostics.error = ''
                if self._error_paused:  # the state that failed is gone: run again
                    self._guarded(self._resume)
        return ok

    def _resume(self) -> None:
        """Run (again) from the current step; clears an error that had paused the node."""
        self._drain()  # inputs queued while paused take effect at this step
        self._paused = self._error_paused = False
        self.diagnostics.error = ''
        if self._lockstep is not None:  # lockstep_timeout counts from now again
            self._lockstep.rearm()
        self._anchor()
        self._wake.set()

    def _fail(self, reason: str) -> None:
        """Stop stepping on an error: logged once, /diagnostics ERROR, services still answer;
        reset or unpause clear it. While paused by an error, a later one (the publish that
        follows a failed step finds the state not finite) is logged, and /diagnostics keeps
        the first: the cause."""
        first = not (self._error_paused and self.diagnostics.error)
        self._paused = self._error_paused = True
        self._failures += 1
        if not first:
            self.get_logger().error(f'and then: {reason}')
            return
        self.diagnostics.error = reason
        if self._stop_step:  # a run that ends by itself has nobody to reset it: it ends
            self.get_logger().error(f'{reason}; ending the run (stop_after): exit 3')
            self._finish(3)
            return
        self.get_logger().error(f'{reason}; paused at the last finite state (reset or unpause '
                                'to go on)')

    def _on_pause(self, request, response):
        with self._lock:
            if request.data:
                # The user's pause: a later reset must not run on by itself.
                self._paused, self._error_paused = True, False
                ok = True
            else:
                ok = self._guarded(self._resume)
        response.success = ok
        response.message = ('paused' if self._paused else 'running') if ok else \
            self.diagnostics.error
        return response

    def _on_step(self, request, response):
        if self.interfaces is not None and self.interfaces.stepping:
            response.success = False
            response.message = 'a step_simulation or simulate_steps is under way'
            return response
        if not self._paused:
            response.success = False
            response.message = 'not paused: call pause with data: true first'
            return response
        if self._lockstep is not None and not self._lockstep.ready.is_set():
            response.success = False
            response.message = f'lockstep: {self._lockstep.describe()}'
            return response
        with self._lock:
            failures = self._failures
            self._guarded(self._period)
            self._error_paused = False  # stepping by hand: the user's pause goes on
            ok = self._failures == failures
        response.success = ok
        response.message = (f'stepped to t = {self.sim.time_ns * 1e-9:.9f} s' if ok else
                            f'step failed: {self.diagnostics.error}')
        return response

    # -- the step loop ---------------------------------------------------------------------
    def _anchor(self) -> None:
        self._anchor_wall = time.monotonic_ns()
        self._anchor_period = self._periods

    def _set_rate(self) -> None:
        rtf = self._v['real_time_factor']
        period = self.config.dt * self.config.steps_per_publish
        self._period_wall_ns = period / rtf * 1e9 if rtf > 0 else 0.0
        self._anchor()

    def _loop(self) -> None:
        """The step-loop thread. It never dies while the node lives: an unexpected error is
        logged once with its reason, pauses the node and shows as ERROR in /diagnostics;
        reset or unpause go on."""
        while not self._stop.is_set():
            try:
                self._loop_once()
            except Exception as e:  # noqa: B902 - whatever it was, the node must not go mute
                if self._stop.is_set():
                    return
                with self._lock:
                    self._fail(f'step loop error: {type(e).__name__}: {e}')
                self._stop.wait(0.1)  # (an error that comes back at once does not spin)

    def _loop_once(self) -> None:
        if self._compiling is not None:
            self._check_compiling()
        if self._paused:
            if self._taken is not None:  # lockstep: its answers are taken while paused too,
                self._taken.take(0.02)  # and inputs that come and go are seen
                self._lockstep_poll_now(timing=False)
            else:
                self._wake.wait(0.1)
                self._wake.clear()
            with self._lock:  # /diagnostics goes on while paused (it may say why)
                self.diagnostics.maybe_publish(self, self._v['real_time_factor'])
        elif self._lockstep is not None:
            self._lockstep_once()
        elif self._period_wall_ns == 0.0:  # as fast as possible
            self._wait_for_recorder()
            self._periods_now(10, as_fast_as_possible=True)
            time.sleep(0)  # let the executor thread take the GIL for inputs
        else:
            self._paced(lambda s: self._stop.wait(min(s, 1.0)))

    def _due_at(self) -> float:
        """When the next period is due by the wall clock (monotonic ns; rtf > 0)."""
        return self._anchor_wall + (self._periods + 1 - self._anchor_period) * \
            self._period_wall_ns

    def _paced(self, wait) -> None:
        """At real_time_factor > 0: step the periods due by now, or ``wait(seconds)`` until
        the next one is due."""
        due_at = self._due_at()
        now = time.monotonic_ns()
        if now < due_at:
            wait((due_at - now) * 1e-9)
            return
        self._wait_for_recorder()
        with self._lock:
            due = self._tick(now, now - due_at)
        self._periods_now(due, as_fast_as_possible=False)

    def _lockstep_once(self) -> None:
        """The step loop in lockstep: it takes the answers itself (taken_inputs), and steps
        a period once they are all in (as soon as they are at real_time_factor 0, else when
        the period is due too); while they are not, it says who is missing now and then."""
        ls = self._lockstep
        if ls.ready.is_set():
            if self._period_wall_ns == 0.0:
                self._wait_for_recorder()
                self._periods_now(1, as_fast_as_possible=True)
                return
            with self._lock:
                if ls.ready_ns > self._due_at():
                    # The answers came after the period was due: it is due from then. The
                    # wait for a controller is neither lateness nor a period to drop.
                    self._anchor_wall = ls.ready_ns - self._period_wall_ns
                    self._anchor_period = self._periods
            self._paced(lambda s: self._taken.take(min(s, 0.05)))
            return
        self._taken.take(0.05)
        self._lockstep_poll_now(timing=True)

    def _lockstep_poll_now(self, timing: bool) -> None:
        """lockstep_poll, every 50 ms at most while an answer is missing."""
        now = time.monotonic_ns()
        if self._lockstep.ready.is_set() or now - self._polled < 50_000_000:
            return
        self._polled = now
        with self._lock:
            if self._paused != timing and not self._lockstep.ready.is_set():
                self.lockstep_poll(timing)

    def _check_compiling(self) -> None:
        """Once the child compiling the kernels is done, go on with them (loaded from the
        cache), between two periods: the run's bits do not change."""
        why = self._compiling.poll()
        if why is None or self._stop.is_set():
            return
        child, self._compiling = self._compiling, None
        try:
            with self._lock:
                jit.run_compiled()
                if why:
                    self.get_logger().warning(f'{why}; compiling in this process instead (the '
                                              'step loop waits for it)')
                elif not jit.precompiled(precompile.parts_of(self.sim.config, self.sim.world)):
                    # a spawn or delete meanwhile needs the other part (a first moving
                    # collider, or none left)
                    self.get_logger().warning(
                        'the bodies spawned or deleted meanwhile step with kernels the child '
                        'did not compile: compiling them in this process (the step loop waits '
                        'for it)')
                self.sim.warm_up()
                self.diagnostics.compiled()
                self._anchor()  # real time goes on from here: no catching up the wait
                self.get_logger().info(
                    f'kernels compiled ({time.monotonic() - child.started:.0f} s): stepping '
                    f'compiled from step {self.sim.step_count}')
        finally:
            child.stop()

    def _periods_now(self, count: int, as_fast_as_possible: bool) -> None:
        """Up to ``count`` periods, the lock taken for each (a service waits one at most);
        stops early on a pause, on shutdown, or when real_time_factor changes mode."""
        lockstep = self._lockstep
        for _ in range(count):
            with self._lock:
                if self._paused or self._stop.is_set() or \
                        (self._period_wall_ns == 0.0) != as_fast_as_possible or \
                        (lockstep is not None and not lockstep.ready.is_set()):
                    return
                self._period()

    def _wait_for_recorder(self) -> None:
        """Back-pressure: while the recording's writer has more than MAX_BACKLOG messages to
        write, wait (the lock free) rather than keep the run in memory. Time is steps, so
        waiting changes nothing of the run; a killed node then loses only the backlog."""
        recorder = self._recorder
        while (recorder is not None and recorder is self._recorder and not recorder.failed
               and recorder.pending > MAX_BACKLOG and not self._stop.is_set()):
            time.sleep(0.002)

    def _tick(self, now: int, lateness_ns: float) -> int:
        """How many periods are due now (at most max_catchup; the rest is dropped, counted)."""
        if self._paused or self._period_wall_ns == 0.0:
            return 0
        due = self._anchor_period + int((now - self._anchor_wall) / self._period_wall_ns) \
            - self._periods
        self.diagnostics.tick(lateness_ns, due > 1)
        if due > self._v['max_catchup']:
            self.diagnostics.dropped_periods += due - self._v['max_catchup']
            due = self._v['max_catchup']
            self._anchor_wall = now
            self._anchor_period = self._periods + due
        return due

    def _period(self, steps: int | None = None) -> None:
        """One publish period (or ``steps`` physics steps): apply inputs, step, publish."""
        sim = self.sim
        started = time.perf_counter()
        if self._first_period is None:
            self._first_period, self._first_periods = started, self._periods
        if self._lockstep is not None:  # the answers due now, before any other input
            for body, answer in self._lockstep.take():
                self._answered(body, answer)
        self._drain()
        if self._timeout_steps:
            for port in self._moving:
                if (sim.step_count - port.last_command_step >= self._timeout_steps
                        and sim.wrench(port.name) != ZERO_WRENCH):
                    self._apply(SetWrench(ZERO_WRENCH, port.name), command=False)
        t0 = time.perf_counter_ns()
        start = sim.step_count
        try:
            # In chunks, so that a long period (many steps, many bodies) still stops at once
            # on shutdown; chunking does not change a run.
            end = start + (self.config.steps_per_publish if steps is None else steps)
            if self._stop_step:
                end = min(end, max(start, self._stop_step))
            while sim.step_count < end and not self._stop.is_set():
                n = min(end - sim.step_count, self._chunk)
                chunk_t0 = time.perf_counter()
                sim.run(n)
                self._chunk = next_chunk(n, time.perf_counter() - chunk_t0)
        except IntegrationError as e:
            self._fail(str(e))
        self.diagnostics.stepped(sim.step_count - start, time.perf_counter_ns() - t0,
                                 sim.time_ns)
        self.diagnostics.contacts = sim.contact_stats()
        self._periods += 1
        if self._recorder is not None and self._recorder.failed:
            recorder, self._recorder = self._recorder, None
            # Kept apart from the physics' error: reset and unpause do not clear it.
            self.diagnostics.recording_error = recorder.failed  # what, where, what to do
            recorder.close()
            if self._stop_step:  # a run that ends by itself is for its recording: it ends
                self.get_logger().error(f'{recorder.failed}; ending the run (stop_after): '
                                        'exit 3')
                self._finish(3)
            else:
                self.get_logger().error(f'{recorder.failed}; simulating on without it')
        if self._stop.is_set():
            return
        final = self._stop_step and sim.step_count >= self._stop_step
        if self._lockstep is not None:  # (the last state's answers are taken, never applied)
            self._lockstep.expect(sim.time_ns)  # before the state goes out: answers may race
        self._publish()
        if self._lockstep is not None:
            self._lockstep.sent()
        self._work_s += time.perf_counter() - started
        if final:
            self.get_logger().info(f'stop_after: stepped to t = {sim.time_ns * 1e-9:.9f} s; '
                                   'ending the run')
            self._finish(0)

    def run_summary(self) -> str:
        """A run that ends by itself, or in lockstep: its periods a second from its first
        step, the node's own work a period, and lockstep's counts ('' for other runs)."""
        lockstep, first = self._lockstep, self._first_period
        if not (self._stop_step or lockstep is not None) or first is None or \
                self._periods <= self._first_periods:
            return ''
        n = self._periods - self._first_periods
        wall = time.perf_counter() - first
        text = (f'{n} periods in {wall:.3f} s ({n / wall:.0f} periods/s); the node'
                f"'s own work {self._work_s / n * 1e6:.0f} us a period")
        if lockstep is not None:
            c = lockstep.counters
            text += (f'; lockstep: {c.waited_ns * 1e-9 / wall:.0%} of the time waiting for '
                     f'answers, refused {c.refused}, repeated {c.repeated}, timed out '
                     f'{c.timeouts}')
        return text

    def _finish(self, code: int) -> None:
        """End the run by itself (stop_after: 0; any error of a stop_after run: 3): the step
        loop stops, and main() closes the node (the recording finished) and exits ``code``.
        The first end stands (an error in the last period is not undone by reaching it)."""
        if self.done.is_set():
            return
        self.exit_code = code
        self._stop.set()
        self.done.set()

    # -- lockstep --------------------------------------------------------------------------
    def _answer(self, body: str, stamp_ns: int, answer) -> bool:
        """A wrench_stamped of ``body`` (the step loop's thread): True if lockstep took it or
        refused it, False if it is an ordinary input (not a lockstep input)."""
        ls = self._lockstep
        with self._lock:  # not while a delete takes the body away (it would join again)
            port = self.ports.get(body)
            if port is None or port.answers is None:
                return True  # a deleted body's, taken as it went
            why = ls.offer(body, stamp_ns, answer)
        if why == 'open':
            return False
        if why:
            self.get_logger().warning(f"lockstep: refused an answer on '{body}': {why}",
                                      throttle_duration_sec=1.0)
        return True

    def _answered(self, body: str, answer) -> None:
        """Apply a lockstep answer now: a wrench, or HOLD (no change, but a command all the
        same: command_timeout counts from it)."""
        if answer is HOLD:
            port = self.ports.get(body)
            if port is not None:
                port.last_command_step = self.sim.step_count
        else:
            self._apply(answer)

    def lockstep_poll(self, timing: bool = True) -> None:
        """While the answers to a state are not all in (the lock held): take in inputs that
        came or went, send the state again to a controller not heard from yet, and, if
        ``timing`` (not while the user paused: the wait is the user's then), time out as
        lockstep_timeout says; /diagnostics keeps saying what is awaited."""
        self._lockstep_members()
        self._lockstep_resend()
        if timing:
            self._lockstep_timeout()
        self.diagnostics.maybe_publish(self, self._v['real_time_factor'])

    def _lockstep_members(self) -> None:
        """Inputs that came (before step 0) or went (no publisher any more), said."""
        ls = self._lockstep
        if not ls.started:  # before step 0: every input there is (or was declared) waits
            if ls.declared is None:
                ls.join(b for b, p in self.ports.items()
                        if self.sim.is_moving(b) and p.answering())
            else:
                ls.join(ls.declared)
        for body in ls.missing():  # gone: no publisher any more (a controller that stopped)
            port = self.ports.get(body)
            if (ls.started or ls.declared is None) and (port is None or not port.answering()):
                if ls.leave(body):
                    self._lockstep_note('left', [body], f"'{body}' has no controller any "
                                        'more: not waited for (its wrench held)')
        for body in ls.inputs():  # two controllers on one input: the first answer stands
            port = self.ports.get(body)
            count = port.answering() if port is not None else 0
            if count > 1 and self._crowded.get(body) != count:
                self.get_logger().warning(
                    f"lockstep: '{port.answers.topic_name}' has {count} publishers: the "
                    'first answer to each state is taken, a different second one refused')
            self._crowded[body] = count
        for note in ls.notes:
            self.get_logger().info(f'lockstep: {note}')
        ls.notes.clear()

    def _lockstep_resend(self) -> None:
        """The state again, every 0.25 s, to a controller never heard from: its subscription
        may have matched after the state went out. A hint if that goes on."""
        ls = self._lockstep
        unheard = ls.unheard()
        now = time.monotonic()
        if not unheard or now - self._resent < 0.25:
            return
        self._resent = now
        self._republish()
        waited = ls.waited()
        if waited >= 2.0:
            topics = ', '.join(f"'{self.ports[b].answers.topic_name}'" for b in unheard
                               if b in self.ports and self.ports[b].answering())
            if topics:
                self.get_logger().warning(
                    f'lockstep: {topics} has a publisher but no answer in {waited:.0f} s: '
                    'does its controller subscribe to the state (its topic, and a QoS that '
                    'matches), and copy its stamp?', throttle_duration_sec=10.0)

    def _lockstep_timeout(self) -> None:
        """lockstep_timeout: step on with the wrenches held, or end in an error."""
        ls = self._lockstep
        timeout = self._v['lockstep_timeout']
        if timeout and ls.waited() >= timeout and not ls.ready.is_set():
            late = ls.missing()
            who = ', '.join(late) if late else 'any controller (none has a publisher)'
            if self._v['lockstep_on_timeout'] == 'hold':
                ls.time_out()
                self._lockstep_note('timeout', late, f'no answer from {who} within '
                                    f'lockstep_timeout ({timeout:g} s): stepping on with '
                                    'their wrenches held')
            else:
                self._lockstep_note('timeout', late, '')
                self._fail(f'lockstep: no answer from {who} to t = {ls.awaited * 1e-9:.9f} s '
                           f'within lockstep_timeout ({timeout:g} s)')

    def _callback_failed(self, error: Exception) -> None:
        """An answer's callback raised (taken_inputs): said, and the loop goes on."""
        self.get_logger().error(f'lockstep: handling an answer failed: '
                                f'{type(error).__name__}: {error}', throttle_duration_sec=1.0)

    def _lockstep_note(self, what: str, bodies: list, text: str) -> None:
        if text:
            self.get_logger().warning(f'lockstep: {text}')
        if self._recorder is not None:
            self._recorder.lockstep(self.sim.step_count, self.sim.time_ns, what, bodies)

    def _republish(self) -> None:
        for port in self.ports.values():
            port.republish()
        if self._tf is not None and self._tf_filled and self._tf.get_subscription_count():
            self._tf.publish(self._tf_msg)
        if self._pub_clock is not None and self._pub_clock.get_subscription_count():
            self._pub_clock.publish(self._clock_msg)

    def _apply(self, event, command: bool = True) -> None:
        if isinstance(event, EntityStateInput):  # pose and twist, now in the world frame
            try:  # both or neither
                events = event.events(self.sim)
            except ValueError as e:
                self._reject('set_entity_state', e)
                return
            for e in events:
                self._apply(e)
            return
        if isinstance(event, TwistInput):  # turned into the world frame now, at its step
            lin, ang = event.linear, event.angular
            if event.in_body:
                q = self.sim.pose_twist(event.body)[1]
                r = ros_messages.rotation_from_quaternion(q)
                lin, ang = ros_messages.rotate(r, lin), ros_messages.rotate(r, ang)
            event = SetTwist(lin, ang, event.body)
        elif isinstance(event, Reset) and event.position is None:
            # Spelled out, so that the recording holds the state reset to.
            event = Reset.to_initial(self.config.body(event.body))
        name = event.body or self.config.bodies[0].name
        moving = self.sim.is_moving(name)
        held = self.sim.wrench(name) if moving else None
        try:
            self.sim.apply(event)
        except (ValueError, IntegrationError) as e:
            self._reject(type(event).__name__, e)
            return
        port = self.ports.get(name)  # None for a body of a large scene without topics
        if port is not None and isinstance(event, SetWrench) and command:
            port.last_command_step = self.sim.step_count
        now = self.sim.wrench(name) if moving else None
        if isinstance(event, SetWrench) and now == held:
            return  # a re-sent wrench: no change, so neither published nor recorded as one
        if port is not None and now != held:
            port.applied(now, self.sim.time_ns)
        if self._recorder is not None:
            self._recorder.event(self.sim.step_count, self.sim.time_ns, event)

    def _publish(self) -> None:
        sim = self.sim
        t_ns = sim.time_ns
        failed = False
        self._tf_filled = False
        for port in self.ports.values():
            moving = sim.is_moving(port.name)  # a static body is not recorded: it never moves
            if not port.publish(sim, self._recorder if moving else None,
                                fill=self._lockstep is not None):
                failed = True
                self._fail(f"body '{port.name}' has a non-finite state at step "
                           f'{sim.step_count}; not published')
        listened = self._tf is not None and self._tf.get_subscription_count()
        if self._tf is not None and not failed and (
                self._recorder is not None or self._lockstep is not None or listened):
            # (in lockstep filled all the same: a state not answered is sent again)
            ros_messages.fill_tf(self._tf_msg, t_ns,
                                 [sim.pose_twist(p.name)[:2] for p in self._moving])
            self._tf_filled = True
            if listened or self._recorder is not None:
                self._tf.publish(self._tf_msg)
            if self._recorder is not None:
                self._recorder.tf(TF, sim.step_count, t_ns, self._tf_msg)
        if self._pub_poses.get_subscription_count():
            self._fill_poses(t_ns)
        if self._tf_static_due and not failed:  # stamped when sent (replay does the same)
            self._tf_static_due = False
            ros_messages.fill_tf(self._tf_static, t_ns, self._tf_static_poses)
            self._pub_tf_static.publish(self._tf_static)
            if self._recorder is not None:
                self._recorder.tf(TF_STATIC, sim.step_count, t_ns, self._tf_static)
        if self._markers is not None and self._pub_markers.get_subscription_count():
            poses = {b.name: sim.pose_twist(b.name)[:2] for b in self.config.bodies}
            self._pub_markers.publish(self._markers.fill(t_ns, poses, sim.last_contacts()))
        if self._pub_clock is not None:  # (best effort, no history: to whoever listens now)
            self._clock_msg.clock = ros_messages.time_msg(t_ns)
            if self._pub_clock.get_subscription_count():
                self._pub_clock.publish(self._clock_msg)
        self.diagnostics.maybe_publish(self, self._v['real_time_factor'])

    def _fill_poses(self, t_ns: int) -> None:
        """Every body's pose, in scene order, as one PoseArray (what a large scene has instead
        of per-body topics); not sent if one is not finite."""
        msg = self._poses_msg
        msg.header.stamp = ros_messages.time_msg(t_ns)
        for spec, pose in zip(self.config.bodies, msg.poses):
            x, q = self.sim.pose_twist(spec.name)[:2]
            if not all(math.isfinite(c) for c in x + q):
                return
            pose.position.x, pose.position.y, pose.position.z = x
            o = pose.orientation
            o.x, o.y, o.z, o.w = q
        self._pub_poses.publish(msg)

    # -- parameters ------------------------------------------------------------------------
    def _apply_settings(self) -> None:
        self._timeout_steps = timeout_steps(self._v, self.config)

    def _on_set_parameters(self, params) -> SetParametersResult:
        if not any(p.name in node_params.BY_NAME for p in params):
            # (qos_overrides.* declared for a spawned body's topics, the lock held: not ours)
            return SetParametersResult(successful=True)
        new = dict(self._v)
        try:
            for p in params:
                if p.name not in node_params.BY_NAME:
                    continue
                node_params.check(p.name, p.value)
                new[p.name] = p.value
            config = config_from(new, self._scene)
            timeout_steps(new, config)
        except ValueError as e:
            return SetParametersResult(successful=False, reason=str(e))
        except Exception as e:  # noqa: B902 - a bug must refuse the value, not kill the node
            return SetParametersResult(successful=False, reason=f'{type(e).__name__}: {e}')
        with self._lock:
            try:
                # The bodies of the run now (spawned, deleted), with the parameters' initial
                # states for those that came from them.
                own = {b.name: b for b in config.bodies}
                config = replace(config, bodies=tuple(
                    b if b.name in self.sim.spawned else own.get(b.name, b)
                    for b in self.sim.config.bodies))
                self.sim.set_initial_states(config)  # used by the next reset
            except ValueError as e:
                return SetParametersResult(successful=False, reason=str(e))
            rtf_changed = new['real_time_factor'] != self._v['real_time_factor']
            self._v = new
            self.config = config
            self._apply_settings()
            if rtf_changed:
                self._set_rate()
        return SetParametersResult(successful=True)

    def close(self) -> None:
        """Stop and join the step loop, then finish the recording (idempotent; safe on a
        node that did not finish starting)."""
        self._stop.set()
        child, self._compiling = getattr(self, '_compiling', None), None
        if child is not None:  # first: the step loop may be about to switch to it
            child.stop()
        wake = getattr(self, '_wake', None)
        if wake is not None:
            wake.set()
        thread = self._thread
        if thread is not None and thread.is_alive() and \
                threading.current_thread() is not thread:
            thread.join()
        summary = self.run_summary()
        if summary:  # said on stderr, as below
            print(f'[rb_sim] {summary}', file=sys.stderr)
        recorder, self._recorder = self._recorder, None
        if recorder is not None:
            recorder.close()
            # Said on stderr: after a signal the logger's context may be gone already.
            print(f"[rb_sim] recording finished: '{os.path.abspath(self._v['record'])}'",
                  file=sys.stderr)


class _Settings:
    """The node's current parameter values, read when a message arrives."""

    def __init__(self, node: SimulatorNode) -> None:
        self._node = node

    def __getitem__(self, name: str):
        return self._node._v[name]


def _open_recorder(node: SimulatorNode, values: dict):
    if not values['record']:
        return None
    from rb_sim_ros.ros.node_recorder import NodeRecorder
    topics = {name: p.topics() for name, p in node.ports.items()
              if node.sim.is_moving(name)}  # a static body never moves: nothing to record
    # Both while /tf is on: a body spawned later may need either.
    tf_topics = [TF, TF_STATIC] if node._tf_on else []
    return NodeRecorder(values['record'], node.config, values, topics,
                        overwrite=bool(values['record_overwrite']), tf_topics=tf_topics)


def type_name(t) -> str:
    """'geometry_msgs/msg/PoseStamped' of a message, service or action class (or a name)."""
    if isinstance(t, str):
        return t
    package, kind = t.__module__.split('.')[:2]
    return f'{package}/{kind}/{t.__name__}'


def endpoints_text() -> str:
    """What ``simulator --help`` says of the node's topics, services and action: from the
    tables the node creates them from (body_ports, TOPICS, SERVICES, sim_interfaces)."""
    def rows(table, when=lambda row: row[2]):
        return [f'    {row[0]}  {type_name(row[1])}: {row[-1]}'
                + (f' (with {when(row)})' if when(row) else '') for row in table]

    def moving(row):
        return 'a moving body' if row[0] in body_ports.MOVING_ONLY else ''
    lines = ["Topics (relative to the node's namespace; with scene_file, each body's own "
             'under <body>/, for the first max_body_topics bodies):',
             '  subscribed, per body:', *rows(body_ports.SUBSCRIBED, lambda row: ''),
             '  published, per body:', *rows(body_ports.PUBLISHED, moving),
             '  published by the node:', *rows(TOPICS), 'Services:', *rows(SERVICES)]
    if sim_interfaces is None:
        lines.append('  simulation_interfaces is not installed here: none of the standard '
                     'simulator services (tools/build_msgs.sh builds it)')
    else:
        lines += ['  simulation_interfaces (the standard simulator API):',
                  *rows(sim_interfaces.SERVICES, lambda row: ''), 'Action:',
                  *rows(sim_interfaces.ACTIONS, lambda row: '')]
    return '\n'.join(lines)


def main(args=None) -> int:
    """Run the node until SIGINT or SIGTERM; then stop and join the step loop, finish the
    recording, destroy the node and shut rclpy down, in that order, and exit 0.

    rclpy's own signal handler is off: it would shut the context down under the step loop,
    which then fails to publish (and a second handler race could leave the process up). Ours
    only sets a flag that the executor loop looks at every 0.1 s; while the node is still
    starting (a large scene), a signal interrupts the start and exits cleanly.
    """
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='simulator', formatter_class=argparse.RawDescriptionHelpFormatter,
        description='rb_sim_ros rigid-body simulator node.\n\n' + endpoints_text(),
        epilog=node_params.help_text())
    parser.parse_args(ros_arguments.non_ros_args(argv, 'simulator'))
    stop = threading.Event()
    starting = [True]
    running: list[SimulatorNode] = []

    def on_signal(signum, frame):
        stop.set()
        for n in running:  # the step loop ends its chunk, frees the lock and returns
            n._stop.set()
            n._wake.set()
        # A second signal is not waited for: it ends the process as it would by default.
        signal.signal(signum, signal.SIG_DFL)
        if starting[0]:
            raise KeyboardInterrupt
    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    node = None
    try:
        rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = SimulatorNode()
        except (ValueError, OSError) as e:
            print(f'simulator: {e}', file=sys.stderr)
            return 2
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        running.append(node)
        starting[0] = False
        while not stop.is_set() and not node.done.is_set():
            try:
                executor.spin_once(timeout_sec=0.1)
            except (KeyboardInterrupt, ExternalShutdownException):
                break
            except Exception as e:  # noqa: B902 - a callback's bug must not kill the node
                node.get_logger().error(f'callback failed: {type(e).__name__}: {e}',
                                        throttle_duration_sec=1.0)
    except KeyboardInterrupt:  # a signal while starting
        pass
    finally:
        starting[0] = False  # a signal during the shutdown does not raise into it
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return node.exit_code if node is not None else 0


if __name__ == '__main__':
    sys.exit(main())
