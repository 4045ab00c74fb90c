# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Recordings for the tests that read them: a run recorded offline as the node records it, and
the parts of an MCAP file read by the mcap library itself (to be rewritten). Needs mcap."""

import json

from mcap.reader import make_reader
from mcap.writer import Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from rb_sim_ros.offline import replay
from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.node_recorder import NodeRecorder, RUN_DEFINITION
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


def mcap_parts(path):
    """(header, schemas, channels, messages, metadata) of the MCAP file ``path``, read by the
    mcap library itself."""
    with open(path, 'rb') as f:
        reader = make_reader(f)
        header, summary = reader.get_header(), reader.get_summary()
        messages = [m for _s, _c, m in reader.iter_messages(log_time_order=False)]
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    return header, summary.schemas, summary.channels, messages, metadata


def topic_parts(path):
    """(schemas, channels, [(topic, message record)], rb_sim_ros metadata), read by mcap."""
    with open(path, 'rb') as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        messages = [(c.topic, m) for _s, c, m in reader.iter_messages()]
        meta = next(dict(m.metadata) for m in reader.iter_metadata() if m.name == 'rb_sim_ros')
    return summary.schemas, summary.channels, messages, meta


def rewrite(path, schemas, channels, messages, meta):
    """Write ``path`` from parts (``topic_parts``, edited): the run definition message says
    what the metadata ``meta`` says, as the node writes them."""
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start(profile='ros2', library='test')
        sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in schemas.items()}
        cids = {c.topic: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                            dict(c.metadata)) for c in channels.values()}
        for topic, m in messages:
            data = m.data
            if topic == RUN_DEFINITION:
                data = serialize_message(String(data=json.dumps(meta, sort_keys=True)))
            w.add_message(cids[topic], m.log_time, data, m.publish_time, m.sequence)
        w.add_metadata('rb_sim_ros', meta)
        w.finish()
    return path
