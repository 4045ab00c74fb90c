# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The benchmark suite's quick mode runs, so the suite cannot rot (no timing is asserted)."""

import json
from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]


def test_quick_benchmark_checks_orders_and_writes_its_report(tmp_path):
    result = subprocess.run([sys.executable, str(ROOT / 'bench' / 'run.py'), '--quick',
                             '--out', str(tmp_path)], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['orders_checked']
    for scene in summary['work_precision'].values():
        for method, data in scene.items():
            if data['expected_order'] is not None:
                assert abs(data['order'] - data['expected_order']) <= 0.3, method
    stress = summary['stress']
    assert stress['blow_up']['raised'] and stress['blow_up']['state_finite']
    assert stress['dzhanibekov']['relative_error'] < 1e-3
    assert stress['long_run']['max_orthonormality_error'] < 1e-12
    assert (tmp_path / 'benchmarks.md').read_text().startswith('# Benchmarks')
    assert len(list((tmp_path / 'img').glob('*.png'))) == 5
