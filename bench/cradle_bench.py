# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Newton's cradle: an impact passed down a row of touching balls, rb_sim_ros beside MuJoCo,
same scene, one run.

    python -m bench.cradle_bench [--quick] [--json out.json]

A ball (r = 5 cm, 0.2 kg) at 1 m/s meets, from 2 cm away, the first of a row of 1, 2 or 4
equal balls touching along its path: no gravity, no friction, e = 1, dt = 1 ms, 300 steps.
The ideal sequence of pairwise collisions leaves the last ball with 1 m/s and the others at
rest: (0, ..., 0, 1). Printed: each engine's final velocities along the row, the largest
difference from the ideal (m/s), and the change of momentum and kinetic energy (relative).
MuJoCo has no restitution: its elastic setting is a soft contact with negative ``solref``
(stiffness 1e6, no damping), as its documentation gives for bouncing; its default contact
(``solref`` 0.02 1, critically damped) is shown too. PyBullet (restitution 1, no bounce
threshold) and Drake (a discrete MultibodyPlant, compliant point contact without dissipation)
when installed (requirements-peers.txt).

Writes docs/bench/cradle_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import numpy as np

from bench import figures
from bench.peers import quiet_mujoco
from rb_sim_ros.contact.collision_shapes import Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

R, MASS, V0, GAP, DT, STEPS = 0.05, 0.2, 1.0, 0.02, 1e-3, 300
# Drake's point contact stiffness (N/m): what its default makes of a ball's weight and its
# penetration allowance (1 mm), m g / 1 mm (with no gravity here it would make none); a contact
# then lasts pi sqrt(m / 2k) = 22 ms. Its discrete solvers dissipate more, the stiffer (at
# 1e6 N/m two balls part at (0.44, 0.56) m/s).
DRAKE_STIFFNESS = MASS * 9.81 / 1e-3
INERTIA = 0.4 * MASS * R * R


def _starts(count: int) -> list[float]:
    """x of the cue ball and of ``count`` touching ones."""
    return [-2 * R - GAP] + [2 * R * i for i in range(count)]


def ours(count: int) -> dict:
    xs = _starts(count)
    bodies = [BodySpec(f'b{i}', MASS, (INERTIA,) * 3, initial_position=(x, 0.0, 0.0),
                       initial_linear_velocity=(V0 if i == 0 else 0.0, 0.0, 0.0),
                       colliders=(Sphere(R),)) for i, x in enumerate(xs)]
    world = collision_world(bodies, DT, (0.0, 0.0, 0.0), contact=ContactSettings(
        restitution=1.0, friction=0.0, sleep_time=0.0))
    start = time.perf_counter()
    world.step(STEPS)
    seconds = time.perf_counter() - start
    v = np.array([world.state(f'b{i}').linear_velocity for i in range(len(xs))])
    w = np.array([world.state(f'b{i}').angular_velocity for i in range(len(xs))])
    return _row(v, w, seconds)


