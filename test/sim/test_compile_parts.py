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
import numpy as np
import pytest

from rb_sim_ros import RigidBody, State, Stepper
from rb_sim_ros.contact import narrow_kernels as nk, world_step as ws
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, Sphere
from rb_sim_ros.core import jit, step_kernel as K
from rb_sim_ros.sim import precompile
from rb_sim_ros.sim.bodies import collision_world, pairs_met, rebuilt
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import (BodySpec, Config, contact_tests, Delete, kernels_after,
                                       Simulation, Spawn)

ROOT = Path(__file__).resolve().parents[2]

# Steps one free body of each integrator named on the command line, printing for each the
# package's kernels that its first step compiled (and the state, to compare tiers).
FIRST_STEPS = """
import json, sys
from numba.core import event
import numpy as np
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
                                      if (f.__module__ or '').startswith('rb_sim_ros.')}),
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
    assert {'step_one_two', 'advance_body_2', 'multistep_step'} <= first
    assert not first & {'advance_body', 'advance_body_k', 'advance_body_split', 'free_flow',
                        'world_steps', '_lanes_step', 'advance_blocks', 'advance_bodies_k',
                        'step_one_k', 'step_one_split'}
    assert {'step_one_k', 'advance_body_k'} <= then
    assert not then & {'advance_body_2', 'advance_body_split', 'world_steps', 'advance_body',
                       'advance_bodies_two', 'step_one_two', 'step_one_split'}
    compiled = _first_steps(['eq27', 'lie4', 'flow4'], tmp_path)
    interpreted = _first_steps(['eq27', 'lie4', 'flow4'], tmp_path, NUMBA_DISABLE_JIT='1')
    assert [s for *_, s in compiled] == [s for *_, s in interpreted]
    assert interpreted[0][1] == []


# Two balls on the ground: the contact tests sphere-sphere and sphere-plane only.
BALLS = (BodySpec('ground', static=True, colliders=(Plane(),)),
         BodySpec('ball', colliders=(Sphere(0.1),), initial_position=(0.0, 0.0, 1.0)),
         BodySpec('ball2', colliders=(Sphere(0.1),), initial_position=(0.5, 0.0, 1.0)))
BALLS_PART = 'contact-two-step:sphere-sphere+sphere-plane'

CONTACT_PART = """
import json, sys
from numba.core import event
import numpy as np
from rb_sim_ros.sim import precompile
from rb_sim_ros.sim.simulation import Config
with event.install_recorder('numba:compile') as rec:
    precompile.precompile([sys.argv[1]])
funcs = [e.data['dispatcher'].py_func for _, e in rec.buffer if e.is_start]
print(json.dumps({'cores': precompile._cores(), 'compiled': [
    f.__module__.rsplit('.', 1)[-1] + '.' + f.__qualname__ for f in funcs
    if (f.__module__ or '').startswith('rb_sim_ros.')]}))
