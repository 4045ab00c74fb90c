# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""rb_sim_ros's benchmarks: a package of the checkout, never installed (setup.py leaves it out).

Run one as a module from the repository root, which puts the root on the path, so that bench,
oracles and (from the checkout or the venv) rb_sim_ros all import::

    python -m bench.step_cost --quick
    python -m bench.step_cost --help          # what it measures and its options

The benchmarks (each writes its figures, with its command, to docs/bench/<name>.json, unless
said otherwise):

* ``run``: the report, run time against error and numerical stress (docs/benchmarks.md's
  generated part, docs/img/, docs/bench/run.json); ``./tools/bench.sh`` runs it in the venv
* ``step_cost``: the cost of one Stepper step, next to MuJoCo and scipy
* ``skip_bench``: what each skip of the step saves
* ``batch_bench``: N free bodies at once, the BatchStepper next to MuJoCo
* ``collision_bench``: spheres settled in a box, next to MuJoCo
* ``collision_cases``: the collision tests' scenarios, measured (docs/collisions.md)
* ``contact_step_bench``: one body in contact, per step, next to MuJoCo
* ``cylinder_bench``: a cylinder in contact (the convex narrow phase), next to MuJoCo
* ``resting_bench``: what sleeping buys, next to MuJoCo
* ``pile_bench``: 100 boxes piling, next to Rapier and MuJoCo
* ``compile_cost``: what a first use compiles, on an empty kernel cache
* ``node_timing``: the node's late ticks, latency and fastest real-time factor
* ``node_lifecycle``: the node's start-up against scene size, and its stops
* ``lockstep_bench``: lockstep round trips with a controller
* ``sweep_bench``: sweep throughput, local and on Ray
* ``energy_drift``: energy drift against the turn per step (prints; writes no JSON)
* ``replay_bench``: republishing a recording, start-up and memory (prints; writes no JSON)

and ``figures``, which checks that every figure the docs quote is in docs/bench/*.json
(``python -m bench.figures``). The rest are the benchmarks' parts: ``scenes``, ``references``
(which uses the checkout's oracles/), ``peers``, ``work_precision``, ``stress`` and ``report``.
"""
