# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The layers import downward only: ros -> sim -> contact -> core, ros -> recording, and
ros -> pictures -> sim (the pictures of a run draw with no ROS at all); the offline tools
(offline: replay, sweep) stand beside ros and use it, and nothing imports them.

Every import of this package's modules, at any depth of a module (a function's too), is read
from the source with ast; an import of a layer above, or beside, fails here, and so does an
import deferred into a function (the way to dodge a circle) unless it is listed below with its
reason.
"""

import ast
from pathlib import Path
import subprocess
import sys

PACKAGE = Path(__file__).resolve().parents[2] / 'rb_sim_ros'
ALLOWED = {
    'core': {'core'},
    'contact': {'contact', 'core'},
    'sim': {'sim', 'contact', 'core'},
    'ros': {'ros', 'sim', 'contact', 'core', 'recording', 'pictures', ''},  # '': __version__
    # the offline tools: beside the live node, never imported by it
    'offline': {'offline', 'ros', 'sim', 'contact', 'core', 'recording', 'pictures', ''},
    'recording': {'recording'},
    'pictures': {'pictures', 'sim', 'contact', 'core'},
    '': {'core'},  # rb_sim_ros/__init__.py re-exports the core's public names
}
# (module, imported module): why it is imported in a function and not at the top.
DEFERRED = {
    ('ros/simulator_node.py', 'rb_sim_ros.ros.node_recorder'):
        'recording needs mcap, a PyPI package a ROS install may not have; a node that does not '
        'record must start without it',
    ('ros/simulator_node.py', 'rb_sim_ros.ros.sim_interfaces'):
        'in a try: simulation_interfaces is not on PyPI (tools/build_msgs.sh builds it); a node '
        'without it starts without the standard API and says so',
}


def _layer(dotted: str) -> str | None:
    parts = dotted.split('.')
    if parts[0] != 'rb_sim_ros':
        return None
    if len(parts) == 1:
        return ''
    return parts[1] if parts[1] in ALLOWED else ''


def _imports(path: Path):
    """(imported module, line, at module level, the statement's own module) of every
    rb_sim_ros import; 'from a.b import c' gives a.b and a.b.c (c may be a module)."""
    tree = ast.parse(path.read_text(), str(path))
    top = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [(a.name, True) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [(node.module, True)] + [(f'{node.module}.{a.name}', False)
                                             for a in node.names]
        else:
            continue
        for name, own in names:
            if name.split('.')[0] == 'rb_sim_ros':
                yield name, node.lineno, id(node) in top, own


def violations(package: Path) -> list[str]:
    problems = []
    for path in sorted(package.rglob('*.py')):
        rel = path.relative_to(package)
        here = rel.parts[0] if len(rel.parts) > 1 else ''
        for name, line, at_top, own in _imports(path):
            target = _layer(name)
            if target not in ALLOWED[here] and (own or target != ''):
                problems.append(f'{rel}:{line} ({here or "package"}) imports {name} '
                                f'({target or "package"})')
            if own and not at_top and (rel.as_posix(), name) not in DEFERRED:
                problems.append(f'{rel}:{line} defers the import of {name} into a function')
    return problems


def test_every_module_is_in_a_layer():
    for path in PACKAGE.rglob('*.py'):
        rel = path.relative_to(PACKAGE)
        assert len(rel.parts) == 1 and rel.name == '__init__.py' or rel.parts[0] in ALLOWED, rel


def test_imports_go_downward_only():
    assert violations(PACKAGE) == []


def test_a_violation_is_caught(tmp_path):
    """The check itself: a core module that imports the sim layer, and a deferred import."""
    fake = tmp_path / 'rb_sim_ros'
    (fake / 'core').mkdir(parents=True)
    (fake / 'core' / 'bad.py').write_text(
        'from rb_sim_ros.sim.simulation import Config\n\n\ndef f():\n'
        '    from rb_sim_ros.core import so3\n')
    found = violations(fake)
    assert 'core/bad.py:1 (core) imports rb_sim_ros.sim.simulation (sim)' in found
    assert 'core/bad.py:5 defers the import of rb_sim_ros.core into a function' in found
    assert len(found) == 3  # and rb_sim_ros.sim.simulation.Config, a name of the sim layer


def _ros_loaded_by(layer: str) -> list[str]:
    """The ROS packages (rclpy, rosidl, message and interface packages) that importing every
    module of ``layer`` loads, in a fresh interpreter."""
    modules = sorted(f'rb_sim_ros.{layer}.{p.stem}' for p in (PACKAGE / layer).glob('*.py'))
    code = ''.join(f'import {m}\n' for m in modules) + (
        'import sys\n'
        'print(sorted({n.split(".")[0] for n in sys.modules if n.split(".")[0] == "rclpy" or '
        'n.startswith("rosidl") or n.split(".")[0].endswith(("_msgs", "_interfaces"))}))\n')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, cwd=PACKAGE.parent)
    return ast.literal_eval(out.stdout.strip())


def test_the_core_the_physics_and_the_pictures_run_without_ros():
    """What runs offline, on a machine with no ROS, loads none: the integrator, the contacts,
    the simulation and the pictures of a run. (The check finds ROS where it is: ros/.)"""
    for layer in ('core', 'contact', 'sim', 'pictures'):
        assert _ros_loaded_by(layer) == [], layer
    assert 'rclpy' in _ros_loaded_by('ros')


LIVE_EXECUTABLES = ('rb_sim_ros.ros.simulator_node', 'rb_sim_ros.ros.send_wrench')


def test_no_module_imports_a_live_executable():
    """The offline tools (replay, sweep), the benchmarks and the rest take what they share
    with the live node from modules of their own (body_ports, node_config, wrench_profile),
    never from the node's or send_wrench's executable module: they run it as a process."""
    root = PACKAGE.parent
    found = [f'{path.relative_to(root)}:{line} imports {name}'
             for path in sorted([*PACKAGE.rglob('*.py'), *(root / 'bench').rglob('*.py')])
             for name, line, _, _ in _imports(path)
             if name.startswith(LIVE_EXECUTABLES) and
             path.with_suffix('').relative_to(root).as_posix().replace('/', '.')
             not in LIVE_EXECUTABLES]
    assert found == []


def _top_level_imports(path: Path):
    """(top-level module name, line) of every absolute import in ``path``, at any depth."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name.split('.')[0], node.lineno
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module.split('.')[0], node.lineno


def test_tests_import_no_test_module_and_bench_and_oracles_stay_out_of_test():
    """What the tests share is in test/support/ (theirs alone) or in oracles/ (shared with the
    benchmarks): no module of test/ imports a test module (test_*.py), bench/ and oracles/
    import nothing of test/ (nor put it on the path), and oracles/ nothing of bench/ (the bench
    package, or one of its modules by its bare name). bench/ edits no path at all: it runs as
    python -m bench.<name> from the repository root, which has bench and oracles on the path."""
    root = PACKAGE.parent
    test_dir = root / 'test'
    test_modules = {p.stem for p in test_dir.rglob('test_*.py')}
    support = {'support'} | {p.stem for p in (test_dir / 'support').glob('*.py')}
    bench = {'bench'} | {p.stem for p in (root / 'bench').glob('*.py')} - {'__init__'}
    found = []
    for path in sorted(test_dir.rglob('*.py')):
        found += [f'{path.relative_to(root)}:{line} imports the test module {name}'
                  for name, line in _top_level_imports(path) if name in test_modules]
    for path in sorted([*(root / 'bench').glob('*.py'), *(root / 'oracles').glob('*.py')]):
        outside = test_modules | support | (bench if path.parent.name == 'oracles' else set())
        found += [f'{path.relative_to(root)}:{line} imports {name}'
                  for name, line in _top_level_imports(path) if name in outside]
        found += [f'{path.relative_to(root)}:{n} puts test/ on the path'
                  for n, text in enumerate(path.read_text().splitlines(), 1)
                  if 'sys.path' in text and "'test'" in text]
        if path.parent.name == 'bench':
            found += [f'{path.relative_to(root)}:{n} edits sys.path'
                      for n, text in enumerate(path.read_text().splitlines(), 1)
                      if 'sys.path' in text]
    assert found == []


def test_the_tests_mirror_the_layers():
    """A test lives in test/<layer>/ for the package of rb_sim_ros it tests (core, contact,
    sim, recording, ros, offline, pictures), or in test/package/ for the checks of the whole
    checkout (style, layers, types, packaging, benchmarks); none at the top of test/, whose
    support/ and fixtures/ are shared."""
    test_dir = PACKAGE.parent / 'test'
    layers = {p.name for p in PACKAGE.iterdir() if (p / '__init__.py').exists()}
    assert {'core', 'contact', 'sim', 'recording', 'ros', 'offline', 'pictures'} <= layers
    found = {p.parent.name for p in test_dir.rglob('test_*.py')}
    assert found <= layers | {'package'}, found - layers
    assert not list(test_dir.glob('test_*.py'))
    assert {p.name for p in test_dir.iterdir() if p.is_dir()} <= (
        layers | {'package', 'support', 'fixtures', '__pycache__'})
    # The layer folders are no packages: pytest imports each test by its base name, and two
    # of one name would fail collection.
    names = [p.name for p in test_dir.rglob('test_*.py')]
    assert len(names) == len(set(names)), sorted({n for n in names if names.count(n) > 1})
