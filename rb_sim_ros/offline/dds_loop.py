# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A closed-loop run over DDS: the simulator node and the user's controller node, two processes
as a user runs them, in lockstep on this process's own ROS domain (ros_domains), until the
run's ``stop_after``; the node records it. The other way of offline/closed_loop (the same
controller called in-process): for the same parameters, the same recording field by field
(``node_recorder.same_run``).

The controller is a Python file (run as ``python FILE --ros-args --params-file ...``) or a
module (``python -m MODULE ...``) that is a ROS node answering each state on
``wrench_stamped`` (``ros/control_loop.ControlLoop``), with the parameters given.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import yaml

from rb_sim_ros.ros import ros_domains

# How long a run may take (wall seconds) before it is given up: a controller that never
# answers ends the simulator (lockstep_timeout) well before.
TIMEOUT = 600.0
LOCKSTEP_TIMEOUT = 60.0


def _params_file(path: str, values: dict) -> str:
    with open(path, 'w') as f:
        yaml.safe_dump({'/**': {'ros__parameters': values}}, f)
    return path


def run(params: dict, controller: str, controller_params: dict, out_path: str,
        scene_data=None, namespace: str = '', timeout: float = TIMEOUT) -> str:
    """Run and record to ``out_path``; '' if the simulator ended the run as asked, else why
    not (one line, with the end of its log). ``params``: the simulator's node parameters
    (``stop_after`` needed; lockstep, recording and pace are set here); ``scene_data``: a
    scene (YAML data) that replaces ``scene_file``'s; ``namespace``: the controller's (a
    scene's body ``a`` has its topics under ``/a``)."""
    env = ros_domains.environment()
    with tempfile.TemporaryDirectory(prefix='rb_sim_dds_') as d:
        sim = dict(params, lockstep=True, record=os.path.abspath(out_path),
                   record_overwrite=True, real_time_factor=0.0,
                   lockstep_timeout=LOCKSTEP_TIMEOUT, compile_in_background=False)
        if scene_data is not None:
            scene = os.path.join(d, 'scene.yaml')
            with open(scene, 'w') as f:
                yaml.safe_dump(scene_data, f)
            sim['scene_file'] = scene
        sim_log = os.path.join(d, 'simulator.log')
        ctl_log = os.path.join(d, 'controller.log')
        command = [sys.executable, controller] if controller.endswith('.py') else \
            [sys.executable, '-m', controller]
        with open(sim_log, 'w') as slog, open(ctl_log, 'w') as clog:
            simulator = subprocess.Popen(
                [sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args',
                 '--params-file', _params_file(os.path.join(d, 'sim.yaml'), sim)],
                env=env, stdout=slog, stderr=subprocess.STDOUT, cwd=d)
            try:
                ros_args = ['-r', f'__ns:=/{namespace}'] if namespace else []
                if controller_params:
                    ros_args += ['--params-file', _params_file(
                        os.path.join(d, 'controller.yaml'), controller_params)]
                node = subprocess.Popen(
                    [*command, '--ros-args', *ros_args] if ros_args else command, env=env,
                    stdout=clog, stderr=subprocess.STDOUT, cwd=d)
            except OSError:
                simulator.kill()
                simulator.wait()
                raise
            try:
                code = simulator.wait(timeout)
            except subprocess.TimeoutExpired:
                code = None
            finally:
                for p in (simulator, node):
                    if p.poll() is None:
                        p.terminate()
                        try:
                            p.wait(30)
                        except subprocess.TimeoutExpired:
                            p.kill()
                            p.wait()
        if code == 0:
            return ''
        with open(sim_log) as f:
            tail = ' | '.join(f.read().strip().splitlines()[-3:])
        with open(ctl_log) as f:
            ctl_tail = ' | '.join(f.read().strip().splitlines()[-2:])
        what = f'timed out after {timeout:g} s' if code is None else f'exited {code}'
        return (f'over DDS the simulator {what}: {tail[-400:]}'
                + (f'; the controller: {ctl_tail[-200:]}' if ctl_tail else ''))
