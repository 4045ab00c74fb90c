# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A controller in lockstep with the simulator, called in-process: no DDS, no node, the run
the simulator node makes with the same controller answering over ROS, bit for bit.

    from rb_sim_ros.offline import closed_loop
    law = closed_loop.load_controller('examples/attitude_controller.py',
                                      {'inertia': [0.1, 0.2, 0.3], 'target_rpy': [0.3, 0, 1]})
    result = closed_loop.run({'inertia': [0.1, 0.2, 0.3], 'stop_after': 10.0},
                             {'body': law}, 'run.mcap')

``run`` takes the node's parameters (``lockstep`` is implied, ``stop_after`` ends the run;
``start_paused`` and a ``lockstep_inputs`` other than the controlled bodies are refused, as
nothing here would unpause the run or answer for another body) and a controller per body, and
records to the file what the node records with ``-p lockstep:=true -p record:=run.mcap`` and
the controller as a ROS node (``ControlLoop``) on that body's ``wrench_stamped``: the same
metadata, states, IMU noise, /tf and wrench inputs at the same steps
(``node_recorder.same_run`` says '' of the two files, and ``replay --verify`` accepts it). It
is made of the node's own pieces: the lockstep bookkeeping (``ros/lockstep.Lockstep``: the
answers of a state take effect together at the step after it, or ``lockstep_delay`` periods
later), the publish of a state with its IMU draw (``sweep.publish_state``), the answer made of
the law's wrench as ``control_loop.command_message`` puts it in the answer
(``command_parts``) and the node takes it (``body_ports.wrench_in``), a re-sent identical
wrench not recorded, a law that raises, or gives a wrench the node refuses, answered with no
change (HOLD), and command_timeout.

