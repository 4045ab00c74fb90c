# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap ray
"""Sweeps: every variant is the scene with its values (free fall from each height, checked in
closed form), every recording verifies, a run depends only on its number (local processes and
a local Ray give the same recordings and rows), and a worker that dies mid-sweep loses
nothing."""

import csv
import io
import json
import math
import os
from pathlib import Path
import re
import shutil
import signal
import subprocess
import sys
import time

import pytest

from rb_sim_ros.offline import sweep
from rb_sim_ros.recording import compare

G = 9.81
SCENE = ('gravity: [0, 0, -9.81]\n'
         'bodies:\n'
         '  - {name: ball, shape: sphere, radius: 0.1, density: 1000, position: [0, 0, 1],\n'
         '     angular_velocity: [0, 0, 1], colliders: shape}\n'
         '  - {name: probe, mass: 1, inertia: [0.1, 0.2, 0.3], position: [5, 0, 0],\n'
         '     angular_velocity: [0.3, 1, 0.2]}\n')
VARIES = [('bodies.ball.position.2', sweep.parse_spec('', '1:3:3')),
          ('bodies.probe.mass', sweep.parse_spec('', 'uniform(0.5, 2)'))]


@pytest.fixture
def scene(tmp_path):
    f = tmp_path / 'scene.yaml'
    f.write_text(SCENE)
    return str(f)


def _run(scene, out, engine, seeds=2):
    return sweep.sweep(scene, VARIES, seeds, 100, str(out),
                       {'imu_accel_noise': 0.01, 'imu_gyro_noise': 0.001}, engine=engine,
                       progress=False)


def _run_locally(scene, out, workers=2):
    engine = sweep.LocalEngine(workers)
    try:
        return _run(scene, out, engine)
    finally:
        engine.close()


def _same_files(a, b):
    """Every recording of ``a`` holds what its namesake in ``b`` holds, bit for bit (not byte
    for byte: rclpy's CDR leaves padding uninitialised; recording/compare.py)."""
    names = sorted(p.name for p in Path(a).glob('*.mcap'))
    assert names == sorted(p.name for p in Path(b).glob('*.mcap')) and len(names) == 6
    return all(compare.difference(str(Path(a) / n), str(Path(b) / n)) == '' for n in names)


def _summary(out, drop=('wall_s', 'cpu_s')):
    with open(Path(out) / 'summary.csv') as f:
        return [{k: v for k, v in row.items() if k not in drop} for row in csv.DictReader(f)]


def test_specs_lists_ranges_and_distributions():
    assert sweep.parse_spec('k', '1:2:3') == ('values', [1.0, 1.5, 2.0])
    assert sweep.parse_spec('k', '[[0, 0, 1], [0, 0, 2]]') == ('values', [[0, 0, 1],
                                                                          [0, 0, 2]])
    assert sweep.parse_spec('k', '0.1, 0.2') == ('values', [0.1, 0.2])
    assert sweep.parse_spec('k', 'normal(0, 0.5)') == ('draw', ('normal', 0.0, 0.5))
    for bad in ('1:2', '1:2:0', 'uniform(2, 1)', 'normal(0, -1)', '[', '[]', 'nan:1:2'):
        with pytest.raises(ValueError, match='--vary k'):
            sweep.parse_spec('k', bad)
    runs, draws = sweep.plan([('a', ('values', [1, 2])), ('b', ('values', [3, 4, 5]))], 2)
    assert len(runs) == 12 and runs[3] == (3, 1, {'a': 1, 'b': 4})
    d = sweep.drawn({'m': ('uniform', 0.5, 2.0)}, 7, 1)
    assert d == sweep.drawn({'m': ('uniform', 0.5, 2.0)}, 7, 1) != sweep.drawn(
        {'m': ('uniform', 0.5, 2.0)}, 8, 1)
    assert 0.5 <= d['m'] <= 2.0


