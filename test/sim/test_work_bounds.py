# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Bounds on the work of a step, and on what the contact code can take (issue 28: N01, N02,
N14, N15): every way a body comes in (a scene file, spawn_entity's body entry, a recording's
config) refuses, in one line naming the body and the bound, colliders the step could not
bound, masses and moments the contact solve cannot invert and shapes whose derived quantities
overflow; and what a legitimate scene can still pile up at run time stays bounded.

Oracles: the bounds as the issue states them (a documented constant, named in the refusal);
the colouring's rule (no moving body twice in one colour) and its greedy reference written
here; the count of interpreted lines as the measure of work (no clocks); float range.
"""

import json
import math
import os
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from rb_sim_ros.contact import broad_phase, collision_shapes, settings, solver_kernels
from rb_sim_ros.contact.colliders import MAX_COLLIDERS
from rb_sim_ros.contact.collision_shapes import Box, Capsule, Plane, shape_from_dict, Sphere
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.sim import scene
from rb_sim_ros.sim.simulation import BodySpec, Config, ContactSettings, Simulation

SPHERE = {'type': 'sphere', 'radius': 0.1}


def _entry(colliders, name='heap', **fields):
    return json.dumps({'name': name, 'mass': 1.0, 'inertia': [0.1, 0.1, 0.1],
                       'colliders': colliders, **fields})


def _one_line(e, *words):
    text = str(e.value)
    assert '\n' not in text and 'Traceback' not in text, text
    for w in words:
        assert w in text, text
    return text


# -- N01 / N02: colliders per body -------------------------------------------------------------

def test_a_spawned_body_with_too_many_colliders_is_refused_naming_it_and_the_bound():
    limit = MAX_COLLIDERS
    assert 8 <= limit <= 256  # a documented constant, a compound shape's handful and more
    scene.body_entry(_entry([SPHERE] * limit))  # at the bound: accepted
    with pytest.raises(scene.SceneError) as e:
        scene.body_entry(_entry([SPHERE] * 350))  # the attack's 10 kB spawn
    _one_line(e, 'heap', 'colliders', '350', f'MAX_COLLIDERS = {limit}')


def test_a_scene_body_with_too_many_colliders_is_refused_naming_it_and_the_bound():
    data = {'bodies': [{'name': 'ground', 'static': True,
                        'colliders': [{'type': 'plane'}]},
                       json.loads(_entry([SPHERE] * (MAX_COLLIDERS + 1), name='pile'))]}
    with pytest.raises(scene.SceneError) as e:
        scene.scene_from_data(data, 'heap.yaml')
    _one_line(e, 'heap.yaml', 'pile', 'colliders', f'MAX_COLLIDERS = {MAX_COLLIDERS}')
    with pytest.raises(ValueError, match='MAX_COLLIDERS'):  # the API's own, as a recording's
        BodySpec('pile', colliders=(Sphere(0.1),) * 400)


def _load_edited_recording(tmp_path, change):
    """replay.load of a recording made offline (two bodies, no colliders) whose config
    ``change`` (a function of the decoded config) edited, as an attacker would."""
    pytest.importorskip('mcap')
    from oracles.node_recording import record_offline
    from support.recordings import rewrite, topic_parts

    from rb_sim_ros.offline import replay

    good = tmp_path / 'good.mcap'
    record_offline(good, Config(bodies=(BodySpec('one'), BodySpec('two'))), periods=2)
    schemas, channels, messages, meta = topic_parts(good)
    config = json.loads(meta['config'])
    change(config)
    meta = {**meta, 'config': json.dumps(config)}
    return replay.load(str(rewrite(tmp_path / 'bad.mcap', schemas, channels, messages, meta)))


def test_a_recording_whose_config_has_too_many_colliders_is_refused_by_load(tmp_path):
    from rb_sim_ros.recording.errors import ReaderError

    def pile(config):  # N02: two bodies of 400 colliders at one place
        for body in config['bodies']:
            body['colliders'] = [SPHERE] * 400

    with pytest.raises(ReaderError) as e:
        _load_edited_recording(tmp_path, pile)
    _one_line(e, 'one', 'colliders', '400', f'MAX_COLLIDERS = {MAX_COLLIDERS}')


def test_a_recording_whose_config_asks_for_endless_iterations_is_refused_by_load(tmp_path):
    from rb_sim_ros.recording.errors import ReaderError

    def endless(config):  # a scene file is held to MAX_ITERATIONS; a recording was not
        config['contact']['velocity_iterations'] = 2 ** 31 - 1

    with pytest.raises(ReaderError) as e:
        _load_edited_recording(tmp_path, endless)
    _one_line(e, 'velocity_iterations', f'{settings.MAX_ITERATIONS}', 'MAX_ITERATIONS')


# -- N01: the colouring of the contact solver is linear in a body's contacts ------------------

def _lines_run(n):
    """Lines the colouring runs (interpreted) for n contacts of one moving body with the
    ground: the measure of its work, independent of the machine and its load."""
    colour = getattr(solver_kernels._colour, 'py_func', solver_kernels._colour)
    body_a = np.zeros(n, dtype=np.int64)
    body_b = np.ones(n, dtype=np.int64)
    moving = np.array([True, False])
    out = np.empty(n, dtype=np.int64)
    count = [0]

    def trace(frame, event, arg):
        if frame.f_code is colour.__code__:
            if event == 'line':
                count[0] += 1
            return trace
        return None

    old = sys.gettrace()
    sys.settrace(trace)
    try:
        colour(body_a, body_b, moving, out)
    finally:
        sys.settrace(old)
    assert len(set(out.tolist())) == n  # one body: every contact a colour of its own
    return count[0]


def test_colouring_work_grows_linearly_with_one_bodys_contacts():
    # Quadratic (the greedy scan of every earlier contact): x16 for 4x the contacts.
    small, large = _lines_run(300), _lines_run(1200)
    assert large < 5 * small, (small, large)


def _greedy(body_a, body_b, moving):
    """The reference: each contact the lowest colour no earlier contact of its moving bodies
    has (the colouring's rule with no scan bound)."""
    return _reference_colours(body_a, body_b, moving, math.inf)


@pytest.mark.parametrize('seed', range(6))
def test_colouring_is_proper_and_greedy_while_bodies_have_few_contacts(seed):
    rng = np.random.default_rng(seed)
    n_bodies = 12 if seed < 3 else 3  # few contacts each, then hundreds on three bodies
    m = 60 if seed < 3 else 900
    moving = rng.random(n_bodies) < 0.8
    moving[0] = True
    body_a = rng.integers(0, n_bodies, m)
    body_b = (body_a + rng.integers(1, n_bodies, m)) % n_bodies
    colour = np.empty(m, dtype=np.int64)
    count = solver_kernels._colour(body_a.astype(np.int64), body_b.astype(np.int64), moving,
                                   colour)
    assert count == colour.max() + 1
    for body in np.flatnonzero(moving):  # proper: no moving body twice in one colour
        mine = colour[(body_a == body) | (body_b == body)]
        assert len(set(mine.tolist())) == len(mine)
    degree = np.bincount(np.concatenate([body_a, body_b]), minlength=n_bodies)
    if degree[moving].max() <= solver_kernels.COLOUR_SCAN:
        assert colour.tolist() == _greedy(body_a.tolist(), body_b.tolist(), moving.tolist())


@pytest.mark.parametrize('first', [0, 10, 23, 40])
def test_colouring_stays_greedy_past_the_first_word_of_held_colours(first):
    # Body 1 pressed by the static body 0 ``first`` times (colours 0 ..), body 2 by body 3,
    # then 1 by 2 until 1 holds 0 .. 62 (solver_kernels.HELD_BITS: the first word of the bits
    # of the colours a body holds), and once more: the greedy colours go past 62 while no
    # body has more than COLOUR_SCAN contacts.
    held = solver_kernels.HELD_BITS
    pairs = [(1, 0)] * first + [(2, 3)] * (first // 2) + [(1, 2)] * (held - first + 1)
    body_a = np.array([a for a, _ in pairs], dtype=np.int64)
    body_b = np.array([b for _, b in pairs], dtype=np.int64)
    moving = np.array([False, True, True, True])
    colour = np.empty(len(pairs), dtype=np.int64)
    count = solver_kernels._colour(body_a, body_b, moving, colour)
    degree = np.bincount(np.concatenate([body_a, body_b]), minlength=4)
    assert degree[moving].max() <= solver_kernels.COLOUR_SCAN
    assert colour.tolist() == _greedy(body_a.tolist(), body_b.tolist(), moving.tolist())
    assert count == colour.max() + 1 == held + 1


def test_colouring_finds_the_highest_free_colour_a_few_contacts_can_leave():
    """Bodies 1 and 3 each pressed by the static body 0 COLOUR_SCAN times (colours 0 .. 63),
    body 2 then by body 3 as often (64 .., past the scan: one after the highest), and 1 by 2:
    both have COLOUR_SCAN earlier contacts (few), holding 0 .. 127 between them, so the
    colour is 128, in the last of the words of held colours."""
    scan = solver_kernels.COLOUR_SCAN
    pairs = [(1, 0)] * scan + [(3, 0)] * scan + [(2, 3)] * scan + [(1, 2)]
    body_a = np.array([a for a, _ in pairs], dtype=np.int64)
    body_b = np.array([b for _, b in pairs], dtype=np.int64)
    colour = np.empty(len(pairs), dtype=np.int64)
    count = solver_kernels._colour(body_a, body_b, np.array([False, True, True, True]), colour)
    assert colour[-1] == 2 * scan and count == 2 * scan + 1
    assert colour[2 * scan:3 * scan].tolist() == list(range(scan, 2 * scan))


def _reference_colours(body_a, body_b, moving, scan):
    """The colouring's rule, written plainly: the lowest colour no earlier contact of its
    moving bodies holds while each has at most ``scan`` earlier contacts, else one after the
    highest they hold."""
    held = [set() for _ in moving]
    out = []
    for a, b in zip(body_a, body_b):
        mine = [x for x in (a, b) if moving[x]]
        if all(len(held[x]) <= scan for x in mine):
            used = set().union(*(held[x] for x in mine))
            c = 0
            while c in used:
                c += 1
        else:
            c = max((max(held[x], default=-1) + 1 for x in mine), default=0)
        out.append(c)
        for x in mine:
            held[x].add(c)
    return out


@pytest.mark.parametrize('seed', range(4))
def test_colouring_follows_its_rule_where_bodies_pass_the_scan(seed):
    # 3 to 5 bodies, 200 to 400 contacts: degrees cross COLOUR_SCAN during the run
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(3, 6))
    m = int(rng.integers(200, 400))
    moving = rng.random(n) < 0.85
    moving[0] = True
    body_a = rng.integers(0, n, m)
    body_b = (body_a + rng.integers(1, n, m)) % n
    colour = np.empty(m, dtype=np.int64)
    solver_kernels._colour(body_a.astype(np.int64), body_b.astype(np.int64), moving, colour)
    assert colour.tolist() == _reference_colours(body_a.tolist(), body_b.tolist(),
                                                 moving.tolist(), solver_kernels.COLOUR_SCAN)


# -- N01: colliders piled up at run time: the step refuses, with the reason --------------------

def test_more_pairs_than_the_broad_phase_bound_stop_the_step_with_the_reason():
    # 12 bodies of MAX_COLLIDERS balls at one place: 270,336 pairs of colliders that touch.
    per = MAX_COLLIDERS
    count = 12
    assert count * per * (count * per - 1) // 2 - count * per * (per - 1) // 2 \
        > broad_phase.MAX_PAIRS
    heap = tuple(BodySpec(f'b{i}', colliders=(Sphere(0.5),) * per,
                          initial_position=(0.0, 0.0, 0.01 * i)) for i in range(count))
    sim = Simulation(Config(bodies=heap, contact=ContactSettings(sleep_time=0.0)))
    with pytest.raises(IntegrationError) as e:
        sim.run(1)
    _one_line(e, str(broad_phase.MAX_PAIRS), 'MAX_PAIRS', 'too many colliders in one place')
    with pytest.raises(IntegrationError):  # and so again, without moving them through
        sim.run(1)


def test_more_contacts_than_the_solve_bound_stop_the_step_with_the_reason():
    # Interpreted (NUMBA_DISABLE_JIT=1, where the bound is read when the step runs), with the
    # bound at 10: three boxes resting apart on the ground make 12 contacts (4 each).
    code = textwrap.dedent("""
        from rb_sim_ros.contact import world_step
        from rb_sim_ros.contact.collision_shapes import Box, Plane
        from rb_sim_ros.core.stepper import IntegrationError
        from rb_sim_ros.sim.simulation import BodySpec, Config, Simulation
        world_step.MAX_CONTACTS = 10
        boxes = tuple(BodySpec(f'box_{i}', colliders=(Box((1.0, 1.0, 1.0)),),
                               initial_position=(1.2 * i, 0.0, 0.4999)) for i in range(3))
        sim = Simulation(Config(bodies=(BodySpec('ground', static=True,
                                                 colliders=(Plane(),)),) + boxes))
        try:
            sim.run(1)
        except IntegrationError as e:
            print(e)
        world_step.MAX_CONTACTS = 12
        sim.run(1)
        print('ran', sim.step_count)
        """)
    env = dict(os.environ, NUMBA_DISABLE_JIT='1')
    run = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    refusal, ran = run.stdout.strip().splitlines()
    assert '12 contacts, more than world_step.MAX_CONTACTS = 10' in refusal, refusal
    assert 'too many colliders in one place' in refusal, refusal
    assert ran == 'ran 1'  # the refused step did not move them: checked again, then stepped


def test_the_broad_phase_returns_its_overflow_past_the_bound(monkeypatch):
    sweep = getattr(broad_phase.sweep_and_prune, 'py_func', broad_phase.sweep_and_prune)
    lower = np.zeros((4, 3))  # 4 unit boxes at one place: 6 pairs
    group, static = np.arange(4), np.zeros(4, dtype=bool)
    monkeypatch.setattr(broad_phase, 'MAX_PAIRS', 6)
    assert sweep(lower, lower + 1.0, group, static, -1).shape == (6, 2)
    monkeypatch.setattr(broad_phase, 'MAX_PAIRS', 5)
    assert sweep(lower, lower + 1.0, group, static, -1).tolist() == [[broad_phase.OVERFLOW] * 2]
    # Overlapping along the sweep axis only (x), apart along y: no pair, but 6 box tests.
    monkeypatch.setattr(broad_phase, 'MAX_PAIRS', 6)
    apart = np.array([[0.0, 2.0 * i, 0.0] for i in range(4)])
    assert sweep(apart, apart + 1.0, group, static, 0).shape == (0, 2)
    monkeypatch.setattr(broad_phase, 'MAX_SWEEP', 5)
    assert sweep(apart, apart + 1.0, group, static, 0).tolist() == [[broad_phase.OVERFLOW] * 2]


# -- N14: masses and moments the contact solve cannot take --------------------------------------

def _stack_and(tiny):
    ground = {'name': 'ground', 'static': True, 'colliders': [{'type': 'plane'}]}
    stack = [{'name': f'stack_{i}', 'mass': 1.0, 'inertia': [1 / 6] * 3,
              'position': [0, 0, 0.5 + i], 'colliders': [{'type': 'box', 'size': [1, 1, 1]}]}
             for i in range(3)]
    return {'gravity': [0, 0, -9.81], 'bodies': [ground, *stack, tiny]}


@pytest.mark.parametrize('mass, inertia, word', [
    (1e-200, [1e-202] * 3, 'mass'),      # the attack's: 1/I cubed overflows in the guard
    (1.0, [1e-200, 1e-200, 1e-200], 'inertia'),
    (1e200, [1e200] * 3, 'mass'),        # 1/I cubed underflows to 0: the guard's det
    (1.0, [1e-70, 1.0, 1.0], 'inertia'),  # a rod too thin: one inverse moment too large
])
def test_a_body_the_contact_solve_cannot_take_is_refused_naming_it(mass, inertia, word):
    tiny = {'name': 'tiny', 'mass': mass, 'inertia': inertia, 'position': [30, 0, 0.1],
            'colliders': [{'type': 'sphere', 'radius': 0.1}]}
    with pytest.raises(scene.SceneError) as e:
        scene.scene_from_data(_stack_and(tiny), 'stack.yaml')
    _one_line(e, 'stack.yaml', 'tiny', word, f'{settings.MIN_CONTACT_MASS:g}',
              f'{settings.MAX_CONTACT_MASS:g}')
    # Without colliders it never enters the solve: the attitude simulator keeps its range.
    del tiny['colliders']
    scene.scene_from_data(_stack_and(tiny), 'stack.yaml')


def test_within_the_bounds_every_product_the_solve_forms_is_a_normal_float():
    # The guard inverts R diag(1/I) R^T through its determinant (1/I)^3 and cofactors (1/I)^2;
    # K = 1/m_a + 1/m_b; the ratio of two masses in contact.
    low, high = settings.MIN_CONTACT_MASS, settings.MAX_CONTACT_MASS
    for inverse in (1.0 / low, 1.0 / high):
        for power in (1, 2, 3):
            value = inverse ** power
            assert math.isfinite(value) and value >= sys.float_info.min
    assert math.isfinite(high / low) and low / high >= sys.float_info.min


def test_a_stack_runs_on_beside_a_body_at_the_bounds():
    tiny = BodySpec('tiny', mass=settings.MIN_CONTACT_MASS,
                    inertia=(settings.MIN_CONTACT_MASS,) * 3, initial_position=(30.0, 0.0, 0.1),
                    colliders=(Sphere(0.1),))
    stack = tuple(BodySpec(f'stack_{i}', mass=1.0, inertia=(1 / 6,) * 3,
                           initial_position=(0.0, 0.0, 0.5 + i), colliders=(Box((1, 1, 1)),))
                  for i in range(3))
    ground = BodySpec('ground', static=True, colliders=(Plane(),))
    sim = Simulation(Config(gravity=(0.0, 0.0, -9.81), bodies=(ground, *stack, tiny),
                            contact=ContactSettings(friction=0.8)))
    sim.run(300)
    assert sim.pose_twist('stack_2')[0][2] == pytest.approx(2.5, abs=1e-3)


# -- N15: shapes whose derived quantities overflow ---------------------------------------------

@pytest.mark.parametrize('collider, field', [
    ({'type': 'capsule', 'radius': 1e150, 'length': 1e300}, 'radius'),  # the attack's
    ({'type': 'capsule', 'radius': 0.1, 'length': 1e300}, 'length'),
    ({'type': 'sphere', 'radius': 1e200}, 'radius'),
    ({'type': 'sphere', 'radius': 1e-200}, 'radius'),  # squares underflow to 0
    ({'type': 'box', 'size': [1e155, 1.0, 1.0]}, 'size[0]'),
    ({'type': 'sphere', 'radius': 0.1, 'position': [0.0, 1e300, 0.0]}, 'position'),
    ({'type': 'plane', 'offset': 1e300}, 'offset'),
])
def test_a_shape_beyond_the_length_bounds_is_refused_naming_the_field(collider, field):
    with pytest.raises(ValueError) as e:
        shape_from_dict(collider)
    _one_line(e, field, 'MAX_LENGTH')
    with pytest.raises(scene.SceneError) as e:  # what spawn_entity reads
        scene.body_entry(json.dumps({'name': 'huge', 'mass': 1.0, 'inertia': [1, 1, 1],
                                     'static': collider['type'] == 'plane',
                                     'colliders': [collider]}))
    _one_line(e, 'huge', field)


def test_at_the_length_bounds_every_derived_quantity_is_finite():
    big, small = collision_shapes.MAX_LENGTH, collision_shapes.MIN_LENGTH
    capsule = Capsule(big, big, position=(big, -big, big))
    box = Box((big, big, big), position=(-big, big, -big))
    reach = max(math.sqrt(sum(c * c for c in s.position)) + s.bounding_radius
                for s in (capsule, box))
    assert math.isfinite(reach ** 4) and small ** 4 >= sys.float_info.min
    mass, moments = scene.mass_and_inertia('box', 1.0, {'size': [big] * 3})
    assert all(math.isfinite(v) for v in (mass, *moments))
    Sphere(small), Capsule(small, 0.0), Box((small,) * 3)  # accepted


def test_spawn_entity_answers_the_huge_capsule_with_its_code_and_reason():
    srv = pytest.importorskip('simulation_interfaces.srv')
    from rb_sim_ros.ros.sim_interfaces import SimulationInterfaces

    interfaces = object.__new__(SimulationInterfaces)  # no node: only the request's reading
    interfaces.node = SimpleNamespace(templates=(), config=Config())
    request = srv.SpawnEntity.Request()
    request.name = 'huge'
    request.resource_string = json.dumps({
        'mass': 1.0, 'inertia': [1, 1, 1],
        'colliders': [{'type': 'capsule', 'radius': 1e150, 'length': 1e300}]})
    code, message, spec = interfaces._spawn_spec(request)
    assert spec is None and code == srv.SpawnEntity.Response.RESOURCE_PARSE_ERROR
    assert 'radius' in message and 'MAX_LENGTH' in message and '\n' not in message
