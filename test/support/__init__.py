# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What the tests share and only the tests use; no test module imports another.

``ros_harness``: an installed simulator and a probe node over DDS (conftest.py's fixtures).
``recordings``: MCAP files taken apart and rewritten by the mcap library, a disk that fills up.
``convergence``: the body, start and wrenches of the order tests, their errors and orders.
``kernel_fingerprint``, ``narrow_fingerprint``, ``solver_fingerprint``: scripts that print
digests of runs, run compiled and interpreted by the tests that compare them. ``entity_bomb``:
untrusted XML that would expand to gigabytes.

What the tests share with the benchmarks (references, closed forms, scenarios, a run recorded
as the node records it) is in oracles/ at the top of the checkout, which conftest.py puts on
the path; ``child_env`` gives a child Python both.
"""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def entity_bomb(root: str) -> str:
    """XML whose element ``root`` has an attribute that nine levels of entities would expand
    to 10^9 characters (a billion laughs): a parser must refuse it."""
    entities = ''.join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">'
                       for p, c in zip('abcdefgh', 'bcdefghi'))
    return (f'<?xml version="1.0"?><!DOCTYPE {root} [<!ENTITY a "aaaaaaaaaa">{entities}]>'
            f'<{root} name="&i;"/>')


def child_env(env=None) -> dict:
    """``env`` (default os.environ) with PYTHONPATH leading with the checkout and test/, so that
    a child Python imports ``oracles`` and ``support`` as the tests do."""
    env = dict(os.environ if env is None else env)
    env['PYTHONPATH'] = os.pathsep.join(
        [str(ROOT), str(ROOT / 'test'), *filter(None, [env.get('PYTHONPATH')])])
    return env
