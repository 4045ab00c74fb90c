# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""N free bodies at once: rb_sim_ros's batch path against MuJoCo with the same bodies.

    python bench/batch_bench.py [--quick] [--json out.json]

First checks that the batch path agrees with single-body Steppers (to 1e-12) and that MuJoCo's
bodies agree with ours to its own accuracy; then times ns per body-step at N = 1, 100, 10,000,
100,000 (MuJoCo: N free joints, gravity and contacts off, Euler and RK4, mj_step with nstep),
and the memory per body of both.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import time
import tracemalloc

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from rb_sim_ros import RigidBody, so3, State, Stepper  # noqa: E402
from rb_sim_ros.batch import BatchStepper  # noqa: E402

DT = 1e-3
# MuJoCo refuses models of 65,534 bodies or more, and compiling 20,000 free bodies from XML
# takes about 90 s here: past that, its (flat) per-body cost is measured at this N.
MUJOCO_MAX_N = 20_000


def bodies(n, seed=0):
    rng = np.random.default_rng(seed)
    moments = np.sort(rng.uniform(0.5, 1.0, (n, 3)), axis=1)
    return rng.uniform(0.5, 2.0, n), moments, rng.normal(size=(n, 3)) * 2.0


def n_mb(n: int) -> int:
    """MuJoCo's arena for n free bodies (its default is too small past a few thousand)."""
    return n // 20


def mujoco_model(masses, moments, omega, integrator):
    parts = [f'<mujoco><size memory="{max(64, n_mb(len(masses)))}M"/>'
             f'<option timestep="{DT}" integrator="{integrator}" gravity="0 0 0">'
             '<flag contact="disable"/></option><worldbody>']
    for m, (a, b, c) in zip(masses, moments):
        parts.append(f'<body><freejoint/><inertial pos="0 0 0" mass="{float(m)!r}" '
                     f'diaginertia="{float(a)!r} {float(b)!r} {float(c)!r}"/></body>')
    parts.append('</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(''.join(parts))
    data = mujoco.MjData(model)
    data.qvel.reshape(-1, 6)[:, 3:] = omega  # body frame = world frame at R = I
    return model, data


def check(n=20, steps=500) -> dict:
    masses, moments, omega = bodies(n, seed=1)
    batch = BatchStepper(masses, moments, DT, angular_velocities=omega)
    batch.step(steps)
    worst = 0.0
    for k in range(n):
        s = Stepper(RigidBody(masses[k], moments[k]), DT, State(angular_velocity=omega[k]))
        s.step(steps)
        worst = max(worst, float(np.max(np.abs(batch.rotations()[k] - s.state.rotation))))
    if worst > 1e-12:
        raise SystemExit(f'batch and single-body paths differ by {worst:.3g}')
    model, data = mujoco_model(masses, moments, omega, 'RK4')
    mujoco.mj_step(model, data, nstep=steps)
    q = data.qpos.reshape(-1, 7)[:, 3:]  # free joint: position, then quaternion w x y z
    mj_rot = np.array([so3.matrix_from_quaternion_xyzw((x, y, z, w)) for w, x, y, z in q])
    agree = max(so3.angle_between(a, b) for a, b in zip(mj_rot, batch.rotations()))
    if agree > 1e-4:
        raise SystemExit(f'MuJoCo and rb_sim_ros disagree by {agree:.3g} rad')
    return {'batch_vs_single': worst, 'mujoco_rk4_vs_ours_rad': agree}


def time_ours(n, steps, repeats) -> float:
    masses, moments, omega = bodies(n)
    batch = BatchStepper(masses, moments, DT, angular_velocities=omega)
    batch.step(2)
    best = float('inf')
    for _ in range(repeats):
        t = time.perf_counter()
        batch.step(steps)
        best = min(best, time.perf_counter() - t)
    return best / (steps * n) * 1e9


def time_mujoco(n, steps, repeats, integrators) -> dict:
    """ns per body-step for each integrator; the model is compiled once (at N = 1e5 that
    takes minutes) and its integrator switched."""
    masses, moments, omega = bodies(n)
    model, data = mujoco_model(masses, moments, omega, 'Euler')
    out = {}
    for name in integrators:
        model.opt.integrator = getattr(mujoco.mjtIntegrator, f'mjINT_{name.upper()}')
        mujoco.mj_resetData(model, data)
        data.qvel.reshape(-1, 6)[:, 3:] = omega
        best = float('inf')
        for _ in range(repeats):
            t = time.perf_counter()
            mujoco.mj_step(model, data, nstep=steps)
            best = min(best, time.perf_counter() - t)
        out[name] = best / (steps * n) * 1e9
    return out


def memory_per_body(n) -> tuple[float, float]:
    masses, moments, omega = bodies(n)
    tracemalloc.start()
    batch = BatchStepper(masses, moments, DT, angular_velocities=omega)
    batch.step(5)
    ours = tracemalloc.get_traced_memory()[1] / n
    tracemalloc.stop()
    model, data = mujoco_model(masses, moments, omega, 'Euler')
    theirs = (model.nbuffer + data.nbuffer) / n
    del batch
    return ours, theirs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--json', help='write the figures here too')
    opts = parser.parse_args()
    out = {'check': check()}
    sizes = [1, 100, 10_000] if opts.quick else [1, 100, 10_000, 100_000]
    rows = []
    for n in sizes:
        steps = max(2, min(2000, 2_000_000 // n)) if not opts.quick else max(2, 20_000 // n)
        repeats = 2 if opts.quick else 3
        mj_n = min(n, MUJOCO_MAX_N)
        mj = time_mujoco(mj_n, steps, repeats, ('Euler', 'RK4'))
        rows.append({'n': n, 'rb_sim_ros_batch_ns': time_ours(n, steps, repeats),
                     'mujoco_n': mj_n, 'mujoco_euler_ns': mj['Euler'], 'mujoco_rk4_ns': mj['RK4']})
        r = rows[-1]
        note = f' (MuJoCo at N = {mj_n})' if mj_n != n else ''
        print(f'N = {n:>7}: rb_sim_ros batch {r["rb_sim_ros_batch_ns"]:8.1f} ns/body-step, '
              f'MuJoCo Euler {r["mujoco_euler_ns"]:8.1f}, RK4 {r["mujoco_rk4_ns"]:8.1f}{note}',
              flush=True)
    out['rows'] = rows
    ours, theirs = memory_per_body(10_000)
    out['memory_bytes_per_body'] = {'rb_sim_ros_batch_peak': ours, 'mujoco_buffers': theirs}
    print(f'memory per body (N = 10,000): rb_sim_ros batch peak {ours:.0f} B, MuJoCo model + '
          f'data buffers {theirs:.0f} B; agreement: {out["check"]}')
    if opts.json:
        Path(opts.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == '__main__':
    sys.exit(main())
