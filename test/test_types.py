# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The type hints are checked, not only written: mypy on the layers that hold no ROS (core,
the integrator; recording, MCAP), where a hint that lies would mislead a reader most. (sim and
offline still have hints mypy refuses: the next layers to check.)"""

from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ('rb_sim_ros/core', 'rb_sim_ros/recording')


def test_mypy_finds_nothing_in_the_checked_layers(tmp_path):
    out = subprocess.run([sys.executable, '-m', 'mypy', '--ignore-missing-imports',
                          '--follow-imports=silent', '--cache-dir', str(tmp_path / 'cache'),
                          *CHECKED], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert 'Success: no issues found' in out.stdout
