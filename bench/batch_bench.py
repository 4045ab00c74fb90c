# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""N free rigid bodies at once: rb_sim_ros's BatchStepper next to MuJoCo, same bodies, one run.

    python -m bench.batch_bench [--quick] [--sizes 1 100 10000 100000] [--json out.json]

First the checks, which stop the run (exit 1) if they fail:

* the batch path against N single-body Steppers (random bodies with full inertia tensors,
  random states, a world force and a body torque, a change of wrench mid-run, 1500 steps):
  agreement to 1e-12;
* the batch path and MuJoCo (Euler, RK4) against a DOP853 reference (rtol 1e-13) for a few
  free bodies over 1 s at dt and dt/2: each error, and the order it falls at, must be its
  method's (2 for ours, 1 for Euler, 4 for RK4), which also shows that MuJoCo is given the
  same bodies (mass, full inertia tensor, orientation, omega).

Then ns per body-step at each N, the minimum over repeats of a block of steps: the batch path
on free bodies (no wrench; several steps per call on every core and on one thread, and one
step per call as a node would step), the batch path under a held world wrench, and MuJoCo's
mj_step on the same free bodies (free joints, full inertia tensors, gravity 0, contacts
disabled, no geoms), each copy stepped a block in one call (``nstep``), with its Euler and RK4
integrators on one thread, and Euler on every core (Python threads sharing the copies; mj_step
releases the GIL). Ratios compare like with like: one thread against one, every core against
every core.
MuJoCo's model compiler is quadratic in the number of free joints (``engine_setconst.c``
forms a Jacobian over all nv dofs for every body: 10,000 bodies take about 35 s here, so
100,000 would take about an hour), so above ``--single-model-max`` bodies MuJoCo steps
N / tile copies (MjData) of a ``--tile``-body model, all of them at every step, as one model
of N bodies would. The full run also times one 10,000-body model against its tiles.

Last, memory per body: the batch's arrays (``BatchStepper.nbytes``, allocated once) and the
peak traced while stepping; MuJoCo's model and data buffers (its arena sized for RK4).

