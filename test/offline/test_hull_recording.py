# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run with hull colliders (a pebble tumbling onto a hull of a box on the ground) is
recorded with its hulls in the run's definition and re-simulated offline to the same bits:
``replay --verify``'s check, every output identical."""

import numpy as np

from oracles.node_recording import record_offline
from rb_sim_ros.contact.collision_shapes import Hull, Plane
from rb_sim_ros.offline import replay
from rb_sim_ros.sim.simulation import BodySpec, Config


def test_a_run_with_hulls_replays_bit_for_bit(tmp_path):
    rng = np.random.default_rng(5)
    pebble = Hull((rng.normal(size=(30, 3)) * (0.1, 0.07, 0.05)).tolist())
    m, _, inertia = pebble.mass_properties(2000.0)
    corners = [[x, y, z] for x in (-0.3, 0.3) for y in (-0.3, 0.3) for z in (-0.1, 0.1)]
    bodies = (BodySpec('pebble', m, tuple(inertia.ravel()), initial_position=(0.05, 0.0, 0.6),
                       initial_orientation_xyzw=(0.3, 0.1, 0.0, 0.95),
                       initial_angular_velocity=(1.0, -2.0, 0.5), colliders=(pebble,)),
              BodySpec('slab', static=True, initial_position=(0.0, 0.0, 0.1),
                       colliders=(Hull(corners),)),
              BodySpec('ground', static=True, colliders=(Plane(),)))
    config = Config(dt=1e-3, steps_per_publish=10, gravity=(0.0, 0.0, -9.81), bodies=bodies)
    path = tmp_path / 'hulls.mcap'
    record_offline(path, config, 60)
    result = replay.verify(str(path))
    assert result.outputs > 0 and result.outputs == result.recorded
    assert result.mismatched_messages == 0 and not result.integration_error
    rec = replay.load(str(path))
    (hull,) = next(b for b in rec.config.bodies if b.name == 'pebble').colliders
    assert hull == pebble  # the same vertices, to the bit