"""


@pytest.mark.slow
@pytest.mark.skipif(not jit.compiling(), reason='NUMBA_DISABLE_JIT=1: nothing compiles')
def test_a_collision_part_compiles_in_two_processes_and_each_kernel_once(tmp_path):
    """On an empty cache, a child compiles the narrow phase and the sorts while this process
    compiles the solver and the body step; world_steps then loads them all (compiled here
    once, in the child not at all): the types world_step.compile_leaves gives them are the
    ones world_steps calls them with. The part of a scene of balls on the ground compiles
    its two contact tests and none of the others, in either process; a run of that scene
    then names that part, precompiled."""
    cache = tmp_path / 'cache'
    env = {k: v for k, v in os.environ.items() if k != ws.ALL_TESTS_VARIABLE}
    out = subprocess.run([sys.executable, '-c', CONTACT_PART, BALLS_PART], cwd=tmp_path,
                         env={**env, 'NUMBA_CACHE_DIR': str(cache)},
                         capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, out.stderr[-3000:]
    found = json.loads(out.stdout.splitlines()[-1])
    compiled = found['compiled']
    entry = f'world_step.world_steps_two_{nk.pairs_named(["sphere-sphere", "sphere-plane"])}'
    assert '=' not in BALLS_PART and ':' in BALLS_PART
    assert entry in compiled
    for here in ('solver_kernels.solve_arrays', 'step_kernel.advance_body_2'):
        assert compiled.count(here) == 1, here
        # before world_steps (events in the order they start): not inside its compile
        assert compiled.index(here) < compiled.index(entry), here
    balls = nk.pairs_named(['sphere-sphere', 'sphere-plane'])
    if found['cores'] >= 2:
        for child in (f'narrow_kernels.collide_pairs_{balls}', 'broad_phase.stable_order',
                      'broad_phase.sorted_copy'):
            assert child not in compiled, child
    # Cached by either process: the two tests of the scene, not one of the others.
    cached = {p.name.split('-')[0] for p in (cache / 'rb_sim_ros').glob('*.nbi')}
    assert {'narrow_kernels._sphere_sphere', 'narrow_kernels._sphere_plane',
            f'narrow_kernels.collide_pairs_{balls}'} <= cached
    assert 'narrow_kernels.collide_pairs' not in cached  # every test
    others = {'_sphere_box', '_sphere_capsule', '_capsule_capsule', '_capsule_box',
              '_capsule_plane', '_box_box', '_box_plane', '_face_contacts', '_clip'}
    assert not {f'narrow_kernels.{k}' for k in others} & cached
    # The run of that scene finds its part precompiled.
    check = ('from rb_sim_ros.sim import precompile; from rb_sim_ros.core import jit; '
             'from test_compile_parts import BALLS; from rb_sim_ros.sim.simulation import '
             'Config; p = precompile.parts_of(Config(bodies=BALLS)); '
             'print(p, jit.precompiled(p))')
    out = subprocess.run([sys.executable, '-c', check], cwd=Path(__file__).parent,
                         env={**env, 'NUMBA_CACHE_DIR': str(cache)},
                         capture_output=True, text=True, timeout=600)
    assert out.stdout.split() == [f"['{BALLS_PART}']", 'True'], out.stderr[-2000:]


def test_a_scene_names_the_parts_it_steps_with(tmp_path, monkeypatch):
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))  # no part precompiled
    monkeypatch.delenv(ws.ALL_TESTS_VARIABLE, raising=False)
    assert precompile.parts_of(Config()) == ['bodies-two-step']
    assert precompile.parts_of(Config(integrator='lie3')) == ['bodies-k-step']
    gravity, bodies, contact = load_scene(str(ROOT / 'scenes' / 'collisions.yaml'))[:3]
    demo = Config(gravity=gravity, bodies=tuple(bodies), contact=contact, integrator='flow2')
    # Every pair of kinds meets in the demo but capsule-capsule (one body has a capsule).
    assert precompile.parts_of(demo) == [
        'contact-splitting:sphere-sphere+sphere-capsule+sphere-box+sphere-plane+capsule-box+'
        'capsule-plane+box-box+box-plane']
    jit.mark_precompiled('contact-splitting')  # every test: colcon build's
    assert precompile.parts_of(demo) == ['contact-splitting']
    assert precompile.parts_of(Config(bodies=BALLS)) == [BALLS_PART]
    # Colliders on static bodies only: no collision world runs (Config.collides, the one
    # switch), and none can be made.
    walls = Config(bodies=(BodySpec('ball'), BodySpec('wall', static=True,
                                                      colliders=(Sphere(0.1),))))
    assert precompile.parts_of(walls) == ['bodies-two-step']
    assert not walls.collides and walls.has_colliders and Simulation(walls).world is None
    with pytest.raises(ValueError, match='no moving body has colliders'):
        collision_world(walls.bodies, walls.dt)
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


def test_a_world_has_the_contact_tests_of_the_shapes_that_can_meet():
    """pairs_met against pairs enumerated by hand: a moving body's collider against any other
    body's; never two static ones, never two of one body."""
    def met(*bodies, planes=()):
        return sorted(nk.pair_names(pairs_met(bodies, planes)))

    ball = BodySpec('ball', colliders=(Sphere(0.1),))
    ground = BodySpec('ground', static=True, colliders=(Plane(),))
    crate = BodySpec('crate', colliders=(Box((0.2, 0.2, 0.2)),))
    post = BodySpec('post', static=True, colliders=(Capsule(0.1, 1.0),))
    bell = BodySpec('bell', colliders=(Capsule(0.02, 0.3), Sphere(0.06, position=(0, 0, 0.18))))
    assert met(ball) == [] and met(bell) == []
    assert met(ball, ground) == ['sphere-plane']
    assert met(ball, replace(ball, name='b2')) == ['sphere-sphere']
    assert met(ball, replace(ball, name='s', static=True)) == ['sphere-sphere']
    assert met(replace(crate, static=True), post, ground) == []
    assert met(bell, ground) == ['capsule-plane', 'sphere-plane']
    assert met(crate, post, ball) == ['capsule-box', 'sphere-box', 'sphere-capsule']
    assert met(ball, planes=(Plane(),)) == ['sphere-plane']
    assert met(bell, replace(bell, name='bell2')) == [
        'capsule-capsule', 'sphere-capsule', 'sphere-sphere']


