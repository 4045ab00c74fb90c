# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Compile the kernels a simulator run needs into the compilation cache, ahead of its start.

    python -m rb_sim_ros.sim.precompile

A run of a scene without colliders needs the step kernel (``step_kernel.advance``); a run with
colliders, or a spawn of the first one, needs the collision world's step
(``world_step.world_steps``). Both are compiled here, for every integrator (one kernel serves
them all), and cached where the package caches them (``core/jit.py``): a later start of the
node, ``replay`` or ``sweep`` loads them instead of compiling. ``setup.py``'s install (what
``colcon build`` runs) calls this for the tree it installed; set RB_SIM_ROS_PRECOMPILE=0 to
skip it there. No ROS here.
"""

from __future__ import annotations

import argparse
import sys
import time

from rb_sim_ros.core import jit
from rb_sim_ros.sim.simulation import Config, warm_up_bodies, warm_up_contacts


def precompile() -> float:
    """Compile (or load) the kernels of a run without colliders and of one with them: the
    seconds it took."""
    start = time.perf_counter()
    config = Config()
    warm_up_bodies(config)
    warm_up_contacts(config)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(
        prog='python -m rb_sim_ros.sim.precompile',
        description="Compile the simulator's kernels into the compilation cache, so that "
                    'the first start of a node loads them instead of compiling them.'
    ).parse_args(sys.argv[1:] if argv is None else argv)
    where = jit.cache_directories()
    seconds = precompile()
    print(f'rb_sim_ros: kernels compiled or loaded in {seconds:.1f} s (cache: the first '
          f'writable of {", ".join(str(w) for w in where)})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
