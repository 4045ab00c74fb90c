# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The figures of docs/collisions.md's "Measured" table: the scenarios of
test/contact/test_collisions.py, run again and measured (the tests assert the bounds; this
prints what the runs reach).

    python -m bench.collision_cases [--quick] [--json out.json]

Each scenario is built with the test module's own helpers (the same bodies, seeds and
settings), at dt = 1 ms, g = 9.81 m/s^2. Prints the "measured" cell of each row and writes
docs/bench/collision_cases.json (or ``--json``; ``--quick``: shorter runs, no file unless
asked). Exit 1 if a figure is outside the bound its test asserts (or not finite).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

import numpy as np

from bench import figures
from oracles import contact_cases as tc  # the tests' scenarios
from rb_sim_ros.contact import contact_solver as cs
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world

RESTITUTIONS = (0.0, 0.3, 1.0)
FRICTIONS = (0.05, 5.0)


def impacts() -> dict:
    """Worst relative errors over test_frictionless_impact_...'s cases (seed 11, 50 each)."""
    worst = {'cases': 0, 'p': 0.0, 'L': 0.0, 'E': 0.0, 'vn': 0.0, 'j': 0.0}
    for e in RESTITUTIONS:
        rng = np.random.default_rng(11)
        for _ in range(50):
            bodies, contacts, masses, inertias, rots, settings = tc.impact(rng, e)
            v0, w0 = bodies.velocity, bodies.angular_velocity
            result = cs.solve(contacts, bodies, settings)
            v1, w1 = result.velocity, result.angular_velocity
            p0, l0, e0 = tc.momenta(bodies, v0, w0, masses, inertias, rots)
            p1, l1, e1 = tc.momenta(bodies, v1, w1, masses, inertias, rots)
            vn0 = tc.normal_velocity(contacts, bodies, v0, w0)
            vn1 = tc.normal_velocity(contacts, bodies, v1, w1)
            k = tc.effective_mass(contacts, bodies)
            j = -(1.0 + e) * vn0 / k
            expected = -(1.0 - e ** 2) / 2.0 * vn0 ** 2 / k
            worst['cases'] += 1
            worst['p'] = max(worst['p'], np.abs(p1 - p0).max() / np.abs(p0).max())
            worst['L'] = max(worst['L'], np.abs(l1 - l0).max() / np.abs(l0).max())
            worst['E'] = max(worst['E'], abs((e1 - e0) - expected) / e0)
            worst['vn'] = max(worst['vn'], abs(vn1 + e * vn0) / abs(vn0))
            worst['j'] = max(worst['j'], abs(result.normal_impulse[0] - j) / j)
    return {k: float(v) for k, v in worst.items()}


def friction() -> dict:
    """test_impact_on_a_static_body_and_coulomb_friction's cases (seed 4, 20 per mu)."""
    rng = np.random.default_rng(4)
    out = {'cases': 0, 'sliding': 0, 'cone': 0.0, 'cosine': 1.0, 'p': 0.0}
    for mu in FRICTIONS:
        for _ in range(20):
            bodies, contacts, masses, inertias, rots, settings = tc.impact(rng, 0.5, mu)
            result = cs.solve(contacts, bodies, settings)
            v1, w1 = result.velocity, result.angular_velocity
            _n, slip, jt = tc.contact_slip(bodies, contacts, result)
            out['cases'] += 1
            out['cone'] = max(out['cone'], np.linalg.norm(jt) / (mu * result.normal_impulse[0]))
            if np.linalg.norm(slip) > 1e-9:
                out['sliding'] += 1
                out['cosine'] = min(out['cosine'], -(jt @ slip) / np.linalg.norm(jt)
                                    / np.linalg.norm(slip))
            p0 = tc.momenta(bodies, bodies.velocity, bodies.angular_velocity, masses, inertias,
                            rots)[0]
            p1 = tc.momenta(bodies, v1, w1, masses, inertias, rots)[0]
            out['p'] = max(out['p'], np.abs(p1 - p0).max() / np.abs(p0).max())
    return {k: float(v) for k, v in out.items()}


