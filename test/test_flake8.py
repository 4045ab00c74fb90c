# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ament linters' conventions (flake8 with quotes and google import order), from PyPI."""

from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]


def test_flake8():
    result = subprocess.run([sys.executable, '-m', 'flake8', 'rb_sim_ros', 'test', 'bench',
                             'setup.py'], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