def test_a_local_sweep_runs_every_variant_and_every_file_verifies(scene, tmp_path):
    out = tmp_path / 'local'
    engine = sweep.LocalEngine(2)
    try:
        rows = _run(scene, out, engine)
        results = sweep.verify_many(sorted(str(p) for p in out.glob('*.mcap')), engine,
                                    progress=False)
    finally:
        engine.close()
    assert len(rows) == 6 and not any(r.get('error') for r in rows)
    assert all(ok for _, ok, _ in results) and len(results) == 6
    for row in _summary(out):
        z0 = float(row['bodies.ball.position.2'])
        # 100 steps of 1 ms: free fall, z = z0 - g t^2 / 2 (exact for the method, to rounding)
        assert float(row['ball.z']) == pytest.approx(z0 - 0.5 * G * 0.1 ** 2, abs=1e-12)
        assert float(row['ball.vz']) == pytest.approx(-G * 0.1, abs=1e-12)
        assert row['steps'] == '100' and row['file'] == f'run_{int(row["run"]):06d}.mcap'
        assert 0.5 <= float(row['bodies.probe.mass']) <= 2.0
    # Seeds differ in the IMU noise (and the drawn mass), not in the ball's motion.
    a, b = _summary(out)[:2]
    assert a['ball.z'] == b['ball.z'] and a['bodies.probe.mass'] != b['bodies.probe.mass']
    assert not (out / 'summary.partial.jsonl').exists()


@pytest.mark.slow  # a Ray cluster started and a worker killed
def test_ray_gives_the_same_files_and_rows_and_a_dead_worker_loses_nothing(
        scene, tmp_path, monkeypatch):
    local = tmp_path / 'local'
    _run_locally(scene, local, workers=1)  # tasks of several runs (of one with 2 workers)
    # A worker dies on its first try of run 3 (os._exit: as if killed), on either engine.
    monkeypatch.setenv(sweep.DIE_ONCE_ENV, f'{tmp_path / "died-local"}:3')
    dead_local = tmp_path / 'dead_local'
    _run_locally(scene, dead_local)
    assert (tmp_path / 'died-local').exists()
    assert _same_files(dead_local, local) and _summary(dead_local) == _summary(local)
    monkeypatch.setenv(sweep.DIE_ONCE_ENV, f'{tmp_path / "died-ray"}:4')
    ray_out = tmp_path / 'ray'
    engine = sweep.RayEngine('local', 2)
    try:
        _run(scene, ray_out, engine)
        results = sweep.verify_many([str(p) for p in sorted(ray_out.glob('*.mcap'))], engine,
                                    progress=False)
    finally:
        engine.close()
    assert (tmp_path / 'died-ray').exists()
    assert _same_files(ray_out, local)
    assert _summary(ray_out) == _summary(local)
    assert all(ok for _, ok, _ in results)


def test_a_variant_that_cannot_run_is_a_row_not_the_end(scene, tmp_path):
    varies = [('bodies.probe.mass', sweep.parse_spec('', '[1.0, -1.0, 2.0]'))]
    engine = sweep.LocalEngine(1)
    try:
        rows = sweep.sweep(scene, varies, 1, 50, str(tmp_path / 'o'), engine=engine,
                           progress=False)
    finally:
        engine.close()
    assert [bool(r.get('error')) for r in rows] == [False, True, False]
    assert 'mass' in rows[1]['error']
    assert sorted(os.listdir(tmp_path / 'o')) == ['run_000000.mcap', 'run_000002.mcap',
                                                  'summary.csv']


@pytest.mark.parametrize('args, words', [
    (['--vary', 'bodies.nobody.mass=1:2:2'], "no 'nobody'"),
    (['--vary', 'gravity'], 'KEY=SPEC'),
    (['--vary', 'contact.restitution=1:2'], '--vary contact.restitution'),
    (['--param', 'nonsense=1'], 'node parameter'),
    (['--param', 'dt=-1'], 'dt'),
    (['--steps', '0'], '--steps'),
    (['--wrench', '/nonexistent.csv'], 'nonexistent'),
    (['--workers', '0'], '--workers'),
])
def test_bad_arguments_are_one_line(scene, tmp_path, capsys, args, words):
    try:
        code = sweep.main(['sweep', scene, '--out', str(tmp_path / 'o'), *args])
    except SystemExit as e:  # argparse's own refusals
        code = e.code
    err = capsys.readouterr().err
    assert code == 2 and err.count('\n') == 1 and words in err, err


