# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""What a first use compiles: seconds and kernels, per case, on an empty kernel cache.

    python -m bench.compile_cost [--cases NAME ...]

Each case runs in a new process with a new, empty NUMBA_CACHE_DIR (so nothing is loaded from
an earlier run) and counts numba's compile events, which name each kernel compiled, and the
CPU seconds of its processes (what one core would take, about):

- ``stepper <integrator>``: a library user's first use, ``import rb_sim_ros``, a Stepper of
  one free body with a body-frame torque, ``step(10)``: the seconds from the start of the
  import to the step's return, and the kernels compiled;
- ``node <scene>``: what a node's first start compiles in its child process for that scene's
  kernel parts (``python -m rb_sim_ros.sim.precompile --part ...``, ``precompile.parts_of``):
  the seconds until the child has them all (the node steps in the interpreter meanwhile);
  a collision scene's part has the contact tests of its pairs of shapes only (the demo all
  but capsule-capsule, two balls on the ground two of nine), and a crate spawned among the
  balls needs a second part (their seconds each);
- ``all parts``: every part, as ``colcon build``'s install precompiles them.

The kernels compiled are those of the case's every process (numba's compile events in the
first, the kernel cache's entries of all); the kernels the package has (jit's registry) are
counted for comparison. Prints a table and writes docs/bench/compile_cost.json (``--cases``
runs some and writes nothing). The times include a loaded machine's slowness: compare cases
within one run.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import re
import resource
import subprocess
import sys
import tempfile
import time

from bench import figures

ROOT = Path(__file__).resolve().parents[1]

# A case's program prints one JSON line: {'seconds': ..., 'compiled': [names]}, the names of
# the package's kernels compiled (numba's own overloads they pull in are not counted).
STEPPER = """
import json, sys, time
start = time.perf_counter()
from numba.core import event
with event.install_recorder('numba:compile') as rec:
    from rb_sim_ros import RigidBody, State, Stepper, Wrench
    body = RigidBody(mass=2.0, inertia=[[0.2, 0.01, 0], [0.01, 0.3, 0], [0, 0, 0.4]])
    sim = Stepper(body, dt=1e-3, state=State(angular_velocity=[0, 0.1, 3.0]),
                  method=sys.argv[1])
    sim.set_wrench(Wrench(torque=[0, 0, 0.01], frame='body'))
    sim.step(10)
seconds = time.perf_counter() - start
funcs = [e.data['dispatcher'].py_func for _, e in rec.buffer if e.is_start]
names = [f.__module__.rsplit('.', 1)[-1] + '.' + f.__qualname__ for f in funcs
         if f.__module__.startswith('rb_sim_ros.')]
print(json.dumps({'seconds': seconds, 'compiled': names}))
"""

NODE = """
import json, sys, time
start = time.perf_counter()
from numba.core import event
with event.install_recorder('numba:compile') as rec:
    from rb_sim_ros.sim import precompile
    from rb_sim_ros.sim.scene import load_scene
    from rb_sim_ros.sim.simulation import Config
    if sys.argv[1] == 'all':
        parts = None
    elif sys.argv[1] == 'default':
        parts = precompile.parts_of(Config())
    elif sys.argv[1].endswith('.yaml'):
        gravity, bodies, contact = load_scene(sys.argv[1])[:3]
        parts = precompile.parts_of(Config(gravity=gravity, bodies=tuple(bodies),
                                           contact=contact))
    else:
        from rb_sim_ros.contact.collision_shapes import Box, Plane, Sphere
        from rb_sim_ros.sim.simulation import BodySpec
        balls = (BodySpec('ground', static=True, colliders=(Plane(),)),
                 BodySpec('a', colliders=(Sphere(0.1),), initial_position=(0, 0, 1)),
                 BodySpec('b', colliders=(Sphere(0.1),), initial_position=(0.5, 0, 1)))
        crate = BodySpec('crate', colliders=(Box((0.4, 0.3, 0.2)),), initial_position=(2, 0, 1))
        # two balls on the ground: two contact tests of nine; then a crate spawned, whose
        # tests the world's step was not compiled with: a second part
        parts = precompile.parts_of(Config(bodies=balls))
        if sys.argv[1] == 'balls+crate':
            parts += precompile.parts_of(Config(bodies=balls + (crate,)))
    took = precompile.precompile(parts)
seconds = time.perf_counter() - start
funcs = [e.data['dispatcher'].py_func for _, e in rec.buffer if e.is_start]
names = [f.__module__.rsplit('.', 1)[-1] + '.' + f.__qualname__ for f in funcs
         if f.__module__.startswith('rb_sim_ros.')]
print(json.dumps({'seconds': seconds, 'compiled': names, 'parts': took}))
"""

