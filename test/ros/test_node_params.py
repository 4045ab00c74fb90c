# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Every node parameter is type- and range-checked before it is used (no ROS needed)."""

import math

from hypothesis import given, settings, strategies as st
import pytest

from rb_sim_ros.ros import node_params
from rb_sim_ros.ros.node_config import config_from as _config
from rb_sim_ros.sim.imu import ImuNoise, ImuSensor, MAX_SIGMA

DEFAULTS = {p.name: p.default for p in node_params.PARAMS}

# Values a ROS parameter can hold: bool, int, float, str and arrays of each.
SCALARS = st.one_of(st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True),
                    st.text(max_size=8))
VALUES = st.one_of(SCALARS, st.lists(st.booleans(), max_size=10),
                   st.lists(st.integers(-10**30, 10**30), max_size=10),
                   st.lists(st.floats(allow_nan=True), max_size=10),
                   st.lists(st.text(max_size=4), max_size=10))


@settings(max_examples=600, deadline=None)
@given(st.sampled_from([p.name for p in node_params.PARAMS]), VALUES)
def test_a_value_is_refused_with_its_name_or_accepted_and_usable(name, value):
    """check() raises ValueError naming the parameter, or the value builds a configuration
    (else ValueError): never TypeError, OverflowError or an unbounded period."""
    try:
        node_params.check(name, value)
    except ValueError as e:
        assert name in str(e)
        return
    values = dict(DEFAULTS, **{name: value})
    try:
        config = _config(values)
    except ValueError:
        return
    assert 1 <= config.steps_per_publish <= node_params.MAX_STEPS_PER_PERIOD
    assert math.isfinite(config.dt) and config.dt > 0


@pytest.mark.parametrize('name, value', [
    ('inertia', 5), ('initial_position', 5), ('initial_orientation', [0, 0, 0, 0]),
    ('record', 5), ('scene_file', 5), ('dt', 1e-300), ('dt', True),
    ('max_catchup', 0.5), ('max_catchup', 0), ('max_catchup', True),
    ('real_time_factor', 1e-300), ('real_time_factor', math.inf),
    ('mass', True), ('max_wrench', True), ('command_timeout', False),
    ('inertia', [True, True, True]), ('initial_position', [1.0, 2.0]),
    ('start_paused', 1), ('publish_clock', 0.0), ('record_overwrite', 'yes'),
    ('integrator', 3), ('wrench_frame', 1), ('world_frame', 7), ('dt', 10**400),
    ('command_timeout', 1e306),
])
def test_the_values_that_killed_the_node_are_refused(name, value):
    with pytest.raises(ValueError, match=name):
        node_params.check(name, value)


@pytest.mark.parametrize('value, why', [
    ([0.1] * 5, 'list of 6 or 36'), ([0.1] * 5 + [-0.1], 'must be >= 0'),
    ([0.1] * 5 + [math.nan], 'finite'), ([0.1] * 5 + [True], 'number'),
    ([1.0 if i % 7 == 0 else (0.5 if i == 1 else 0.0) for i in range(36)], 'symmetric'),
])
def test_odom_covariances_are_refused_with_the_reason(value, why):
    for name in ('odom_pose_covariance', 'odom_twist_covariance'):
        with pytest.raises(ValueError, match=f'{name}.*{why}'):
            node_params.check(name, value)


