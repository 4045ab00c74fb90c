# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The type hints are checked, not only written: mypy on the layers that hold no ROS (core,
the integrator; sim, the simulation and scene files; recording, MCAP) and on the offline tools
(replay, sweep), where a hint that lies would mislead a reader most. (contact, whose kernels
numba types, and the live node are not checked yet.)"""

from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]
CHECKED = ('rb_sim_ros/core', 'rb_sim_ros/sim', 'rb_sim_ros/recording', 'rb_sim_ros/offline')


def test_mypy_finds_nothing_in_the_checked_layers(tmp_path):
    out = subprocess.run([sys.executable, '-m', 'mypy', '--ignore-missing-imports',
                          '--follow-imports=silent', '--cache-dir', str(tmp_path / 'cache'),
                          *CHECKED], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert 'Success: no issues found' in out.stdout
