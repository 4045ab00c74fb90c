# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The package as a ROS user installs it: launch file, parameters file, RViz and Foxglove
layouts in share/rb_sim_ros, each consistent with the node's own parameter table."""

import ast
import importlib.util
import json
import os
from pathlib import Path
import re
import subprocess
import sys
import types

from geometry_msgs.msg import PoseStamped
import pytest
from rcl_interfaces.srv import GetParameters
import yaml

from rb_sim_ros.ros import node_params
from support import ros_harness

ROOT = Path(__file__).resolve().parents[2]
SHARE_FILES = ('launch/sim.launch.py', 'config/params.yaml', 'rviz/rb_sim.rviz',
               'foxglove/rb_sim_layout.json', 'scenes/collisions.yaml', 'scenes/terrain.yaml',
               'package.xml')


def _params_file(path: Path) -> dict:
    return yaml.safe_load(path.read_text())['rb_sim']['ros__parameters']


def test_params_yaml_has_every_parameter_at_its_default_and_nothing_else():
    values = _params_file(ROOT / 'config' / 'params.yaml')
    assert list(values) == [p.name for p in node_params.PARAMS]
    for p in node_params.PARAMS:
        assert values[p.name] == p.default and type(values[p.name]) is type(p.default), p.name
        node_params.check(p.name, values[p.name])
    sys.path.insert(0, str(ROOT / 'tools'))
    try:
        import make_params_yaml
    finally:
        sys.path.remove(str(ROOT / 'tools'))
    assert (ROOT / 'config' / 'params.yaml').read_text() == make_params_yaml.text()


def test_the_launch_file_sets_only_parameters_the_node_has():
    tree = ast.parse((ROOT / 'launch' / 'sim.launch.py').read_text())
    names = [n for n in ast.walk(tree) if isinstance(n, ast.Assign)
             and any(getattr(t, 'id', '') == 'NODE_PARAMETERS' for t in n.targets)]
    assert len(names) == 1
    params = ast.literal_eval(names[0].value)
    assert params and all(p in node_params.BY_NAME for p in params)
    declared = {n.args[0].value for n in ast.walk(tree) if isinstance(n, ast.Call)
                and getattr(n.func, 'id', '') == 'DeclareLaunchArgument'}
    assert set(params) <= declared and {'params_file', 'rviz'} <= declared


def test_rviz_and_foxglove_layouts_show_the_world_frame_tf_and_markers():
    rviz = yaml.safe_load((ROOT / 'rviz' / 'rb_sim.rviz').read_text())['Visualization Manager']
    assert rviz['Global Options']['Fixed Frame'] == node_params.BY_NAME['world_frame'].default
    classes = {d['Class'] for d in rviz['Displays']}
    assert {'rviz_default_plugins/TF', 'rviz_default_plugins/MarkerArray',
            'rviz_default_plugins/PoseArray'} <= classes
    topics = {d['Topic']['Value'] for d in rviz['Displays'] if 'Topic' in d}
    assert {'/collision_markers', '/poses'} <= topics
    fox = json.loads((ROOT / 'foxglove' / 'rb_sim_layout.json').read_text())
    assert fox['configById']['3D!rbsim']['followTf'] == 'world'
    assert set(fox['configById']) >= {'3D!rbsim'}


def _layout_topics(value):
    """Every topic a Foxglove layout names: topic keys, and the topic of each message path."""
    if isinstance(value, dict):
        for key, item in value.items():
            if key.startswith('/'):
                yield key
            if key in ('value', 'topicToRender') and isinstance(item, str):
                yield re.match(r'/[^.\[]*', item).group(0)
            yield from _layout_topics(item)
    elif isinstance(value, list):
        for item in value:
            yield from _layout_topics(item)


def test_the_foxglove_layout_watches_topics_every_scene_has_and_titles_current_foxglove_shows():
    """The layout works for any scene: it names only the node's scene-wide topics (not a body's
    ``pose`` or ``imu``, which exist under those names only for the one-body default), and its
    panel titles use the key Foxglove reads (``foxglovePanelTitle``; ``title`` is ignored)."""
    fox = json.loads((ROOT / 'foxglove' / 'rb_sim_layout.json').read_text())
    topics = set(_layout_topics(fox['configById']))
    assert {'/poses', '/collision_markers'} <= topics
    assert topics <= {'/poses', '/collision_markers', '/diagnostics', '/tf', '/tf_static',
                      '/clock'}, topics
    for panel, config in fox['configById'].items():
        assert 'title' not in config, panel
        if panel.startswith('Plot!'):
            assert config.get('foxglovePanelTitle'), panel


