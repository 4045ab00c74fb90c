# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Collision response: the solver on single impacts, then whole worlds (docs/collisions.md).

The figures of these scenarios (dt = 1 ms, gravity 9.81 m/s^2) in docs/collisions.md
("Measured") come from `python -m bench.collision_cases`, which runs them with the same
helpers (oracles/contact_cases.py); the bounds asserted here are the documented ones.
"""

import math

import numpy as np
import pytest

from oracles.contact_cases import (apexes, ball, contact_slip, cube, effective_mass, G, GROUND,
                                   impact, mechanical_energy, mixed_scene, momenta,
                                   normal_velocity, random_contact_set, thin_wall_run)
from rb_sim_ros.contact import contact_solver as cs, solver_kernels as sk
from rb_sim_ros.contact.colliders import ColliderSet, Owner
from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
from rb_sim_ros.contact.collision_world import CollisionWorld
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.core.rigid_body import State
from rb_sim_ros.core.stepper import step_all, Stepper
from rb_sim_ros.sim.bodies import collision_world, make_steppers, rebuilt
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, Simulation
from support.solver_fingerprint import solver_fingerprints


# -- the solver on single impacts --------------------------------------------------------------
@pytest.mark.parametrize('restitution', [0.0, 0.3, 1.0])
def test_frictionless_impact_conserves_momenta_and_obeys_restitution(restitution):
    rng = np.random.default_rng(11)
    worst = {'p': 0.0, 'L': 0.0, 'E': 0.0, 'vn': 0.0}
    for _ in range(50):
        bodies, contacts, masses, inertias, rots, settings = impact(rng, restitution)
        v0, w0 = bodies.velocity, bodies.angular_velocity
        result = cs.solve(contacts, bodies, settings)
        v1, w1 = result.velocity, result.angular_velocity
        p0, l0, e0 = momenta(bodies, v0, w0, masses, inertias, rots)
        p1, l1, e1 = momenta(bodies, v1, w1, masses, inertias, rots)
        worst['p'] = max(worst['p'], np.abs(p1 - p0).max() / np.abs(p0).max())
        worst['L'] = max(worst['L'], np.abs(l1 - l0).max() / np.abs(l0).max())
        vn0 = normal_velocity(contacts, bodies, v0, w0)
        vn1 = normal_velocity(contacts, bodies, v1, w1)
        k = effective_mass(contacts, bodies)
        # j = -(1 + e) vn / K, and Delta E = -(1 - e^2)/2 vn^2 / K.
        assert result.normal_impulse[0] == pytest.approx(-(1.0 + restitution) * vn0 / k,
                                                         rel=1e-12)
        expected = -(1.0 - restitution ** 2) / 2.0 * vn0 ** 2 / k
        worst['E'] = max(worst['E'], abs((e1 - e0) - expected) / e0)
        worst['vn'] = max(worst['vn'], abs(vn1 + restitution * vn0) / abs(vn0))
        assert result.touched.tolist() == [True, True]
    assert worst['p'] < 1e-12 and worst['L'] < 1e-12
    assert worst['E'] < 1e-12                # e = 1: kinetic energy kept to 1e-12
    assert worst['vn'] < 1e-12               # e = 0: no normal separation velocity left


def test_impact_on_a_static_body_and_coulomb_friction():
    rng = np.random.default_rng(4)
    for friction in (0.05, 5.0):
        slips = []
        for _ in range(20):
            bodies, contacts, masses, inertias, rots, settings = impact(rng, 0.5, friction)
            result = cs.solve(contacts, bodies, settings)
            v1, w1 = result.velocity, result.angular_velocity
            n, slip, jt = contact_slip(bodies, contacts, result)
            assert abs(jt @ n) < 1e-12
            # Inside the cone always; on its edge, opposite the slip (maximal dissipation).
            assert np.linalg.norm(jt) <= friction * result.normal_impulse[0] * (1 + 1e-12)
            if np.linalg.norm(slip) > 1e-9:
                assert np.linalg.norm(jt) == pytest.approx(
                    friction * result.normal_impulse[0], rel=1e-9)
                cosine = -(jt @ slip) / np.linalg.norm(jt) / np.linalg.norm(slip)
                assert cosine > 1.0 - 1e-9
            slips.append(np.linalg.norm(slip))
            p0, l0, _ = momenta(bodies, bodies.velocity, bodies.angular_velocity, masses,
                                inertias, rots)
            p1, l1, _ = momenta(bodies, v1, w1, masses, inertias, rots)
            assert np.abs(p1 - p0).max() < 1e-12 * np.abs(p0).max()
            assert np.abs(l1 - l0).max() < 1e-12 * np.abs(l0).max()
        if friction > 1.0:                       # a high mu mostly sticks (not when the normal
            assert sum(s < 1e-9 for s in slips) >= 15     # impulse is small next to the slip)
    bodies, contacts, *_, settings = impact(rng, 1.0, static_b=True)
    result = cs.solve(contacts, bodies, settings)
    assert result.touched.tolist() == [True, False]
    np.testing.assert_array_equal(result.velocity[1], 0.0)


def test_compiled_and_interpreted_solver_give_the_same_bits():
    """One kernel, two paths: compiled, and interpreted (NUMBA_DISABLE_JIT=1), the same bits
    for 120 random contacts with restitution, friction, a warm start and the position pass,
    and for a solve that the energy guard blends (per-contact materials, couples)."""
    compiled, interpreted = solver_fingerprints('friction_warm', 'energy_guard')
    assert compiled == interpreted
    assert compiled['friction_warm']['colours'] > 1
    assert compiled['friction_warm']['position_iterations'] > 0
    assert compiled['energy_guard']['velocity_iterations'] > 3   # the plastic solve ran too


def test_many_contacts_keep_momentum():
    """The 120 random contacts less those with the static body, couples on: each impulse and
    couple is equal and opposite, so over many colours linear momentum and angular momentum
    about a fixed point are what they were; each normal impulse pushes, each tangent one is
    perpendicular to n. (After 10 iterations a tangent impulse may lie outside the cone of
    the final normal one, which the last normal update lowered: the cone holds at
    convergence, test_impact_on_a_static_body_and_coulomb_friction.)"""
    rng = np.random.default_rng(9)
    bodies, every = random_contact_set(rng, 120)
    free = every.body_b != len(bodies.inverse_mass) - 1
    contacts = cs.ContactArrays(every.body_a[free], every.body_b[free], every.point[free],
                                every.normal[free], every.depth[free])
    count = len(contacts)
    warm = rng.uniform(0.0, 0.1, count), rng.normal(size=(count, 3)) * 0.01
    settings = cs.SolverSettings(restitution=0.4, friction=0.6, rolling_resistance=0.02,
                                 torsional_friction=0.01)
    result = cs.solve(contacts, bodies, settings, *warm)
    assert result.colours > 1 and (result.normal_impulse > 0.0).sum() > 20
    mass = 1.0 / bodies.inverse_mass[:-1]
    inertia = np.linalg.inv(bodies.inverse_inertia[:-1])
    origin = np.array([0.3, -0.7, 1.1])

    def momenta_of(v, w):
        p = mass[:, None] * v[:-1]
        spin = np.einsum('nij,nj->ni', inertia, w[:-1])
        return p.sum(axis=0), (np.cross(bodies.position[:-1] - origin, p) + spin).sum(axis=0)
    p0, l0 = momenta_of(bodies.velocity, bodies.angular_velocity)
    p1, l1 = momenta_of(result.velocity, result.angular_velocity)
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12 * np.abs(mass).sum())
    np.testing.assert_allclose(l1, l0, rtol=0, atol=1e-12 * np.abs(l0).max())
    assert np.all(result.normal_impulse >= 0.0)
    along = np.einsum('mi,mi->m', result.tangent_impulse, contacts.normal)
    assert np.abs(along).max() < 1e-12


def test_solver_settings_refuse_bad_values_naming_them():
    for kwargs, field in (({'restitution': 1.5}, 'restitution'), ({'friction': -1}, 'friction'),
                          ({'dt': 0.0}, 'dt'), ({'position_fraction': 0.0}, 'position_frac'),
                          ({'velocity_iterations': 1.5}, 'velocity_iterations'),
                          ({'slop': math.nan}, 'slop'), ({'tolerance': -1.0}, 'tolerance')):
        with pytest.raises(ValueError, match=field):
            cs.SolverSettings(**kwargs)


# -- worlds ------------------------------------------------------------------------------------
@pytest.mark.parametrize('speculative', [True, False])
def test_ball_bounces_to_e_squared_h(speculative):
    """Ballistic flight is integrated exactly (AB2 is exact for a constant acceleration), so
    the only error is when, within a step, the impact happens. With speculative contacts the
    ball bounces at the step before it would reach the ground, at a height gap in [0, v dt],
    with the speed it has there: the next top is e^2 h + (1 - e^2) gap, so the error lies in
    [0, (1 - e^2) v dt] (measured: 0.17 to 1.24 mm against bounds of 0.64 to 2.3 mm). Without,
    it bounces from a penetration d in [0, v dt] with the speed it has gained there and is
    projected out of the ground: the top is e^2 (h + d), an error in [0, e^2 v dt]; when d is
    below the slop nothing is projected and the top is e^2 h - (1 - e^2) d, down to
    -(1 - e^2) slop (measured: -0.02 to 1.5 mm against bounds of 1.1 to 4.0 mm)."""
    r, e, dt = 0.1, 0.8, 1e-3
    for h in (1.0, 0.7313, 0.25):
        world = collision_world([ball(radius=r, position=(0.0, 0.0, r + h))], dt, G, planes=GROUND,
                                contact=ContactSettings(restitution=e, speculative=speculative))
        tops = apexes(world, 'ball', int(4.2 * math.sqrt(2 * h / 9.81) / dt) + 50)
        assert len(tops) >= 2
        previous = h
        for top in tops[:2]:
            v = math.sqrt(2 * 9.81 * previous)
            error = (top - r) - e * e * previous
            bound = ((1 - e * e) if speculative else e * e) * v * dt + 1e-5
            low = -1e-5 if speculative else -(1 - e * e) * world.settings.slop - 1e-6
            assert low <= error <= bound, (h, previous, top - r, error, bound)
            previous = top - r


def test_warm_starts_are_the_last_steps_impulses_only():
    """The next step's warm start is this step's impulses (and those of sleepers): a ball in
    flight between bounces keeps none, however it got there, so that no landing starts from
    the impulse of the last one. Checked at every step of two bounces, with sleeping off,
    against the contacts the step reports (one key for each, none in flight)."""
    world = collision_world([ball(radius=0.1, position=(0.0, 0.0, 0.4))], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(restitution=0.8, sleep_time=0.0))
    flights = landings = 0
    for _ in range(1200):
        world.step(1)
        keys = world._current_outputs()[0]  # the warm-start keys the next step reads
        contacts = world.last_contacts()
        assert len(keys) == len(contacts)
        flights += not contacts
        landings += bool(contacts)
    assert flights > 100 and landings >= 2  # both phases met, each more than once


@pytest.mark.parametrize('seed', range(4))
def test_warm_starts_are_matched_to_the_first_equal_key_as_a_binary_search_finds_it(seed):
    """world_step._match gallops from the last key found: it must find, for every key, what
    np.searchsorted finds (the first old key not below it) and take that one's impulses,
    for keys in any order, repeated old keys, keys before and past them all; compiled and
    interpreted."""
    import numba
    from rb_sim_ros.contact import world_step as ws
    match = getattr(ws._match, 'py_func', ws._match)
    rng = np.random.default_rng(seed)
    for trial in range(300):
        old = np.sort(rng.integers(0, 80, int(rng.integers(0, 60)))).astype(np.int64)
        keys = rng.integers(-5, 90, int(rng.integers(0, 60))).astype(np.int64)
        if trial % 2:
            keys = np.sort(keys)
        old_normal, old_tangent = rng.random(len(old)), rng.random((len(old), 3))
        at = np.searchsorted(old, keys)
        found = (at < len(old)) & (old[np.minimum(at, len(old) - 1)] == keys if len(old)
                                   else np.zeros(len(keys), dtype=bool))
        expected_n = np.where(found, old_normal[np.minimum(at, len(old) - 1)] if len(old)
                              else 0.0, 0.0)
        for run in (match, numba.njit(match)):
            normal, tangent = np.zeros(len(keys)), np.zeros((len(keys), 3))
            run(keys, old, old_normal, old_tangent, normal, tangent)
            assert np.array_equal(normal, expected_n)
            for k in range(len(keys)):
                assert np.array_equal(tangent[k], old_tangent[at[k]] if found[k]
                                      else np.zeros(3))


def test_a_step_in_flight_reports_no_contact_and_no_solve():
    """What a user reads of the last step is that step's: in flight after a bounce (a pass
    that finds no pair) no contact, no count of the solve and no solve energy, not the
    landing's."""
    world = collision_world([ball(radius=0.1, position=(0.0, 0.0, 0.4))], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(restitution=0.8, sleep_time=0.0))
    landed = flown = 0
    for _ in range(700):
        world.step(1)
        counts = {k: v for k, v in vars(world.last_stats).items() if k != 'seconds'}
        if world.last_contacts():
            landed += counts['contacts'] > 0 and world.last_solve_energy[0] > 0.0
        elif landed:
            flown += 1
            assert counts == {k: 0 for k in counts}
            assert world.last_solve_energy == (0.0, 0.0)
    assert landed and flown > 100


