# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The run a node's parameters describe: ``config_from(values, scene)`` is the ``Config`` the
simulator node steps, and what ``sweep`` runs offline for the same parameters. No ROS."""

from __future__ import annotations

import math

from rb_sim_ros.core import multistep
from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.lockstep import HOLD
from rb_sim_ros.sim.simulation import BodySpec, Config, ContactSettings


def config_from(v: dict, scene=None) -> Config:
    """The run's Config from the node's parameter values ``v`` and a scene (or the single
    body of the parameters)."""
    steps = 1.0 / (v['publish_rate'] * v['dt'])
    # (1/(rate*dt) is a whole number up to rounding: 10 Hz at 1e-6 s is 100000.00000000001)
    if not math.isfinite(steps) or steps > node_params.MAX_STEPS_PER_PERIOD * (1 + 1e-9):
        raise ValueError(f"publish_rate {v['publish_rate']} Hz with dt {v['dt']} s makes "
                         f'{steps:.3g} steps a period; at most '
                         f'{node_params.MAX_STEPS_PER_PERIOD} (raise publish_rate or dt)')
    if abs(steps - round(steps)) > 1e-6 * steps or round(steps) < 1:
        raise ValueError(f"publish_rate {v['publish_rate']} Hz must divide 1/dt = "
                         f"{1.0 / v['dt']:.9g} Hz into a whole number of steps >= 1")
    contact = ContactSettings()
    integrator = v['integrator'] or multistep.EQ27.name
    if scene is not None:
        gravity, bodies, contact = scene.gravity, scene.bodies, scene.contact
        for b in bodies:  # a point named like a fixed frame would never be reached
            for name, _ in b.points:
                if name == v['world_frame']:
                    raise ValueError(f"body '{b.name}': point '{name}' is named like "
                                     'world_frame: rename one of them')
                if name == HOLD and v.get('lockstep'):
                    raise ValueError(f"body '{b.name}': point '{name}' is named like "
                                     "lockstep's answer of no change: rename it")
        integrator = v['integrator'] or scene.integrator or integrator
    else:
        gravity = (0.0, 0.0, 0.0)
        bodies = (BodySpec(name='body', mass=float(v['mass']),
                           inertia=tuple(float(c) for c in v['inertia']),
                           initial_position=tuple(float(c) for c in v['initial_position']),
                           initial_orientation_xyzw=tuple(
                               float(c) for c in v['initial_orientation']),
                           initial_linear_velocity=tuple(
                               float(c) for c in v['initial_linear_velocity']),
                           initial_angular_velocity=tuple(
                               float(c) for c in v['initial_angular_velocity'])),)
    for b in bodies:  # ValueError if a body's frame is world_frame
        node_params.body_frame(v, b.name, scene is None)
    return Config(dt=float(v['dt']), steps_per_publish=int(round(steps)),
                  integrator=integrator, gravity=gravity, bodies=bodies, contact=contact)


def timeout_steps(v: dict, config: Config) -> int:
    """command_timeout in steps: 0 disables; a timeout shorter than a step still times out
    (at the next step), never disables."""
    timeout = v['command_timeout']
    return max(1, math.ceil(timeout / config.dt - 1e-9)) if timeout else 0


def stop_step(v: dict, config: Config) -> int:
    """The step stop_after ends the run at (0: it does not end by itself)."""
    return math.ceil(v['stop_after'] / config.dt - 1e-9) if v['stop_after'] else 0
