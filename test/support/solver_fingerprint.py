# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Print, as JSON, a SHA-256 of every output of a few contact solves, one per case named on the
command line, with their colour and iteration counts: test_collisions.py and
test_rolling_resistance.py run it compiled and with NUMBA_DISABLE_JIT=1 and compare
(``solver_fingerprints``)."""

import hashlib
import json
from pathlib import Path
import subprocess
import sys
import types

import numpy as np

from oracles.contact_cases import random_contact_set
from rb_sim_ros.contact import contact_solver as cs, solver_kernels
from support import child_env

FIELDS = ('velocity', 'angular_velocity', 'displacement', 'rotation', 'normal_impulse',
          'tangent_impulse', 'position_impulse', 'touched')


def _fingerprint(result: cs.SolveResult) -> dict:
    h = hashlib.sha256()
    for name in FIELDS:
        h.update(np.ascontiguousarray(getattr(result, name)).tobytes())
    return {'digest': h.hexdigest(), 'colours': result.colours,
            'velocity_iterations': result.velocity_iterations,
            'position_iterations': result.position_iterations,
            'pressed': int(np.count_nonzero(result.normal_impulse > 0.0))}


def friction_warm() -> dict:
    """120 random contacts among 30 free bodies (full inertia tensors) and a static one, with
    restitution, friction, a warm start and penetrations for the position pass."""
    rng = np.random.default_rng(9)
    bodies, contacts = random_contact_set(rng, 120)
    warm = rng.uniform(0.0, 0.1, 120), rng.normal(size=(120, 3)) * 0.01
    settings = cs.SolverSettings(restitution=0.4, friction=0.6)
    return _fingerprint(cs.solve(contacts, bodies, settings, *warm))


def couples() -> dict:
    """The same kind of set, spinning fast, with rolling resistance and torsional friction."""
    bodies, contacts = random_contact_set(np.random.default_rng(21), spin=3.0)
    settings = cs.SolverSettings(friction=0.6, rolling_resistance=0.02, torsional_friction=0.01)
    return _fingerprint(cs.solve(contacts, bodies, settings))


def energy_guard() -> dict:
    """12 contacts among 4 free bodies and a static one, per-contact materials, couples and
    a large warm start that 3 iterations do not undo: the solve gains energy, so the guard
    solves the plastic problem too (velocity_iterations > 3) and blends."""
    rng = np.random.default_rng(0)
    bodies, contacts = random_contact_set(rng, count=12, bodies_count=5)
    warm = rng.uniform(0.0, 2.0, 12), rng.normal(size=(12, 3))
    settings = cs.SolverSettings(velocity_iterations=3, tolerance=0.0, rolling_resistance=0.01,
                                 torsional_friction=0.01)
    restitution = np.linspace(0.5, 1.0, 12)
    friction = np.linspace(0.0, 1.5, 12)
    return _fingerprint(cs.solve(contacts, bodies, settings, *warm, restitution, friction))


def solver_fingerprints(*cases: str) -> tuple[dict, dict]:
    """(compiled, interpreted): this script's digests of the solves ``cases``,
    run compiled and with NUMBA_DISABLE_JIT=1, each in a fresh interpreter."""
    out = []
    for disable in ('0', '1'):
        env = dict(child_env(), NUMBA_DISABLE_JIT=disable)
        run = subprocess.run([sys.executable, str(Path(__file__).resolve()), *cases],
                             env=env, capture_output=True, text=True, timeout=900)
        assert run.returncode == 0, run.stderr[-3000:]
        out.append(json.loads(run.stdout.strip().splitlines()[-1]))
    compiled, interpreted = out
    assert compiled.pop('compiled') is True and interpreted.pop('compiled') is False
    return compiled, interpreted


CASES = {'friction_warm': friction_warm, 'couples': couples, 'energy_guard': energy_guard}

if __name__ == '__main__':
    out = {name: CASES[name]() for name in sys.argv[1:]}
    out['compiled'] = not isinstance(solver_kernels.solve_arrays, types.FunctionType)
    print(json.dumps(out))