def _falling_and_resting():
    """A ball in flight and a box at rest on the ground (warm starts), sleeping off."""
    return ([ball(radius=0.1, position=(1.0, 0.0, 2.0)),
             cube('box', (0.2, 0.2, 0.2), (0.0, 0.0, 0.1))],
            dict(dt=1e-3, gravity=G, planes=GROUND,
                 contact=ContactSettings(friction=0.5, sleep_time=0.0)))


def test_a_world_steps_on_from_what_its_steppers_were_stepped_to():
    """A world's Steppers stepped by themselves (``step_all``: one call for their store, which
    swaps its state arrays), then the world: it steps from the states they left. With nothing
    near a contact, that is the run of the world alone (the bodies' own step is the one the
    world takes)."""
    bodies, _ = _falling_and_resting()
    bodies = bodies[:1] + [ball('high', radius=0.1, position=(-1.0, 0.0, 3.0))]
    alone, split = (collision_world(bodies, 1e-3, G, planes=GROUND) for _ in range(2))
    alone.step(10)
    split.step(2)
    step_all(list(split.steppers.values()), 3)
    split.step(5)
    for name in alone.steppers:
        assert split.steppers[name].pose_twist() == alone.steppers[name].pose_twist()


def test_what_a_compiled_entry_reads_keeps_the_types_it_was_made_for():
    """A world and a Stepper call their kernel's compiled entry without numba's checks
    (``jit.entry_point``), which reads its arguments as the types it was made for: every
    array of a world's call and of its store is C-contiguous and writable, and keeps its
    type, layout and flags through steps and the store's swap of state and spare."""
    bodies, settings = _falling_and_resting()
    world = collision_world(bodies, **settings)
    store = next(iter(world.steppers.values()))._store

    def types():
        arrays = [a for a in world._world() if isinstance(a, np.ndarray)]
        arrays += [store.state, store.spare, store.params, store.coefficients, store.status,
                   store.taken, store.bad, store.work, store.clock, store.warn_sq]
        assert all(a.flags.c_contiguous and a.flags.writeable for a in arrays)
        return [(a.dtype, a.ndim, a.shape) for a in arrays]
    before, state = types(), store.state
    world.step(3)
    step_all(list(world.steppers.values()), 2)
    assert store.state is not state  # swapped
    world.step(3)
    assert types() == before


