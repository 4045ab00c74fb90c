# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The two tiers of one process (core/jit.py): kernels run in the interpreter for a while, then
compiled again, and a run goes on with the bits of an all-compiled one; nothing compiles in
the process meanwhile."""

import ast
import os
from pathlib import Path
import subprocess
import sys

from numba.core import event
import numpy as np
import pytest

from rb_sim_ros.contact import narrow_kernels as nk, world_step as ws
from rb_sim_ros.contact.collision_shapes import Sphere
from rb_sim_ros.core import jit, so3, step_kernel as K
from rb_sim_ros.core.batch import BatchStepper
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.sim import precompile
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, Delete, SetWrench, Simulation, Spawn
from support.kernel_fingerprint import _batch_reads, _digest, _sim_digest, mixed_inertias

PACKAGE = Path(__file__).resolve().parents[2] / 'rb_sim_ros'
DECORATORS = {'kernel', 'inline_kernel', 'parallel_kernel'}

pytestmark = pytest.mark.skipif(not jit.compiling(), reason='NUMBA_DISABLE_JIT=1: one tier')


@pytest.fixture(autouse=True)
def compiled_after():
    yield
    jit.run_compiled()


def _kernels_in_source() -> set:
    """(module, function) of every function the sources decorate as a kernel (read with ast,
    not from jit's own list)."""
    out = set()
    for path in PACKAGE.rglob('*.py'):
        module = '.'.join(path.relative_to(PACKAGE.parent).with_suffix('').parts)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and any(
                    isinstance(d, ast.Name) and d.id in DECORATORS for d in node.decorator_list):
                out.add((module, node.name))
    # and the kernels factories make, on demand too: the collision world's entries, one a
    # family and set of contact tests (world_step), and the narrow phase's, one a set
    for name, module in list(sys.modules.items()):
        if name in ('rb_sim_ros.contact.world_step', 'rb_sim_ros.contact.narrow_kernels'):
            out |= {(name, key) for key in vars(module)
                    if key.startswith('world_steps_') or key == 'collide_pairs'
                    or key.startswith('collide_pairs_') and key[len('collide_pairs_'):].isdigit()}
    return out


def _kernel_globals() -> tuple[set, set]:
    """The package's module globals naming a kernel, as (module, name): (compiled,
    interpreted)."""
    kernels = _kernels_in_source()
    compiled, interpreted = set(), set()
    for name, module in list(sys.modules.items()):
        if module is None or not name.startswith('rb_sim_ros'):
            continue
        for key, value in vars(module).items():
            function = getattr(value, 'py_func', value)
            if (getattr(function, '__module__', None),
                    getattr(function, '__name__', None)) in kernels:
                (compiled if function is not value else interpreted).add((name, key))
    return compiled, interpreted


def test_a_tier_rebinds_every_global_naming_a_kernel():
    made = ws.entry(K.FAMILY_TWO, 5), nk.pairs_kernel(5).__name__  # on demand, not compiled
    compiled, interpreted = _kernel_globals()
    assert not interpreted and len(compiled) > 50  # kernels made at import are compiled
    assert ('rb_sim_ros.contact.world_step', 'world_steps_split') in compiled
    assert ('rb_sim_ros.contact.world_step', made[0]) in compiled
    assert ('rb_sim_ros.contact.narrow_kernels', made[1]) in compiled
    assert ('rb_sim_ros.core.step_kernel', 'advance_bodies_two') in compiled
    jit.run_interpreted()
    try:
        assert jit.interpreted()
        # made while interpreted: bound to its Python function, and rebound with the others
        late = ws.entry(K.FAMILY_K, 6), nk.pairs_kernel(6).__name__
        now_compiled, now_interpreted = _kernel_globals()
        assert not now_compiled
        assert now_interpreted == compiled | {('rb_sim_ros.contact.world_step', late[0]),
                                              ('rb_sim_ros.contact.narrow_kernels', late[1])}
    finally:
        jit.run_compiled()
    assert not jit.interpreted()
    assert _kernel_globals() == (now_interpreted, set())


def _demo(segments) -> str:
    """The collision demo in segments of (interpreted?, steps), with a wrench on the crate
    after the first, a spawned ball after the second and its delete after the third; no
    compile while interpreted."""
    gravity, bodies, contact = load_scene(str(PACKAGE.parent / 'scenes' / 'collisions.yaml'))[:3]
    sim = Simulation(Config(gravity=gravity, bodies=tuple(bodies), contact=contact))
    events = [SetWrench(Wrench(force=(3.0, 0.0, 0.0), torque=(0.0, 0.0, 0.5)), 'crate'),
              Spawn(BodySpec('extra', 0.5, (0.002,) * 3, initial_position=(0.0, 0.0, 0.8),
                             colliders=(Sphere(0.1),))),
              Delete('extra')]
    for k, (interpreted, steps) in enumerate(segments):
        (jit.run_interpreted if interpreted else jit.run_compiled)()
        with event.install_recorder('numba:compile') as compiles:
            if k and k <= len(events):
                sim.apply(events[k - 1])
            sim.run(steps)
        assert not (interpreted and compiles.buffer)
    jit.run_compiled()
    return _sim_digest(sim, [b.name for b in bodies])


def test_the_collision_demo_keeps_its_bits_across_tiers():
    """Interpreted, compiled, interpreted (a spawn too), compiled: the states of an
    all-compiled run, to the bit."""
    tiers = [(True, 40), (False, 200), (True, 30), (True, 20), (False, 300)]
    assert _demo(tiers) == _demo([(False, n) for _, n in tiers])


def _batch(tiers) -> str:
    """40 bodies (a block of lanes and a rest), a wrench change half way."""
    rng = np.random.default_rng(8)
    n = 40
    b = BatchStepper(rng.uniform(0.5, 3.0, n), np.array(mixed_inertias(rng, n, 4)), 1e-3,
                     rng.normal(size=(n, 3)), [so3.exp(rng.normal(size=3)) for _ in range(n)],
                     rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 3.0,
                     gravity=(0.0, 0.0, -9.81), angular_damping=0.1)
    torques = rng.normal(size=(len(tiers), n, 3))
    for k, interpreted in enumerate(tiers):
        (jit.run_interpreted if interpreted else jit.run_compiled)()
        with event.install_recorder('numba:compile') as compiles:
            b.set_wrench(None, torque=torques[k], frame='body')
            b.step(12)
        assert not (interpreted and compiles.buffer)
    jit.run_compiled()
    return _digest(*_batch_reads(b))


def test_batch_lanes_keep_their_bits_across_tiers():
    assert _batch([True, False, True, False]) == _batch([False] * 4)


def test_a_stepper_steps_in_the_tier_of_now_with_the_same_bits(monkeypatch):
    """A Stepper calls its row's compiled entry directly (``BodyStore.one``), kept per tier:
    after a swap it steps in the new tier (the interpreted one runs the kernel's Python, and
    compiles nothing), and back, all with the bits of an all-compiled run."""
    from rb_sim_ros.core.rigid_body import RigidBody, State
    from rb_sim_ros.core.stepper import Stepper

    def stepper():
        return Stepper(RigidBody(2.0, [1.0, 2.0, 3.0]), 1e-3,
                       State((0.0, 0.0, 1.0), angular_velocity=(0.3, 2.0, -0.5)),
                       gravity=(0.0, 0.0, -9.81))
    reference, s = stepper(), stepper()
    reference.step(30)
    s.step(10)
    jit.run_interpreted()
    name = s._store._step_one
    calls = []
    python = getattr(K, name)
    monkeypatch.setattr(K, name, lambda *a: (calls.append(1), python(*a))[1])
    with event.install_recorder('numba:compile') as compiles:
        s.step(1)
        s.step(9)
    assert len(calls) == 2 and not compiles.buffer
    monkeypatch.undo()
    jit.run_compiled()
    s.step(10)
    assert len(calls) == 2  # compiled again, not the Python of before
    assert s.step_count == reference.step_count == 30
    assert s.components() == reference.components()


def test_the_precompiled_marker_names_these_sources(monkeypatch, tmp_path):
    """precompile's marker is per cache, source text and numba: another cache or a changed
    source is not precompiled; nor is a part that was not marked."""
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path / 'a'))
    assert not jit.precompiled(['bodies-two-step'])
    jit.mark_precompiled('bodies-two-step')
    assert jit.precompiled(['bodies-two-step'])
    assert not jit.precompiled(['bodies-two-step', 'contact-two-step'])
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path / 'b'))
    assert not jit.precompiled(['bodies-two-step'])
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path / 'a'))
    jit.process_stamp()
    monkeypatch.setattr(jit, '_stamp', 'an edited source')
    assert not jit.precompiled(['bodies-two-step'])