def test_odom_covariance_diagonal_and_full_forms():
    diag = node_params.covariance36([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert [diag[7 * k] for k in range(6)] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert sum(diag) == 21.0
    full = [float(i == j) + 0.1 * (i != j) for i in range(6) for j in range(6)]
    node_params.check('odom_pose_covariance', full)
    assert node_params.covariance36(full) == tuple(full)


def test_a_period_of_unbounded_work_is_refused():
    values = dict(DEFAULTS, dt=1e-9, publish_rate=1e-3)
    with pytest.raises(ValueError, match='steps a period'):
        _config(values)
    assert _config(dict(DEFAULTS, dt=1e-6, publish_rate=10.0)).steps_per_publish == 10**5


def test_a_period_that_would_hold_the_lock_for_seconds_is_refused_in_one_line():
    """dt 1e-9 at 1 kHz is 10^6 steps a period, stepped with the node's lock held: a pause
    waited 4 to 10 s for it. The bound is the documented constant, 10^5 steps."""
    assert node_params.MAX_STEPS_PER_PERIOD == 100_000
    with pytest.raises(ValueError) as e:
        _config(dict(DEFAULTS, dt=1e-9, publish_rate=1000.0))
    why = str(e.value)
    assert '1e+06 steps a period' in why and 'at most 100000' in why and '\n' not in why
    # The bound itself is a period.
    assert _config(dict(DEFAULTS, dt=1e-8, publish_rate=1000.0)).steps_per_publish == 10**5


@pytest.mark.parametrize('name, value', [
    ('body_frame', 'a b'), ('body_frame', 'a//b'), ('body_frame', 'a/'), ('body_frame', '/a'),
    ('body_frame', '1a'), ('body_frame', ''), ('body_frame', 'a-b'), ('body_frame', 'a.b'),
    ('world_frame', 'my world'), ('world_frame', 'map/'), ('world_frame', 'map\t'),
    ('frame_prefix', 'a//'), ('frame_prefix', 'a b/'), ('frame_prefix', '/sim1/'),
    ('frame_prefix', '1/'), ('frame_prefix', '//'), ('frame_prefix', 'a/b-'),
])
def test_a_frame_id_that_is_not_a_ros_name_is_refused_naming_the_parameter(name, value):
    """tf frame ids are ROS names without the leading slash: tokens of letters, digits and _
    (not starting with a digit) joined by single slashes; frame_prefix + a body frame too."""
    with pytest.raises(ValueError, match=f'^{name} must be') as e:
        node_params.check(name, value)
    assert '\n' not in str(e.value)


@pytest.mark.parametrize('name, value', [
    ('body_frame', 'base_link'), ('body_frame', 'robot1/base_link'), ('body_frame', '_b'),
    ('world_frame', 'map'), ('world_frame', 'odom'), ('frame_prefix', ''),
    ('frame_prefix', 'sim1/'), ('frame_prefix', 'sim1_'), ('frame_prefix', 'a/b/'),
])
def test_frame_ids_that_are_ros_names_are_taken(name, value):
    node_params.check(name, value)
    frame = node_params.body_frame(dict(DEFAULTS, **{name: value}), 'body', True)
    assert node_params._FRAME.fullmatch(frame)


def test_every_parameter_has_a_description_and_accepts_its_default():
    for p in node_params.PARAMS:
        assert p.description
        node_params.check(p.name, p.default)
    _config(DEFAULTS)


SIGMAS = ('imu_gyro_noise', 'imu_accel_noise', 'imu_gyro_bias_walk', 'imu_accel_bias_walk')


@pytest.mark.parametrize('name', SIGMAS)
@pytest.mark.parametrize('value', [1.3e154, 1.5e308, 1e6 * (1 + 1e-15)])
def test_imu_deviations_whose_derived_values_overflow_are_refused(name, value):
    with pytest.raises(ValueError, match=name):
        node_params.check(name, value)


def test_the_largest_imu_deviations_keep_covariances_and_samples_finite():
    """At the bound, what the node derives from the deviations stays finite: the variances it
    publishes and a bias walked for 10^5 samples a day apart (as the node samples it)."""
    for name in SIGMAS:
        node_params.check(name, MAX_SIGMA)
    noise = node_params.imu_noise(dict(DEFAULTS, **{n: MAX_SIGMA for n in SIGMAS}))
    assert math.isfinite(noise.gyro_noise ** 2) and math.isfinite(noise.accel_noise ** 2)
    sensor = ImuSensor(noise, 0)
    day = 86_400 * 10**9
    for k in range(100_000):
        gyro, accel = sensor.sample(k * day)
    assert all(math.isfinite(v) for v in gyro + accel)
    with pytest.raises(ValueError, match='gyro_bias_walk'):
        ImuNoise(gyro_bias_walk=1.5e308)


@pytest.mark.parametrize('overrides', [
    {'body_frame': 'world'}, {'world_frame': 'base_link'},
    {'frame_prefix': 'wor', 'body_frame': 'ld'},
    {'frame_prefix': 'a/', 'world_frame': 'a/base_link'},
])
def test_a_body_frame_equal_to_world_frame_is_refused(overrides):
    with pytest.raises(ValueError, match="body 'body': its frame .* is world_frame"):
        _config(dict(DEFAULTS, **overrides))
    _config({**DEFAULTS, **overrides, 'world_frame': 'map'})  # another world frame is fine


def test_a_scene_body_named_like_world_frame_is_refused():
    with pytest.raises(ValueError, match="body 'world': its frame 'world' is world_frame"):
        node_params.body_frame(DEFAULTS, 'world', False)
    assert node_params.body_frame(dict(DEFAULTS, frame_prefix='sim1/'), 'world', False) == \
        'sim1/world'


def test_a_keep_all_override_takes_the_depth_0_rosbag2_records_and_keep_last_needs_1():
    from rclpy.qos import HistoryPolicy, QoSProfile

    from rb_sim_ros.ros.body_ports import _valid_overrides, MAX_DEPTH
    assert _valid_overrides(QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0)).successful
    assert _valid_overrides(QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1)).successful
    for history, depth in ((HistoryPolicy.KEEP_LAST, 0), (HistoryPolicy.KEEP_ALL, MAX_DEPTH + 1)):
        profile = QoSProfile(history=history, depth=1)
        profile.depth = depth
        result = _valid_overrides(profile)
        assert not result.successful and 'depth must be from' in result.reason
