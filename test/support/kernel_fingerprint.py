# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Print a SHA-256 of the states of a few runs, one per case named on the command line, as
JSON: test_kernels.py runs it compiled and with NUMBA_DISABLE_JIT=1 and compares."""

import hashlib
import json
from pathlib import Path
import sys
import types

import numpy as np

from rb_sim_ros.contact.collision_shapes import Plane, Sphere
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3, step_kernel
from rb_sim_ros.core.batch import BatchStepper
from rb_sim_ros.core.rigid_body import Wrench
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.scene import load_scene
from rb_sim_ros.sim.simulation import BodySpec, Config, SetWrench, Simulation

SCENES = Path(__file__).resolve().parents[2] / 'scenes'


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()


def _batch_reads(batch) -> tuple:
    return (batch.positions(), batch.rotations(), batch.linear_velocities(),
            batch.angular_velocities())


def mixed_inertias(rng, n: int, isotropic_every: int) -> list:
    """n body-frame inertia tensors (kg m^2): principal moments in [0.5, 1], every
    ``isotropic_every``-th body isotropic, every second one about rotated axes."""
    inertias = []
    for k in range(n):
        moments = np.sort(rng.uniform(0.5, 1.0, 3))
        if k % isotropic_every == isotropic_every - 1:
            moments[:] = moments[0]
        q = so3.exp(rng.normal(size=3)) if k % 2 else np.eye(3)
        inertias.append(q @ np.diag(moments) @ q.T)
    return inertias


def batch() -> str:
    """1000 random bodies (diagonal, rotated and isotropic inertias; gravity, damping), with a
    start-up, wrench changes in both frames on a subset, and a few bodies past the 1024-step
    orthonormalisation."""
    rng = np.random.default_rng(3)
    n = 1000
    inertias = mixed_inertias(rng, n, 5)
    b = BatchStepper(rng.uniform(0.5, 3.0, n), np.array(inertias), 1e-3,
                     rng.normal(size=(n, 3)), [so3.exp(rng.normal(size=3)) for _ in range(n)],
                     rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 3.0,
                     gravity=(0.0, 0.0, -9.81), linear_damping=rng.uniform(0, 0.3, n),
                     angular_damping=0.1)
    b.set_wrench(None, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)),
                 ['world', 'body'] * (n // 2))
    b.step(1)
    b.step(4)
    b.set_wrench(np.arange(0, n, 3), rng.normal(size=3), rng.normal(size=3), 'body')
    b.step(10)
    out = [_batch_reads(b)]
    few = BatchStepper(np.ones(6), np.array(inertias[:6]), 1e-3,
                       angular_velocities=rng.normal(size=(6, 3)))
    few.set_wrench(None, torque=rng.normal(size=(6, 3)) * 0.1, frame='body')
    few.step(1100)
    out.append(_batch_reads(few))
    return _digest(*(a for reads in out for a in reads))


def _sim_digest(sim, names) -> str:
    parts = []
    for name in names:
        parts.extend(sim.pose_twist(name))
    return _digest(*parts)


def demo() -> str:
    """The collision demo scene, 1.5 s of it (the bodies fall, hit and roll), with a wrench
    on the crate half way."""
    gravity, bodies, contact = load_scene(str(SCENES / 'collisions.yaml'))[:3]
    sim = Simulation(Config(gravity=gravity, bodies=tuple(bodies), contact=contact))
    sim.run(750)
    sim.apply(SetWrench(Wrench(force=(3.0, 0.0, 0.0), torque=(0.0, 0.0, 0.5)), 'crate'))
    sim.run(750)
    return _sim_digest(sim, [b.name for b in bodies])


def heap() -> str:
    """1000 spheres on a lattice in a box, falling: a few steps."""
    radius, side = 0.05, 10
    rng = np.random.default_rng(0)
    pitch = 2 * radius + 0.01
    specs = []
    for k in range(1000):
        i, j, layer = k % side, (k // side) % side, k // (side * side)
        specs.append(BodySpec(f's{k}', 0.1, (0.4 * 0.1 * radius * radius,) * 3,
                              initial_position=((i - 4.5) * pitch, (j - 4.5) * pitch,
                                                radius + 0.005 + layer * pitch),
                              initial_linear_velocity=tuple(rng.normal(size=3) * 0.5),
                              colliders=(Sphere(radius),)))
    half = side * pitch / 2 + 2 * radius
    planes = (Plane((0.0, 0.0, 1.0), 0.0), Plane((1.0, 0.0, 0.0), -half),
              Plane((-1.0, 0.0, 0.0), -half), Plane((0.0, 1.0, 0.0), -half),
              Plane((0.0, -1.0, 0.0), -half))
    world = collision_world(specs, 1e-3, (0.0, 0.0, -9.81),
                            planes=planes, contact=ContactSettings(restitution=0.2, friction=0.5))
    world.step(3)
    states = [world.state(s.name) for s in specs]
    return _digest(*(np.concatenate([st.position, st.rotation.reshape(9), st.linear_velocity,
                                     st.angular_velocity]) for st in states))


def high_order() -> str:
    """lie3, lie4, flow2 and flow4: 200 batch bodies with start-up, wrench changes in both
    frames and a rotated inertia, and the collision demo on lie4 and on flow4 for 0.6 s
    (contacts restart histories and invariants)."""
    rng = np.random.default_rng(5)
    n = 200
    out = []
    for method in ('lie3', 'lie4', 'flow2', 'flow4'):
        inertias = [np.diag(np.sort(rng.uniform(0.5, 1.0, 3))) for _ in range(n)]
        q = so3.exp(rng.normal(size=3))
        inertias[1] = q @ inertias[1] @ q.T
        flow = method.startswith('flow')
        b = BatchStepper(rng.uniform(0.5, 3.0, n), np.array(inertias), 1e-3,
                         rng.normal(size=(n, 3)), [so3.exp(rng.normal(size=3)) for _ in range(n)],
                         rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 3.0,
                         gravity=(0.0, 0.0, -9.81), method=method,
                         angular_damping=0.0 if flow else 0.1)
        b.step(3)
        # the flows: half the bodies stay torque-free (their polhode kept between steps)
        torqued = np.arange(0, n // 2 if flow else n)
        b.set_wrench(torqued, rng.normal(size=(len(torqued), 3)),
                     rng.normal(size=(len(torqued), 3)), ['world', 'body'] * (len(torqued) // 2))
        b.step(20)
        out.extend(_batch_reads(b))
    gravity, bodies, contact = load_scene(str(SCENES / 'collisions.yaml'))[:3]
    digest = _digest(*out)
    for method in ('lie4', 'flow4'):
        sim = Simulation(Config(gravity=gravity, bodies=tuple(bodies), contact=contact,
                                integrator=method))
        sim.run(600)
        digest += _sim_digest(sim, [b.name for b in bodies])
    return digest


CASES = {'batch': batch, 'demo': demo, 'heap': heap, 'high_order': high_order}

if __name__ == '__main__':
    out = {name: CASES[name]() for name in sys.argv[1:]}
    out['compiled'] = not isinstance(step_kernel.advance_bodies_two, types.FunctionType)
    print(json.dumps(out))