def test_a_world_that_stepped_before_it_takes_over_another_goes_on_from_what_it_took():
    """``carry`` into a world that has stepped (its call made for its own arrays and warm
    starts) goes on from the taken-over states and warm starts, as a fresh world does."""
    bodies, settings = _falling_and_resting()
    old = collision_world(bodies, **settings)
    old.step(300)
    fresh = rebuilt(old, bodies, False, G)
    stepped = collision_world(bodies, **settings)
    stepped.step(5)
    stepped.carry(old, old.steppers, old.step_count, False)
    fresh.step(200)
    stepped.step(200)
    for name in fresh.steppers:
        assert stepped.steppers[name].pose_twist() == fresh.steppers[name].pose_twist()


def test_resting_box_stays_still_for_10_s():
    """dt = 1 ms, 10 s: no sinking (penetration <= slop + g dt^2 / 2), no drift, no jitter.
    Without sleeping, which would freeze the box after 0.5 s: this is the solver's test."""
    world = collision_world([cube('box', (0.4, 0.3, 0.2), (0.0, 0.0, 0.1), mass=3.0)], 1e-3, G,
                            planes=GROUND,
                            contact=ContactSettings(restitution=0.5, friction=0.5, sleep_time=0.0))
    start = world.state('box').position
    depth, speed = 0.0, 0.0
    for _ in range(10000):
        world.step(1)
        depth = max([depth] + [c.depth for c in world.last_contacts()])
        speed = max(speed, float(np.abs(world.state('box').linear_velocity).max()))
    st = world.state('box')
    assert depth < 1e-3 and depth < world.settings.slop + 1e-5
    assert np.abs(st.position - start).max() < 1e-3
    assert abs(st.position[2] - start[2]) < world.settings.slop + 1e-5
    assert np.abs(st.position[:2] - start[:2]).max() < 1e-6
    assert speed < 1e-5 and np.abs(st.angular_velocity).max() < 1e-5
    assert world.last_stats.contacts == 4 and world.last_stats.velocity_iterations <= 2