def test_a_world_steps_with_the_smallest_precompiled_set_of_tests_that_holds_its_own(
        tmp_path, monkeypatch):
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))
    monkeypatch.delenv(ws.ALL_TESTS_VARIABLE, raising=False)
    two = K.FAMILY_TWO
    balls = nk.pairs_named(['sphere-sphere', 'sphere-plane'])
    crate = nk.pairs_named(['box-plane'])
    assert ws.tests_for(two, balls) == balls  # nothing precompiled: its own
    jit.mark_precompiled('contact-two-step')
    assert ws.tests_for(two, balls) == nk.PAIRS_ALL
    assert ws.tests_for(K.FAMILY_K, balls) == balls  # another family's part does not serve
    jit.mark_precompiled(ws.contact_part(two, balls | nk.pairs_named(['sphere-box'])))
    assert ws.tests_for(two, balls) == balls | nk.pairs_named(['sphere-box'])
    assert ws.tests_for(two, crate) == nk.PAIRS_ALL
    jit.mark_precompiled('contact-two-step:typo-sphere')  # a stray marker: not a set
    assert ws.tests_for(two, crate) == nk.PAIRS_ALL
    monkeypatch.setenv(ws.ALL_TESTS_VARIABLE, 'all')
    assert ws.tests_for(K.FAMILY_K, balls) == nk.PAIRS_ALL
    # A world of one ball needs no test: an entry of its own (made, not compiled, here).
    assert ws.entry(two, 0) == 'world_steps_two_0' and hasattr(ws, 'world_steps_two_0')
    assert ws.entry(two, nk.PAIRS_ALL) == 'world_steps_two'
    # Sets named and read back: none, all, each row alone, all but it, and random ones (every
    # set is 2^rows: 5e8 of them at 29 rows).
    rows = len(nk.PAIR_TESTS)
    sets = [0, nk.PAIRS_ALL] + [1 << i for i in range(rows)]
    sets += [nk.PAIRS_ALL & ~(1 << i) for i in range(rows)]
    sets += np.random.default_rng(1).integers(0, nk.PAIRS_ALL + 1, 2000).tolist()
    for family in K.FAMILIES:
        for tests in sets:
            assert ws.part_tests(ws.contact_part(family, tests)) == (family, tests)
            assert precompile.part(ws.contact_part(family, tests)) == ('contact', family, tests)


