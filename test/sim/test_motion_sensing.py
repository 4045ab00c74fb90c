# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A body's acceleration and its IMU, without ROS: against Newton and Euler in closed form,
a body at rest on the ground, free fall, and the noise model's statistics."""

import math

import numpy as np
import pytest

from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.core import multistep
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.sim.imu import ImuNoise, ImuSensor, specific_force
from rb_sim_ros.sim.simulation import (BodySpec, Config, ContactSettings, SetPose, SetWrench,
                                       Simulation)

G = (0.0, 0.0, -9.81)
DT = 1e-3


def _free(method='eq27', inertia=(0.1, 0.2, 0.3), **body):
    spec = BodySpec('b', 2.0, inertia, **body)
    return Simulation(Config(dt=DT, steps_per_publish=10, integrator=method, bodies=(spec,)))


@pytest.mark.parametrize('method', sorted(multistep.METHODS))
def test_acceleration_of_a_free_body_is_newton_and_euler(method):
    """a = F/m, and beta = I^-1 (tau - omega x I omega) in the world frame, whatever the
    method (the splittings keep no accelerations of their own)."""
    q = (0.2, -0.3, 0.1, 0.927)
    sim = _free(method, initial_orientation_xyzw=q, initial_angular_velocity=(0.4, -1.0, 2.0))
    force, torque = (1.0, -2.0, 0.5), (0.05, 0.0, -0.1)
    sim.apply(SetWrench(Wrench(force, torque)))
    sim.run(37)
    x, quat, v, w = sim.pose_twist('b')
    a, beta = sim.accelerations('b')
    assert a == pytest.approx(np.array(force) / 2.0, abs=1e-15)
    x_, y_, z_, w_ = (c / np.linalg.norm(quat) for c in quat)
    r = np.array([[1 - 2 * (y_ * y_ + z_ * z_), 2 * (x_ * y_ - z_ * w_), 2 * (x_ * z_ + y_ * w_)],
                  [2 * (x_ * y_ + z_ * w_), 1 - 2 * (x_ * x_ + z_ * z_), 2 * (y_ * z_ - x_ * w_)],
                  [2 * (x_ * z_ - y_ * w_), 2 * (y_ * z_ + x_ * w_), 1 - 2 * (x_ * x_ + y_ * y_)]])
    inertia = r @ np.diag([0.1, 0.2, 0.3]) @ r.T
    w = np.array(w)
    want = np.linalg.solve(inertia, np.array(torque) - np.cross(w, inertia @ w))
    assert np.allclose(beta, want, rtol=1e-9, atol=1e-12)