def test_the_comparison_sees_one_bit(scene, tmp_path):
    """compare.difference: equal for two runs of the same variant, not for another seed's
    IMU noise, nor for a run whose one input differs."""
    a, b = tmp_path / 'a', tmp_path / 'b'
    engine = sweep.LocalEngine(1)
    try:
        for out in (a, b):
            sweep.sweep(scene, [], 2, 50, str(out), {'imu_accel_noise': 0.01}, engine=engine,
                        progress=False)
    finally:
        engine.close()
    assert compare.difference(str(a / 'run_000000.mcap'), str(b / 'run_000000.mcap')) == ''
    diff = compare.difference(str(a / 'run_000000.mcap'), str(b / 'run_000001.mcap'))
    assert 'metadata' in diff  # imu_seed is a parameter: the metadata says so first
    assert compare.message_values(-0.0) != compare.message_values(0.0)


def test_a_run_that_always_kills_its_worker_fails_alone(scene, tmp_path, monkeypatch):
    """Run 2 kills its worker every time: after its retry it is recorded as failed; the
    runs that shared the pool with it are run again, not charged, and all succeed."""
    monkeypatch.setenv(sweep.DIE_ONCE_ENV, 'always:2')
    rows = _run_locally(scene, tmp_path / 'o')
    failed = [r['run'] for r in rows if r.get('error')]
    assert failed == [2] and 'worker died twice' in rows[2]['error']
    assert len(list((tmp_path / 'o').glob('*.mcap'))) == 5


def test_the_wrench_schedule_is_what_send_wrench_sends(tmp_path, scene):
    """A 1 N push on the 1 kg probe from t = 0, the profile's only row, held 0.05 s, then the
    zero send_wrench sends: the probe ends at 0.05 m/s (the zero taken at the period boundary,
    t = 0.05 s, as the node takes inputs)."""
    profile = tmp_path / 'p.csv'
    profile.write_text('t,fx,fy,fz,tx,ty,tz\n0,1,0,0,0,0,0\n')
    engine = sweep.LocalEngine(1)
    try:
        rows = sweep.sweep(scene, [], 1, 200, str(tmp_path / 'o'), None,
                           str(profile), 'probe', engine, progress=False, wrench_hold=0.05)
    finally:
        engine.close()
    assert float(rows[0]['probe.vx']) == pytest.approx(0.05, abs=1e-12)
    assert sweep.verify_many([str(tmp_path / 'o' / 'run_000000.mcap')], progress=False)[0][1]


def test_a_ray_address_that_is_not_one_is_one_line(scene, tmp_path, capsys):
    code = sweep.main(['sweep', scene, '--out', str(tmp_path / 'o'), '--ray', 'bogus://x'])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith('sweep: --ray bogus://x') and err.count('\n') == 1


# -- stopping: SIGTERM as SIGINT, and workers that never outlive the driver ---------------------
def _children(pid):
    """{child pid: its start time} of the processes whose parent is ``pid`` (from /proc)."""
    out = {}
    for entry in os.listdir('/proc'):
        if entry.isdigit():
            stat = _stat(int(entry))
            if stat is not None and stat[1] == pid:
                out[int(entry)] = stat[2]
    return out