def test_a_background_compile_is_done_only_with_the_marker(monkeypatch, tmp_path):
    """The node's child: done when it exits 0 and the cache is marked; else one line why
    (here the child is /bin/false or /bin/true, which compile nothing)."""
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))
    monkeypatch.setattr(precompile.sys, 'executable', '/bin/false')
    parts = ['bodies-k-step', 'contact-k-step']
    child = precompile.Background(parts)
    assert child.wait() == 'the compiling process exited with 1'
    child.stop()
    monkeypatch.setattr(precompile.sys, 'executable', '/bin/true')
    child = precompile.Background(parts)
    assert child.wait() == f'the compiling process left no marker in {tmp_path}/rb_sim_ros'
    child.stop()
    jit.mark_precompiled(parts[0])
    child = precompile.Background(parts)
    assert child.wait() == f'the compiling process left no marker in {tmp_path}/rb_sim_ros'
    child.stop()
    jit.mark_precompiled(parts[1])
    child = precompile.Background(parts)
    assert child.wait() == ''
    child.stop()


def test_precompile_refuses_a_parent_that_is_not_its_own(capsys):
    with pytest.raises(SystemExit) as e:
        precompile.main(['--parent', '1'])
    assert e.value.code == 2
    assert '--parent: process 1 is not the parent of this one' in capsys.readouterr().err