NARROW_ONLY = """
import json, sys
import numpy as np
from numba.core import event
import numpy as np
from rb_sim_ros.contact import narrow_kernels as nk
import numba
TESTS = nk.pairs_named(['sphere-sphere', 'sphere-plane'])

@numba.njit  # a caller of its own, not cached (world_steps is one)
def balls(a, b, kinds, geoms, centres, rot, margins, point, normal, depth, feature, source):
    return nk.collide_pairs_of(TESTS, a, b, kinds, geoms, np.zeros(0), centres, rot, margins,
                               point, normal, depth, feature, source)

def run(function, kinds):
    geoms = np.array([[0.1, 0, 0.1, 0.1, 0.1], [0.2, 0, 0.1, 0.1, 0.1], [0, 0, 0, 0, 1.0]])
    centres = np.array([[0, 0, 0.09], [0.25, 0.0, 0.15], [0, 0, 0]])
    rot = np.tile(np.eye(3).reshape(9), (3, 1))
    a, b = np.array([0, 0, 1]), np.array([1, 2, 2])
    out = [np.zeros((27, 3)), np.zeros((27, 3)), np.zeros(27)] + [
        np.zeros(27, dtype=np.int64)] * 2
    try:
        m = function(a, b, np.array(kinds), geoms, centres, rot, np.full(3, 0.01), *out)
    except ValueError as e:
        return str(e)
    return [m] + [x[:m].tolist() for x in out]

with event.install_recorder('numba:compile') as rec:
    mine = run(balls, [nk.KIND_SPHERE, nk.KIND_SPHERE, nk.KIND_PLANE])
    boxed = run(balls, [nk.KIND_SPHERE, nk.KIND_BOX, nk.KIND_PLANE])
funcs = {e.data['dispatcher'].py_func.__qualname__ for _, e in rec.buffer if e.is_start}
every = run(lambda a, b, kinds, geoms, *rest: nk.collide_pairs(a, b, kinds, geoms, np.zeros(0),
                                                                *rest),
            [nk.KIND_SPHERE, nk.KIND_SPHERE, nk.KIND_PLANE])
print(json.dumps({'compiled': sorted(funcs), 'mine': mine, 'every': every, 'boxed': boxed}))
"""