def mujoco_run(count: int, solref: str) -> dict:
    import mujoco
    quiet_mujoco()
    bodies = ''.join(
        f'<body pos="{x!r} 0 0"><freejoint/><geom type="sphere" size="{R}" mass="{MASS}"/>'
        '</body>' for x in _starts(count))
    xml = (f'<mujoco><option timestep="{DT}" gravity="0 0 0"/><default><geom friction="0 0 0" '
           f'condim="1" solref="{solref}"/></default><worldbody>{bodies}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qvel[0] = V0
    start = time.perf_counter()
    mujoco.mj_step(model, data, STEPS)
    seconds = time.perf_counter() - start
    qvel = np.array(data.qvel).reshape(-1, 6)
    return _row(qvel[:, :3], qvel[:, 3:], seconds)


def pybullet_run(count: int) -> dict:
    """PyBullet (Bullet's sequential impulses, as its users run it: stepSimulation in C), the
    balls' restitution 1, no friction or damping, no bounce threshold."""
    import pybullet as pb
    client = pb.connect(pb.DIRECT)
    try:
        pb.setGravity(0.0, 0.0, 0.0, physicsClientId=client)
        pb.setPhysicsEngineParameter(fixedTimeStep=DT, restitutionVelocityThreshold=0.0,
                                     physicsClientId=client)
        shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=R, physicsClientId=client)
        ids = []
        for x in _starts(count):
            body = pb.createMultiBody(MASS, shape, basePosition=(x, 0.0, 0.0),
                                      physicsClientId=client)
            pb.changeDynamics(body, -1, restitution=1.0, lateralFriction=0.0,
                              spinningFriction=0.0, rollingFriction=0.0, linearDamping=0.0,
                              angularDamping=0.0, physicsClientId=client)
            ids.append(body)
        pb.resetBaseVelocity(ids[0], (V0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=client)
        start = time.perf_counter()
        for _ in range(STEPS):
            pb.stepSimulation(physicsClientId=client)
        seconds = time.perf_counter() - start
        vel = [pb.getBaseVelocity(b, physicsClientId=client) for b in ids]
    finally:
        pb.disconnect(client)
    return _row(np.array([v for v, _ in vel]), np.array([w for _, w in vel]), seconds)


def drake_run(count: int) -> dict:
    """Drake's MultibodyPlant, discrete at dt with its default contact solver (compliant
    point contact), no Hunt-Crossley dissipation (elastic), no friction, no gravity."""
    from pydrake.geometry import AddContactMaterial, ProximityProperties, Sphere as DSphere
    from pydrake.math import RigidTransform
    from pydrake.multibody.math import SpatialVelocity
    from pydrake.multibody.plant import (AddMultibodyPlantSceneGraph, CoulombFriction,
                                         DiscreteContactApproximation)
    from pydrake.multibody.tree import SpatialInertia
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=DT)
    plant.set_discrete_contact_approximation(DiscreteContactApproximation.kTamsi)
    bodies = []
    for i in range(len(_starts(count))):
        body = plant.AddRigidBody(f'b{i}', SpatialInertia.SolidSphereWithMass(MASS, R))
        props = ProximityProperties()
        AddContactMaterial(dissipation=0.0, point_stiffness=DRAKE_STIFFNESS,
                           friction=CoulombFriction(0.0, 0.0), properties=props)
        plant.RegisterCollisionGeometry(body, RigidTransform(), DSphere(R), f'c{i}', props)
        bodies.append(body)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    for body, x in zip(bodies, _starts(count)):
        plant.SetFreeBodyPose(context, body, RigidTransform([x, 0.0, 0.0]))
    plant.SetFreeBodySpatialVelocity(context, bodies[0],
                                     SpatialVelocity([0.0, 0.0, 0.0], [V0, 0.0, 0.0]))
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(STEPS * DT)
    seconds = time.perf_counter() - start
    vel = [plant.EvalBodySpatialVelocityInWorld(context, b) for b in bodies]
    return _row(np.array([v.translational() for v in vel]),
                np.array([v.rotational() for v in vel]), seconds)


def _installed(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def _row(v: np.ndarray, w: np.ndarray, seconds: float) -> dict:
    ideal = np.zeros(len(v))
    ideal[-1] = V0
    p0, e0 = MASS * V0, 0.5 * MASS * V0 * V0
    p = MASS * v.sum(axis=0)
    e = 0.5 * MASS * float((v * v).sum()) + 0.5 * INERTIA * float((w * w).sum())
    return {'velocities': v[:, 0].tolist(), 'error': float(np.abs(v[:, 0] - ideal).max()),
            'momentum_change': float(np.linalg.norm(p - np.array([p0, 0.0, 0.0])) / p0),
            'energy_change': (e - e0) / e0, 'seconds_per_step': seconds / STEPS}


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.cradle_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='the cradle of 3 only')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/cradle_bench.json; --quick: none)')
    opts = parser.parse_args()
    counts = (2,) if opts.quick else (1, 2, 4)
    engines = (('rb_sim_ros', ours),
               ('MuJoCo, elastic (solref -1e6 -1e-6)', lambda n: mujoco_run(n, '-1e6 -1e-6')),
               ('MuJoCo, default (solref 0.02 1)', lambda n: mujoco_run(n, '0.02 1')))
    missing = []
    for module, name, run in (('pybullet', 'PyBullet', pybullet_run),
                              ('pydrake', 'Drake (point contact, no dissipation)', drake_run)):
        if _installed(module):
            engines += ((name, run),)
        else:
            missing.append(module)
    if missing:
        print(f"not installed, not run: {', '.join(missing)} (pip install -r "
              'requirements-peers.txt)')
    ours(1)  # (compiled before anything is timed)
    rows: dict = {}
    print('| balls | engine | final velocities along the row (m/s) | largest error (m/s) | '
          'momentum change | energy change |\n| ---: | --- | --- | ---: | ---: | ---: |')
    for count in counts:
        for name, run in engines:
            r = run(count)
            rows.setdefault(str(count + 1), {})[name] = r
            print(f'| {count + 1} | {name} | '
                  f'({", ".join(f"{x:.3f}" for x in r["velocities"])}) | {r["error"]:.3f} | '
                  f'{r["momentum_change"]:.1e} | {r["energy_change"]:+.1e} |')
    s = figures.Sanity()
    for balls, by in rows.items():
        mine = by['rb_sim_ros']
        s.within(f'cradle of {balls}: ours, largest error (m/s)', mine['error'], 0.0, 0.02 * V0)
        s.within(f'cradle of {balls}: ours, momentum change', mine['momentum_change'], 0.0, 1e-12)
        s.within(f'cradle of {balls}: ours, energy change', abs(mine['energy_change']), 0.0,
                 1e-9)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'cradle_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, 'steps': STEPS, 'dt': DT, 'cradles': rows})
    return s.report()


if __name__ == '__main__':
    sys.exit(main())
