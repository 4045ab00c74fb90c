# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap ray
"""Sweeps: every variant is the scene with its values (free fall from each height, checked in
closed form), every recording verifies, a run depends only on its number (local processes and
a local Ray give the same recordings and rows), and a worker that dies mid-sweep loses
nothing."""

import csv
import os
from pathlib import Path

import pytest

from rb_sim_ros.recording import compare
from rb_sim_ros.ros import sweep

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