def test_a_box_whose_principal_axes_are_not_its_own_rests_flat():
    """A box's inertia given as a tensor whose principal axes are turned 30 degrees about x
    (a box of uneven density): the step works in principal axes (r = R Q), the world places
    its collider with R = r Q^T from the store's frames. Resting on a face it stays there
    (a collider placed with r, not R, would be turned in the ground and tumble)."""
    q = so3.exp((math.pi / 6, 0.0, 0.0))
    tensor = q @ np.diag([0.05, 0.08, 0.1]) @ q.T
    spec = BodySpec('box', 1.0, tuple(tensor.reshape(9)), initial_position=(0.0, 0.0, 0.1),
                    colliders=(Box((0.4, 0.3, 0.2)),))
    world = collision_world([spec], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(friction=0.5, sleep_time=0.0))
    store = world.steppers['box'].store
    row = world.steppers['box'].row
    assert store.has_frame[row] and not np.allclose(store.frames[row], np.eye(3).reshape(9))
    world.step(1000)
    st = world.state('box')
    np.testing.assert_allclose(st.rotation, np.eye(3), atol=1e-6)  # 30 degrees if misplaced
    assert abs(st.position[2] - 0.1) < 2e-4 and np.abs(st.position[:2]).max() < 1e-9


def test_box_stack_of_three_stands_for_10_s():
    size = (0.2, 0.2, 0.2)
    world = collision_world([cube(f'box{i}', size, (0.0, 0.0, 0.1 + 0.2 * i)) for i in range(3)],
                            1e-3, G, planes=GROUND,
                            contact=ContactSettings(friction=0.5, sleep_time=0.0))  # the solver
    start = [world.state(f'box{i}').position for i in range(3)]
    depth, speed = 0.0, 0.0
    for k in range(10000):
        world.step(1)
        depth = max([depth] + [c.depth for c in world.last_contacts()])
        if k >= 1000:                  # settled within 0.3 s (measured); no jitter after
            speed = max([speed] + [max(map(abs, world.steppers[f'box{i}'].pose_twist()[2]))
                                   for i in range(3)])
    for i in range(3):
        st = world.state(f'box{i}')
        assert np.abs(st.position - start[i]).max() < 1e-3              # drift
        assert np.abs(st.position[:2] - start[i][:2]).max() < 1e-4
        assert abs(st.rotation[2, 2] - 1.0) < 1e-9
    assert depth < 1e-3 and depth < world.settings.slop + 1e-5
    assert speed < 1e-5