Writes docs/bench/batch_bench.json (or ``--json``; ``--quick`` writes none unless asked).
Sanity, after the timings (exit 1 if it fails; plausibility, not budgets): every figure finite
and positive, ns per body-step between 1 and 1e6, the ratios MuJoCo / batch within 0.01-1000,
bytes per body between 100 B and 100 kB.
"""

from __future__ import annotations

import argparse
from concurrent.futures import ThreadPoolExecutor
import math
from pathlib import Path
import platform
import sys
import time
import tracemalloc

import mujoco
import numba
import numpy as np
from scipy.integrate import solve_ivp

from bench import figures
from rb_sim_ros import RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3
from rb_sim_ros.core.batch import BatchStepper

DT = 1e-3
CORES = numba.config.NUMBA_NUM_THREADS  # numba's default: every core


def bodies(n: int, seed: int = 0) -> dict:
    """Random free bodies: mass (kg), full inertia tensors (kg m^2, body frame: principal
    moments in [0.5, 1] about random axes), orientation, omega (rad/s) and v (m/s), world."""
    rng = np.random.default_rng(seed)
    moments = np.sort(rng.uniform(0.5, 1.0, (n, 3)), axis=1)
    axes = _rotations(rng, n)
    return {'masses': rng.uniform(0.5, 2.0, n),
            'inertias': axes @ (moments[:, :, None] * np.eye(3)) @ axes.transpose(0, 2, 1),
            'rotations': _rotations(rng, n), 'angular_velocities': rng.normal(size=(n, 3)) * 2.0,
            'linear_velocities': rng.normal(size=(n, 3)), 'positions': rng.normal(size=(n, 3))}


def _rotations(rng, n):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                     2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                     2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
                    axis=1).reshape(n, 3, 3)


def _batch(b: dict, dt: float = DT) -> BatchStepper:
    return BatchStepper(b['masses'], b['inertias'], dt, b['positions'], b['rotations'],
                        b['linear_velocities'], b['angular_velocities'])


# -- MuJoCo ------------------------------------------------------------------------------------
def mujoco_model(b: dict, dt: float = DT, integrator: str = 'Euler') -> mujoco.MjModel:
    """Free bodies with b's masses and full inertia tensors (about the centre of mass, body
    frame), no geoms, gravity 0, contacts disabled; the arena sized for RK4."""
    n = len(b['masses'])
    parts = [f'<mujoco><size memory="{max(1024, n)}K"/>'
             f'<option timestep="{dt!r}" integrator="{integrator}" gravity="0 0 0">'
             '<flag contact="disable"/></option><worldbody>']
    for m, i in zip(b['masses'], b['inertias']):
        full = ' '.join(repr(float(c)) for c in (i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2],
                                                 i[1, 2]))
        parts.append(f'<body><freejoint/><inertial pos="0 0 0" mass="{float(m)!r}" '
                     f'fullinertia="{full}"/></body>')
    parts.append('</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(''.join(parts))
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    return model


def mujoco_data(model: mujoco.MjModel, b: dict) -> mujoco.MjData:
    """MjData at b's state: a free joint holds (x, quaternion w x y z) and (v world, omega in
    the body frame)."""
    data = mujoco.MjData(model)
    qpos, qvel = data.qpos.reshape(-1, 7), data.qvel.reshape(-1, 6)
    qpos[:, 0:3] = b['positions']
    qpos[:, 3:7] = _quaternions_wxyz(b['rotations'])
    qvel[:, 0:3] = b['linear_velocities']
    qvel[:, 3:6] = np.einsum('kji,kj->ki', b['rotations'], b['angular_velocities'])
    mujoco.mj_forward(model, data)
    return data


def _quaternions_wxyz(rot):
    return np.array([np.roll(so3.quaternion_xyzw_from_matrix(r), 1) for r in rot])


def mujoco_state(data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """(rotations, omega in the world frame)."""
    q = data.qpos.reshape(-1, 7)[:, 3:7]
    rot = np.array([so3.matrix_from_quaternion_xyzw(np.roll(c, -1)) for c in q])
    return rot, np.einsum('kij,kj->ki', rot, data.qvel.reshape(-1, 6)[:, 3:6])


# -- checks --------------------------------------------------------------------------------------
def check_against_steppers(n: int = 16, steps: int = 1500) -> float:
    b = bodies(n, seed=1)
    batch = _batch(b)
    singles = [Stepper(RigidBody(m, i), DT, State(x, r, v, w)) for m, i, x, r, v, w in zip(
        b['masses'], b['inertias'], b['positions'], b['rotations'], b['linear_velocities'],
        b['angular_velocities'])]
    rng = np.random.default_rng(2)
    worst = 0.0
    for part in range(2):  # a change of wrench half way
        force, torque = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
        batch.set_wrench(None, force, 0.0 * force, 'world')
        batch.set_wrench(range(n // 2), force[:n // 2], torque[:n // 2], 'body')
        for k, s in enumerate(singles):
            s.set_wrench(Wrench(force[k], torque[k] if k < n // 2 else (0, 0, 0),
                                'body' if k < n // 2 else 'world'))
            s.step(steps // 2)
        batch.step(steps // 2)
        states = [s.state for s in singles]
        worst = max(worst, float(np.max(np.abs(batch.rotations() - [s.rotation for s in states]))),
                    float(np.max(np.abs(batch.angular_velocities()
                                        - [s.angular_velocity for s in states]))),
                    float(np.max(np.abs(batch.positions() - [s.position for s in states]))))
    return worst


def _reference(b: dict, t_end: float):
    """DOP853 on eq. (10) in the world frame (I = R I_body R^T solved with numpy)."""
    out = []
    for m, inertia, rot, w in zip(b['masses'], b['inertias'], b['rotations'],
                                  b['angular_velocities']):
        def f(_t, y, inertia=inertia):
            r, om = y[0:9].reshape(3, 3), y[9:12]
            iw = r @ inertia @ r.T
            beta = np.linalg.solve(iw, -np.cross(om, iw @ om))
            return np.concatenate([(so3.hat(om) @ r).reshape(9), beta])
        y = solve_ivp(f, (0.0, t_end), np.concatenate([rot.reshape(9), w]), method='DOP853',
                      rtol=1e-13, atol=1e-14).y[:, -1]
        out.append((so3.orthonormalize(y[0:9].reshape(3, 3)), y[9:12]))
    return out


def check_against_reference(n: int = 4, t_end: float = 1.0) -> dict:
    """Errors (rad and rad/s, worst body) at dt and dt/2 and the order between them."""
    b = bodies(n, seed=3)
    ref = _reference(b, t_end)

    def error(rot, w):
        return max(max(so3.angle_between(r, rr) for r, (rr, _) in zip(rot, ref)),
                   float(np.max(np.abs(w - [ww for _, ww in ref]))))

    result = {}
    for name in ('rb_sim_ros batch', 'MuJoCo Euler', 'MuJoCo RK4'):
        errs = []
        for dt in (0.01, 0.005):
            steps = round(t_end / dt)
            if name == 'rb_sim_ros batch':
                batch = _batch(b, dt)
                batch.step(steps)
                errs.append(error(batch.rotations(), batch.angular_velocities()))
            else:
                model = mujoco_model(b, dt, name.split()[1])
                data = mujoco_data(model, b)
                mujoco.mj_step(model, data, nstep=steps)
                errs.append(error(*mujoco_state(data)))
        result[name] = {'error_dt_0.01': errs[0], 'error_dt_0.005': errs[1],
                        'order': math.log2(errs[0] / errs[1])}
    return result


ORDERS = {'rb_sim_ros batch': (1.7, 2.3), 'MuJoCo Euler': (0.7, 1.3), 'MuJoCo RK4': (3.5, 4.5)}


# -- timing --------------------------------------------------------------------------------------
def _best(run, steps: int, repeats: int, n: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        run(steps)
        best = min(best, time.perf_counter() - t)
    return best / (steps * n) * 1e9


def _block(run, n: int, seconds: float) -> int:
    """Steps per timed block: about ``seconds`` of work, at least 1."""
    t = time.perf_counter()
    run(1)
    per_step = max(time.perf_counter() - t, 1e-7)
    return max(1, int(seconds / per_step))


def time_batch(b: dict, seconds: float, repeats: int, wrench: bool = False,
               per_call: int | None = None, threads: int | None = None) -> float:
    """ns per body-step of the batch path; ``threads`` caps numba's threads for the timing
    (None: all cores, as a user gets by default)."""
    if threads is None:
        return _time_batch(b, seconds, repeats, wrench, per_call)
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        return _time_batch(b, seconds, repeats, wrench, per_call)
    finally:
        numba.set_num_threads(before)


def _time_batch(b: dict, seconds: float, repeats: int, wrench: bool,
                per_call: int | None) -> float:
    n = len(b['masses'])
    batch = _batch(b)
    if wrench:
        # A torque small enough that no body spins past Stepper.MAX_TURN (1 rad a step, where
        # the batch raises, as Stepper does) in the millions of steps the timing takes.
        rng = np.random.default_rng(4)
        batch.set_wrench(None, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 1e-3,
                         'world')
    batch.step(2)  # start-up
    if per_call is None:
        run = batch.step
    else:
        def run(steps):
            for _ in range(steps // per_call):
                batch.step(per_call)
    steps = _block(run, n, seconds)
    if per_call:
        steps = max(per_call, steps - steps % per_call)
    return _best(run, steps, repeats, n)


def mujoco_tiles(b: dict, n: int, tile: int, single_max: int):
    """(model, datas): one model of n bodies, or n / tile copies of a tile-body model."""
    if n <= single_max:
        model = mujoco_model(b)
        return model, [mujoco_data(model, b)]
    first = {k: v[:tile] for k, v in b.items()}
    model = mujoco_model(first)
    return model, [mujoco_data(model, {k: v[i:i + tile] for k, v in b.items()})
                   for i in range(0, n, tile)]


def time_mujoco(model, datas, integrator: str, seconds: float, repeats: int,
                threads: int = 1) -> float:
    """ns per body-step of MuJoCo: each copy steps ``steps`` in one ``mj_step`` call (the loop
    in C, as ours); with ``threads``, that many Python threads share the copies (``mj_step``
    releases the GIL, so they run on as many cores, as ``mujoco.rollout`` would)."""
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f'mjINT_{integrator.upper()}')
    n = model.nbody - 1
    if threads == 1:
        def run(steps):
            for data in datas:
                mujoco.mj_step(model, data, nstep=steps)
    else:
        shares = [datas[i::threads] for i in range(threads)]

        def share(part, steps):
            for data in part:
                mujoco.mj_step(model, data, nstep=steps)

        pool = ThreadPoolExecutor(threads)

        def run(steps):
            for f in [pool.submit(share, part, steps) for part in shares]:
                f.result()
    try:
        steps = _block(run, n * len(datas), seconds)
        return _best(run, steps, repeats, n * len(datas))
    finally:
        if threads != 1:
            pool.shutdown()


def memory(b: dict, model, datas) -> dict:
    n = len(b['masses'])
    batch = _batch(b)
    batch.step(2)
    tracemalloc.start()
    batch.step(10)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {'batch_arrays_B': batch.nbytes / n, 'batch_step_peak_B': peak / n,
            'mujoco_model_plus_data_B': (model.nbuffer + len(datas) * datas[0].nbuffer) / n}


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.batch_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='N up to 10,000, tiles above 1,000 bodies, shorter timings')
    parser.add_argument('--sizes', type=int, nargs='+', help='the N to time')
    parser.add_argument('--seconds', type=float, help='length of one timed block (s)')
    parser.add_argument('--repeats', type=int, help='timed blocks per figure (the minimum)')
    parser.add_argument('--tile', type=int, default=1000, help='bodies per MuJoCo copy')
    parser.add_argument('--single-model-max', type=int,
                        help='largest N given to MuJoCo as one model (default 10,000)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/batch_bench.json; --quick: none)')
    opts = parser.parse_args()
    sizes = opts.sizes or ([1, 100, 10_000] if opts.quick else [1, 100, 10_000, 100_000])
    seconds = opts.seconds or (0.1 if opts.quick else 0.3)
    repeats = opts.repeats or (3 if opts.quick else 5)
    single_max = opts.single_model_max or (1000 if opts.quick else 10_000)
    out = {'machine': {'python': platform.python_version(), 'numpy': np.__version__,
                       'mujoco': mujoco.__version__, 'cpu': platform.processor()
                       or platform.machine()}}

    worst = check_against_steppers()
    print(f'batch against single-body Steppers: {worst:.2e} (must be < 1e-12)')
    out['batch_vs_steppers'] = worst
    ref = check_against_reference()
    out['against_reference'] = ref
    print(f'\n{"against DOP853, 1 s, 4 bodies":<30} {"dt 0.01":>9} {"dt 0.005":>9} {"order":>6}')
    failed = worst >= 1e-12
    for name, r in ref.items():
        lo, hi = ORDERS[name]
        ok = lo <= r['order'] <= hi
        failed |= not ok
        print(f'{name:<30} {r["error_dt_0.01"]:9.2e} {r["error_dt_0.005"]:9.2e} '
              f'{r["order"]:6.2f}{"" if ok else "  NOT its order"}')
    if failed:
        print('checks failed: no timings', file=sys.stderr)
        return 1

    print(f'\nns per body-step, the minimum of {repeats} blocks of ~{seconds} s. batch: free '
          'bodies stepped n at a\ntime (step(n)) on every core and on one, one at a time '
          '(step(1)), and under a held world\nforce and torque; MuJoCo: the same free bodies '
          '(gravity 0, contacts off), each copy stepped\nn at a time (mj_step nstep), on one '
          'thread and on every core; ratios MuJoCo Euler / batch\nwith the same threads on '
          'both sides')
    print(f'{"N":>8} {"step(n)":>8} {"step(n)":>8} {"step(1)":>8} {"wrench":>8} {"Euler":>8} '
          f'{"Euler":>8} {"RK4":>8} {"ratio":>7} {"ratio":>7}')
    print(f'{"":>8} {"cores":>8} {"1 thr":>8} {"cores":>8} {"cores":>8} {"1 thr":>8} '
          f'{"cores":>8} {"1 thr":>8} {"1 thr":>7} {"cores":>7}')
    rows = []
    for n in sizes:
        b = bodies(n)
        row = {'n': n,
               'batch_free_ns': time_batch(b, seconds, repeats),
               'batch_free_one_thread_ns': time_batch(b, seconds, repeats, threads=1),
               'batch_free_one_step_per_call_ns': time_batch(b, seconds, repeats, per_call=1),
               'batch_world_wrench_ns': time_batch(b, seconds, repeats, wrench=True)}
        t = time.perf_counter()
        model, datas = mujoco_tiles(b, n, opts.tile, single_max)
        row['mujoco_layout'] = (f'{len(datas)} x {model.nbody - 1} bodies' if len(datas) > 1
                                else f'one model of {n}')
        row['mujoco_build_s'] = time.perf_counter() - t
        for integrator in ('Euler', 'RK4'):
            row[f'mujoco_{integrator.lower()}_ns'] = time_mujoco(
                model, datas, integrator, seconds, repeats)
        if CORES > 1 and n >= 2 * CORES and n % CORES == 0:
            # Both engines on every core: MuJoCo's copies shared among threads (at least one
            # copy a thread: one model of n bodies is cut into CORES copies for this).
            many = (model, datas) if len(datas) >= CORES else mujoco_tiles(b, n, n // CORES, 0)
            row['mujoco_euler_all_cores_ns'] = time_mujoco(*many, 'Euler', seconds, repeats,
                                                           threads=CORES)
        row['memory_per_body'] = memory(b, model, datas)
        rows.append(row)
        cores = row.get('mujoco_euler_all_cores_ns', math.nan)
        print(f'{n:>8} {row["batch_free_ns"]:8.1f} {row["batch_free_one_thread_ns"]:8.1f} '
              f'{row["batch_free_one_step_per_call_ns"]:8.1f} '
              f'{row["batch_world_wrench_ns"]:8.1f} {row["mujoco_euler_ns"]:8.1f} '
              f'{cores:8.1f} {row["mujoco_rk4_ns"]:8.1f} '
              f'{row["mujoco_euler_ns"] / row["batch_free_one_thread_ns"]:7.1f} '
              f'{cores / row["batch_free_ns"]:7.1f}   MuJoCo: {row["mujoco_layout"]}', flush=True)
    out['rows'] = rows
    if not opts.quick and 10_000 in sizes and single_max >= 10_000:
        b = bodies(10_000)
        model, datas = mujoco_tiles(b, 10_000, opts.tile, 0)
        out['mujoco_10000_as_tiles'] = {
            i: time_mujoco(model, datas, i, seconds, repeats) for i in ('Euler', 'RK4')}
        tiles = out['mujoco_10000_as_tiles']
        print(f'{"":>8} MuJoCo at N = 10,000 as {len(datas)} x {opts.tile} bodies: Euler '
              f'{tiles["Euler"]:.1f}, RK4 {tiles["RK4"]:.1f} (one model: above)')

    print('\nbytes per body: batch arrays (allocated once) / batch peak while stepping / '
          'MuJoCo model + data')
    for row in rows:
        m = row['memory_per_body']
        print(f'{row["n"]:>8} {m["batch_arrays_B"]:10.0f} {m["batch_step_peak_B"]:10.1f} '
              f'{m["mujoco_model_plus_data_B"]:10.0f}')
    sane = sanity(rows)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'batch_bench.json')
    if path:
        figures.write(path, {'quick': opts.quick, **out})
    return sane.report()


def sanity(rows: list[dict]) -> figures.Sanity:
    s = figures.Sanity()
    for row in rows:
        n = row['n']
        for key in ('batch_free_ns', 'batch_free_one_thread_ns', 'batch_free_one_step_per_call_ns',
                    'batch_world_wrench_ns', 'mujoco_euler_ns', 'mujoco_rk4_ns',
                    'mujoco_euler_all_cores_ns'):
            if key in row:
                s.within(f'N = {n}: {key}', row[key], 1.0, 1e6)
        for key in ('mujoco_euler_ns', 'mujoco_rk4_ns'):
            s.within(f'N = {n}: {key} / batch_free_ns', row[key] / row['batch_free_ns'],
                     0.01, 1000.0)
        for key, value in row['memory_per_body'].items():
            if key != 'batch_step_peak_B':
                s.within(f'N = {n}: {key}', value, 100.0, 1e5)
    return s


if __name__ == '__main__':
    sys.exit(main())