CASES = {
    'stepper eq27': (STEPPER, 'eq27'),
    'stepper lie4': (STEPPER, 'lie4'),
    'stepper flow4': (STEPPER, 'flow4'),
    'node default scene': (NODE, 'default'),
    'node collision demo': (NODE, str(ROOT / 'scenes' / 'collisions.yaml')),
    'node balls on the ground': (NODE, 'balls'),
    'node balls, a crate spawned': (NODE, 'balls+crate'),
    'all parts': (NODE, 'all'),
}


def package_kernels() -> int:
    """How many kernels the package's modules make (jit's own registry, after importing
    every module of the kernel layers: the decorated functions and those a factory makes)."""
    import importlib
    from rb_sim_ros.core import jit
    for path in jit.kernel_sources():
        importlib.import_module('.'.join(
            path.relative_to(jit.PACKAGE.parent).with_suffix('').parts))
    return len(jit._PY_FUNCS)


def cached_kernels(cache: Path) -> list[str]:
    """module.function of every kernel with an index in the kernel cache ``cache``: those
    compiled by the case's every process (a collision part compiles in two)."""
    names = set()
    for index in cache.rglob('*.nbi'):
        match = re.match(r'(.+?)-\d+\.py\d+\.nbi$', index.name)
        if match:
            names.add(match.group(1))
    return sorted(names)


def run_case(name: str) -> dict:
    program, arg = CASES[name]
    with tempfile.TemporaryDirectory(prefix='rb_sim_ros_compile_') as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        env.pop('NUMBA_DISABLE_JIT', None)
        start = time.perf_counter()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = subprocess.run([sys.executable, '-c', program, arg], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=3600)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)  # its children's too, waited for
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        in_cache = cached_kernels(Path(cache))
    if out.returncode != 0:
        raise SystemExit(f'{name}: exited with {out.returncode}: {out.stderr[-2000:]}')
    result = json.loads(out.stdout.strip().splitlines()[-1])
    compiled = sorted(set(result['compiled']) | set(in_cache))
    return {'case': name, 'seconds': result['seconds'], 'process_seconds': wall,
            'cpu_seconds': cpu,
            'kernels_compiled': len(compiled), 'compiled': compiled,
            'parts': result.get('parts', {})}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.compile_cost', description=__doc__.split('\n\n')[0])
    parser.add_argument('--cases', nargs='+', choices=sorted(CASES), metavar='NAME',
                        help=f'only these cases (of: {", ".join(CASES)}); writes no JSON')
    args = parser.parse_args(argv)
    total = package_kernels()
    rows = []
    names = args.cases or list(CASES)
    print(f'{"case":<28} {"seconds":>8} {"cpu s":>6} {"kernels":>12}  (the package has '
          f'{total} kernels)')
    for k, name in enumerate(names):
        print(f'[{k + 1}/{len(names)}] {name} ...', file=sys.stderr, flush=True)
        row = run_case(name)
        rows.append(row)
        print(f'{name:<28} {row["seconds"]:8.1f} {row["cpu_seconds"]:6.0f} '
              f'{row["kernels_compiled"]:5d} of {total:<4d}'
              + ''.join(f'  {p} {s:.1f} s' for p, s in row['parts'].items()), flush=True)
    sanity = figures.Sanity()
    for row in rows:
        sanity.within(f'{row["case"]} seconds', row['seconds'], 0.1, 3600)
        sanity.within(f'{row["case"]} kernels', row['kernels_compiled'], 1, total)
    by = {r['case']: r for r in rows}
    if 'stepper eq27' in by:
        eq27 = set(by['stepper eq27']['compiled'])
        for other in ('step_kernel.advance_body_k', 'step_kernel.advance_body_split',
                      'world_step.world_steps_two', 'free_flow.free_flow'):
            sanity.true(f'stepper eq27 compiled {other}', other not in eq27)
    if 'node balls on the ground' in by:
        balls = set(by['node balls on the ground']['compiled'])
        for other in ('_box_box', '_sphere_box', '_capsule_capsule', '_box_plane'):
            sanity.true(f'balls compiled {other}', f'narrow_kernels.{other}' not in balls)
    if not args.cases:
        figures.write(figures.DOCS_BENCH / 'compile_cost.json',
                      {'quick': False, 'package_kernels': total, 'rows': rows})
    return sanity.report()


if __name__ == '__main__':
    sys.exit(main())
