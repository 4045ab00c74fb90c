# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap
"""examples/attitude_controller.py closed over DDS with the simulator: the body settles on the
target orientation within the time and with the overshoot of the second-order system its gains
make (the linear theory, with margin for the large first turn and the loop's delay), and the
recorded run replays bit for bit."""

import importlib
import math
from pathlib import Path
import subprocess
import sys

from nav_msgs.msg import Odometry
import numpy as np
import pytest
from std_srvs.srv import SetBool

from rb_sim_ros.offline import replay
from support.ros_harness import stamp_ns

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'examples'))
ctl = importlib.import_module('attitude_controller')

WN, ZETA = 2.0, 0.8
INERTIA = [0.1, 0.2, 0.3]
TARGET_RPY = [0.3, -0.2, 1.2]


def test_the_pd_law_pushes_back_along_the_error():
    """Small errors about each axis: torque -K_p theta / 2 about it; the short way round."""
    target = ctl.quaternion_from_rpy(0.0, 0.0, 0.0)
    kp, kd = [4.0] * 3, [0.0] * 3
    for axis in range(3):
        rv = [0.0, 0.0, 0.0]
        rv[axis] = 0.01
        q = (*[math.sin(0.005) * (k == axis) for k in range(3)], math.cos(0.005))
        tau = ctl.pd_torque(target, q, (0.0, 0.0, 0.0), kp, kd, 10.0)
        assert tau[axis] == pytest.approx(-4.0 * math.sin(0.005)) and \
            sum(abs(t) for t in tau) == pytest.approx(abs(tau[axis]))
    minus_q = tuple(-c for c in q)  # the same rotation: the same torque
    assert ctl.pd_torque(target, minus_q, (0, 0, 0), kp, kd, 10.0) == \
        pytest.approx(ctl.pd_torque(target, q, (0, 0, 0), kp, kd, 10.0))
    assert ctl.pd_torque(target, (0, 0, 0, 1), (1.0, -2.0, 0.5), kp, [0.5] * 3, 10.0) == \
        pytest.approx((-0.5, 1.0, -0.25))
    assert ctl.pd_torque(target, (0, 0, 0, 1), (100.0, 0, 0), kp, [1.0] * 3, 3.0)[0] == -3.0


def test_the_controller_settles_the_body_on_its_target(start_sim, probe, ros_env, tmp_path):
    f = tmp_path / 'run.mcap'
    sim = start_sim('-p', f'inertia:={INERTIA}', '-p', f'record:={f}',
                    '-p', 'start_paused:=true')
    log = open(tmp_path / 'controller.log', 'w')
    controller = subprocess.Popen(
        [sys.executable, str(ROOT / 'examples' / 'attitude_controller.py'), '--ros-args',
         '-p', f'target_rpy:={TARGET_RPY}', '-p', f'inertia:={INERTIA}',
         '-p', f'natural_frequency:={WN}', '-p', f'damping_ratio:={ZETA}'],
        env=ros_env, stdout=log, stderr=subprocess.STDOUT)
    try:
        odom = probe.collect(Odometry, 'odom')
        probe.wait_for(lambda: probe.node.count_publishers('/wrench_stamped') >= 1
                       and probe.node.count_subscribers('/odom') >= 2,
                       what='the controller on the graph')
        assert probe.call(SetBool, 'pause', SetBool.Request(data=False)).success
        probe.wait_for(lambda: odom and stamp_ns(odom[-1].header.stamp) > 6e9, timeout=300,
                       what='6 s of closed loop')
    finally:
        controller.terminate()
        try:  # (a loaded machine may take long to end it: never leave it on the graph)
            controller.wait(120)
        except subprocess.TimeoutExpired:
            controller.kill()
            controller.wait(60)
        log.close()
        sim.stop()
    rec = replay.load(str(f))
    target = np.array(ctl.quaternion_from_rpy(*TARGET_RPY))
    # The first 6 s, while the controller ran: after it is stopped (a loaded machine may take
    # seconds to end it) the body drifts with what is left of its rate.
    rows = [(o[5] * 1e-9, o[4].pose.pose.orientation) for o in rec.outputs
            if o[2] == 'odom' and o[5] <= 6e9]
    t = np.array([r[0] for r in rows])
    errors = np.array([ctl.error_quaternion(target, (o.x, o.y, o.z, o.w)) for _, o in rows])
    errors *= np.sign(errors[:, 3:4])
    angle = 2.0 * np.arctan2(np.linalg.norm(errors[:, :3], axis=1), errors[:, 3])
    axis0 = errors[0, :3] / np.linalg.norm(errors[0, :3])
    along = 2.0 * np.arcsin(np.clip(errors[:, :3] @ axis0, -1.0, 1.0))  # signed, first axis
    theta0 = angle[0]
    assert theta0 > 1.0
    settle_theory = 4.0 / (ZETA * WN)                                     # 2.5 s
    overshoot_theory = math.exp(-math.pi * ZETA / math.sqrt(1.0 - ZETA ** 2))  # 1.5 %
    outside = np.nonzero(angle > 0.02 * theta0)[0]
    settled_at = t[outside[-1] + 1] if outside[-1] + 1 < len(t) else math.inf
    overshoot = max(0.0, -along.min()) / theta0
    print(f'settled to 2 % at {settled_at:.2f} s (theory {settle_theory:.2f} s), overshoot '
          f'{overshoot:.2%} (theory {overshoot_theory:.2%})')
    assert settled_at < 1.5 * settle_theory, (settled_at, overshoot)
    assert overshoot < overshoot_theory + 0.04, (settled_at, overshoot)
    assert t[-1] > 5.9 and angle[-1] < 0.005, (t[-1], angle[-1])  # at rest on the target
    # The run (its commands arrived when DDS delivered them) replays bit for bit.
    assert replay.verify(str(f)).identical