def test_tumbling_box_comes_to_rest_face_down():
    size = (0.3, 0.2, 0.1)
    spec = cube('box', size, (0.0, 0.0, 0.5), mass=2.0, initial_orientation_xyzw=tuple(
        so3.quaternion_xyzw_from_matrix(so3.exp((0.4, 0.7, 0.2)))),
        initial_linear_velocity=(1.0, 0.3, 0.0), initial_angular_velocity=(3.0, -5.0, 8.0))
    world = collision_world([spec], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(restitution=0.3, friction=0.6))
    body = spec.body()
    energies = []
    for _ in range(30):
        world.step(100)
        energies.append(world.state('box').kinetic_energy(body))
    assert max(energies[:5]) > 1.0
    settled = world.state('box')
    assert energies[-1] < 1e-9
    # Face down: some body axis vertical, the centre at that half-size above the ground.
    axis = int(np.argmax(np.abs(settled.rotation[2])))
    assert abs(abs(settled.rotation[2, axis]) - 1.0) < 1e-6
    assert settled.position[2] == pytest.approx(size[axis] / 2, abs=2e-4)
    world.step(1000)
    assert np.abs(world.state('box').position - settled.position).max() < 1e-6


def test_sliding_box_stops_where_coulomb_says():
    """v0^2 / (2 mu g) on 4 corner contacts: each friction impulse opposes its slip."""
    mu, v0 = 0.4, 2.0
    world = collision_world([cube('box', (0.2, 0.2, 0.2), (0.0, 0.0, 0.1 - 1e-4),
                                  initial_linear_velocity=(v0, 0.0, 0.0))], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(friction=mu))
    world.step(700)
    st = world.state('box')
    assert st.position[0] == pytest.approx(v0 ** 2 / (2 * mu * 9.81), abs=v0 * 1e-3)
    assert abs(st.position[1]) < 1e-5 and np.abs(st.angular_velocity).max() < 1e-4