def test_share_files_are_installed(installed):
    share = installed / 'share' / 'rb_sim_ros'
    for f in SHARE_FILES:
        assert (share / f).read_bytes() == (ROOT / f).read_bytes(), f
    assert (installed / 'share' / 'doc' / 'rb_sim_ros' / 'LICENSE').is_file()


def test_the_install_compiles_the_kernels_into_its_own_tree(installed, tmp_path):
    """setup.py install (colcon build) compiles the kernels into the installed package's cache:
    a process running from the install then loads every kernel of a run, with and without
    colliders (``precompile``), and compiles none (numba's compile events count them); the
    cache's marker says so to a node (which then does not start in the interpreter)."""
    site = ros_harness.site_packages(installed)
    cache = site / 'rb_sim_ros' / '__pycache__' / 'numba'
    for kernel in ('step_kernel.advance_bodies_two-', 'world_step.world_steps_two-'):
        assert any(f.name.startswith(kernel) for f in cache.glob('*.nbi')), kernel
    code = ('from numba.core import event\n'
            'import rb_sim_ros\n'
            'from rb_sim_ros.core import jit\n'
            'from rb_sim_ros.sim.precompile import PARTS, precompile\n'
            'marked = jit.precompiled(PARTS)\n'
            "with event.install_recorder('numba:compile') as compiled:\n"
            '    precompile()\n'
            'print(rb_sim_ros.__file__, len(compiled.buffer), marked)\n')
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    env['PYTHONPATH'] = str(site)
    out = subprocess.run([sys.executable, '-c', code], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    where, compiles, marked = out.stdout.split()[-3:]
    assert Path(where).is_relative_to(site) and compiles == '0', out.stdout
    assert marked == 'True'  # so a node started from it steps compiled from its first step


def test_the_installed_params_yaml_loads_into_a_running_node(start_sim, probe, installed):
    params = installed / 'share' / 'rb_sim_ros' / 'config' / 'params.yaml'
    sim = start_sim('--params-file', str(params), '-p', 'imu_seed:=3')
    poses = probe.collect(PoseStamped, 'pose')
    probe.wait_for(lambda: poses, what='a pose from the node started with params.yaml')
    names = ['dt', 'world_frame', 'inertia', 'publish_tf', 'imu_seed']
    reply = probe.call(GetParameters, '/rb_sim/get_parameters', GetParameters.Request(
        names=names))
    got = {n: reply.values[i] for i, n in enumerate(names)}
    file = _params_file(params)
    assert got['dt'].double_value == file['dt']
    assert got['world_frame'].string_value == file['world_frame']
    assert list(got['inertia'].double_array_value) == file['inertia']
    assert got['publish_tf'].bool_value is file['publish_tf']
    assert got['imu_seed'].integer_value == 3  # the command line after the file wins
    sim.stop()


@pytest.mark.skipif(importlib.util.find_spec('launch_ros') is None,
                    reason='launch_ros is not on PyPI; it runs on a ROS install')
def test_the_launch_description_builds(installed, ros_env, monkeypatch):
    monkeypatch.setenv('AMENT_PREFIX_PATH', ros_env['AMENT_PREFIX_PATH'])
    spec = importlib.util.spec_from_file_location(
        'sim_launch', installed / 'share' / 'rb_sim_ros' / 'launch' / 'sim.launch.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    assert len(description.entities) >= 5


@pytest.mark.parametrize('ci', ['', 'true'])
def test_a_module_needing_a_missing_pypi_package_is_skipped_with_why_and_fails_in_ci(
        tmp_path, ci):
    """What `colcon test` on a ROS install without mcap or rosbags does: skip, saying which
    package is missing; in CI, where tools/test.sh installed everything, fail instead."""
    (tmp_path / 'support').mkdir()
    for name in ('conftest.py', 'support/__init__.py', 'support/ros_harness.py'):
        (tmp_path / name).write_text((ROOT / 'test' / name).read_text())
    (tmp_path / 'test_needs.py').write_text(
        '# pypi-only: no_such_package_xyz\nimport no_such_package_xyz\n\n\n'
        'def test_it():\n    assert no_such_package_xyz\n')
    (tmp_path / 'test_other.py').write_text('def test_other():\n    assert True\n')
    env = {k: v for k, v in os.environ.items() if k != 'CI'}
    if ci:
        env['CI'] = ci
    result = subprocess.run([sys.executable, '-m', 'pytest', '-rs', '-p', 'no:cacheprovider',
                             str(tmp_path)], cwd=tmp_path, env=env, capture_output=True,
                            text=True, timeout=300)
    if ci:
        assert result.returncode != 0 and 'needs no_such_package_xyz' in result.stdout
    else:
        assert result.returncode == 0, result.stdout + result.stderr
        assert 'SKIPPED' in result.stdout and 'needs no_such_package_xyz' in result.stdout


def _fake_launch_modules() -> dict:
    """Stand-ins for launch and launch_ros (not on PyPI) that keep what the file builds."""
    class Recorded:
        def __init__(self, *args, **kwargs):
            self.args, self.kwargs = args, kwargs

    class LaunchConfiguration(Recorded):
        def perform(self, context):
            return context.launch_configurations[self.args[0]]

    names = {'launch': {'LaunchDescription': Recorded},
             'launch.actions': {'DeclareLaunchArgument': Recorded, 'OpaqueFunction': Recorded},
             'launch.conditions': {'IfCondition': Recorded},
             'launch.substitutions': {'LaunchConfiguration': LaunchConfiguration},
             'launch_ros': {}, 'launch_ros.actions': {'Node': Recorded},
             'ament_index_python': {},
             'ament_index_python.packages': {'get_package_share_directory': lambda p: '/share'}}
    modules = {}
    for name, attrs in names.items():
        modules[name] = types.ModuleType(name)
        for k, v in attrs.items():
            setattr(modules[name], k, v)
    return modules


@pytest.mark.parametrize('given', [{}, {'scene_file': 's.yaml'}, {'record': 'r.mcap'},
                                   {'scene_file': 's.yaml', 'record': 'r.mcap'}])
def test_the_launch_file_passes_scene_file_and_record_only_when_given(monkeypatch, given):
    for name, module in _fake_launch_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location('sim_launch_fake',
                                                  ROOT / 'launch' / 'sim.launch.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    opaque = [e for e in description.args[0] if 'function' in e.kwargs]
    assert len(opaque) == 1
    context = types.SimpleNamespace(launch_configurations={
        'params_file': 'p.yaml', 'rviz': 'false', 'scene_file': '', 'record': '', **given})
    (node,) = opaque[0].kwargs['function'](context)
    assert node.kwargs['executable'] == 'simulator'
    params = node.kwargs['parameters']
    # The params file first; then only the arguments given, so that the file's own scene_file
    # and record stand when the command line leaves them out.
    assert params[0].args == ('params_file',)
    overrides = {k: v for p in params[1:] for k, v in p.items()}
    assert overrides == given


# The rosdep key of each third-party Python module the package imports, where it differs from
# the module's name (ROS packages are keyed by their own name); PyPI-only modules have none,
# and the README says how to install them on a ROS machine.
ROSDEP_KEY = {'numpy': 'python3-numpy', 'yaml': 'python3-yaml', 'numba': 'python3-numba',
              'regex': 'python3-regex', 'matplotlib': 'python3-matplotlib', 'PIL': 'python3-pil',
              'imageio': 'python3-imageio', 'tqdm': 'python3-tqdm', 'scipy': 'python3-scipy',
              'trimesh': 'python3-trimesh'}
PYPI_ONLY = {'mcap', 'ray', 'imageio_ffmpeg', 'mujoco', 'coacd'}


def test_every_module_the_package_imports_has_a_rosdep_key_in_package_xml():
    """rosdep installs what package.xml names: a new import without its key works here (pip)
    and fails on a ROS install."""
    import xml.etree.ElementTree as ET
    xml = ET.parse(ROOT / 'package.xml').getroot()
    keys = {e.text for e in xml if e.tag.endswith('depend')}
    missing = set()
    for path in (ROOT / 'rb_sim_ros').rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split('.')[0]
                if top in sys.stdlib_module_names or top in ('rb_sim_ros', '__future__') \
                        or top in PYPI_ONLY:
                    continue
                if ROSDEP_KEY.get(top, top) not in keys:
                    missing.add(f'{top} ({path.relative_to(ROOT)})')
    assert not missing, sorted(missing)