def _stat(pid):
    """(state, parent, start time) of a process from /proc/PID/stat, None if it is gone."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            text = f.read()
    except OSError:
        return None
    fields = text[text.rindex(')') + 2:].split()  # after 'pid (name) '
    return fields[0], int(fields[1]), int(fields[19])


def _alive(children):
    """Those of ``children`` still running: not gone, not a zombie, not a new process that
    took a freed pid."""
    return [pid for pid, start in children.items()
            if (s := _stat(pid)) is not None and s[0] not in 'ZX' and s[2] == start]


def _wait_for(condition, what, bound_s=600.0):
    deadline = time.monotonic() + bound_s
    while not condition():
        assert time.monotonic() < deadline, f'gave up waiting for {what}'
        time.sleep(0.2)


def _partial_rows(out):
    try:
        with open(out / 'summary.partial.jsonl') as f:
            return [json.loads(line) for line in f if line.endswith('\n')]
    except OSError:
        return []


@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGKILL])
def test_a_signal_to_the_driver_ends_its_workers_and_sigterm_keeps_what_finished(
        scene, tmp_path, signum):
    """N04: the sweep command with two workers, signalled once its first rows are in. SIGTERM
    (as SIGINT): exit 128 + 15 with one line, summary.csv of every finished run (free fall,
    checked in closed form) and nothing else. SIGKILL: no summary can be written, but the
    workers and the resource tracker go with the driver, none blocked for ever."""
    out = tmp_path / 'o'
    stdout_file, stderr_file = tmp_path / 'stdout', tmp_path / 'stderr'
    with open(stdout_file, 'w') as o, open(stderr_file, 'w') as e:  # not pipes: a child that
        driver = subprocess.Popen(  # outlived the driver would hold them open
            [sys.executable, '-m', 'rb_sim_ros.offline.sweep', scene, '--seeds', '400', '--steps',
             '2000', '--workers', '2', '--out', str(out)], stdout=o, stderr=e)
    try:
        _wait_for(lambda: _partial_rows(out) or driver.poll() is not None, 'a first row')
        children = _children(driver.pid)
        before = _partial_rows(out)
        assert driver.poll() is None and len(children) >= 2  # two workers (and a tracker)
        os.kill(driver.pid, signum)
        code = driver.wait(timeout=300)
    finally:
        if driver.poll() is None:
            driver.kill()
    _wait_for(lambda: not _alive(children), f'the workers {_alive(children)} to end', 120)
    stdout, stderr = stdout_file.read_text(), stderr_file.read_text()
    if signum == signal.SIGKILL:
        assert code == -signal.SIGKILL
        return
    assert code == 128 + signal.SIGTERM, stderr
    # One line says what happened; progress lines (one each 10 s) never claim it finished.
    said = [line for line in stderr.splitlines()
            if not re.match(r'sweep: \d+/400 runs \(', line)]
    assert len(said) == 1 and 'SIGTERM' in said[0] and stdout == '', stderr
    assert '400/400' not in stderr and '100.0%' not in stderr, stderr
    rows = _summary(out)
    runs = [int(r['run']) for r in rows]
    assert set(r['run'] for r in before) <= set(runs) and len(runs) < 400
    assert runs == sorted(set(runs))
    assert sorted(os.listdir(out)) == sorted([f'run_{r:06d}.mcap' for r in runs]
                                             + ['summary.csv'])
    for row in rows:  # 2000 steps of 1 ms from z = 1: z = 1 - g t^2 / 2
        assert not row['error'] and row['steps'] == '2000'
        assert float(row['ball.z']) == pytest.approx(1 - 0.5 * G * 2.0 ** 2, abs=1e-9)
    assert f'{len(rows)} of 400 runs finished' in stderr


# -- what --vary takes -----------------------------------------------------------------------
@pytest.mark.parametrize('spec', [
    'uniform(-1e308, 1e308)',  # the span b - a overflows (numpy's traceback, before)
    'normal(1e308, 1e307)',  # draws beyond a float
    'normal(0, 1e307)',
    '-1e308:1e308:3',  # the span, so the spacing (a NaN blamed on the scene file, before)
    '1.7e308:-1.7e308:2',
    '[1e999]', '[.inf, 1]', '[.nan]', '[[0, 0, -.inf]]', '1, 2e400',
    '[1' + '0' * 400 + ']',  # an integer no float holds
])
def test_a_vary_spec_with_a_value_that_is_not_a_finite_float_is_refused(spec):
    with pytest.raises(ValueError) as e:
        sweep.parse_spec('bodies.probe.mass', spec)
    assert str(e.value).startswith(f'--vary bodies.probe.mass={spec}: '[:60])
    assert '\n' not in str(e.value)


def test_vary_specs_at_the_edge_of_a_float_that_fit_are_taken():
    assert sweep.parse_spec('k', '-8e307:8e307:3') == ('values', [-8e307, 0.0, 8e307])
    kind, (_, a, b) = sweep.parse_spec('k', 'uniform(-8e307, 8e307)')
    assert kind == 'draw' and (a, b) == (-8e307, 8e307)
    draws = [sweep.drawn({'k': ('uniform', a, b)}, r, 0)['k'] for r in range(100)]
    draws += [sweep.drawn({'k': ('normal', 0.0, 1e306)}, r, 0)['k'] for r in range(1000)]
    assert all(math.isfinite(v) for v in draws)
    assert sweep.parse_spec('k', '[1' + '0' * 300 + ']') == ('values', [10 ** 300])


@pytest.mark.parametrize('spec', ['uniform(-1e308, 1e308)', '-1e308:1e308:3'])
def test_the_sweep_command_refuses_an_overflowing_vary_in_one_line(scene, tmp_path, capsys,
                                                                   spec):
    code = sweep.main(['sweep', scene, '--out', str(tmp_path / 'o'), '--vary',
                       f'bodies.probe.mass={spec}'])
    err = capsys.readouterr().err
    assert code == 2 and err.count('\n') == 1, err
    assert err.startswith(f'sweep: --vary bodies.probe.mass={spec}: ') and 'scene' not in err
    assert not (tmp_path / 'o').exists()


def test_a_vector_index_is_a_plain_number():
    data = {'bodies': [{'name': 'b', 'position': [0, 0, 1]}]}
    for part in ('\u00b2', '9' * 5000):  # str.isdigit() takes both; int() takes neither
        with pytest.raises(ValueError, match=f'--vary bodies.b.position.{part[:10]}'):
            sweep.set_key(data, f'bodies.b.position.{part}', 2.0)
    sweep.set_key(data, 'bodies.b.position.2', 2.0)
    assert data['bodies'][0]['position'] == [0, 0, 2.0]


@pytest.mark.parametrize('count, workers', [(1, 1), (10, 1), (100, 2), (61, 3), (10_000, 2)])
def test_tasks_cover_the_runs_largest_first_and_end_in_single_runs(count, workers):
    """Guided scheduling: every run once, in order; sizes never grow, at most 64; the last
    tasks (as many as the workers) are single runs, so no worker idles long at the end."""
    tasks = sweep.chunks(count, workers)
    assert [r for start, stop in tasks for r in range(start, stop)] == list(range(count))
    sizes = [stop - start for start, stop in tasks]
    assert sizes == sorted(sizes, reverse=True) and max(sizes) <= 64
    assert sizes[-workers:] == [1] * min(workers, len(sizes))
    assert len(tasks) < count / 4 + 8 * workers + 40  # (not one task a run: amortised)


# -- --verify of many files ------------------------------------------------------------------
def test_verify_reports_a_missing_file_alone(scene, tmp_path, capsys):
    """N17: ten paths on one worker (the first tasks of two), the fourth not there: one line
    names it; the nine recordings that are there verify, as they do alone."""
    engine = sweep.LocalEngine(1)
    try:
        sweep.sweep(scene, [], 1, 50, str(tmp_path / 'o'), engine=engine, progress=False)
    finally:
        engine.close()
    good = tmp_path / 'o' / 'run_000000.mcap'
    paths = []
    for k in range(10):
        path = tmp_path / f'copy_{k}.mcap'
        if k != 3:
            shutil.copy(good, path)
        paths.append(str(path))
    # the missing one shares its task with a good one
    assert (2, 4) in sweep.chunks(10, 1)
    code = sweep.main(['sweep', '--verify', *paths, '--workers', '1'])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1
    assert lines == [f'MISSING {paths[3]}',
                     'sweep: 9 of 10 recordings verify bit for bit, 1 could not be read']
    results = sweep.verify_many(paths, progress=False)
    assert [ok for _, ok, _ in results] == [True] * 3 + [None] + [True] * 6, results


# -- progress --------------------------------------------------------------------------------
class _Stream(io.StringIO):
    def __init__(self, tty):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


def test_progress_is_whole_lines_in_a_pipe_and_a_bar_on_a_terminal(monkeypatch):
    pipe = _Stream(False)
    monkeypatch.setattr(sys, 'stderr', pipe)
    monkeypatch.setattr(sweep.Progress, 'PLAIN_EVERY_S', 0.0)
    show = sweep.Progress(3, 'sweep', 'runs')
    for done in range(4):
        show(done)
    show.close()
    text = pipe.getvalue()
    assert '\r' not in text and text.endswith('\n')
    assert text.splitlines()[-1].startswith('sweep: 3/3 runs (100.0%)')
    pytest.importorskip('tqdm')
    tty = _Stream(True)
    monkeypatch.setattr(sys, 'stderr', tty)
    show = sweep.Progress(3, 'sweep', 'runs')
    bar = show.bar
    for done in range(4):
        show(done)
    show.close()
    assert bar is not None and '3/3' in tty.getvalue()