def bounces() -> dict:
    """test_ball_bounces_to_e_squared_h: top - e^2 h (m) of the first two bounces, with and
    without speculative contacts, from the test's three heights."""
    r, e, dt = 0.1, 0.8, 1e-3
    out = {}
    for speculative in (True, False):
        errors = []
        for h in (1.0, 0.7313, 0.25):
            world = collision_world([tc.ball(radius=r, position=(0.0, 0.0, r + h))], dt, tc.G,
                                    planes=tc.GROUND, contact=ContactSettings(
                                        restitution=e, speculative=speculative))
            tops = tc.apexes(world, 'ball', int(4.2 * math.sqrt(2 * h / 9.81) / dt) + 50)
            previous = h
            for top in tops[:2]:
                errors.append((top - r) - e * e * previous)
                previous = top - r
        out['speculative' if speculative else 'discrete'] = [min(errors), max(errors)]
    return out


def resting_box(seconds: float) -> dict:
    """test_resting_box_stays_still_for_10_s."""
    world = collision_world([tc.cube('box', (0.4, 0.3, 0.2), (0.0, 0.0, 0.1), mass=3.0)], 1e-3,
                            tc.G, planes=tc.GROUND,
                            contact=ContactSettings(restitution=0.5, friction=0.5, sleep_time=0.0))
    start = world.state('box').position
    depth = speed = spin = 0.0
    iterations = set()
    for k in range(round(seconds * 1000)):
        world.step(1)
        depth = max([depth] + [c.depth for c in world.last_contacts()])
        st = world.state('box')
        speed = max(speed, float(np.abs(st.linear_velocity).max()))
        spin = max(spin, float(np.abs(st.angular_velocity).max()))
        if k >= 100:
            iterations.add(world.last_stats.velocity_iterations)
    st = world.state('box')
    return {'seconds': seconds, 'depth': depth, 'sank': float(start[2] - st.position[2]),
            'drift': float(np.abs(st.position[:2] - start[:2]).max()), 'speed': speed,
            'spin': spin, 'iterations': [min(iterations), max(iterations)]}


def stack(seconds: float) -> dict:
    """test_box_stack_of_three_stands_for_10_s."""
    size = (0.2, 0.2, 0.2)
    world = collision_world([tc.cube(f'box{i}', size, (0.0, 0.0, 0.1 + 0.2 * i))
                            for i in range(3)], 1e-3, tc.G, planes=tc.GROUND,
                            contact=ContactSettings(friction=0.5, sleep_time=0.0))
    start = [world.state(f'box{i}').position for i in range(3)]
    depth = speed = 0.0
    for k in range(round(seconds * 1000)):
        world.step(1)
        depth = max([depth] + [c.depth for c in world.last_contacts()])
        if k >= 1000:
            speed = max([speed] + [max(map(abs, world.steppers[f'box{i}'].pose_twist()[2]))
                                   for i in range(3)])
    states = [world.state(f'box{i}') for i in range(3)]
    return {'seconds': seconds, 'depth': depth, 'speed_after_1s': speed,
            'drift_x': [float(abs(s.position[0] - p[0])) for s, p in zip(states, start)],
            'drift_y': [float(abs(s.position[1] - p[1])) for s, p in zip(states, start)],
            'sank': [float(p[2] - s.position[2]) for s, p in zip(states, start)],
            'tilt_deg': [math.degrees(math.acos(min(1.0, s.rotation[2, 2]))) for s in states]}


def tumbling_box() -> dict:
    """test_tumbling_box_comes_to_rest_face_down: when the kinetic energy falls below 1e-9 J."""
    size = (0.3, 0.2, 0.1)
    spec = tc.cube('box', size, (0.0, 0.0, 0.5), mass=2.0, initial_orientation_xyzw=tuple(
        tc.so3.quaternion_xyzw_from_matrix(tc.so3.exp((0.4, 0.7, 0.2)))),
        initial_linear_velocity=(1.0, 0.3, 0.0), initial_angular_velocity=(3.0, -5.0, 8.0))
    world = collision_world([spec], 1e-3, tc.G, planes=tc.GROUND,
                            contact=ContactSettings(restitution=0.3, friction=0.6))
    body = spec.body()
    at_rest = None
    for k in range(3000):
        world.step(1)
        if world.state('box').kinetic_energy(body) < 1e-9:
            at_rest = at_rest if at_rest is not None else (k + 1) * 1e-3
        else:
            at_rest = None
    st = world.state('box')
    axis = int(np.argmax(np.abs(st.rotation[2])))
    return {'at_rest_s': at_rest, 'height_error': float(st.position[2] - size[axis] / 2)}


