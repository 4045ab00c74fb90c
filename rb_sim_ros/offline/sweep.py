# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""sweep: many offline runs of a scene, each recorded as the node records it, on local
processes or on Ray.

    sweep scene.yaml --vary bodies.ball.position.2=1:3:5 --vary contact.restitution=[0.2,0.8]
          --seeds 4 --steps 2000 --out runs/ [--wrench profile.csv] [--param dt=0.0005]
          [--workers 2 | --ray local|auto|ADDRESS]
    sweep --verify runs/*.mcap [--workers 2 | --ray ...]

Every variant runs through the same ``Simulation`` the node steps (no DDS): the scene with the
varied values put in at KEY (a path into the scene file: ``gravity``, ``contact.friction``,
``bodies.<name>.<field>[.<index>]``, ``templates.<name>.<field>``), for each of ``--seeds``
seeds (the IMU noise's ``imu_seed``, and the draws of seeded distributions). SPEC is a list
``[a, b, c]`` (YAML, so vectors too: ``[[0, 0, 1], [0, 0, 2]]``), a range ``a:b:n`` (n values
from a to b), or a distribution drawn per run: ``uniform(a, b)``, ``normal(mu, sigma)``. The
runs are the product of the lists and ranges, times the seeds, numbered in that order. A wrench
schedule (a CSV as send_wrench reads it) applies to every run, to ``--wrench-body`` (default
the first moving body), each row from the first publish period at or after its time, as the
node takes what send_wrench sends: held (send_wrench republishes it, so command_timeout does
not fire) until the next, the last one ``--wrench-hold`` seconds (default 0), then a zero.
Node parameters (``dt``, ``publish_rate``, ``integrator``, the IMU's noise) come from
``--param NAME=VALUE``.

Each run writes ``run_NNNNNN.mcap`` (what the node would record: pose, twist, odom, imu and
accel of every moving body, inputs at their steps; ``replay --verify`` accepts it) and one row
of ``summary.csv``: the run, its seed and varied values, each moving body's final pose and
twist, the total kinetic energy, the contacts of the last step and the most at a publish, the
steps taken, the error if it failed, and what it cost (``wall_s``, ``cpu_s``: seconds). Rows
go to ``summary.partial.jsonl`` as runs finish (in any order), and ``summary.csv`` is written
sorted when the sweep ends. Apart from the costs, the files (what a reader gets:
``recording.compare``) and rows do not depend on the engine, the number of workers or the
order runs finish in: a run depends only on its number. A worker writes its recordings inline
(no writer thread): one core a worker.

Engines: local processes (default: as many as cores) or Ray (``--ray local`` starts one on this
machine; ``--ray auto`` joins the cluster this machine is part of; ``--ray ADDRESS`` joins that
one). Runs go in tasks of several, sized to amortise scheduling; a task whose worker dies or
that raises is retried once, then its runs are recorded as failed and the sweep goes on. The
scene and parameters travel in each task; recordings come back as bytes and are written by the
driver, so workers need no shared file system.

SIGINT and SIGTERM stop a sweep alike: the workers are killed, ``summary.csv`` holds the runs
that finished (and only they), one line says how many, exit status 128 + the signal. Local
workers end with the driver however it ends (Linux's parent-death signal). Each --vary value
must be a finite float (so must a range's span and a distribution's reach): else one line.
``--verify`` names a missing file on a line of its own (MISSING PATH), the others verified.
"""

from __future__ import annotations

import argparse
import collections
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
import copy
import csv
import itertools
import json
import math
import multiprocessing
import os
import re
import signal
import sys
import tempfile
import threading
import time
from typing import Any

import numpy as np

from rb_sim_ros.core.rigid_body import Wrench, ZERO_WRENCH
from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.offline import replay
from rb_sim_ros.offline.progress import Progress
from rb_sim_ros.ros import node_params, node_recorder, ros_arguments
from rb_sim_ros.ros.node_config import config_from
from rb_sim_ros.ros.node_recorder import NodeRecorder
from rb_sim_ros.ros.ros_messages import OutputMessages, rotation_from_quaternion
from rb_sim_ros.ros.wrench_profile import load_profile
from rb_sim_ros.sim import safe_yaml
from rb_sim_ros.sim.imu import ImuSensor
from rb_sim_ros.sim.scene import read_scene_data, scene_from_data
from rb_sim_ros.sim.simulation import SetWrench, Simulation

MAX_RUNS = 10_000_000
MAX_VALUES = 100_000  # in one list or range
NORMAL_REACH = 64  # sigmas: numpy's ziggurat draws stay within about 14
OUTPUT_KINDS = tuple(node_recorder.OUTPUTS)
# Fault injection for the tests: "<marker file>:<run>" makes the worker running that run die
# (os._exit) the first time, as a killed worker would; "always:<run>" every time.
DIE_ONCE_ENV = 'RB_SIM_SWEEP_DIE_ONCE'


# -- what to run -----------------------------------------------------------------------------
def parse_spec(key: str, spec: str):
    """('values', [v, ...]) for a list or range, ('draw', (kind, a, b)) for a distribution;
    ValueError naming KEY. Every value a spec can give is finite: a list's numbers, a range's
    ends, span and spacing, a distribution's span (uniform) or its widest draw (normal, out to
    ``NORMAL_REACH`` sigmas, beyond any draw numpy's ziggurat makes)."""
    where = f'--vary {key}={spec.strip()}'
    m = re.fullmatch(r'\s*(uniform|normal)\(\s*([^,()]+)\s*,\s*([^,()]+)\s*\)\s*', spec)
    if m:
        kind = m.group(1)
        try:
            a, b = float(m.group(2)), float(m.group(3))
        except ValueError:
            raise ValueError(f'{where}: {kind} takes two numbers') from None
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ValueError(f'{where}: {kind} takes finite numbers')
        if (kind == 'uniform' and b < a) or (kind == 'normal' and b < 0):
            raise ValueError(f'{where}: bad {kind}({a}, {b})')
        reach = b - a if kind == 'uniform' else abs(a) + NORMAL_REACH * b
        if not math.isfinite(reach):
            raise ValueError(f'{where}: its draws overflow a float ('
                             + ('b - a' if kind == 'uniform' else
                                f'|mu| + {NORMAL_REACH:g} sigma') + ' is not finite)')
        return 'draw', (kind, a, b)
    m = re.fullmatch(r'\s*([^:\[\]]+):([^:\[\]]+):([^:\[\]]+)\s*', spec)
    if m:
        try:
            a, b, n = float(m.group(1)), float(m.group(2)), int(m.group(3))
        except ValueError:
            raise ValueError(f'{where}: a range is a:b:n (numbers, n an integer)') from None
        if not (math.isfinite(a) and math.isfinite(b)) or not 1 <= n <= MAX_VALUES:
            raise ValueError(f'{where}: a range needs finite ends and 1 to {MAX_VALUES} '
                             'values')
        if not math.isfinite(b - a):
            raise ValueError(f'{where}: the span b - a of the range overflows a float')
        with np.errstate(all='ignore'):
            values = [float(v) for v in np.linspace(a, b, n)]
        if not all(math.isfinite(v) for v in values):  # not seen with a finite span; a guard
            raise ValueError(f'{where}: the range spacing overflows a float')
        return 'values', values
    if ':' in spec and not spec.strip().startswith('['):
        raise ValueError(f'{where}: a range is a:b:n (n values from a to b)')
    try:
        data = safe_yaml.load(spec if spec.strip().startswith('[') else f'[{spec}]',
                              max_depth=4, max_nodes=MAX_VALUES)
    except safe_yaml.YamlError as e:
        raise ValueError(f'{where}: not a list, range a:b:n, uniform(a, b) or '
                         f'normal(mu, sigma): {e.reason}') from None
    if not isinstance(data, list) or not data:
        raise ValueError(f'{where}: an empty list')
    bad = _not_finite(data)
    if bad is not None:
        raise ValueError(f'{where}: {bad} is not a finite number')
    return 'values', data


def _not_finite(value):
    """The first number in ``value`` (lists and mappings searched) that is not a finite
    float (inf, nan, an integer beyond a float's range), as text; None if there is none."""
    if isinstance(value, (list, tuple)):
        items = value
    elif isinstance(value, dict):
        items = value.values()
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    else:
        try:
            ok = math.isfinite(float(value))
        except OverflowError:
            ok = False
        text = repr(value)
        if len(text) > 40:
            text = f'{text[:20]}... ({len(text)} digits)'
        return None if ok else text
    for item in items:
        bad = _not_finite(item)
        if bad is not None:
            return bad
    return None


def set_key(data: dict, key: str, value) -> None:
    """Put ``value`` at ``key`` (dot-separated) of scene data; a list of bodies or templates is
    indexed by name, a vector by position. ValueError naming the key."""
    parts = key.split('.')
    node = data
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, list):
            by_name = [k for k, item in enumerate(node)
                       if isinstance(item, dict) and item.get('name') == part]
            if by_name:
                index = by_name[0]
            elif re.fullmatch(r'[0-9]{1,9}', part) and int(part) < len(node):
                index = int(part)
            else:
                where = '.'.join(parts[:i]) or 'the scene'
                raise ValueError(f"--vary {key}: no '{part}' in {where}")
            if last:
                node[index] = value
            else:
                node = node[index]
        elif isinstance(node, dict):
            if last:
                node[part] = value
            elif part not in node and part == 'contact':
                node = node.setdefault(part, {})
            elif part not in node:
                raise ValueError(f"--vary {key}: the scene has no '{'.'.join(parts[:i + 1])}'")
            else:
                node = node[part]
        else:
            raise ValueError(f"--vary {key}: '{'.'.join(parts[:i])}' holds no fields")


class Plan:
    """The runs of a sweep, by number, without listing them: run r is seed r mod seeds of
    the grid point r div seeds, the grid being the product of the lists and ranges in the
    order given (the last varies fastest); distributions are drawn per run (``drawn``)."""

    def __init__(self, varies, seeds: int) -> None:
        self.keys = [k for k, (kind, _) in varies if kind == 'values']
        self.grids = [v for _, (kind, v) in varies if kind == 'values']
        self.draws = {k: v for k, (kind, v) in varies if kind == 'draw'}
        self.seeds = seeds
        self.count = math.prod(len(g) for g in self.grids) * seeds
        if self.count > MAX_RUNS:
            raise ValueError(f'{self.count} runs: at most {MAX_RUNS}')

    def __len__(self) -> int:
        return self.count

    def run(self, r: int) -> tuple:
        """(run, seed, {key: value}) of run ``r``."""
        point, seed = divmod(r, self.seeds)
        values = {}
        for key, grid in zip(reversed(self.keys), reversed(self.grids)):
            point, k = divmod(point, len(grid))
            values[key] = grid[k]
        values = {k: values[k] for k in self.keys}  # in the order given
        values.update(drawn(self.draws, r, seed))
        return r, seed, values


def plan(varies, seeds: int):
    """[(run, seed, grid values by key)] and the distributions by key (for small sweeps and
    the tests; ``Plan`` is the lazy form)."""
    p = Plan(varies, seeds)
    runs = []
    for r in range(len(p)):
        run, seed, values = p.run(r)
        runs.append((run, seed, {k: values[k] for k in p.keys}))
    return runs, p.draws


def drawn(draws: dict, run: int, seed: int) -> dict:
    """The seeded distributions' values of one run: from its own PCG64 stream (run, seed,
    key's place), whatever engine or order runs in."""
    out = {}
    for k, (key, (kind, a, b)) in enumerate(sorted(draws.items())):
        rng = np.random.Generator(np.random.PCG64([run, seed, k]))
        out[key] = float(rng.uniform(a, b) if kind == 'uniform' else rng.normal(a, b))
    return out


# -- one run ---------------------------------------------------------------------------------
def run_one(context: dict, run: int, seed: int, values: dict, out_path: str) -> dict:
    """Simulate and record one run to ``out_path``; its summary row (``error`` set, not raised,
    for a variant that cannot run or that went non-finite)."""
    t0, c0 = time.perf_counter(), time.process_time()
    row = {'run': run, 'seed': seed, **{k: _cell(v) for k, v in values.items()}}
    try:
        data = copy.deepcopy(context['scene'])
        for key, value in values.items():
            set_key(data, key, value)
        scene = scene_from_data(data, context['scene_path'])
        params = dict(context['params'], imu_seed=seed)
        config = config_from(params, scene)
        row.update(_simulate(config, params, context, out_path))
    except (ValueError, IntegrationError) as e:
        row['error'] = str(e).splitlines()[0][:500]
    row['wall_s'] = f'{time.perf_counter() - t0:.6f}'
    row['cpu_s'] = f'{time.process_time() - c0:.6f}'  # of every thread of the worker
    return row


def _simulate(config, params, context, out_path) -> dict:
    sim = Simulation(config)
    moving = [b.name for b in config.bodies[:params['max_body_topics']] if not b.static]
    topics = {n: {k: f'/{n}/{k}' for k in OUTPUT_KINDS} for n in moving}
    recorder = NodeRecorder(out_path, config, params, topics, overwrite=True,
                            max_chunk_age_s=None, background=False)  # one thread a worker
    noise = node_params.imu_noise(params)
    index = {b.name: i for i, b in enumerate(config.bodies)}
    outs = {n: OutputMessages(params['world_frame'], node_params.body_frame(params, n, False),
                              params['twist_frame'],
                              node_params.covariance36(params['odom_pose_covariance']),
                              node_params.covariance36(params['odom_twist_covariance']), noise)
            for n in moving}
    sensors = {n: ImuSensor(noise, index[n]) for n in moving}
    spp = config.steps_per_publish
    periods = max(1, math.ceil(context['steps'] / spp))
    target = context.get('wrench_body') or (moving[0] if moving else '')
    events: dict = {}
    profile = context.get('wrench') or ()

    def at(t):  # the first period boundary at or after t: period p starts at step (p-1) spp
        return math.ceil(t / (config.dt * spp) - 1e-9) + 1
    for t, values, frame in profile:
        events.setdefault(at(t), []).append(SetWrench(
            Wrench(values[:3], values[3:], frame or params['wrench_frame']), target))
    if profile:  # as send_wrench: the last row held --wrench-hold more, then a zero wrench
        events.setdefault(at(profile[-1][0] + context['wrench_hold']), []).append(
            SetWrench(ZERO_WRENCH, target))
    most = 0
    error = ''
    try:
        for period in range(periods + 1):
            for event in events.get(period, []) if period else ():
                sim.apply(event)
                recorder.event(sim.step_count, sim.time_ns, event)
            if period:
                try:
                    sim.run(spp)
                except IntegrationError as e:
                    error = str(e).splitlines()[0][:500]
            if error:
                break
            for n in moving:
                publish_state(sim, n, outs[n], sensors[n], recorder)
            stats = sim.contact_stats()
            most = max(most, stats.contacts if stats is not None else 0)
    finally:
        recorder.close()
    if recorder.failed:
        raise ValueError(recorder.failed)
    row: dict[str, Any] = {}
    energy = 0.0
    for n in moving:
        x, q, v, w = sim.pose_twist(n)
        for names, vec in (('x y z', x), ('qx qy qz qw', q), ('vx vy vz', v),
                           ('wx wy wz', w)):
            for name, c in zip(names.split(), vec):
                row[f'{n}.{name}'] = repr(float(c))
        spec = config.body(n)
        inertia = np.array(spec.inertia, dtype=float)
        inertia = np.diag(inertia) if inertia.size == 3 else inertia.reshape(3, 3)
        r = _rotation(q)
        wb = r.T @ np.array(w)
        energy += 0.5 * spec.mass * float(np.dot(v, v)) + 0.5 * float(wb @ inertia @ wb)
    stats = sim.contact_stats()
    row.update(energy=repr(energy), contacts=stats.contacts if stats is not None else 0,
               max_contacts=most, steps=sim.step_count, error=error)
    return row


def publish_state(sim, name, out, sensor, recorder, step: int | None = None,
                  time_ns: int | None = None) -> bool:
    """One publish of ``name`` as the node's BodyPorts.publish makes it with a recorder (the
    messages filled in ``out``, the IMU's noise drawn, the outputs recorded); False, nothing
    drawn nor recorded, for a state that is not finite. ``step`` and ``time_ns``: the sim's
    (read here if None)."""
    if step is None or time_ns is None:
        step, time_ns = sim.step_count, sim.time_ns
    t = time_ns
    pose_twist = sim.pose_twist(name)
    if not all(map(math.isfinite, itertools.chain(*pose_twist))):
        return False
    r = rotation_from_quaternion(pose_twist[1])
    if not out.fill(t, *pose_twist, rotation=r):
        return False
    a, b = sim.accelerations(name)
    offsets = sensor.sample(t)
    if not out.fill_motion(t, pose_twist[1], pose_twist[3], a, b, sim.config.gravity,
                           offsets, rotation=r):
        sensor.undo()
        return False
    recorder.output(name, step, t, out)
    return True


def _rotation(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _cell(value) -> str:
    return repr(float(value)) if isinstance(value, float) else str(value)


# -- tasks and engines -----------------------------------------------------------------------
def run_task(context: dict, start: int, stop: int) -> list:
    """A task: [(row, recording bytes)] of runs ``start`` to ``stop`` - 1 of the context's
    plan, each made by the context's ``run_one`` (default: a sweep's run) and recorded in a
    directory of its own under the name it gets (the file name is in the recording). A run
    that fails in any way is a row with its error; the task goes on."""
    results = []
    die = os.environ.get(DIE_ONCE_ENV, '')
    with tempfile.TemporaryDirectory(prefix='rb_sim_sweep_') as d:
        for r in range(start, stop):
            run, seed, values = context['plan'].run(r)
            if die:
                marker, _, which = die.rpartition(':')
                if which == str(run) and (marker == 'always' or not os.path.exists(marker)):
                    if marker != 'always':
                        open(marker, 'w').close()
                    os._exit(17)  # the worker dies, as if killed
            path = os.path.join(d, file_name(run))
            try:
                row = context.get('run_one', run_one)(context, run, seed, values, path)
            except Exception as e:  # noqa: B902 - a bug in one run must not cost the others
                row = {'run': run, 'seed': seed, **{k: _cell(v) for k, v in values.items()},
                       'error': f'{type(e).__name__}: {e}'.splitlines()[0][:500]}
            data = b''
            if os.path.exists(path):
                if 'steps' in row:  # it ran (to its end, or to where it went non-finite)
                    with open(path, 'rb') as f:
                        data = f.read()
                os.unlink(path)
            results.append((row, data))
    return results


class _Files:
    """Files for a worker, read when the task is sent (pickled), not before: the driver holds
    the bytes of the tasks in flight only, and workers need no shared disk."""

    def __init__(self, paths: list) -> None:
        self.paths = list(paths)
        # (path, its bytes or why not): read when it is sent (__getstate__)
        self.items: list[tuple[str, bytes | str]] | None = None

    def __getstate__(self) -> dict:
        items: list[tuple[str, bytes | str]] = []
        for path in self.paths:  # a file that cannot be read is its own result, not the task's
            try:
                with open(path, 'rb') as f:
                    items.append((path, f.read()))
            except OSError as e:
                items.append((path, _unreadable(e)))
        return {'paths': self.paths, 'items': items}


def _unreadable(e: OSError) -> str:
    """Why a file cannot be read, in a line ('missing' for one that is not there)."""
    if isinstance(e, FileNotFoundError):
        return 'missing'
    return f'cannot read it: {e.strerror or type(e).__name__}'


def verify_task(_shared, files: _Files) -> list:
    """A task of ``replay --verify``: [(path, identical, one-line summary)] of the files;
    identical is None for a file that could not be read (the summary says why)."""
    out: list[tuple[str, bool | None, str]] = []
    assert files.items is not None, 'a _Files is read when it is sent to a worker'
    with tempfile.TemporaryDirectory(prefix='rb_sim_verify_') as d:
        for name, data in files.items:
            if isinstance(data, str):
                out.append((name, None, data))
                continue
            path = os.path.join(d, os.path.basename(name))
            with open(path, 'wb') as f:
                f.write(data)
            try:
                r = replay.verify(path)
                out.append((name, r.identical, f'{r.outputs} of {r.recorded} outputs compared, '
                            f'{r.mismatched_messages} differ'))
            except Exception as e:  # noqa: B902 - one bad file is its own line
                out.append((name, False, f'{type(e).__name__}: {e}'.replace(
                    path, name).splitlines()[0]))
            os.unlink(path)
    return out


def file_name(run: int) -> str:
    return f'run_{run:06d}.mcap'


def chunks(count: int, workers: int) -> list:
    """Tasks as (start, stop) of ``count`` items, largest first (guided scheduling): each a
    quarter of a worker's share of what is left, at most 64 items, so that the scheduling is
    amortised while much is left, and the last tasks are of one item: the workers finish
    together (a task of k items last on one worker left the others idle for k runs)."""
    tasks, i = [], 0
    while i < count:
        size = max(1, min(64, (count - i) // max(1, 4 * workers)))
        tasks.append((i, i + size))
        i += size
    return tasks


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM in the driver (a KeyboardInterrupt, so that whatever stops on one
    stops on both): ``signum``, and what was done before it (``note``)."""

    def __init__(self, signum: int = signal.SIGINT, note: str = '') -> None:
        super().__init__(signum, note)
        self.signum, self.note = signum, note


_HANDLED = (signal.SIGINT, signal.SIGTERM)  # main's: either stops the sweep, keeping rows
_SIGNALS: list[int] = []  # those main's handler took: Ray turns what a handler raises into a plain
# KeyboardInterrupt (its waits check for signals), so the signal is kept here too


_DEFERRING = [False]  # True while the driver waits inside the pool (it holds its locks)
_PENDING: list[int] = []  # signals that came then, raised once the wait is left


def _on_signal(signum, _frame) -> None:
    _SIGNALS.append(signum)
    if _DEFERRING[0]:  # raised inside concurrent.futures.wait, it could leave a future's lock
        _PENDING.append(signum)  # held and the pool's shutdown would wait for ever
        return
    raise Interrupted(signum)


def _wait_first(running) -> set:
    """The futures of ``running`` done first (``wait``, FIRST_COMPLETED), in slices: a signal
    that comes meanwhile is raised between two slices, when no lock of the pool is held."""
    while True:
        _DEFERRING[0] = True
        try:
            done = wait(running, timeout=0.2, return_when=FIRST_COMPLETED)[0]
        finally:
            _DEFERRING[0] = False
        if _PENDING:
            signum = _PENDING[-1]
            _PENDING.clear()
            raise Interrupted(signum)
        if done:
            return done


def _hold_signals() -> None:
    """After the first SIGINT or SIGTERM: later ones are noted, not raised, while the workers
    are stopped and the summary is written (main restores its handlers after)."""
    try:
        for n in _HANDLED:
            signal.signal(n, lambda signum, _frame: _SIGNALS.append(signum))
    except ValueError:  # not the main thread: nothing of ours is installed there
        pass


def _signum(e: BaseException) -> int:
    """The signal that interrupted: Interrupted's own, else the last main's handler took."""
    return getattr(e, 'signum', None) or (_SIGNALS[-1] if _SIGNALS else signal.SIGINT)


def _worker_init(driver: int) -> None:
    """A local worker: SIGINT is the driver's to act on (it stops the pool); the worker ends
    when the driver does, however it ends (SIGKILL too): Linux's parent-death signal, else a
    thread that watches the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    armed = False
    if sys.platform.startswith('linux'):
        try:
            import ctypes
            armed = ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL) == 0  # DEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != driver:  # the driver went before the signal was armed
        os._exit(1)
    if not armed:
        threading.Thread(target=_watch_parent, args=(driver,), daemon=True).start()


def _watch_parent(driver: int) -> None:
    while os.getppid() == driver:
        time.sleep(1.0)
    os._exit(1)


class LocalEngine:
    """Worker processes on this machine (spawned: nothing of the driver's state is shared;
    each ends with the driver)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self._pool = None

    def _fresh(self):
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = ProcessPoolExecutor(self.workers,
                                         mp_context=multiprocessing.get_context('spawn'),
                                         initializer=_worker_init, initargs=(os.getpid(),))
        return self._pool

    def abort(self) -> None:
        """Stop now: the workers are killed, what they were running is lost."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        processes = list((getattr(pool, '_processes', None) or {}).values())
        for p in processes:
            p.kill()
        pool.shutdown(wait=True, cancel_futures=True)
        for p in processes:
            p.join()

    def map(self, fn, shared, tasks: list):
        """Yield (task index, result or exception) as tasks finish, ``fn(shared, *task)``.

        At most two tasks a worker are in the pool at once (a worker that ends a task starts
        the next without waiting for the driver to take the result). A task that raises is
        tried once more. A worker that dies breaks the pool and the tasks in it: they run
        again one at a time, so that the one that kills its worker is found; it is tried
        once more alone, then given up (the others are not charged)."""
        pool = self._pool or self._fresh()
        waiting = collections.deque(range(len(tasks)))
        # suspects of a dead worker, to run one at a time
        alone: collections.deque[int] = collections.deque()
        attempts = [0] * len(tasks)
        running: dict = {}
        solo = None  # the task running alone, if one is
        while waiting or alone or running:
            broken = False
            try:
                if alone and not running:
                    solo = alone.popleft()
                    running[pool.submit(fn, shared, *tasks[solo])] = solo
                elif not alone:
                    solo = None
                    while waiting and len(running) < 2 * self.workers:
                        i = waiting.popleft()
                        try:
                            running[pool.submit(fn, shared, *tasks[i])] = i
                        except BrokenProcessPool:
                            waiting.appendleft(i)
                            raise
            except BrokenProcessPool:
                broken = True
            failed = []
            for future in (_wait_first(running) if running and not broken else ()):
                i = running.pop(future)
                try:
                    result = future.result()
                except BrokenProcessPool:
                    broken = True
                    failed.append(i)
                    continue
                except Exception as e:  # noqa: B902 - a task's failure is recorded
                    attempts[i] += 1
                    if attempts[i] < 2:
                        waiting.appendleft(i)
                    else:
                        yield i, e
                    continue
                yield i, result
            if not broken:
                continue
            suspects = failed
            for future, i in running.items():  # a task that ended before the break stands
                if future.done() and not future.cancelled() and future.exception() is None:
                    yield i, future.result()
                else:
                    suspects.append(i)
            running.clear()
            pool = self._fresh()
            if solo is not None and suspects == [solo]:  # it killed its worker, alone
                attempts[solo] += 1
                if attempts[solo] < 2:
                    alone.appendleft(solo)
                else:
                    yield solo, RuntimeError('its worker died twice')
            else:  # which one? each runs alone next; none is charged yet
                alone.extend(suspects)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)


class RayEngine:
    """Ray tasks (ray.init with the address given; 'local' starts one here with ``workers``
    CPUs). Ray retries a task once when its worker dies or it raises. The shared part goes
    to the object store once; at most four tasks a CPU are in flight."""

    def __init__(self, address: str, workers: int) -> None:
        try:
            import ray
        except ImportError:
            raise ValueError('--ray needs ray (pip install ray)') from None
        self.ray = ray
        try:
            if address == 'local':
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                         ignore_reinit_error=True)
            else:
                ray.init(address=address, log_to_driver=False, ignore_reinit_error=True)
        except (RuntimeError, ConnectionError, ValueError, OSError) as e:
            raise ValueError(f'--ray {address}: cannot start or join Ray: '
                             f'{str(e).strip().splitlines()[0] if str(e).strip() else e!r}'
                             ) from None
        self.workers = int(ray.cluster_resources().get('CPU', workers))
        self._refs: dict = {}

    def map(self, fn, shared, tasks: list):
        remote = self.ray.remote(max_retries=1, retry_exceptions=True)(fn)
        shared_ref = self.ray.put(shared)
        waiting = collections.deque(range(len(tasks)))
        refs = self._refs = {}
        while waiting or refs:
            while waiting and len(refs) < 4 * self.workers:
                i = waiting.popleft()
                refs[remote.remote(shared_ref, *tasks[i])] = i
            done, _ = self.ray.wait(list(refs), num_returns=1)
            for ref in done:
                i = refs.pop(ref)
                try:
                    yield i, self.ray.get(ref)
                except Exception as e:  # noqa: B902 - failed twice: recorded
                    yield i, e

    def abort(self) -> None:
        """Stop now: the tasks in flight are cancelled (their workers killed)."""
        for ref in list(self._refs):
            try:
                self.ray.cancel(ref, force=True)
            except Exception:  # noqa: B902 - done already, or Ray going: nothing to stop
                pass
        self._refs.clear()

    def close(self) -> None:
        self.ray.shutdown()


def make_engine(ray_address: str | None, workers: int):
    return RayEngine(ray_address, workers) if ray_address else LocalEngine(workers)


# -- the driver --------------------------------------------------------------------------------
class _NoProgress:
    def __call__(self, done: int) -> None:
        pass

    def close(self, finished: bool = True) -> None:
        pass


def sweep(scene_path: str, varies: list, seeds: int, steps: int, out_dir: str,
          params: dict | None = None, wrench_csv: str | None = None,
          wrench_body: str | None = None, engine=None, progress: bool = True,
          wrench_hold: float = 0.0) -> list:
    """Run the sweep; its rows, sorted by run (also in ``out_dir``/summary.csv)."""
    data = read_scene_data(scene_path)
    values = {p.name: p.default for p in node_params.PARAMS}
    values.update(params or {})
    values.update(scene_file=scene_path, publish_tf=False, record='')
    for name, value in values.items():
        node_params.check(name, value)
    if not isinstance(steps, int) or not 1 <= steps <= 10 ** 9:
        raise ValueError(f'--steps must be from 1 to 1e9, got {steps!r}')
    if not isinstance(seeds, int) or not 1 <= seeds <= MAX_RUNS:
        raise ValueError(f'--seeds must be from 1 to {MAX_RUNS}, got {seeds!r}')
    if not (isinstance(wrench_hold, (int, float)) and 0 <= wrench_hold <= 1e9):
        raise ValueError(f'--wrench-hold must be from 0 to 1e9 s, got {wrench_hold!r}')
    runs = Plan(varies, seeds)
    context = {'scene': data, 'scene_path': scene_path, 'params': values, 'steps': steps,
               'wrench': load_profile(wrench_csv, values['max_wrench']) if wrench_csv
               else None, 'wrench_body': wrench_body, 'wrench_hold': float(wrench_hold),
               'plan': runs}
    # The first run's variant is checked here: a bad key is one line, before any worker.
    probe = copy.deepcopy(data)
    for key, value in runs.run(0)[2].items():
        set_key(probe, key, value)
    scene = scene_from_data(probe, scene_path)
    config_from(values, scene)
    if wrench_body and not any(b.name == wrench_body and not b.static for b in scene.bodies):
        raise ValueError(f'--wrench-body {wrench_body}: no moving body of that name')
    return drive(context, [k for k, _ in varies], out_dir, engine, progress, 'sweep')


# The summary's last columns: what a run is and cost, after the varied values and the states.
TAIL = ('energy', 'contacts', 'max_contacts', 'steps', 'file', 'error', 'wall_s', 'cpu_s')


def drive(context: dict, keys: list, out_dir: str, engine=None, progress: bool = True,
          name: str = 'sweep', tail=TAIL) -> list:
    """Run every run of ``context['plan']`` with ``run_task`` on ``engine``, the recordings
    and ``summary.csv`` (the ``keys``' columns first, ``tail``'s last) written to ``out_dir``
    as they come; the rows, sorted by run. Interrupted (a KeyboardInterrupt) by SIGINT or
    SIGTERM, the rows of the runs that finished in the summary."""
    runs = context['plan']
    os.makedirs(out_dir, exist_ok=True)
    own = engine is None
    engine = engine or LocalEngine(os.cpu_count() or 1)
    tasks = chunks(len(runs), engine.workers)
    rows = []
    partial = os.path.join(out_dir, 'summary.partial.jsonl')
    show = Progress(len(runs), name, 'runs') if progress else _NoProgress()
    stop = None
    try:
        with open(partial, 'w') as f:
            for i, result in engine.map(run_task, context, tasks):
                if isinstance(result, BaseException):
                    why = f'task failed twice: {type(result).__name__}: {result}'
                    result = []
                    for r in range(*tasks[i]):
                        run, seed, vals = runs.run(r)
                        result.append(({'run': run, 'seed': seed,
                                        **{k: _cell(v) for k, v in vals.items()},
                                        'error': why.splitlines()[0][:500]}, b''))
                for row, blob in result:
                    if blob:
                        _write_atomically(os.path.join(out_dir, file_name(row['run'])), blob)
                        row['file'] = file_name(row['run'])
                    rows.append(row)
                    f.write(json.dumps(row, sort_keys=True) + '\n')
                    f.flush()
                show(len(rows))
    except KeyboardInterrupt as e:  # SIGINT, or SIGTERM by main's handler: stop, keep rows
        stop = e
        _hold_signals()  # a second one must not lose the summary of the first
        engine.abort()
    finally:
        show.close(finished=stop is None)
        if own:
            engine.close()
    rows.sort(key=lambda r: r['run'])
    summary = os.path.join(out_dir, 'summary.csv')
    _write_summary(summary, rows, keys, tail)
    os.unlink(partial)
    if stop is not None:  # the runs not finished are not in the summary
        raise Interrupted(_signum(stop),
                          f'{len(rows)} of {len(runs)} runs finished, their summary in '
                          f'{summary}') from None
    return rows


def _write_atomically(path: str, data: bytes) -> None:
    tmp = path + '.part'
    try:
        with open(tmp, 'wb') as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:  # an interrupt too: no half file left
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write_summary(path: str, rows: list, keys: list, tail=TAIL) -> None:
    columns = ['run', 'seed', *keys]
    for row in rows:
        for c in row:
            if c not in columns and c not in tail:
                columns.append(c)
    columns += list(tail)
    tmp = path + '.part'
    with open(tmp, 'w', newline='') as f:
        writer = csv.DictWriter(f, columns, extrasaction='ignore')
        writer.writeheader()
        for row in rows:
            writer.writerow(row)
    os.replace(tmp, path)


def verify_many(paths: list, engine=None, progress: bool = True) -> list:
    """replay --verify of every file on the engine: [(path, identical, summary)] in order;
    identical is None for a file that cannot be read (missing, say), and only for it."""
    own = engine is None
    engine = engine or LocalEngine(os.cpu_count() or 1)
    tasks = chunks(len(paths), engine.workers)
    results = {}
    show = Progress(len(paths), 'sweep --verify', 'files') if progress else _NoProgress()
    stopped = False
    try:
        for i, result in engine.map(verify_task, None,
                                    [(_Files(paths[a:b]),) for a, b in tasks]):
            if isinstance(result, BaseException):
                why = f'task failed twice: {type(result).__name__}: {result}'.splitlines()[0]
                result = [(name, False, why) for name in paths[slice(*tasks[i])]]
            for name, ok, text in result:
                results[name] = (ok, text)
            show(len(results))
    except KeyboardInterrupt as e:
        stopped = True
        _hold_signals()
        engine.abort()
        raise Interrupted(_signum(e),
                          f'{len(results)} of {len(paths)} files verified') from None
    finally:
        show.close(finished=not stopped)
        if own:
            engine.close()
    return [(p, *results[p]) for p in paths]


# -- command line ------------------------------------------------------------------------------
_Parser = ros_arguments.OneLineParser


def main(args=None) -> int:
    argv = sys.argv if args is None else args
    parser = _Parser(prog='sweep', description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('inputs', nargs='+', help='SCENE.yaml, or with --verify the files')
    parser.add_argument('--verify', action='store_true', help='replay --verify every file')
    parser.add_argument('--vary', action='append', default=[], metavar='KEY=SPEC')
    parser.add_argument('--seeds', type=int, default=1)
    parser.add_argument('--steps', type=int, default=1000, help='physics steps a run (rounded '
                        'up to whole publish periods)')
    parser.add_argument('--out', default='sweep_out', help='directory of the runs')
    parser.add_argument('--wrench', metavar='CSV', help='a wrench schedule for every run')
    parser.add_argument('--wrench-body', metavar='NAME')
    parser.add_argument('--wrench-hold', type=float, default=0.0, metavar='SECONDS',
                        help="how long the profile's last row is held before the zero wrench "
                        "(send_wrench's --duration)")
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='a node parameter (YAML value), e.g. dt=0.0005')
    parser.add_argument('--workers', type=int, default=os.cpu_count() or 1)
    parser.add_argument('--ray', metavar='ADDRESS', help="run on Ray: 'local', 'auto' or an "
                        'address')
    opts = parser.parse_args(ros_arguments.non_ros_args(argv, 'sweep'))
    if not 1 <= opts.workers <= 4096:
        parser.error(f'--workers must be from 1 to 4096, got {opts.workers}')
    return handling_signals('sweep', lambda handle: _main(parser, opts, handle))


def handling_signals(prog: str, run) -> int:
    """``run(handle)`` (handle: this is the main thread, whose SIGINT and SIGTERM it takes)
    with SIGINT and SIGTERM stopping it alike: what finished is kept, one line says so, exit
    status 128 + the signal. The tool's own handlers (sweep's, campaign's)."""
    handle = threading.current_thread() is threading.main_thread()
    _SIGNALS.clear()
    previous = {n: signal.signal(n, _on_signal) for n in _HANDLED} if handle else {}
    try:
        return run(handle)
    except KeyboardInterrupt as e:  # SIGINT, or SIGTERM: what finished is kept
        signum = _signum(e)
        note = getattr(e, 'note', '')
        print(f'{prog}: interrupted by {signal.Signals(signum).name}'
              + (f': {note}' if note else ''), file=sys.stderr)
        return 128 + signum
    finally:
        for n, handler in previous.items():
            signal.signal(n, handler)


def _main(parser, opts, handle: bool) -> int:
    try:
        if opts.verify:
            engine = _engine(opts, handle)
            try:
                results = verify_many(opts.inputs, engine)
            finally:
                engine.close()
            bad = [r for r in results if not r[1]]
            unread = [r for r in bad if r[1] is None]
            for path, ok, text in results:
                if ok is None:  # a line of its own: the file, not the recording, is bad
                    print(f'MISSING {path}' if text == 'missing' else
                          f'UNREADABLE {path}: {text}')
                elif not ok:
                    print(f'MISMATCH {path}: {text}')
            print(f'sweep: {len(results) - len(bad)} of {len(results)} recordings verify '
                  'bit for bit' + (f', {len(unread)} could not be read' if unread else ''))
            return 1 if bad else 0
        if len(opts.inputs) != 1:
            parser.error('one scene file (or --verify and files)')
        varies = []
        for item in opts.vary:
            key, sep, spec = item.partition('=')
            if not sep or not key:
                parser.error(f'--vary takes KEY=SPEC, got {item!r}')
            varies.append((key, parse_spec(key, spec)))
        params = {}
        for item in opts.param:
            name, sep, text = item.partition('=')
            if not sep or name not in node_params.BY_NAME:
                parser.error(f'--param takes NAME=VALUE with a node parameter, got {item!r}')
            try:
                params[name] = safe_yaml.load(text, max_depth=3, max_nodes=100)
            except safe_yaml.YamlError as e:
                parser.error(f'--param {name}: {e.reason}')
        engine = _engine(opts, handle)
        try:
            rows = sweep(opts.inputs[0], varies, opts.seeds, opts.steps, opts.out, params,
                         opts.wrench, opts.wrench_body, engine, wrench_hold=opts.wrench_hold)
        finally:
            engine.close()
        failed = sum(1 for r in rows if r.get('error'))
        print(f'sweep: {len(rows)} runs in {opts.out} ({failed} failed); summary '
              f'{os.path.join(opts.out, "summary.csv")}')
        return 0
    except (ValueError, OSError) as e:
        print(f'sweep: {str(e).splitlines()[0]}', file=sys.stderr)
        return 2


def _engine(opts, handle: bool):
    engine = make_engine(opts.ray, opts.workers)
    if handle:  # ray.init sets a SIGTERM handler of its own (sys.exit): ours again
        for n in _HANDLED:
            signal.signal(n, _on_signal)
    return engine


if __name__ == '__main__':
    sys.exit(main())