def test_a_body_frame_force_turns_with_the_body_and_damping_counts():
    spec = BodySpec('b', 4.0, (0.1, 0.1, 0.1),
                    initial_orientation_xyzw=(0, 0, 0.7071068, 0.7071068),
                    initial_linear_velocity=(1.0, 0.0, 0.0), linear_damping=0.5)
    sim = Simulation(Config(dt=DT, steps_per_publish=1, bodies=(spec,), gravity=G))
    sim.apply(SetWrench(Wrench((2.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'body')))
    a, _ = sim.accelerations('b')
    # body x is world y (90 degrees about z): F/m along y, -c v along x, and g
    assert a == pytest.approx((-0.5, 0.5, -9.81), abs=1e-6)


def _ground_world(*bodies):
    ground = BodySpec('ground', static=True, colliders=(Plane(),))
    return Simulation(Config(dt=DT, steps_per_publish=10, gravity=G, bodies=(*bodies, ground),
                             contact=ContactSettings(friction=0.5, sleep_time=0.5)))


def test_a_box_at_rest_on_the_ground_accelerates_nowhere_and_its_imu_reads_plus_g():
    box = BodySpec('box', 1.0, (1 / 150,) * 3, initial_position=(0.0, 0.0, 0.1),
                   colliders=(Box((0.2, 0.2, 0.2)),))
    sim = _ground_world(box)
    sim.run(200)  # settled, not yet asleep (0.5 s)
    assert 'box' not in sim.world.sleeping
    a, beta = sim.accelerations('box')
    assert np.linalg.norm(a) < 1e-3 * 9.81 and np.linalg.norm(beta) < 1e-2
    assert specific_force(a, G) == pytest.approx((0.0, 0.0, 9.81), abs=1e-2)
    sim.run(1000)
    assert 'box' in sim.world.sleeping
    assert sim.accelerations('box') == ((0.0,) * 3, (0.0,) * 3)  # held at rest exactly


def test_free_fall_reads_zero_and_the_bounce_reads_the_impulse():
    """Before the ground, a = g exactly (an accelerometer reads 0); in the step of the bounce
    the contact's velocity change over dt: upward, and as large as |dv|/dt."""
    ball = BodySpec('ball', 1.0, (0.004,) * 3, initial_position=(0.0, 0.0, 0.3),
                    colliders=(Sphere(0.1),))
    sim = _ground_world(ball)
    sim.run(50)
    a, _ = sim.accelerations('ball')
    assert specific_force(a, G) == (0.0, 0.0, 0.0)
    peak = 0.0
    for _ in range(400):
        v_before = sim.pose_twist('ball')[2][2]
        sim.run(1)
        v_after = sim.pose_twist('ball')[2][2]
        a, _ = sim.accelerations('ball')
        if v_before < 0.0 <= v_after:  # the bounce: g dt integrated, the rest the contact's
            assert a[2] == pytest.approx((v_after - v_before) / DT, rel=1e-9)
            peak = a[2]
    assert peak > 100.0  # about 2.4 m/s reversed in one step


def test_a_teleport_is_not_an_acceleration():
    box = BodySpec('box', 1.0, (1 / 150,) * 3, initial_position=(0.0, 0.0, 0.1),
                   colliders=(Box((0.2, 0.2, 0.2)),))
    sim = _ground_world(box)
    sim.run(100)
    sim.apply(SetPose((0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), 'box'))
    assert sim.accelerations('box')[0] == (0.0, 0.0, -9.81)  # in the air: g only
    assert sim.accelerations('ground') == ((0.0,) * 3, (0.0,) * 3)


def test_no_noise_is_no_change_and_the_noise_has_the_asked_statistics():
    assert ImuSensor(ImuNoise(), 0).sample(1000) is None
    sigma_g, sigma_a = 0.01, 0.2
    s = ImuSensor(ImuNoise(gyro_noise=sigma_g, accel_noise=sigma_a, seed=7), 3)
    draws = np.array([np.concatenate(s.sample(k * 10_000_000)) for k in range(20_000)])
    assert np.allclose(draws.mean(axis=0), 0.0, atol=4 * sigma_a / math.sqrt(20_000))
    assert np.allclose(draws.std(axis=0)[:3], sigma_g, rtol=0.03)
    assert np.allclose(draws.std(axis=0)[3:], sigma_a, rtol=0.03)
    # independent axes
    assert abs(np.corrcoef(draws[:, 0], draws[:, 1])[0, 1]) < 0.03


def test_the_bias_walks_as_sigma_sqrt_t():
    """Without white noise the offsets are the biases: their increments over dt have standard
    deviation sigma_b sqrt(dt), and they start at zero."""
    walk_g, walk_a, dt_ns = 0.002, 0.05, 5_000_000
    s = ImuSensor(ImuNoise(gyro_bias_walk=walk_g, accel_bias_walk=walk_a, seed=1), 0)
    biases = np.array([np.concatenate(s.sample(k * dt_ns)) for k in range(20_000)])
    assert np.all(biases[0] == 0.0)
    steps = np.diff(biases, axis=0) / math.sqrt(dt_ns * 1e-9)
    assert np.allclose(steps.std(axis=0)[:3], walk_g, rtol=0.03)
    assert np.allclose(steps.std(axis=0)[3:], walk_a, rtol=0.03)


def test_a_turn_on_bias_is_the_offset_of_every_sample_and_where_the_walk_starts():
    still = ImuSensor(ImuNoise(gyro_bias=(0.01, -0.02, 0.03), accel_bias=(0.1, 0.0, -0.2)), 0)
    for k in range(5):
        assert still.sample(k * 10_000_000) == ((0.01, -0.02, 0.03), (0.1, 0.0, -0.2))
    walking = ImuSensor(ImuNoise(gyro_bias_walk=0.1, gyro_bias=(0.5, 0.0, 0.0), seed=3), 0)
    first, second = walking.sample(0), walking.sample(10_000_000)
    assert first == ((0.5, 0.0, 0.0), (0.0, 0.0, 0.0)) and second[0] != first[0]
    plain = ImuSensor(ImuNoise(gyro_bias_walk=0.1, seed=3), 0)
    plain.sample(0)
    assert np.allclose(np.subtract(second[0], plain.sample(10_000_000)[0]), (0.5, 0, 0),
                       rtol=0, atol=1e-15)  # the same walk, from the bias


def test_the_noise_is_a_function_of_seed_body_and_times():
    noise = ImuNoise(gyro_noise=0.1, accel_noise=0.1, gyro_bias_walk=0.1, seed=42)
    times = [k * 10_000_000 for k in range(50)]
    one = [ImuSensor(noise, 2).sample(t) for t in times[:1]]
    a, b = ImuSensor(noise, 2), ImuSensor(noise, 2)
    seq_a, seq_b = [a.sample(t) for t in times], [b.sample(t) for t in times]
    assert seq_a == seq_b and seq_a[0] == one[0]
    other = ImuSensor(noise, 3)
    assert [other.sample(t) for t in times] != seq_a
    reseeded = ImuSensor(ImuNoise(gyro_noise=0.1, accel_noise=0.1, gyro_bias_walk=0.1, seed=43), 2)
    assert [reseeded.sample(t) for t in times] != seq_a


@pytest.mark.parametrize('field, value', [
    ('gyro_noise', float('nan')), ('accel_noise', -1.0), ('gyro_bias_walk', float('inf')),
    ('accel_bias_walk', True), ('seed', -1), ('seed', 1.5),
    ('gyro_bias', (float('nan'), 0.0, 0.0)), ('accel_bias', (1.0, 2.0)),
    ('gyro_bias', [0.0, 0.0, 0.0]), ('accel_bias', (0.0, 0.0, 2e6))])
def test_bad_noise_is_refused_with_its_name(field, value):
    with pytest.raises(ValueError, match=field if field != 'seed' else 'seed'):
        ImuNoise(**{field: value})


def test_an_undone_sample_leaves_the_stream_as_it_was():
    """A publish that could not go out takes its draw back (as replay never saw it)."""
    noise = ImuNoise(gyro_noise=0.1, accel_noise=0.2, gyro_bias_walk=0.3, seed=9)
    a, b = ImuSensor(noise, 1), ImuSensor(noise, 1)
    first = a.sample(10_000_000)
    a.sample(20_000_000)
    a.undo()
    assert b.sample(10_000_000) == first
    assert a.sample(30_000_000) == b.sample(30_000_000)


def test_the_stream_is_twelve_normals_a_sample_of_the_seeded_pcg64():
    """The documented stream, from numpy alone: sample k adds the normals 12k .. 12k + 11 of
    PCG64(SeedSequence([seed, body index])) (gyro, accel, then the walks' steps), across the
    sensor's batches of draws, with a sample undone at the edge of a batch."""
    noise = ImuNoise(gyro_noise=0.1, accel_noise=0.2, seed=5)
    sensor = ImuSensor(noise, 4)
    normals = np.random.Generator(np.random.PCG64(np.random.SeedSequence([5, 4]))) \
        .standard_normal(12 * 150).reshape(150, 12)
    for k in range(150):
        if k in (63, 64, 128):
            sensor.sample(k * 10_000_000)
            sensor.undo()
        gyro, accel = sensor.sample(k * 10_000_000)
        assert gyro == tuple(0.1 * c for c in normals[k, :3].tolist())  # (no bias)
        assert accel == tuple(0.2 * c for c in normals[k, 3:6].tolist())
