# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
import importlib.util
import os
from pathlib import Path
import re
import sys

from hypothesis import settings
import pytest

from support import ros_harness

# oracles/ (the references, closed forms and scenarios that the tests share with the
# benchmarks) is a directory of the checkout beside test/, not installed with the package: the
# tests import it from the checkout, however pytest was started (colcon test, tools/test.sh, a
# pytest run from elsewhere). test/ itself is on the path already (this file's directory), for
# the tests' own support package.
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.append(str(ROOT))

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
# Hypothesis also draws constants found in the project's modules that the process has imported
# (hypothesis.internal.conjecture.providers): in a pytest-xdist worker those depend on which
# tests ran there before, so derandomized examples still changed from run to run (a CI run
# found an energy gain no run before it had drawn; test_untrusted_physics_contacts.py keeps it).
# Without them the examples depend on the test alone.
try:
    from hypothesis.internal.conjecture import providers as _providers
    if hasattr(_providers, '_get_local_constants') and hasattr(_providers, '_local_constants'):
        _none = _providers._local_constants  # empty until a first draw scans the modules
        _providers._get_local_constants = lambda: _none
except ImportError:  # pragma: no cover - another Hypothesis: its own behaviour then
    pass


# Test modules that need a package with no rosdep key (PyPI only) say so in a line
# '# pypi-only: mcap rosbags'; those that need a message package PyPI lacks, which
# tools/build_msgs.sh builds into the venv, in a line '# built-msgs: tf2_msgs'. Where one is
# missing (colcon test on a ROS install without it) the module is skipped with the reason; in CI
# (CI set), where tools/test.sh installed and built them all, a missing one fails.
NEEDS = re.compile(r'^# (pypi-only|built-msgs):(.*)$', re.MULTILINE)
IN_CI = os.environ.get('CI', '').lower() not in ('', '0', 'false')
HOW = {'pypi-only': 'on PyPI only (pip install {}; ./tools/test.sh installs them)',
       'built-msgs': 'not on PyPI: tools/build_msgs.sh builds {} (see '
                     '.venv/.rb_sim_ros-msgs.log), a ROS install has it'}


class _Needs(pytest.Module):
    def collect(self):
        for kind, names in NEEDS.findall(self.path.read_text()):
            missing = [m for m in names.split() if importlib.util.find_spec(m) is None]
            if missing:
                why = f"needs {', '.join(missing)}, " + HOW[kind].format(' '.join(missing))
                if IN_CI:
                    raise RuntimeError(why)
                pytest.skip(why)
        return super().collect()


def pytest_pycollect_makemodule(module_path, parent):
    if module_path.name.startswith('test_') and NEEDS.search(module_path.read_text()):
        return _Needs.from_parent(parent, path=module_path)
    return None


def pytest_configure(config):
    # The suite meets many scenes: every contact test compiled once, not a world step for each
    # scene's set (world_step.tests_for); the tests of that choice unset it.
    os.environ.setdefault('RB_SIM_ROS_CONTACT_TESTS', 'all')
    config.addinivalue_line(
        'markers', 'slow: seconds to minutes each: a real node over DDS (every test that uses '
        'the installed package), a benchmark or a long search; the fast set is -m "not slow"')


def pytest_collection_modifyitems(items):
    for item in items:
        if 'installed' in getattr(item, 'fixturenames', ()):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope='session')
def installed():
    """The package installed into a prefix colcon-style (lib/rb_sim_ros/...), its kernels
    compiled into the installed tree: made once for these sources and shared
    (``ros_harness.shared_install``), by a parallel run's workers and by later runs."""
    return ros_harness.shared_install()


@pytest.fixture
def ros_env(installed):
    return ros_harness.ros_env(installed)


@pytest.fixture
def probe(ros_env):
    p = ros_harness.Probe(ros_env)
    yield p
    p.close()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Each phase's report kept on the test (``item.rep_call``), for fixtures that say more
    when the test failed."""
    outcome = yield
    report = outcome.get_result()
    setattr(item, f'rep_{report.when}', report)


@pytest.fixture
def start_sim(installed, ros_env, tmp_path, request):
    """start_sim('-p', 'dt:=0.001', ...) runs the installed simulator with --ros-args. When
    the test fails, the end of each node's log is printed (in the failure's report)."""
    procs = []

    def start(*ros_args, exe='simulator', args=()):
        full = [*args, '--ros-args', *ros_args] if ros_args else list(args)
        proc = ros_harness.SimProcess(installed, ros_env, full, tmp_path, exe)
        procs.append(proc)
        return proc

    yield start
    for p in procs:
        p.stop()
    report = getattr(request.node, 'rep_call', None)
    if report is not None and report.failed:
        for p in procs:
            lines = p.output().splitlines()
            print(f'--- the last {min(len(lines), 60)} lines of {p.log.name} ---',
                  *lines[-60:], sep='\n')
