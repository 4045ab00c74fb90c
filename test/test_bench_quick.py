# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The benchmark suite's quick mode runs, so that it cannot rot. Nothing timed is asserted
(the machine is noisy): orders, agreement with the references, and the stress outcomes."""

import importlib
import json
import math
from pathlib import Path
import subprocess
import sys

from rb_sim_ros import METHODS

ROOT = Path(__file__).resolve().parents[1]


def _bench(name):
    """A module of bench/ (which is not a package), imported by name."""
    sys.path.insert(0, str(ROOT / 'bench'))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / 'bench'))


def test_quick_benchmark_checks_orders_and_writes_its_report(tmp_path):
    result = subprocess.run([sys.executable, str(ROOT / 'bench' / 'run.py'), '--quick',
                             '--out', str(tmp_path)], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['quick'] and summary['orders_checked'] and not summary.get('failures')

    for scene in summary['work_precision'].values():
        assert scene['reference_check']['ok'], scene['reference_check']
        methods = scene['methods']
        assert {f'rb_sim_ros {m}' for m in METHODS} <= set(methods)
        assert {'MuJoCo Euler', 'MuJoCo implicitfast', 'MuJoCo RK4', 'scipy DOP853'} <= \
            set(methods)
        for name, data in methods.items():
            assert data['ok'], name
            if data['expected_order'] is not None:
                for what in ('angle', 'omega'):
                    assert abs(data[f'order_{what}'] - data['expected_order']) <= 0.3, \
                        (name, what, data[f'order_{what}'])
            timed = [p for p in data['points'] if 'diverged' not in p]
            assert timed and all(p['seconds_per_sim_second'] > 0 for p in timed)

    stress = summary['stress']
    for row in stress['blow_up']:
        assert row['raised'] and row['consistent'] and row['state_finite'], row
    flip = stress['dzhanibekov']
    eq27 = next(r for r in flip['rows'] if r['method'] == 'rb_sim_ros eq27')
    assert abs(eq27['relative_error']) < 1e-3
    for case in stress['extreme_inertia']:
        ours = case['results']['rb_sim_ros eq27']
        assert ours['finite'] and ours['angle_max'] < 1e-2, (case['case'], ours)
    first = stress['fast_spin']['rows'][0]
    assert first['omega_dt'] == 0.01
    assert first['results']['rb_sim_ros eq27']['status'] == 'accurate'
    long_run = stress['long_run']['methods']['rb_sim_ros eq27']
    assert long_run['diverged'] is None
    assert long_run['max_orthonormality_error'] < 1e-12
    assert abs(long_run['energy_drift'][-1]) < 1e-6

    assert (tmp_path / 'benchmarks.md').read_text().startswith('# Benchmarks')
    pngs = {p.name for p in (tmp_path / 'img').glob('*.png')}
    assert {'fast_spin.png', 'long_run.png'} <= pngs
    assert len([p for p in pngs if p.startswith('work_precision_')]) == 4


def test_order_check_fails_loudly_on_a_method_off_its_order():
    wp = _bench('work_precision')
    dts = [0.01, 0.005, 0.0025, 0.00125]

    def scene(order):
        points = [{'dt': dt, 'angle_final': 0.1 * (dt / 0.01) ** order,
                   'omega_final': 0.1 * (dt / 0.01) ** order} for dt in dts]
        return {'s': {'scene': {'omega0': 1.0}, 'methods': {
            'a second-order method': {'expected_order': 2, 'points': points}}}}

    assert wp.check_orders(scene(2.0)) == []
    failures = wp.check_orders(scene(1.0))
    assert len(failures) == 2 and 'falls at order 1.00, expected 2' in failures[0]
    assert math.isclose(wp.fit_order(scene(2.0)['s']['methods']['a second-order method']
                                     ['points'], 'angle_final')['order'], 2.0)


def test_collision_benchmarks_pass_their_checks_in_quick_mode(tmp_path):
    """Their checks: both engines' heaps stay in the box and agree; a resting floor of boxes
    stays put in every engine and all of it falls asleep; a drop wakes only what it hits."""
    for name in ('collision_bench', 'resting_bench'):
        out = tmp_path / f'{name}.json'
        result = subprocess.run([sys.executable, str(ROOT / 'bench' / f'{name}.py'), '--quick',
                                 '--json', str(out)], capture_output=True, text=True,
                                timeout=300)
        assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
        assert json.loads(out.read_text())
    resting = json.loads((tmp_path / 'resting_bench.json').read_text())
    assert resting['asleep']['contacts'] == 0 and resting['awake']['contacts'] > 0
    assert 1 < resting['asleep']['awake_after_drop'] < 2 * resting['side'] ** 2
