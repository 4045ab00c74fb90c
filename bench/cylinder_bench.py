# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A cylinder in contact, per step: rb_sim_ros's convex narrow phase next to MuJoCo's, same
scene, one run.

    python -m bench.cylinder_bench [--quick] [--json out.json]

The scenes, each moving (or pressed, awake) the whole time it is timed:

* ``rolling cylinder``: a cylinder (r = 0.1 m, 0.3 m long, 1 kg) rolling down a 20 degree
  incline from rest, mu = 0.5: a = 2/3 g sin(20 deg) (GJK-free: the plane test);
* ``tipping cylinder``: standing, tipped 0.3 rad: it rocks back onto its cap (the plane);
* ``cylinder on a box``: standing on a 1 m static box, dropped 1 cm (cylinder-box: GJK,
  EPA and the clipped faces every step);
* ``crossed cylinders``: one lying across another that lies on the ground (cylinder-cylinder,
  curved on curved: EPA).

Checks first (exit 1 if one fails), for both engines: rolling acceleration within 2%, the
tipped one upright on its cap, the others resting where their heights say (1 mm). Then the
time per step (median over a run's calls, best of the repeats) at one step a call and ten
(``step(10)``, ``mj_step(m, d, 10)``), MuJoCo with its default Newton solver, dt = 1 ms,
no sleeping on either side; ratios ours / MuJoCo.

Writes docs/bench/cylinder_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import math
import sys

import numpy as np

from bench.contact_step_bench import scenes_main
from rb_sim_ros.contact.collision_shapes import Box, Cylinder, Plane
from rb_sim_ros.core import so3
from rb_sim_ros.sim.scene import mass_and_inertia
from rb_sim_ros.sim.simulation import BodySpec

DT = 1e-3
G = 9.81
SLOPE = math.radians(20.0)
R, LENGTH = 0.1, 0.3


def _quat(rotation) -> tuple:
    return tuple(float(c) for c in so3.quaternion_xyzw_from_matrix(rotation))


def _mj_quat(q) -> str:
    return f'{q[3]:.17g} {q[0]:.17g} {q[1]:.17g} {q[2]:.17g}'


def scenes() -> dict:
    """name -> (bodies, planes, restitution, friction, MuJoCo XML, steps, {}): the form
    ``contact_step_bench.ours`` and ``theirs`` take."""
    m = 1.0
    _, moments = mass_and_inertia('cylinder', m / (math.pi * R * R * LENGTH),
                                  {'radius': R, 'length': LENGTH})
    n = (-math.sin(SLOPE), 0.0, math.cos(SLOPE))
    lying = so3.exp((math.pi / 2, 0.0, 0.0))          # its axis along y, across the slope
    across = so3.exp((0.0, math.pi / 2, 0.0))         # its axis along x
    tipped = so3.exp((0.3, 0.0, 0.0))
    geom = (f'<geom type="cylinder" size="{R} {LENGTH / 2}" mass="{m}" '
            'friction="0.5 0.005 0.0001"/>')
    ground = '<geom type="plane" size="50 50 0.1" friction="0.5 0.005 0.0001"/>'

    def xml(world, *bodies):
        body = ''.join(f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" quat="{_mj_quat(q)}">'
                       f'<freejoint/>{geom}</body>' for p, q in bodies)
        return (f'<mujoco><option timestep="{DT}" gravity="0 0 {-G}"/>'
                f'<worldbody>{world}{body}</worldbody></mujoco>')

    def can(name, position, rotation):
        return BodySpec(name, m, moments, initial_position=tuple(position),
                        initial_orientation_xyzw=_quat(rotation), colliders=(Cylinder(R, LENGTH),))

    start = R * np.array(n)
    incline = ('<geom type="plane" size="50 50 0.1" friction="0.5 0.005 0.0001" '
               f'zaxis="{n[0]:.17g} {n[1]:.17g} {n[2]:.17g}"/>')
    up = (0.0, 0.0, LENGTH / 2 + 0.001 + R * math.sin(0.3))
    on_box = (0.0, 0.0, 1.0 + LENGTH / 2 + 0.01)
    box = BodySpec('box', 1.0, (1.0, 1.0, 1.0), static=True, initial_position=(0.0, 0.0, 0.5),
                   colliders=(Box((1.0, 1.0, 1.0)),))
    low, high = (0.0, 0.0, R), (0.0, 0.0, 3 * R + 0.005)
    return {
        'rolling cylinder': (
            [can('b', start, lying)], (Plane(n, 0.0),), 0.0, 0.5,
            xml(incline, (start, _quat(lying))), 500, {}),
        'tipping cylinder': (
            [can('b', up, tipped)], (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(ground, (up, _quat(tipped))), 1500, {}),
        'cylinder on a box': (
            [box, can('b', on_box, np.eye(3))], (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(ground + '<geom type="box" size="0.5 0.5 0.5" pos="0 0 0.5" '
                'friction="0.5 0.005 0.0001"/>', (on_box, _quat(np.eye(3)))), 1000, {}),
        'crossed cylinders': (
            [can('a', low, lying), can('b', high, across)], (Plane((0, 0, 1), 0.0),), 0.0, 0.5,
            xml(ground, (low, _quat(lying)), (high, _quat(across))), 1000, {}),
    }


def check(name: str, world, data, scene) -> list[str]:
    """Each scene's outcome (module doc), for both engines (MuJoCo's body 'b' is its last)."""
    st = world.state('b')
    x = np.array(st.position)
    qx = np.array(data.qpos[-7:-4])
    qr = so3.matrix_from_quaternion_xyzw((*data.qpos[-3:], data.qpos[-4]))
    problems = []
    if name == 'rolling cylinder':
        t = world.time
        expect = 0.5 * 2.0 / 3.0 * G * math.sin(SLOPE) * t * t
        along = np.array([math.cos(SLOPE), 0.0, math.sin(SLOPE)])
        start = R * np.array([-math.sin(SLOPE), 0.0, math.cos(SLOPE)])
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            moved = -float((xx - start) @ along)
            if abs(moved - expect) > 0.02 * expect:
                problems.append(f'{who}: rolled {moved:.4f} m, expected {expect:.4f}')
    elif name == 'tipping cylinder':
        for who, xx, r in (('rb_sim_ros', x, st.rotation), ('MuJoCo', qx, qr)):
            if abs(xx[2] - LENGTH / 2) > 1e-3 or abs(r[2, 2]) < 0.999:
                problems.append(f'{who}: at {xx[2]:.4f} m, axis z {r[2, 2]:.4f}: not upright')
    else:
        rest = 1.0 + LENGTH / 2 if name == 'cylinder on a box' else 3 * R
        for who, xx in (('rb_sim_ros', x), ('MuJoCo', qx)):
            if abs(xx[2] - rest) > 1e-3:
                problems.append(f'{who}: at {xx[2]:.4f} m, expected {rest:.4f}')
    return problems


def main() -> int:
    return scenes_main('cylinder_bench', __doc__, scenes(), check, 'cylinder_bench.json')


if __name__ == '__main__':
    sys.exit(main())