def test_no_tunnelling_through_a_thin_wall():
    """A ball of radius r = 5 cm at a wall w = 1 cm thick, dt = 1 ms. Discrete contacts hold
    up to (r + w/2) / dt = 55 m/s and fail past (2 r + w) / dt (bench/collision_cases.py
    measures where); speculative contacts hold at every speed tried here, up to 10 km/s."""
    phases = np.linspace(0.0, 1.0, 7)[:-1]
    for speed in (1.0, 20.0, 54.0):
        assert all(thin_wall_run(speed, False, p) < 0.0 for p in phases)
    assert any(thin_wall_run(250.0, False, p) > 0.0 for p in phases)
    for speed in (54.0, 250.0, 1000.0, 10000.0):
        assert all(thin_wall_run(speed, True, p) < 0.0 for p in phases), speed


def test_touched_bodies_restart_their_history_untouched_ones_keep_it():
    """A spinning asymmetric box: the Stepper's extrapolation differs after a restart, so bit
    equality shows which history each body used."""
    spin = dict(initial_angular_velocity=(2.0, 5.0, -1.0))
    far = cube('far', (0.3, 0.2, 0.1), (10.0, 0.0, 3.0), **spin)
    falling = cube('falling', (0.3, 0.2, 0.1), (0.0, 0.0, 0.3), **spin)
    world = collision_world([far, falling], 1e-3, G, planes=GROUND,
                            contact=ContactSettings(restitution=0.5))
    alone = Stepper(far.body(), 1e-3, far.initial_state(), gravity=G)
    hit = None
    for k in range(400):
        world.step(1)
        alone.step(1)
        if hit is None and world.last_stats.touched:
            hit = (k, world.state('falling'))
            # A Stepper with no history at the world's exact (x, R, v, omega).
            fresh = Stepper(falling.body(), 1e-3, gravity=G)
            fresh.apply_contact(*world.steppers['falling'].components())
            world.step(1)
            alone.step(1)
            if world.last_stats.touched == 0:       # no contact at this step
                fresh.step(1)
                after = world.state('falling')
                np.testing.assert_array_equal(after.position, fresh.state.position)
                np.testing.assert_array_equal(after.angular_velocity,
                                              fresh.state.angular_velocity)
    assert hit is not None
    np.testing.assert_array_equal(world.state('far').rotation, alone.state.rotation)
    np.testing.assert_array_equal(world.state('far').angular_velocity,
                                  alone.state.angular_velocity)


