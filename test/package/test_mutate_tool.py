# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""tools/mutate.py stays usable: every mutant's edits still find their text, once, in its
file (a refactor that moves the text must move the mutant with it)."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_every_mutant_still_applies():
    spec = importlib.util.spec_from_file_location('mutate', ROOT / 'tools' / 'mutate.py')
    mutate = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mutate)
    assert mutate.MUTANTS
    for name, path, edits, *_ in mutate.MUTANTS:
        text = (ROOT / path).read_text()
        assert mutate.mutated(text, edits) != text, name