def sliding_box() -> dict:
    """test_sliding_box_stops_where_coulomb_says."""
    mu, v0 = 0.4, 2.0
    world = collision_world([tc.cube('box', (0.2, 0.2, 0.2), (0.0, 0.0, 0.1 - 1e-4),
                                     initial_linear_velocity=(v0, 0.0, 0.0))], 1e-3, tc.G,
                            planes=tc.GROUND, contact=ContactSettings(friction=mu))
    world.step(700)
    return {'stopped_at': float(world.state('box').position[0]),
            'coulomb': v0 ** 2 / (2 * mu * 9.81)}


def thin_wall(quick: bool) -> dict:
    """test_no_tunnelling_through_a_thin_wall's ball and wall, at more phases and speeds: the
    largest whole speed (m/s) at which every phase held without speculative contacts, and the
    speeds held with them."""
    phases = np.linspace(0.0, 1.0, 7 if quick else 21)[:-1]
    held = None
    for speed in range(50, 61):
        if all(tc.thin_wall_run(float(speed), False, p) < 0.0 for p in phases):
            held = speed
        else:
            break
    speeds = (54.0, 1000.0, 10000.0) if quick else (54.0, 250.0, 1000.0, 10000.0, 100000.0)
    fastest = max((s for s in speeds if all(tc.thin_wall_run(s, True, p) < 0.0
                                            for p in phases)), default=None)
    return {'phases': len(phases), 'discrete_held_up_to': held,
            'discrete_first_failure': None if held is None else held + 1,
            'speculative_speeds': list(speeds), 'speculative_held_up_to': fastest}


def mixed(quick: bool) -> dict:
    """test_mixed_scene_...: the largest rise of mechanical energy over 0.1 s steps, and
    whether a run in calls of 100 steps and one in calls of one step agree bit for bit."""
    worlds = [tc.mixed_scene(), tc.mixed_scene()]
    energy = [tc.mechanical_energy(worlds[0])]
    for _ in range(5 if quick else 15):
        worlds[0].step(100)
        for _ in range(100):
            worlds[1].step(1)
        energy.append(tc.mechanical_energy(worlds[0]))
    names = list(worlds[0].steppers)
    same = all(other.steppers[n].pose_twist() == worlds[0].steppers[n].pose_twist()
               for other in worlds[1:] for n in names)
    return {'largest_rise_J': max(b - a for a, b in zip(energy, energy[1:])),
            'energy_start_J': energy[0], 'energy_end_J': energy[-1], 'bit_identical': same}


def cells(m: dict) -> dict:
    """The "measured" cell of each row of the table, by test name."""
    i, f, b = m['impacts'], m['friction'], m['bounces']
    r, s, w = m['resting_box'], m['stack'], m['thin_wall']

    low, high = r['iterations']
    iterations = f'{low}' if low == high else f'{low}-{high}'

    def um(values):
        return ', '.join(f'{v * 1e6:.1f}' for v in values)

    return {
        'test_frictionless_impact_': (
            f'{i["cases"]:.0f} cases: linear momentum {i["p"]:.1e}, angular momentum about a '
            f'fixed point {i["L"]:.1e} (relative); energy change against (32) {i["E"]:.1e} of '
            f'E; normal velocity after + e before {i["vn"]:.1e} of it; j against (31) '
            f'{i["j"]:.1e}'),
        'test_impact_on_a_static_body_and_coulomb_friction': (
            f'{f["cases"]:.0f} cases ({f["sliding"]:.0f} sliding): linear momentum '
            f'{f["p"]:.1e}; |J_t| / (mu j_n) at most {f["cone"]:.12f}; sliding: opposite the '
            f'slip, cosine at least 1 - {1 - f["cosine"]:.0e}'),
        'test_ball_bounces_to_e_squared_h': (
            f'top - e^2 h: {b["speculative"][0] * 1e3:.2f} to {b["speculative"][1] * 1e3:.2f} '
            f'mm speculative, {b["discrete"][0] * 1e3:.2f} to {b["discrete"][1] * 1e3:.2f} mm '
            'discrete (h = 0.25 to 1 m)'),
        'test_resting_box_stays_still_for_10_s': (
            f'over {r["seconds"]:g} s: penetration {r["depth"] * 1e3:.4f} mm; centre sank '
            f'{r["sank"] * 1e3:.4f} mm; horizontal drift {r["drift"]:.1e} m; largest speed '
            f'{r["speed"]:.1e} m/s, spin {r["spin"]:.1e} rad/s; {iterations} velocity '
            'iteration(s) a step after the first 0.1 s'),
        'test_box_stack_of_three_stands_for_10_s': (
            f'over {s["seconds"]:g} s: drift {um(s["drift_x"])} um (x) and {um(s["drift_y"])} '
            f'um (y); sank {", ".join(f"{v * 1e3:.2f}" for v in s["sank"])} mm; tilt '
            f'{", ".join(f"{v:.1e}" for v in s["tilt_deg"])} degrees; penetration '
            f'{s["depth"] * 1e3:.3f} mm; largest speed after 1 s {s["speed_after_1s"]:.1e}'),
        'test_tumbling_box_comes_to_rest_face_down': (
            f'kinetic energy below 1e-9 J from {m["tumbling_box"]["at_rest_s"]:.3f} s on, face '
            f'down, height - half size {m["tumbling_box"]["height_error"] * 1e3:.3f} mm'),
        'test_sliding_box_stops_where_coulomb_says': (
            f'stops at {m["sliding_box"]["stopped_at"]:.4f} m, v0^2/(2 mu g) = '
            f'{m["sliding_box"]["coulomb"]:.4f} m'),
        'test_no_tunnelling_through_a_thin_wall': (
            f'discrete: all {w["phases"]} phases held up to {w["discrete_held_up_to"]} m/s, '
            f'some tunnelled at {w["discrete_first_failure"]} m/s ((r + w/2)/dt = 55 m/s); '
            f'speculative: all held at every speed tried, up to '
            f'{w["speculative_held_up_to"]:,.0f} m/s'),
        'test_mixed_scene_': (
            ('mechanical energy never rose (largest change over 0.1 s: '
             if m['mixed']['largest_rise_J'] <= 0.0 else 'mechanical energy rose by at most ('
             ) + f'{m["mixed"]["largest_rise_J"]:.1e} J; {m["mixed"]["energy_start_J"]:.2f} J '
            f'to {m["mixed"]["energy_end_J"]:.2f} J); runs in calls of 100 steps and of 1 step '
            f'{"bit-identical" if m["mixed"]["bit_identical"] else "DIFFER"}'),
    }