def test_a_run_without_colliders_on_moving_bodies_has_no_world():
    """One switch: a collision world exists only where a moving body has colliders. Bodies
    without (planes, a static wall with colliders: nothing they could hit) are refused one,
    and a Simulation of them has none; its bodies step as plain Steppers do."""
    specs = (BodySpec('a', 2.0, (0.1, 0.2, 0.3), initial_angular_velocity=(1.0, 2.0, 3.0)),
             BodySpec('b', 1.0, (0.1, 0.1, 0.1), initial_linear_velocity=(1.0, 0.0, 0.0)),
             BodySpec('wall', static=True, colliders=(Box((1.0, 1.0, 1.0)),),
                      initial_position=(0.0, 0.0, -5.0)))
    with pytest.raises(ValueError, match='no moving body has colliders'):
        collision_world(specs, 1e-3, G, planes=GROUND)
    owners = ColliderSet([Owner('wall', specs[2].colliders, pose=State())], GROUND)
    steppers, _ = make_steppers(specs, 1e-3, 'eq27', G)
    with pytest.raises(ValueError, match='no moving body has one'):
        CollisionWorld(steppers, owners)
    sim = Simulation(Config(dt=1e-3, gravity=G, bodies=specs))
    assert sim.world is None and not sim.config.collides and sim.config.has_colliders
    sim.run(1000)
    for name in ('a', 'b'):
        alone = Stepper(specs[0 if name == 'a' else 1].body(), 1e-3,
                        specs[0 if name == 'a' else 1].initial_state(), gravity=G)
        alone.step(1000)
        assert sim.steppers[name].pose_twist() == alone.pose_twist()


def test_mixed_scene_stays_inside_its_walls_loses_energy_and_is_deterministic():
    """Spheres, a capsule, a box and a body of three colliders among walls and a static
    pillar. Balls and the rod go on rolling (rigid bodies have no rolling resistance); the
    crate comes to rest. A run in calls of one step agrees bit for bit with one in calls of
    100 (a world keeps nothing between calls that a longer call would not)."""
    worlds = [mixed_scene(), mixed_scene()]
    energy = [mechanical_energy(worlds[0])]
    for _ in range(15):
        worlds[0].step(100)
        for _ in range(100):
            worlds[1].step(1)
        energy.append(mechanical_energy(worlds[0]))
    assert all(e1 <= e0 + 1e-3 for e0, e1 in zip(energy, energy[1:]))
    assert energy[-1] < 0.7 * energy[0]
    names = list(worlds[0].steppers)
    for name in names:
        st = worlds[0].state(name)
        assert np.all(np.abs(st.position[:2]) < 1.0) and st.position[2] > 0.0
        for other in worlds[1:]:
            assert other.steppers[name].pose_twist() == worlds[0].steppers[name].pose_twist()
    assert np.abs(worlds[0].state('crate').linear_velocity).max() < 1e-4
    assert worlds[0].totals.contacts > 0


