# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Compile the kernels a simulator run needs into the compilation cache, ahead of its start.

    python -m rb_sim_ros.sim.precompile

A run of a scene without colliders needs the step kernel (``step_kernel.advance``); a run with
colliders, or a spawn of the first one, needs the collision world's step
(``world_step.world_steps``). Both are compiled here, for every integrator (one kernel serves
them all), and cached where the package caches them (``core/jit.py``): a later start of the
node, ``replay`` or ``sweep`` loads them instead of compiling, and a marker in the cache says
they are all there (``jit.precompiled``). ``setup.py``'s install (what ``colcon build`` runs)
calls this for the tree it installed; set RB_SIM_ROS_PRECOMPILE=0 to skip it there.

A node that finds no marker (a first start from a source checkout or a wheel) runs this in a
child process (``Background``) and steps in the interpreter meanwhile (``jit.run_interpreted``):
its first poses come within seconds instead of after the compilation. No ROS here.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
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
    jit.mark_precompiled()
    return time.perf_counter() - start


class Background:
    """``python -m rb_sim_ros.sim.precompile`` in a child process (same interpreter,
    environment and cache), its output kept for a failure's message."""

    def __init__(self) -> None:
        self.started = time.monotonic()
        self._out = tempfile.TemporaryFile()
        # This very package: run from the directory holding it (python -m puts the working
        # directory first on the path), and first on PYTHONPATH too.
        here = str(jit.PACKAGE.parent)
        path = os.pathsep.join([here] + ([os.environ['PYTHONPATH']]
                                         if os.environ.get('PYTHONPATH') else []))
        self._child = subprocess.Popen(
            [sys.executable, '-m', 'rb_sim_ros.sim.precompile', '--parent', str(os.getpid())],
            cwd=here, stdin=subprocess.DEVNULL, stdout=self._out, stderr=subprocess.STDOUT,
            env=dict(os.environ, PYTHONPATH=path))
        self.pid = self._child.pid

    def poll(self) -> str | None:
        """None while it runs; then '' if every kernel is in the cache, else why not (one
        line)."""
        code = self._child.poll()
        if code is None:
            return None
        if code == 0 and jit.precompiled():
            return ''
        if code == 0:
            return f'the compiling process left no marker in {jit.cache_directory()}'
        self._out.seek(0)
        lines = [x for x in self._out.read().decode(errors='replace').splitlines() if x.strip()]
        return (f'the compiling process exited with {code}' +
                (f': {lines[-1].strip()}' if lines else ''))

    def wait(self) -> str:
        """Wait for the child: ``poll``'s answer."""
        self._child.wait()
        return self.poll()

    def stop(self) -> None:
        """End the child if it still runs (what it cached so far stays valid)."""
        if self._child.poll() is None:
            self._child.terminate()
            try:
                self._child.wait(5)
            except subprocess.TimeoutExpired:
                self._child.kill()
                self._child.wait()
        self._out.close()


def _exit_with(parent: int) -> None:
    """End this process when ``parent`` is no longer its parent (killed, say): a node's
    compiling child does not outlive it. What it cached so far stays valid."""
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m rb_sim_ros.sim.precompile',
        description="Compile the simulator's kernels into the compilation cache, so that "
                    'the first start of a node loads them instead of compiling them.')
    parser.add_argument('--parent', type=int, default=0, metavar='PID',
                        help='exit when the process PID is gone (a node compiling in the '
                             'background)')
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if args.parent and args.parent != os.getppid():
        parser.error(f'--parent: process {args.parent} is not the parent of this one')
    if args.parent:
        threading.Thread(target=_exit_with, args=(args.parent,), daemon=True).start()
    where = jit.cache_directories()
    seconds = precompile()
    print(f'rb_sim_ros: kernels compiled or loaded in {seconds:.1f} s (cache: the first '
          f'writable of {", ".join(str(w) for w in where)})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