A controller is a Python file or module with ``make_law(parameters: dict)``, returning the
law: called with each state message (nav_msgs/Odometry, or sensor_msgs/Imu if the law's
``state`` attribute is 'imu'), it returns ``(force, torque)`` (N, N m, in the law's ``frame``
attribute: 'body' by default) or None for no change (``state`` and ``frame`` are read once,
when the run is made, as a ControlLoop reads them when it is made). The same file run as a
ROS node (``python FILE --ros-args -p NAME:=VALUE``) takes the same parameters: that is the
other way to run it (examples/attitude_controller.py is both). The message the law gets is the
simulator's own, refilled for the next state: a law that keeps a state past its call copies
what it keeps (over ROS each state is a fresh message; a law keeping the message itself would
see it change here, and the two ways would differ).
"""

from __future__ import annotations

from dataclasses import dataclass
import hashlib
import importlib
import importlib.util
import os
import sys
from typing import Any, Callable

from rb_sim_ros.core.rigid_body import ZERO_WRENCH
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.offline.sweep import publish_state
from rb_sim_ros.ros import node_params, ros_messages
from rb_sim_ros.ros.body_ports import PUBLISHED, RECORDED, wrench_in
from rb_sim_ros.ros.control_loop import command_parts, stamp_ns
from rb_sim_ros.ros.lockstep import HOLD, Lockstep
from rb_sim_ros.ros.node_config import config_from, stop_step, timeout_steps
from rb_sim_ros.ros.node_recorder import NodeRecorder
from rb_sim_ros.sim.imu import ImuSensor
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import SetWrench, Simulation

TF, TF_STATIC = '/tf', '/tf_static'


def load_controller(where: str, parameters: dict | None = None):
    """The law of controller ``where`` (a .py file, or a module's dotted name) made with
    ``parameters``: its ``make_law(parameters)``. ValueError naming what is wrong."""
    return make_law(controller_module(where), where, parameters)


def controller_module(where: str):
    """The module of controller ``where`` (a .py file, or a dotted name), imported."""
    try:
        if where.endswith('.py'):
            path = os.path.abspath(where)
            name = 'rb_sim_controller_' + hashlib.sha1(path.encode()).hexdigest()[:12]
            if name in sys.modules:
                return sys.modules[name]
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:
                raise ValueError(f'controller {where}: not a Python file')
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module  # (as an import: dataclasses and pickling look it up)
            try:
                spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[name]
                raise
            return module
        return importlib.import_module(where)
    except ValueError:
        raise
    except Exception as e:  # noqa: B902 - whatever its import raised: the user's file
        raise ValueError(f'controller {where}: cannot load it: {type(e).__name__}: '
                         f'{str(e).splitlines()[0] if str(e) else ""}') from None


def make_law(module, where: str, parameters: dict | None = None):
    """``module.make_law(parameters)``, checked (``where`` names it in errors)."""
    make = getattr(module, 'make_law', None)
    if not callable(make):
        raise ValueError(f'controller {where}: it has no make_law(parameters) to call '
                         'in-process')
    try:
        law = make(dict(parameters or {}))
    except Exception as e:  # noqa: B902 - whatever the user's make_law raised
        text = str(e).splitlines()[0] if str(e) else ''
        raise ValueError(f'controller {where}: make_law: '
                         + (text if isinstance(e, ValueError) else
                            f'{type(e).__name__}: {text}')) from None
    if not callable(law) or getattr(law, 'state', 'odom') not in ('odom', 'imu'):
        raise ValueError(f"controller {where}: make_law must return a callable whose 'state' "
                         "(if any) is 'odom' or 'imu'")
    return law


def node_values(params: dict) -> dict:
    """Every node parameter: its default, or the value in ``params``, each checked as the node
    checks it (ValueError naming a bad one); ``lockstep`` on."""
    values = {p.name: p.default for p in node_params.PARAMS}
    for name, value in params.items():
        if name not in values:
            raise ValueError(f"'{name}' is not a parameter of the simulator")
        values[name] = value
    values['lockstep'] = True
    for name, value in values.items():
        node_params.check(name, value)
    if not values['stop_after']:
        raise ValueError('stop_after: a closed-loop run in-process needs an end (sim seconds)')
    if values['start_paused']:
        raise ValueError('start_paused: nothing would unpause a closed-loop run in-process')
    return values


@dataclass
class Result:
    steps: int
    time_ns: int
    error: str = ''
    refused: int = 0       # answers the node would refuse (a bad wrench, a law that raised)
    answered: int = 0      # states the laws answered
    refusal: str = ''      # why the first of them was refused, one line


class _Body:
    """One moving body with topics: its messages, IMU and controller."""

    def __init__(self, values: dict, spec, index: int, single: bool, law) -> None:
        self.name = spec.name
        self.frame = node_params.body_frame(values, spec.name, single)
        noise = node_params.imu_noise(values)
        # the messages read of a state: the outputs recorded (but odom: the recorder packs
        # it from the numbers) and the law's state
        read = set(node_params.record_outputs(values['record_outputs'])) - {'odom'}
        if law is not None:
            read.add(getattr(law, 'state', 'odom'))
        self.out = ros_messages.OutputMessages(
            values['world_frame'], self.frame, values['twist_frame'],
            node_params.covariance36(values['odom_pose_covariance']),
            node_params.covariance36(values['odom_twist_covariance']), noise, read)
        self.sensor = ImuSensor(noise, index)
        prefix = '/' if single else f'/{spec.name}/'
        self.topics = {kind: prefix + kind for kind, _, _ in PUBLISHED if kind in RECORDED}
        self.points = dict(spec.points)
        self.law = law
        self.reads_imu = getattr(law, 'state', 'odom') == 'imu'
        self.law_frame = getattr(law, 'frame', 'body')
        self.last_command_step = 0
        # (with trace) every published state's time and orientation, every recorded wrench
        # input's time and torque: the recording's own values, for metrics without reading
        # it back
        self.times: list[float] = []
        self.orientations: list[tuple] = []
        self.wrench_times: list[float] = []
        self.torques: list[tuple] = []


class ClosedLoop:
    """The run, period by period, as the node steps it in lockstep (``run`` drives it)."""

    def __init__(self, values: dict, laws: dict[str, Callable], out_path: str,
                 scene=None, trace: bool = False, metadata: dict | None = None) -> None:
        self.values = values
        self.trace = trace
        self.contact_periods = 0  # periods that ended with a contact
        if scene is None and values['scene_file']:
            scene = load_scene(values['scene_file'])
        self.config = config_from(values, scene)
        self.sim = Simulation(self.config)
        self.sim.warm_up()
        single = scene is None
        shown = self.config.bodies[:1 if single else values['max_body_topics']]
        unknown = sorted(set(laws) - {b.name for b in shown if not b.static})
        if unknown:
            raise ValueError(f"controller for '{unknown[0]}': not a moving body with topics")
        self.bodies = [_Body(values, spec, index, single, laws.get(spec.name))
                       for index, spec in enumerate(shown) if not spec.static]
        statics = [spec for spec in shown if spec.static]
        self._tf = self._tf_static = None
        try:  # as the node: without tf2_msgs, no /tf (it warns)
            from tf2_msgs.msg import TFMessage
        except ImportError:
            TFMessage = None
        tf_on = bool(values['publish_tf']) and TFMessage is not None
        if tf_on:
            world = values['world_frame']
            if self.bodies:  # (the node makes /tf for moving bodies with topics only)
                self._tf = ros_messages.tf_message(TFMessage, world,
                                                   [b.frame for b in self.bodies])
            if statics:
                self._tf_static = ros_messages.tf_message(
                    TFMessage, world, [node_params.body_frame(values, s.name, single)
                                       for s in statics])
                self._static_poses = [self.sim.pose_twist(s.name)[:2] for s in statics]
        self.recorder = NodeRecorder(
            out_path, self.config, values, {b.name: b.topics for b in self.bodies},
            overwrite=True, tf_topics=[TF, TF_STATIC] if tf_on else [],
            max_chunk_age_s=None, background=False)
        for name, record in (metadata or {}).items():  # (what made the run: a campaign's)
            self.recorder.metadata(name, record)
        declared = node_params.names_list(values['lockstep_inputs'])
        if declared and set(declared) != set(laws):
            raise ValueError(f'lockstep_inputs {sorted(set(declared))}: in-process, the '
                             f'inputs are the bodies with a controller ({sorted(laws)})')
        self.lockstep = Lockstep(sorted(laws), values['lockstep_delay'], threaded=False)
        self.lockstep.join(self.lockstep.declared)
        self.stop_step = stop_step(values, self.config)
        self.timeout_steps = timeout_steps(values, self.config)
        self.result = Result(0, 0)
        self._read_clock()

    # -- the node's period ---------------------------------------------------------------
    def start(self) -> bool:
        """Step 0: its state published and answered. False if the run ended."""
        return self._publish_and_answer()

    def _read_clock(self) -> None:
        """The step and its time (ns), read once a period."""
        self.step: int = self.sim.step_count
        self.t_ns: int = self.sim.time_ns_of(self.step)

    def period(self) -> bool:
        """One publish period: the answers due applied, the steps, the state published and
        answered. False once the run has ended (stop_after, or an error)."""
        sim = self.sim
        step = self.step
        for name, answer in self.lockstep.take():
            body = self._body(name)
            if isinstance(answer, SetWrench):
                self._apply(body, answer, command=True)
            else:  # HOLD
                body.last_command_step = step
        if self.timeout_steps:
            for body in self.bodies:
                if step - body.last_command_step >= self.timeout_steps and \
                        sim.wrench(body.name) != ZERO_WRENCH:
                    self._apply(body, SetWrench(ZERO_WRENCH, body.name), command=False)
        end = min(step + self.config.steps_per_publish, self.stop_step)
        try:
            sim.run(end - step)
        except IntegrationError as e:
            self.result.error = str(e).splitlines()[0][:500]
            return False
        finally:
            self._read_clock()
        if self.step >= self.stop_step:
            self.lockstep.expect(self.t_ns)
            self._publish()
            return False
        return self._publish_and_answer()

    def _body(self, name: str) -> _Body:
        return next(b for b in self.bodies if b.name == name)

    def _apply(self, body: _Body, event: SetWrench, command: bool) -> None:
        """The node's _apply of a wrench: taken, its step a command's (command_timeout), and
        recorded only if it changed the wrench held."""
        sim = self.sim
        held = sim.wrench(body.name)
        sim.apply(event)
        if command:
            body.last_command_step = self.step
        if sim.wrench(body.name) != held:
            self.recorder.event(self.step, self.t_ns, event)
            if self.trace:
                body.wrench_times.append(self.t_ns * 1e-9)
                body.torques.append(event.wrench.components[3:])

    def _publish(self) -> bool:
        sim, step, t_ns = self.sim, self.step, self.t_ns
        failed = False
        for body in self.bodies:  # (all of them, as the node: the others are published)
            if not publish_state(sim, body.name, body.out, body.sensor, self.recorder,
                                 step, t_ns) and not failed:
                failed = True
                self.result.error = (f"body '{body.name}' has a non-finite state at step "
                                     f'{step}; not published')
        if failed:
            return False
        if self.trace:
            for body in self.bodies:
                body.times.append(t_ns * 1e-9)
                body.orientations.append(tuple(body.out.last[2]))
            stats = sim.contact_stats()
            if stats is not None and stats.contacts:
                self.contact_periods += 1
        if self._tf is not None:
            ros_messages.fill_tf(self._tf, t_ns, [sim.pose_twist(b.name)[:2]
                                                  for b in self.bodies])
            self.recorder.tf(TF, step, t_ns, self._tf)
        if self._tf_static is not None:  # once, at the first publish
            ros_messages.fill_tf(self._tf_static, t_ns, self._static_poses)
            self.recorder.tf(TF_STATIC, step, t_ns, self._tf_static)
            self._tf_static = None
        return True

    def _publish_and_answer(self) -> bool:
        self.lockstep.expect(self.t_ns)
        if not self._publish():
            return False
        for body in self.bodies:
            if body.law is not None:
                self._answer(body)
        return True

    def _answer(self, body: _Body) -> None:
        """The controller's answer to the state just published, as its ControlLoop and the
        node's wrench_stamped make it: command_message's numbers and frame (command_parts)
        and stamp (the state's, read after the law), taken as the node takes a
        wrench_stamped (body_ports.wrench_in), without making the message itself."""
        law = body.law
        state = body.out.imu if body.reads_imu else body.out.odom
        answer: Any = HOLD
        try:
            fid, force, torque = command_parts(state, law(state), body.law_frame)
            fid = fid.lstrip('/')  # (as the node reads a wrench_stamped's frame_id)
        except Exception as e:  # noqa: B902 - as ControlLoop: a law that raises answers HOLD
            self._refused(f'the law raised {type(e).__name__}: {e}')
            fid = HOLD
        if fid != HOLD:
            v = self.values
            try:
                answer = SetWrench(wrench_in(force, torque, fid, v['world_frame'],
                                             body.frame, body.points, v['wrench_frame'],
                                             v['max_wrench']), body.name)
            except ValueError as e:  # the node refuses it, and answers with no change
                self._refused(f'its wrench was refused: {e}')
        self.lockstep.offer(body.name, stamp_ns(state.header.stamp), answer)
        self.result.answered += 1

    def run_to_end(self) -> Result:
        """Start, every period to the end, and close (the recording finished however it
        ends)."""
        try:
            if self.start():
                while self.period():
                    pass
        finally:
            result = self.close()
        return result

    def _refused(self, why: str) -> None:
        self.result.refused += 1
        if not self.result.refusal:
            self.result.refusal = (f't = {self.t_ns * 1e-9:.9f} s: '
                                   + why.splitlines()[0])[:300]

    def close(self) -> Result:
        self.recorder.close()
        if self.recorder.failed and not self.result.error:
            self.result.error = self.recorder.failed
        self.result.steps, self.result.time_ns = self.sim.step_count, self.sim.time_ns
        return self.result


def run(params: dict, laws: dict[str, Callable], out_path: str, scene=None) -> Result:
    """One closed-loop run to its ``stop_after``, recorded to ``out_path``: see the module's
    doc. ``params``: node parameters (the rest their defaults); ``laws``: body name -> law
    (``load_controller``); ``scene``: the scene (sim.scene.Scene) in place of
    ``scene_file``'s (None: that file's, or the single body of the parameters).
    ValueError for a bad parameter, scene or controller."""
    return ClosedLoop(node_values(params), laws, out_path, scene).run_to_end()
