# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The compiled kernels: one source for the compiled and the interpreted path, Thm 1 as the
report writes it, and a cache that cannot serve stale machine code."""

import ast
import json
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from rb_sim_ros.core import euler_dynamics, jit, so3, step_kernel as K
from support import kernel_fingerprint

HERE = Path(__file__).resolve().parent


def _fingerprints(disable_jit: bool) -> dict:
    env = dict(os.environ, NUMBA_DISABLE_JIT='1' if disable_jit else '0')
    cases = ['batch', 'demo', 'heap', 'high_order']
    out = subprocess.run([sys.executable, kernel_fingerprint.__file__, *cases], env=env,
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_compiled_and_interpreted_paths_give_the_same_bits():
    """1000 batch bodies, the collision demo (1.5 s, a wrench change), the 1000-sphere heap
    (3 steps) and the lie3 / lie4 / flow2 / flow4 runs: compiled, and interpreted with
    NUMBA_DISABLE_JIT=1, the same states to the bit."""
    compiled, interpreted = _fingerprints(False), _fingerprints(True)
    assert compiled.pop('compiled') is True and interpreted.pop('compiled') is False
    assert compiled == interpreted


def _thm1_world(moments, q, rot, omega, torque_world):
    """eq. (10) literally: I = R I_body R^T in the world frame, solved with numpy."""
    inertia_body = q @ np.diag(moments) @ q.T
    inertia_world = rot @ inertia_body @ rot.T
    return euler_dynamics.angular_acceleration_world(inertia_world, omega, torque_world)


@pytest.mark.parametrize('frame', ['world', 'body'])
@pytest.mark.parametrize('isotropic', [False, True])
def test_kernel_accelerations_are_thm1_in_the_world_frame(frame, isotropic):
    rng = np.random.default_rng(11)
    for _ in range(50):
        moments = np.sort(rng.uniform(0.5, 2.0, 3))
        if isotropic:
            moments[:] = moments[1]
        rot = so3.exp(rng.normal(size=3))  # R of the principal frame
        omega, torque, force = rng.normal(size=(3, 3)) * 2.0
        mass, gravity = 1.7, np.array([0.1, -0.2, -9.81])
        p = np.zeros((1, K.PARAM_WIDTH))
        in_body = frame == 'body'
        p[0, K.MOMENTS:K.MOMENTS + 3] = moments
        p[0, K.INVERSE_MOMENTS:K.INVERSE_MOMENTS + 3] = 1.0 / moments
        p[0, K.FORCE:K.FORCE + 3] = force / mass
        p[0, K.TORQUE:K.TORQUE + 3] = torque
        p[0, K.GRAVITY:K.GRAVITY + 3] = gravity
        p[0, K.WORLD_A:K.WORLD_A + 3] = force / mass + gravity
        p[0, K.FLAGS] = ((K.FORCE_IN_BODY | K.TORQUE_IN_BODY if in_body else 0)
                         | K.SPECIALIZE | (K.ISOTROPIC if isotropic else 0))
        out = K.accelerations(p, 0, *rot.reshape(9), *omega, 0.0, 0.0, 0.0, False)
        torque_world = rot @ torque if in_body else torque
        expect_b = _thm1_world(moments, np.eye(3), rot, omega, torque_world)
        expect_a = (rot @ force if in_body else force) / mass + gravity
        np.testing.assert_allclose(out[:3], expect_a, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(out[3:], expect_b, rtol=1e-12, atol=1e-12)


def test_every_compiled_module_is_in_the_cache_stamp():
    """numba keys its own cache on the one file of a function; ours hashes every module of the
    kernel layers, so an edit of a helper recompiles what calls it. A kernel outside those
    layers would not be stamped."""
    package = Path(jit.__file__).resolve().parent.parent
    with_kernels = {f for f in package.rglob('*.py')
                    if re.search(r'^@(parallel_)?kernel\b', f.read_text(), re.M)}
    assert with_kernels and with_kernels <= set(jit.kernel_sources())


def test_the_world_tuple_is_never_passed_to_a_function():
    """numba increfs every array of a tuple argument on entry and decrefs it on exit, and with
    a call in between LLVM keeps all those atomic operations: passing the World (48 arrays) to
    a stage cost 0.45 us an invocation (in a compiled loop over resting boxes, 720 against
    270 ns a body). The stages of world_step.py take the arrays they use; only world_steps
    holds ``w``."""
    package = Path(jit.__file__).resolve().parent.parent
    tree = ast.parse((package / 'contact' / 'world_step.py').read_text())
    passed = [f'line {node.lineno}' for node in ast.walk(tree) if isinstance(node, ast.Call)
              for arg in [*node.args, *(k.value for k in node.keywords)]
              if isinstance(arg, (ast.Name, ast.Starred)) and 'w' in {
                  n.id for n in ast.walk(arg) if isinstance(n, ast.Name)}]
    takes = [f.name for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)
             and f.name != 'world_steps' and 'w' in {a.arg for a in f.args.args}]
    assert not passed and not takes, (passed, takes)


def test_the_stamp_changes_with_any_kernel_source(tmp_path, monkeypatch):
    package = Path(jit.__file__).resolve().parent.parent
    for layer in jit.KERNEL_LAYERS:
        shutil.copytree(package / layer, tmp_path / layer,
                        ignore=shutil.ignore_patterns('__pycache__'))
    monkeypatch.setattr(jit, 'PACKAGE', tmp_path)
    before = jit.source_stamp()
    assert before == jit.source_stamp()
    sources = jit.kernel_sources()
    assert len(sources) > 10
    for path in sources:
        text = path.read_text()
        path.write_text(text + '\n# an edit\n')
        assert jit.source_stamp() != before, path
        path.write_text(text)
    assert jit.source_stamp() == before


def test_the_cache_moves_to_the_user_directory_where_the_package_is_read_only(
        tmp_path, monkeypatch):
    unwritable = Path('/dev/null/numba')  # under a file: mkdir fails, as in a read-only tree
    monkeypatch.setattr(jit, 'cache_directories', lambda: [unwritable, tmp_path / 'user'])
    function = getattr(K.advance_bodies_two, 'py_func', K.advance_bodies_two)
    locator = jit._SourceHashLocator.from_function(function, K.__file__)
    assert locator is not None and Path(locator.get_cache_path()) == tmp_path / 'user'
    # Functions outside the package are left to numba's own locators.
    assert jit._SourceHashLocator.from_function(np.add.__call__, __file__) is None


def test_numba_cache_dir_moves_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))
    assert jit.cache_directories() == [tmp_path / 'rb_sim_ros']
    monkeypatch.delenv('NUMBA_CACHE_DIR')
    assert jit.cache_directories()[0] == jit.PACKAGE / '__pycache__' / 'numba'


def test_warm_up_compiles_and_changes_nothing():
    """The node warms the kernels up before its clock starts; a run after it is the run
    without it, to the bit (collision demo, with a body without colliders too)."""
    from rb_sim_ros.sim.scene import load_scene
    from rb_sim_ros.sim.simulation import Config, Simulation
    gravity, bodies, contact = load_scene(str(HERE.parents[1] / 'scenes' / 'collisions.yaml'))[:3]
    config = Config(gravity=gravity, bodies=tuple(bodies), contact=contact)
    warmed, cold = Simulation(config), Simulation(config)
    warmed.warm_up()
    warmed.warm_up()
    assert warmed.step_count == 0
    for sim in (warmed, cold):
        sim.run(300)
    assert [warmed.pose_twist(b.name) for b in bodies] == [cold.pose_twist(b.name)
                                                           for b in bodies]
    assert warmed.contact_stats().contacts == cold.contact_stats().contacts


def _mixed_batch(n: int = 75):
    """A batch whose bodies between them take every branch of a step: diagonal, rotated and
    isotropic inertias, forces and torques in both frames, damping, gravity, spins past the
    small-angle series (0.4 rad a step), bodies at rest (skipped), a new wrench (history
    re-evaluated) and orthonormalisation countdowns running out during the run."""
    from rb_sim_ros.core.batch import BatchStepper
    rng = np.random.default_rng(7)
    inertias = kernel_fingerprint.mixed_inertias(rng, n, 4)
    omega = rng.normal(size=(n, 3)) * 3.0
    omega[::9] *= 400.0 / np.linalg.norm(omega[::9], axis=1, keepdims=True)
    b = BatchStepper(rng.uniform(0.5, 3.0, n), np.array(inertias), 1e-3,
                     rng.normal(size=(n, 3)), [so3.exp(rng.normal(size=3)) for _ in range(n)],
                     rng.normal(size=(n, 3)), omega, gravity=(0.0, 0.0, -9.81),
                     linear_damping=rng.uniform(0, 0.3, n) * (np.arange(n) % 3 == 0),
                     angular_damping=rng.uniform(0, 0.2, n) * (np.arange(n) % 5 == 0))
    half = (n + 1) // 2
    b.set_wrench(np.arange(0, n, 2), rng.normal(size=(half, 3)), rng.normal(size=(half, 3)),
                 (['world', 'body'] * n)[:half])
    b.step(3)  # past the start-up: valid histories
    rest = np.arange(5, n, 11)
    b.set_state(rest, angular_velocities=(0.0, 0.0, 0.0))
    b.set_wrench(rest, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'world')
    b.step(2)
    b.set_wrench(np.arange(1, n, 7), rng.normal(size=3), rng.normal(size=3), 'body')  # stale
    state = b._state.copy()
    state[:, K.COUNTDOWN] = rng.integers(1, 30, n)
    return b, state


def test_a_block_of_lanes_gives_each_body_the_bits_of_its_own_steps():
    """``advance`` steps bodies in blocks of SIMD lanes; each body must end with the bits
    ``advance_body`` gives it alone: state, status, steps taken and work counted, for a batch
    that takes every branch (``_mixed_batch``) over 40 steps."""
    b, state = _mixed_batch()
    n = state.shape[0]
    lanes = [i for i in range(n) if K._lane_ready(state, b._params, i)]
    assert 0.6 * n < len(lanes) < n  # most bodies in lanes, some not
    bodies = np.arange(n, dtype=np.int64)
    runs = []
    for blocked in (True, False):
        dst, work = np.zeros_like(state), b._work.copy()
        status, taken = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        bad = np.zeros((n, 3))
        if blocked:
            assert K.blocked(b._coefficients, len(bodies), 40, False)
            K.advance(state, dst, b._params, b._coefficients, bodies, 40, False, status, taken,
                      bad, work)
        else:
            for i in bodies:
                K.advance_body(state, dst, b._params, b._coefficients, i, 40, False, status,
                               taken, bad, work)
        runs.append((dst, status, taken, work))
    for blocked, alone in zip(*runs):
        assert blocked.tobytes() == alone.tobytes()
    dst = runs[0][0]
    assert not np.array_equal(dst[lanes, K.X:K.HISTORY], state[lanes, K.X:K.HISTORY])
