#!/usr/bin/env python3
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A closed-loop controller test for CI: the simulator in lockstep with the controller, a run
that ends by itself, and assertions on its recording.

    pytest examples/closed_loop_ci.py       # (a ROS install sourced, or the venv's)

The simulator waits for the controller's answer to every state it publishes before it steps
on (``lockstep:=true``), so the run is the same, bit for bit, on a laptop, on a loaded CI
runner, as fast as possible (``real_time_factor:=0``) or in real time. It stops at
``stop_after`` seconds of sim time, finishes the recording and exits 0; the test then reads
the recording and asserts what the controller must do: here, settle the body on its target
within the time its gains promise, with the overshoot they promise.

``closed_loop`` runs one such test (the simulator and ``attitude_controller.py`` as the two
processes a user runs) and returns the recording; the test suite of rb_sim_ros calls it to
check that runs repeat bit for bit under load and at any pace.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
import random
import subprocess
import sys

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import attitude_controller as ctl  # noqa: E402,I100,I202  (beside this file)

INERTIA = [0.1, 0.2, 0.3]
TARGET_RPY = [0.3, -0.2, 1.2]
WN, ZETA = 2.0, 0.8


def ros_environment() -> dict:
    """This process's environment, its DDS traffic kept on this machine, on a ROS domain of
    its own unless one is set (parallel CI jobs on one runner do not hear each other)."""
    env = dict(os.environ)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    env.setdefault('ROS_DOMAIN_ID', str(random.randrange(1, 102)))
    return env


def closed_loop(out: Path, sim_args=(), controller_args=(), controllers=None, env=None,
                stop_after: float = 4.0, timeout: float = 600.0) -> Path:
    """Run the simulator in lockstep with the attitude controller until ``stop_after`` sim
    seconds, recording to ``out``; returns ``out``. ``controllers``: the controllers'
    extra arguments, one list per controller process (default: one, ``controller_args``).
    AssertionError with both logs if the simulator does not exit 0."""
    env = env or ros_environment()
    log_dir = out.parent
    sim_log = open(log_dir / f'{out.stem}-simulator.log', 'w')
    sim = subprocess.Popen(
        [sys.executable, '-m', 'rb_sim_ros.ros.simulator_node', '--ros-args',
         '-p', 'lockstep:=true', '-p', f'stop_after:={stop_after}', '-p', f'record:={out}',
         # a controller that dies or never answers fails the test in a minute (exit 3)
         '-p', 'lockstep_timeout:=60.0',
         '-p', 'record_overwrite:=true', '-p', f'inertia:={INERTIA}', *sim_args],
        env=env, stdout=sim_log, stderr=subprocess.STDOUT, cwd=log_dir)
    procs, logs = [], []
    try:
        for k, extra in enumerate(controllers or [list(controller_args)]):
            logs.append(open(log_dir / f'{out.stem}-controller{k}.log', 'w'))
            procs.append(subprocess.Popen(
                [sys.executable, str(HERE / 'attitude_controller.py'), '--ros-args',
                 '-p', f'target_rpy:={TARGET_RPY}', '-p', f'inertia:={INERTIA}',
                 '-p', f'natural_frequency:={WN}', '-p', f'damping_ratio:={ZETA}', *extra],
                env=env, stdout=logs[-1], stderr=subprocess.STDOUT, cwd=log_dir))
        code = sim.wait(timeout)
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.wait()
        for p in procs:  # (a controller slow to stop on a loaded machine: killed)
            p.terminate()
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for f in logs + [sim_log]:
            f.close()
    assert code == 0, f'the simulator exited {code}:\n' + '\n'.join(
        p.read_text()[-3000:] for p in sorted(log_dir.glob(f'{out.stem}-*.log')))
    return out


def attitude_errors(path: Path, topic: str = '/odom', target_rpy=TARGET_RPY):
    """(t, angle to the target) of every recorded odom of the body on ``topic``."""
    from rb_sim_ros.recording.reader import RecordingReader
    target = np.array(ctl.quaternion_from_rpy(*target_rpy))
    t, angle = [], []
    for m in RecordingReader(str(path)).messages(topics=[topic]):
        o = m.message.pose.pose.orientation
        e = np.array(ctl.error_quaternion(target, (o.x, o.y, o.z, o.w)))
        t.append(m.log_time_ns * 1e-9)
        angle.append(2.0 * math.atan2(np.linalg.norm(e[:3]), abs(e[3])))
    return np.array(t), np.array(angle)


def test_the_attitude_controller_settles_as_its_gains_promise(tmp_path):
    run = closed_loop(tmp_path / 'run.mcap', sim_args=['-p', 'real_time_factor:=0.0'])
    t, angle = attitude_errors(run)                    # from the recorded odom
    settled_at = t[np.nonzero(angle > 0.02 * angle[0])[0][-1] + 1]
    assert settled_at < 1.5 * 4.0 / (ZETA * WN)        # 2 % settling, with margin
    assert angle[-1] < 0.005