def test_world_refuses_bad_arguments_naming_them():
    with pytest.raises(ValueError, match='only a static body'):
        collision_world([BodySpec('a', colliders=(Plane(),))], 1e-3)
    with pytest.raises(ValueError, match=r'colliders\[0\]'):
        collision_world([BodySpec('a', colliders=('sphere',))], 1e-3)
    with pytest.raises(ValueError, match='restitution'):
        collision_world([ball()], 1e-3, contact=ContactSettings(restitution=2.0))
    with pytest.raises(ValueError, match=r'planes\[0\]'):
        collision_world([ball()], 1e-3, planes=(Sphere(1.0),))
    with pytest.raises(ValueError, match='speculative'):
        collision_world([ball()], 1e-3, contact=ContactSettings(speculative='yes'))
    with pytest.raises(ValueError, match='contact must be a ContactSettings'):
        collision_world([ball()], 1e-3, contact={'restitution': 0.5})
    with pytest.raises(ValueError, match='warm_start'):
        ContactSettings(warm_start=1)
    with pytest.raises(ValueError, match='gravity'):
        collision_world([ball()], 1e-3, gravity=(0, 0))
    world = collision_world([ball()], 1e-3, planes=GROUND)
    with pytest.raises(ValueError, match='n must be'):
        world.step(-1)
    with pytest.raises(ValueError, match=r'n must be an int from 0 to 2\^62, got an int of 1329'):
        world.step(10 ** 400)
    with pytest.raises(ValueError, match="no moving body named 'x'"):
        world.set_state('x', State())


def test_from_config_and_teleport_checks_before_integrating():
    config = Config(dt=1e-3, gravity=G, bodies=(ball(position=(0.0, 0.0, 0.5)),),
                    contact=ContactSettings(restitution=0.0, friction=0.2))
    world = collision_world(config.bodies, config.dt, config.gravity, GROUND,
                            config.integrator, config.contact)
    assert world.contact == config.contact and world.settings.friction == 0.2
    world.step(10)
    # Teleport the ball to 1 cm above the ground, falling at 100 m/s: one step would bury it.
    world.set_state('ball', State((0.0, 0.0, 0.11), None, (0.0, 0.0, -100.0)))
    world.step(1)
    assert world.state('ball').position[2] >= 0.1 - world.settings.slop


def test_a_scenes_contact_settings_reach_the_world_that_steps_it(tmp_path):
    """The contact settings are given once (a scene's ``contact:``, a ContactSettings) and
    the world steps with them: the solver's (here the tolerance) and the kernel's (warm
    starts off: a resting box keeps no impulses for the next step; on, it does)."""
    scene = tmp_path / 'box.yaml'
    kept = {}
    for warm in (True, False):
        scene.write_text(
            'gravity: [0.0, 0.0, -9.81]\n'
            f'contact: {{tolerance: 2.0e-5, warm_start: {str(warm).lower()}, '
            'sleep_time: 0.0}\n'
            'bodies:\n'
            '  - {name: box, shape: box, size: [0.2, 0.2, 0.2], density: 125.0, '
            'position: [0.0, 0.0, 0.1], colliders: shape}\n'
            '  - {name: ground, static: true, colliders: [{type: plane}]}\n')
        gravity, bodies, contact = load_scene(str(scene))[:3]
        sim = Simulation(Config(dt=1e-3, gravity=gravity, bodies=tuple(bodies),
                                contact=contact))
        sim.run(100)
        assert sim.world.contact == contact and sim.world.settings.tolerance == 2.0e-5
        assert sim.world._settings_array[sk.TOLERANCE] == 2.0e-5  # what the kernel reads
        assert sim.world.warm_start is warm
        kept[warm] = len(sim.world._current_outputs()[0])  # the keys the next step reads
    assert kept[True] >= 4 and kept[False] == 0


@pytest.mark.parametrize('name', ['velocity_iterations', 'position_iterations'])
def test_iteration_counts_beyond_what_the_kernel_reads_are_refused(name):
    """The solver kernel reads its settings as floats: a count past 2^31 - 1 is refused, not
    turned into no iterations at all (10**19 once let a ball fall through the floor)."""
    cs.SolverSettings(**{name: cs.MAX_COUNT})
    for bad in (cs.MAX_COUNT + 1, 10 ** 19, 10 ** 400):
        with pytest.raises(ValueError, match=name):
            cs.SolverSettings(**{name: bad})
