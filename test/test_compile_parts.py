# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run compiles the kernels it uses and no others (core/jit.py, step_kernel.body_step):
counted by numba's own compile events in a new process on an empty cache."""

from dataclasses import replace
import json
import os
from pathlib import Path
import subprocess
import sys

from numba.core import event
import pytest

from rb_sim_ros import RigidBody, State, Stepper
from rb_sim_ros.contact.collision_shapes import Plane, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.core import jit, step_kernel as K
from rb_sim_ros.sim import precompile
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, Delete, kernels_after, Simulation, Spawn

ROOT = Path(__file__).resolve().parents[1]

# Steps one free body of each integrator named on the command line, printing for each the
# package's kernels that its first step compiled (and the state, to compare tiers).
FIRST_STEPS = """
import json, sys
from numba.core import event
from rb_sim_ros import RigidBody, State, Stepper, Wrench
for method in sys.argv[1:]:
    with event.install_recorder('numba:compile') as rec:
        body = RigidBody(mass=2.0, inertia=[[0.2, 0.01, 0], [0.01, 0.3, 0], [0, 0, 0.4]])
        sim = Stepper(body, dt=1e-3, state=State(angular_velocity=[0, 0.1, 3.0]),
                      method=method)
        sim.set_wrench(Wrench(torque=[0, 0, 0.01], frame='body'))
        sim.step(10)
    funcs = [e.data['dispatcher'].py_func for _, e in rec.buffer if e.is_start]
    print(json.dumps([method, sorted({f.__qualname__ for f in funcs
                                      if f.__module__.startswith('rb_sim_ros.')}),
                      [float(c) for v in (sim.state.position, sim.state.angular_velocity)
                       for c in v]]))
"""