def sanity(m: dict) -> figures.Sanity:
    """The bounds the tests assert."""
    s = figures.Sanity()
    i, f, r, st = m['impacts'], m['friction'], m['resting_box'], m['stack']
    for key in ('p', 'L', 'E', 'vn', 'j'):
        s.within(f'impacts: {key}', i[key], 0.0, 1e-12)
    s.within('friction: cone', f['cone'], 0.0, 1 + 1e-12)
    s.within('friction: cosine', f['cosine'], 1 - 1e-9, 1.0 + 1e-12)
    s.within('resting box: penetration', r['depth'], 0.0, 1e-4 + 1e-5)
    s.within('resting box: drift', r['drift'], 0.0, 1e-6)
    s.within('resting box: speed', r['speed'], 0.0, 1e-5)
    s.within('stack: penetration', st['depth'], 0.0, 1e-4 + 1e-5)
    for v in st['drift_x'] + st['drift_y']:
        s.within('stack: horizontal drift', v, 0.0, 1e-4)
    s.within('tumbling box: at rest (s)', m['tumbling_box']['at_rest_s'], 0.0, 3.0)
    s.within('sliding box: stop - Coulomb', abs(m['sliding_box']['stopped_at']
                                                - m['sliding_box']['coulomb']), 0.0, 2e-3)
    s.within('thin wall: discrete held up to (m/s)', m['thin_wall']['discrete_held_up_to'],
             54, 249)
    s.within('thin wall: speculative held up to (m/s)',
             m['thin_wall']['speculative_held_up_to'], 1e4, 1e6)
    s.within('mixed scene: energy rise (J)', m['mixed']['largest_rise_J'], -1e9, 1e-3)
    s.true('mixed scene: runs in calls of 100 and of 1 step bit-identical',
           m['mixed']['bit_identical'])
    return s


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.collision_cases', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='1.2 s instead of 10 for the '
                        'resting box and the stack, 6 phases, fewer speeds (a few seconds)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/collision_cases.json; --quick: none)')
    opts = parser.parse_args()
    seconds = 1.2 if opts.quick else 10.0
    m = {'impacts': impacts(), 'friction': friction(), 'bounces': bounces(),
         'resting_box': resting_box(seconds), 'stack': stack(seconds),
         'tumbling_box': tumbling_box(), 'sliding_box': sliding_box(),
         'thin_wall': thin_wall(opts.quick), 'mixed': mixed(opts.quick)}
    m['cells'] = cells(m)
    for test, cell in m['cells'].items():
        print(f'{test}: {cell}')
    sane = sanity(m)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'collision_cases.json')
    if path:
        figures.write(path, {'quick': opts.quick, **m})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