def _scaled_through_views(a, factor):
    """Scales ``a`` in place through a borrowed view, and returns the sum of a scratch array
    made here and used through a borrowed view, kept alive to the end."""
    view = jit.borrowed(a)
    own = np.empty(a.size)
    scratch = jit.borrowed(own)
    total = 0.0
    for i in range(view.shape[0]):
        for j in range(view.shape[1]):
            view[i, j] *= factor
            scratch[i * view.shape[1] + j] = view[i, j]
    for k in range(scratch.shape[0]):
        total += scratch[k]
    jit.keep_alive(own)
    return total


def test_a_borrowed_view_is_its_array_in_either_tier():
    """jit.borrowed: compiled code sees the same data, shape and strides (a view with a stride,
    here) and writes through to the owner; interpreted, it is the array itself."""
    import numba
    compiled = numba.njit(_scaled_through_views)
    for run in (compiled, _scaled_through_views):
        base = np.arange(24.0).reshape(4, 6)
        a = base[:, ::2]  # not contiguous: its strides must carry over
        expected = a * 3.0
        assert run(a, 3.0) == expected.sum()
        assert np.array_equal(a, expected)
        assert np.array_equal(base[:, 1::2], np.arange(24.0).reshape(4, 6)[:, 1::2])


ROOM = 19


def _sums_of_stack_arrays(x, rounds):
    """Fills stack arrays of each kind (one made in a loop, refilled each round) and returns
    their sums with their shapes and strides, and the dtypes' kinds."""
    a = jit.stack_empty(ROOM, 3, np.float64)
    b = jit.stack_empty(4, 0, np.int64)
    c = jit.stack_empty(5, 0, np.bool_)
    looped = 0.0
    for r in range(rounds):
        t = jit.stack_empty(7, 0, np.float64)
        for i in range(7):
            t[i] = x * i + r
        for i in range(7):
            looped += t[i]
    for i in range(ROOM):
        for j in range(3):
            a[i, j] = x * i + j
    for i in range(4):
        b[i] = 3 * i
    c[:] = False
    c[2] = True
    return (a.sum(), a.shape, a.strides, b.sum(), b.shape, b.strides, c.sum(), c.shape,
            looped)


def test_a_stack_array_is_np_empty_in_either_tier():
    """jit.stack_empty: compiled, an array of the shape, strides and dtype np.empty gives,
    that holds what is written to it; interpreted, np.empty itself."""
    import numba
    compiled = numba.njit(_sums_of_stack_arrays)(2.0, 3)
    expected = _sums_of_stack_arrays(2.0, 3)
    assert compiled == expected
    assert expected == (3 * sum(2.0 * i for i in range(ROOM)) + ROOM * 3, (ROOM, 3), (24, 8),
                        18, (4,), (8,), 1, (5,), 3 * sum(2.0 * i for i in range(7)) + 7 * 3)


def test_a_stack_array_lives_in_its_callers_frame_unoptimised_too():
    """Compiled without LLVM's inlining (NUMBA_OPT=0, in a process of its own), the arrays
    still hold what was written: their memory is the calling function's frame, not that of
    a helper that has returned."""
    code = """if True:
        import numba
        import numpy as np
        from rb_sim_ros.core import jit

        def filled():
            a = jit.stack_empty(19, 3, np.float64)
            b = jit.stack_empty(19, 3, np.float64)
            for i in range(19):
                for j in range(3):
                    a[i, j], b[i, j] = 1.0, 2.0 * i
            return a.sum(), b.sum()
        print(*numba.njit(filled)())
    """
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         env={**os.environ, 'NUMBA_OPT': '0'}, timeout=600)
    assert out.returncode == 0, out.stderr
    assert [float(v) for v in out.stdout.split()] == [57.0, 3.0 * 2.0 * sum(range(19))]


def test_stack_arrays_allocate_nothing_compiled():
    """The same function allocates one array per np.empty and none per jit.stack_empty
    (numba's allocation count, NUMBA_NRT_STATS, in a process of its own)."""
    code = """if True:
        import numba, numpy as np
        from numba.core.runtime import rtsys
        from rb_sim_ros.core import jit

        def made(stack):
            a = jit.stack_empty(19, 3, np.float64) if stack else np.empty((19, 3))
            b = jit.stack_empty(4, 0, np.int64) if stack else np.empty(4, dtype=np.int64)
            a[0, 0], b[0] = 1.0, 2
            return a[0, 0] + b[0]
        f = numba.njit(made)
        for stack in (True, False):
            f(stack)
            before = rtsys.get_allocation_stats().alloc
            f(stack)
            print(rtsys.get_allocation_stats().alloc - before)
    """
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         env={**os.environ, 'NUMBA_NRT_STATS': '1'},
                         timeout=600)
    assert out.returncode == 0, out.stderr
    # stack: nothing; np.empty: both branches are compiled, the two arrays of the one taken
    assert out.stdout.split() == ['0', '2']
