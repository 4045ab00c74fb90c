# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run recorded offline as the node records it, without a node or a ROS graph: for the tests
that read, replay or draw recordings and for bench/replay_bench.py. Needs mcap."""

from rb_sim_ros.offline import replay
from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.node_recorder import NodeRecorder
from rb_sim_ros.ros.ros_messages import OutputMessages
from rb_sim_ros.sim.simulation import Delete, Simulation, Spawn


def record_offline(path, config, periods, events=None):
    """Record a run as the node does (scene mode: topics /<name>/pose, ...): publish at step
    0, then each period its inputs (``events``: period -> [event]), its steps, a publish."""
    params = {p.name: p.default for p in node_params.PARAMS}
    params.update(dt=config.dt, publish_rate=1.0 / (config.dt * config.steps_per_publish),
                  scene_file='scene.yaml')
    moving = [b.name for b in config.bodies if not b.static]
    topics = {n: {k: f'/{n}/{k}' for k in ('pose', 'twist', 'odom')} for n in moving}
    rec = NodeRecorder(str(path), config, params, topics)
    sim = Simulation(config)
    outs = {n: OutputMessages(params['world_frame'], n, params['twist_frame']) for n in moving}
    for period in range(periods + 1):
        for event in (events or {}).get(period, []):
            sim.apply(event)
            if isinstance(event, Spawn):  # as the node: topics of its own from now on
                n = event.spec.name
                moving.append(n)
                outs[n] = OutputMessages(params['world_frame'], n, params['twist_frame'])
                rec.spawned(sim.step_count, sim.time_ns, event,
                            {k: f'/{n}/{k}' for k in ('pose', 'twist', 'odom')})
            elif isinstance(event, Delete):
                moving.remove(event.body)
                rec.deleted(sim.step_count, sim.time_ns, event.body)
            else:
                rec.event(sim.step_count, sim.time_ns, event)
        if period:
            sim.run(config.steps_per_publish)
        for n in moving:
            outs[n].fill(sim.time_ns, *sim.pose_twist(n))
            rec.output(n, sim.step_count, sim.time_ns, outs[n])
    rec.close()
    assert rec.failed is None
    return replay.load(str(path))