@pytest.mark.parametrize('tier', ['compiled', 'interpreted'])
def test_a_set_of_contact_tests_compiles_those_alone_and_refuses_the_others(tmp_path, tier):
    """collide_pairs_of with the tests of balls and planes: the same contacts as every test
    (a constant in the caller, as in world_steps), none of the other tests compiled, and a
    box among the pairs refused in both tiers."""
    env = {**os.environ, 'NUMBA_CACHE_DIR': str(tmp_path / 'cache')}
    if tier == 'interpreted':
        env['NUMBA_DISABLE_JIT'] = '1'
    out = subprocess.run([sys.executable, '-c', NARROW_ONLY], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    found = json.loads(out.stdout)
    assert found['mine'] == found['every'] and found['mine'][0] == 3
    assert 'not in the set its kernels were compiled for' in found['boxed']
    if tier == 'compiled':
        tests = nk.pairs_named(['sphere-sphere', 'sphere-plane'])
        assert {'_sphere_sphere', '_sphere_plane', f'collide_pairs_{tests}'} <= set(
            found['compiled'])
        assert not set(found['compiled']) & {
            '_sphere_box', '_box_box', '_box_plane', '_capsule_box', '_capsule_capsule',
            '_capsule_plane', '_sphere_capsule', 'collide_pair', 'collide_pairs'}


def test_a_spawn_of_shapes_whose_tests_the_world_lacks_names_the_collision_kernels(
        tmp_path, monkeypatch):
    """A world compiled for balls on the ground: another ball needs no other step, a crate
    does (a set holding the balls' tests and its own), and nothing is compiled here."""
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path))  # no part precompiled
    monkeypatch.delenv(ws.ALL_TESTS_VARIABLE, raising=False)
    balls = nk.pairs_named(['sphere-sphere', 'sphere-plane'])
    world = collision_world(BALLS, dt=1e-3)
    assert world.pair_tests == world.pairs_needed == balls
    sim = type('Run', (), {'world': world, 'config': Config(bodies=BALLS)})()
    ball3 = replace(BALLS[1], name='ball3', initial_position=(3.0, 0.0, 1.0))
    crate = BodySpec('crate', colliders=(Box((0.4, 0.3, 0.2)),), initial_position=(-3, 0, 1))
    assert kernels_after(sim, Spawn(ball3)) is None
    assert kernels_after(sim, Spawn(crate)) == 'contact'
    with_crate = Config(bodies=BALLS + (crate,))
    assert contact_tests(with_crate, world) == balls | nk.pairs_named(
        ['sphere-box', 'box-plane'])
    assert kernels_after(sim, Delete('ball2')) is None  # sphere-plane alone: the same step
    # A world rebuilt around the crate has those tests; one around a ball keeps its own.
    none = (0.0, 0.0, 0.0)  # (their gravity)
    assert rebuilt(world, BALLS + (crate,), True, none).pair_tests == \
        contact_tests(with_crate, world)
    assert rebuilt(world, BALLS[:2], False, none).pair_tests == balls


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
    for bad, why in (('contact', "no kernel part 'contact'"),
                     ('contact-two-step:sphere-cone', "no pair of kinds 'sphere-cone'"),
                     ('contact-two-step:plane-plane', "no contact test between 'plane-plane'"),
                     ('contact-two-step:', "no contact part 'contact-two-step:'")):
        with pytest.raises(SystemExit) as e:
            precompile.main(['--part', bad])
        assert e.value.code == 2
        err = capsys.readouterr().err
        assert why in err and len(err.strip().splitlines()[-1]) < 500  # a line, no dump
    for wrong in ([], ['--part', 'bodies-two-step'],
                  ['--part', 'contact-two-step', '--no-contact'],
                  ['--part', 'contact-two-step', '--integrator', 'eq27'],
                  ['--part', 'contact-two-step', 'contact-k-step']):
        with pytest.raises(SystemExit) as e:
            precompile.main(['--leaves', 'narrow', *wrong])
        assert e.value.code == 2
        assert '--leaves: with one collision --part' in capsys.readouterr().err


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
        world = collision_world(spheres, 1e-3, (0.0, 0.0, -9.81), planes=(Plane(),),
                                integrator=method)
        return one.step, world.step

    for run in steppers():
        run(1)  # compiles or loads
        with event.install_recorder('numba:compile') as rec:
            for _ in range(3):
                run(1)
                run(7)
        assert [e.data['dispatcher'].py_func.__qualname__ for _, e in rec.buffer] == []


@pytest.mark.slow
def test_a_world_gives_the_same_bits_with_its_own_contact_tests_as_with_all():
    """A ball and a crate on the ground, stepped by a world compiled with their three tests
    and by one with every test: the same bits; a delete keeps the step the run has."""
    crate = BodySpec('crate', colliders=(Box((0.4, 0.3, 0.2)),), initial_position=(0.3, 0, 0.5),
                     initial_orientation_xyzw=(0.3, 0.2, 0.1, 0.927362))
    config = Config(bodies=BALLS[:2] + (crate,), gravity=(0.0, 0.0, -9.81))
    own = nk.pairs_named(['sphere-box', 'sphere-plane', 'box-plane'])
    finals = []
    for tests in (own, nk.PAIRS_ALL):
        sim = Simulation(config, tests)
        assert sim.world.pair_tests == tests
        sim.run(400)
        sim.apply(Delete('ball'))
        assert sim.world.pair_tests == tests  # box-plane alone: the same step serves
        assert sim.world.pairs_needed == nk.pairs_named(['box-plane'])
        sim.run(200)
        finals.append([float(c) for part in sim.pose_twist('crate') for c in part])
    assert finals[0] == finals[1]
