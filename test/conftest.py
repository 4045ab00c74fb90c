# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
import os

from hypothesis import settings
import pytest

import ros_harness

# Property tests: no deadline anywhere (a loaded machine is slow, not wrong). In CI (CI set, as
# CI services do) the examples are derandomized, so a run is repeatable, and a failure prints the
# blob that reproduces it; HYPOTHESIS_PROFILE chooses one explicitly.
# Both from Hypothesis's own defaults, not from the profile it picks itself when CI is set.
settings.register_profile('ci', settings.get_profile('default'), derandomize=True,
                          deadline=None, print_blob=True, database=None)
settings.register_profile('dev', settings.get_profile('default'), deadline=None)
settings.load_profile(os.environ.get(
    'HYPOTHESIS_PROFILE',
    'ci' if os.environ.get('CI', '').lower() not in ('', '0', 'false') else 'dev'))


@pytest.fixture(scope='session')
def installed(tmp_path_factory):
    """The package installed into a temporary prefix, colcon-style (lib/rb_sim_ros/...)."""
    return ros_harness.install(tmp_path_factory.mktemp('ws') / 'install')


@pytest.fixture
def ros_env(installed):
    return ros_harness.ros_env(installed)


@pytest.fixture
def probe(ros_env):
    p = ros_harness.Probe(ros_env)
    yield p
    p.close()


@pytest.fixture
def start_sim(installed, ros_env, tmp_path):
    """start_sim('-p', 'dt:=0.001', ...) runs the installed simulator with --ros-args."""
    procs = []

    def start(*ros_args, exe='simulator', args=()):
        full = [*args, '--ros-args', *ros_args] if ros_args else list(args)
        proc = ros_harness.SimProcess(installed, ros_env, full, tmp_path, exe)
        procs.append(proc)
        return proc

    yield start
    for p in procs:
        p.stop()
