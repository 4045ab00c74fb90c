# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ament linters' conventions (flake8 with quotes and google import order), from PyPI."""

from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]


def _flake8(*paths):
    return subprocess.run([sys.executable, '-m', 'flake8', *map(str, paths)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)


def test_flake8():
    result = _flake8('rb_sim_ros', 'test', 'bench', 'oracles', 'examples', 'tools', 'setup.py')
    assert result.returncode == 0, result.stdout + result.stderr


# Each marked line breaks one convention that setup.cfg's [flake8] and its plugins enforce: sys
# before os is out of order (I100) and numpy, third party, follows the standard library without
# a blank line (I201) under google style; "x" is not single-quoted (Q000); the last line is 100
# columns (E501 at max-line-length 99, where the default 79 would flag the 90-column line too).
BAD = """import sys
import os
import numpy as np

x = "x"
y = (sys, os, np, x)
z = '{}'
w = '{}'
""".format('a' * 84, 'a' * 94)


def test_flake8_enforces_the_plugins_and_limits_of_setup_cfg(tmp_path):
    """The plugins are loaded and the project's configuration is read: without them flake8
    would pass code that ament_flake8 refuses."""
    bad = tmp_path / 'bad.py'
    bad.write_text(BAD)
    result = _flake8(bad)
    found = {(int(line.split(':')[1]), line.split(': ')[1].split()[0])
             for line in result.stdout.splitlines()}
    found = {(n, code) for n, code in found if code[0] in 'IQ' or code.startswith('E50')}
    assert found == {(2, 'I100'), (3, 'I201'), (5, 'Q000'), (8, 'E501')}, result.stdout
