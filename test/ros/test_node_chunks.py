# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node steps a period in chunks between looks at its stop flag (so SIGINT ends it at
once), each chunk as many steps as run in about 50 ms: slow steps (a heap of contacts) make
short chunks. Chunking must not change a run, whatever the sizes."""

from pathlib import Path
import random

import numpy as np
import pytest

from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.node_config import config_from
from rb_sim_ros.ros.simulator_node import _CHUNK_STEPS, _CHUNK_WALL_S, describe_bodies, \
    next_chunk
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize('per_step_s, expected', [
    (1e-7, _CHUNK_STEPS),           # fast steps: the step cap
    (_CHUNK_WALL_S / 10, 10),        # ten steps fill the wall time
    (_CHUNK_WALL_S * 3, 1),          # a step longer than the wall time: one at a time
    (120.0, 1)])
def test_a_chunk_is_what_runs_in_its_wall_time(per_step_s, expected):
    for steps in (1, 7, 1000):
        assert next_chunk(steps, steps * per_step_s) == expected


def test_a_chunk_that_took_no_measurable_time_is_the_step_cap():
    assert next_chunk(5, 0.0) == _CHUNK_STEPS
    assert next_chunk(0, 1.0) == _CHUNK_STEPS


def test_chunks_of_any_size_give_the_bits_of_one_call():
    """The collision demo (contacts, sleeping, waking) stepped 3000 steps in one call, and in
    chunks of random sizes: the same bits for every body."""
    values = {p.name: p.default for p in node_params.PARAMS}
    config = config_from(values, load_scene(str(ROOT / 'scenes' / 'collisions.yaml')))
    one = Simulation(config)
    one.run(3000)
    rng = random.Random(1)
    chunked, left = Simulation(config), 3000
    while left:
        n = min(left, rng.choice([1, 2, 3, 7, 50, 333]))
        chunked.run(n)
        left -= n
    moving = [b.name for b in config.bodies if not b.static]
    assert moving
    for name in moving:
        for a, b in zip(one.pose_twist(name), chunked.pose_twist(name)):
            assert np.array_equal(np.asarray(a), np.asarray(b)), name


def test_the_start_up_line_gives_a_moving_body_its_mass_and_a_static_one_none():
    values = {p.name: p.default for p in node_params.PARAMS}
    config = config_from(values, load_scene(str(ROOT / 'scenes' / 'collisions.yaml')))
    line = describe_bodies(config.bodies, 0)
    for b in config.bodies:
        part = line.split(f'{b.name} (')[1].split(')')[0]
        assert part == ('static' if b.static else f'{b.mass:g} kg'), (b.name, line)
    assert any(b.static for b in config.bodies) and not all(b.static for b in config.bodies)
