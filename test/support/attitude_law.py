# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The oracle of a closed loop with examples/attitude_controller.py (the gains of
examples/closed_loop_ci.py): every recorded wrench is the law of the state recorded where the
lockstep protocol says. Needs mcap."""

import importlib
from pathlib import Path
import sys

from rb_sim_ros.recording.reader import RecordingReader

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'examples'))
ctl = importlib.import_module('attitude_controller')
loop = importlib.import_module('closed_loop_ci')


def wrenches_follow_the_law(path: Path, body_topic: str, state: str, delay: int,
                            target_rpy=loop.TARGET_RPY) -> int:
    """Every wrench recorded for a body is the attitude law of the state recorded ``delay``
    periods before it (10 steps of 1 ms each): the answer took effect where the protocol
    says. Returns how many were checked."""
    kp = [2.0 * i * loop.WN ** 2 for i in loop.INERTIA]
    kd = [2.0 * loop.ZETA * loop.WN * i for i in loop.INERTIA]
    target = ctl.quaternion_from_rpy(*target_rpy)
    states, wrenches = {}, []
    reader = RecordingReader(str(path))
    for m in reader.messages(topics=[f'/{body_topic}{state}', f'/rb_sim/input/'
                                     f'{body_topic.rstrip("/") or "body"}/wrench']):
        if m.topic.startswith('/rb_sim/input/'):
            wrenches.append((m.sequence, m.message))
        else:
            msg = m.message
            if state == 'odom':
                o, w = msg.pose.pose.orientation, msg.twist.twist.angular
            else:
                o, w = msg.orientation, msg.angular_velocity
            states[m.sequence] = ((o.x, o.y, o.z, o.w), (w.x, w.y, w.z))
    assert len(wrenches) > 50
    for step, msg in wrenches:
        q, w = states[step - 10 * delay]
        t = msg.wrench.torque
        assert (t.x, t.y, t.z) == ctl.pd_torque(target, q, w, kp, kd, 10.0), step
    return len(wrenches)