def _first_steps(methods, tmp_path, **env):
    out = subprocess.run([sys.executable, '-c', FIRST_STEPS, *methods], cwd=tmp_path,
                         env={**os.environ, 'NUMBA_CACHE_DIR': str(tmp_path / 'cache'), **env},
                         capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, out.stderr[-3000:]
    return [json.loads(line) for line in out.stdout.splitlines()]


@pytest.mark.slow
@pytest.mark.skipif(not jit.compiling(), reason='NUMBA_DISABLE_JIT=1: nothing compiles')
def test_a_free_body_compiles_its_own_family_only(tmp_path):
    """eq27 compiles the two-step body step and nothing of the k-step or splitting families
    nor of contact; lie4 then compiles the k-step one and no two-step or splitting one; the
    bits are those of the interpreter."""
    (eq27, first), (lie4, then) = [(m, set(c)) for m, c, _ in
                                   _first_steps(['eq27', 'lie4'], tmp_path)]
    assert {'advance_bodies_two', 'advance_body_2', 'multistep_step'} <= first
    assert not first & {'advance_body', 'advance_body_k', 'advance_body_split', 'free_flow',
                        'world_steps', '_lanes_step', 'advance_blocks', 'advance_bodies_k'}
    assert {'advance_bodies_k', 'advance_body_k'} <= then
    assert not then & {'advance_body_2', 'advance_body_split', 'world_steps', 'advance_body',
                       'advance_bodies_two'}
    compiled = _first_steps(['eq27', 'lie4', 'flow4'], tmp_path)
    interpreted = _first_steps(['eq27', 'lie4', 'flow4'], tmp_path, NUMBA_DISABLE_JIT='1')
    assert [s for *_, s in compiled] == [s for *_, s in interpreted]
    assert interpreted[0][1] == []


CONTACT_PART = """
import json, sys
from numba.core import event
from rb_sim_ros.sim import precompile
with event.install_recorder('numba:compile') as rec:
    precompile.precompile(['contact-two-step'])
funcs = [e.data['dispatcher'].py_func for _, e in rec.buffer if e.is_start]
print(json.dumps({'cores': precompile._cores(), 'compiled': [
    f.__module__.rsplit('.', 1)[-1] + '.' + f.__qualname__ for f in funcs
    if f.__module__.startswith('rb_sim_ros.')]}))
"""


@pytest.mark.slow
@pytest.mark.skipif(not jit.compiling(), reason='NUMBA_DISABLE_JIT=1: nothing compiles')
def test_a_collision_part_compiles_in_two_processes_and_each_kernel_once(tmp_path):
    """On an empty cache, a child compiles the narrow phase and the sorts while this process
    compiles the solver and the body step; world_steps then loads them all (compiled here
    once, in the child not at all): the types world_step.compile_leaves gives them are the
    ones world_steps calls them with."""
    out = subprocess.run([sys.executable, '-c', CONTACT_PART], cwd=tmp_path,
                         env={**os.environ, 'NUMBA_CACHE_DIR': str(tmp_path / 'cache')},
                         capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, out.stderr[-3000:]
    found = json.loads(out.stdout.splitlines()[-1])
    compiled = found['compiled']
    assert 'world_step.world_steps_two' in compiled
    for here in ('solver_kernels.solve_arrays', 'step_kernel.advance_body_2'):
        assert compiled.count(here) == 1, here
        # before world_steps (events in the order they start): not inside its compile
        assert compiled.index(here) < compiled.index('world_step.world_steps_two'), here
    if found['cores'] >= 2:
        for child in ('narrow_kernels.collide_pairs', 'narrow_kernels.collide_pair',
                      'broad_phase.stable_order', 'broad_phase.sorted_copy'):
            assert child not in compiled, child


def test_a_scene_names_the_parts_it_steps_with():
    assert precompile.parts_of(Config()) == ['bodies-two-step']
    assert precompile.parts_of(Config(integrator='lie3')) == ['bodies-k-step']
    gravity, bodies, contact = load_scene(str(ROOT / 'scenes' / 'collisions.yaml'))[:3]
    demo = Config(gravity=gravity, bodies=tuple(bodies), contact=contact, integrator='flow2')
    assert precompile.parts_of(demo) == ['contact-splitting']
    # Colliders on static bodies only: no collision world runs (collision_world's enabled).
    walls = Config(bodies=(BodySpec('ball'), BodySpec('wall', static=True,
                                                      colliders=(Sphere(0.1),))))
    assert precompile.parts_of(walls) == ['bodies-two-step']
    assert CollisionWorld.from_config(walls).enabled is False
    assert sorted(precompile.parts()) == sorted(precompile.PARTS) and len(precompile.PARTS) == 7
    assert precompile.parts(['eq27', 'taylor1', 'lie4'], False) == [
        'bodies-two-step', 'bodies-k-step', 'blocks-two-step']
    assert precompile.parts(['lie4']) == ['bodies-k-step', 'contact-k-step']
    # Four free bodies or more step a block at a time (two-step methods: step_kernel.blocked)
    many = tuple(BodySpec(f'b{i}', initial_position=(i, 0, 0)) for i in range(K.BLOCK_MIN))
    assert precompile.parts_of(Config(bodies=many)) == ['bodies-two-step', 'blocks-two-step']
    assert precompile.parts_of(Config(bodies=many[1:])) == ['bodies-two-step']
    assert precompile.parts_of(Config(bodies=many, integrator='lie4')) == ['bodies-k-step']
    store = Simulation(Config(bodies=many))._moving[0]._store
    assert K.blocked(store.coefficients, len(store.clock), 1, False)


def test_a_spawn_or_delete_names_the_kernels_the_run_then_steps_with():
    """The node compiles (or loads) them before its lock: a first moving collider brings the
    collision world's (colliders on static bodies alone make none), the last one deleted
    the step kernel's; other changes keep what the run steps with."""
    ball = BodySpec('ball', colliders=(Sphere(0.1),))
    ball2 = replace(ball, name='ball2', initial_position=(1.0, 0.0, 0.0))
    wall = BodySpec('wall', static=True, colliders=(Sphere(0.1),), initial_position=(0, 3, 0))
    free = BodySpec('free', initial_position=(0.0, -3.0, 0.0))
    walls_only = Simulation(Config(bodies=(free, wall)))
    assert kernels_after(walls_only, Spawn(ball)) == 'contact'
    assert kernels_after(walls_only, Spawn(replace(wall, name='post'))) is None
    assert kernels_after(walls_only, Spawn(BodySpec('other'))) is None
    three = Simulation(Config(bodies=tuple(replace(free, name=f'f{i}') for i in range(3))))
    assert kernels_after(three, Spawn(BodySpec('fourth'))) == 'blocks'  # K.BLOCK_MIN
    assert kernels_after(walls_only, Delete('wall')) is None
    assert kernels_after(Simulation(Config(bodies=(free,))), Spawn(ball)) == 'contact'
    one = Simulation(Config(bodies=(ball, free, wall)))
    assert kernels_after(one, Delete('ball')) == 'bodies'
    assert kernels_after(one, Delete('free')) is None
    assert kernels_after(one, Delete('wall')) is None
    assert kernels_after(one, Spawn(ball2)) is None
    assert kernels_after(Simulation(Config(bodies=(ball, ball2))), Delete('ball')) is None


def test_every_integrator_has_a_family_and_a_part():
    from rb_sim_ros.core import multistep
    for name, method in multistep.METHODS.items():
        family = K.family_of(method.steps)
        assert family in K.FAMILIES, name
        stands_for = multistep.METHODS[precompile.FAMILY_METHODS[family]]
        assert K.family_of(stands_for.steps) == family, name


def test_precompile_refuses_an_unknown_part(capsys):
    with pytest.raises(ValueError, match="no kernel part 'bodies-three-step'"):
        precompile.precompile(['bodies-three-step'])
    with pytest.raises(SystemExit) as e:
        precompile.main(['--part', 'contact'])
    assert e.value.code == 2
    assert "invalid choice: 'contact'" in capsys.readouterr().err
    for wrong in (['--part', 'contact-two-step'], ['--no-contact'],
                  ['--integrator', 'eq27', 'lie4']):
        with pytest.raises(SystemExit) as e:
            precompile.main(['--leaves', 'narrow', *wrong])
        assert e.value.code == 2
        assert '--leaves: with one --integrator at most' in capsys.readouterr().err


@pytest.mark.skipif(not jit.compiling(), reason='NUMBA_DISABLE_JIT=1: nothing compiles')
@pytest.mark.parametrize('method', ['eq27', 'lie4', 'flow4'])
def test_a_later_call_compiles_nothing(method):
    """Once a run's first call has compiled (or loaded) its kernels, a call from Python finds
    them: no compile event, for free bodies, a block of them and a collision world. (A kernel
    given its family as an argument from Python never matched the one compiled for the
    family's value, and entered numba's compiler at every call: 15 ms a step.)"""
    def steppers():
        one = Stepper(RigidBody(1.0, [0.2, 0.3, 0.4]), dt=1e-3, method=method,
                      state=State(angular_velocity=[0.0, 0.1, 3.0]))
        spheres = [BodySpec(f'b{i}', 1.0, (0.004,) * 3, initial_position=(3.0 * i, 0.0, 0.2),
                            colliders=(Sphere(0.1),)) for i in range(5)]
        world = CollisionWorld(spheres, 1e-3, (0.0, 0.0, -9.81), planes=(Plane(),),
                               integrator=method)
        return one.step, world.step

    for run in steppers():
        run(1)  # compiles or loads
        with event.install_recorder('numba:compile') as rec:
            for _ in range(3):
                run(1)
                run(7)
        assert [e.data['dispatcher'].py_func.__qualname__ for _, e in rec.buffer] == []
