# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Compile the kernels a simulator run needs into the compilation cache, ahead of its start.

    python -m rb_sim_ros.sim.precompile [--integrator NAME ...] [--no-contact]

The kernels come in parts (``PARTS``): the step of a family of integrators (``step_kernel``:
two-step, k-step, splitting) for bodies without colliders, and the collision world's step
(``world_step.world_steps_two`` and its twins) with that family's body step inside (its
longest kernels compiled in two processes side by side, ``_contact_leaves_beside``). The
collision parts of ``PARTS`` hold every contact test; a scene's own part
(``world_step.contact_part``, 'contact-two-step:sphere-plane', what ``parts_of`` names when
no precompiled part holds its tests) only the tests of the pairs of shapes it has. A kernel
is compiled the first time a run calls it, so a run compiles its parts only; this compiles
the parts asked for (by default all of them) and caches them where the package caches them
(``core/jit.py``), leaving a marker for each (``jit.precompiled``): a later start of the
node, ``replay`` or ``sweep`` loads them instead of compiling. ``setup.py``'s install (what
``colcon build`` runs) calls this for the tree it installed; set RB_SIM_ROS_PRECOMPILE=0 to
skip it there.

A node that finds the markers of its own parts missing (a first start from a source checkout
or a wheel) runs this for those parts in a child process (``Background``) and steps in the
interpreter meanwhile (``jit.run_interpreted``): its first poses come within seconds instead of
after the compilation. No ROS here.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time

from rb_sim_ros.contact import narrow_kernels as nk, world_step as ws
from rb_sim_ros.core import jit, multistep, step_kernel as K
from rb_sim_ros.sim.simulation import Config, contact_probe, contact_tests, warm_up_bodies


# One integrator of each family of the step kernel: the kernels compiled for it serve the
# family's others (lie3 and lie4, eq27 and taylor1, flow2 and flow4).
FAMILY_METHODS = {K.FAMILY_TWO: multistep.EQ27.name, K.FAMILY_K: multistep.LIE4.name,
                  K.FAMILY_SPLIT: multistep.FLOW4.name}
FAMILY_NAMES = K.FAMILY_NAMES
# The kinds of parts: the body step of a few bodies, of many bodies a block at a time (two-step
# methods only: ``step_kernel.blocked``), and the collision world's step.
KINDS = ('bodies', 'blocks', 'contact')


def _exists(kind: str, family: int) -> bool:
    return kind != 'blocks' or family == K.FAMILY_TWO


PARTS = tuple(f'{kind}-{FAMILY_NAMES[f]}' for kind in KINDS for f in K.FAMILIES
              if _exists(kind, f))


def parts(integrators=None, contact: bool = True) -> list[str]:
    """The parts for runs with these integrators (names; None: every family), with colliders
    too when ``contact``."""
    families = (K.FAMILIES if integrators is None else
                sorted({K.family_of(multistep.method_by_name(i).steps) for i in integrators}))
    kinds = KINDS if contact else KINDS[:-1]
    return [f'{kind}-{FAMILY_NAMES[f]}' for kind in kinds for f in families
            if _exists(kind, f)]


def parts_of(config: Config, world=None) -> list[str]:
    """The parts a run of ``config`` (its collision ``world`` if it has one) steps with: the
    collision world's of its family and contact tests (``simulation.contact_tests``: the
    world's, else a precompiled part that holds those its shapes need, else its own) when a
    moving body has colliders, else its family's body step, and the block step too with
    ``step_kernel.BLOCK_MIN`` moving bodies or more (two-step methods). The others only a
    spawn or a delete can call for (a first moving collider, a new kind of shape, the last
    collider deleted, the BLOCK_MIN-th body); the node then compiles (or loads) them
    (``sim.kernels_after``)."""
    family = K.family_of(multistep.method_by_name(config.integrator).steps)
    if any(b.colliders for b in config.moving_bodies):
        return [ws.contact_part(family, contact_tests(config, world))]
    many = len(config.moving_bodies) >= K.BLOCK_MIN
    return [f'{kind}-{FAMILY_NAMES[family]}' for kind in ('bodies', 'blocks')
            if kind == 'bodies' or (many and _exists(kind, family))]


def part(name: str) -> tuple[str, int, int]:
    """(kind, family, contact tests) of the part ``name``: one of ``PARTS`` (every contact
    test) or a collision part of some tests (``world_step.contact_part``); ValueError (one
    line) for another."""
    if name in PARTS:
        kind, family_name = name.split('-', 1)
        family = next(f for f, n in FAMILY_NAMES.items() if n == family_name)
        return kind, family, nk.PAIRS_ALL
    try:
        family, tests = ws.part_tests(name)
    except ValueError as e:
        raise ValueError(f'no kernel part {name!r}: one of {", ".join(PARTS)}, or a contact '
                         "part, as 'contact-two-step:sphere-sphere+sphere-plane' "
                         f'({e})') from None
    return 'contact', family, tests


def precompile(names=None, progress=None) -> dict[str, float]:
    """Compile (or load) the kernels of the parts ``names`` (None: all of ``PARTS``), marking
    each once it is cached: the seconds each took. ``progress(part, seconds)`` after each."""
    took = {}
    names = list(PARTS if names is None else names)
    for name in names:
        part(name)  # every name checked before anything compiles
    for name in names:
        kind, family, tests = part(name)
        start = time.perf_counter()
        config = Config(integrator=FAMILY_METHODS[family])
        marker = name
        if kind == 'contact':
            # marked by its name in one spelling (another order of the same pairs is the same)
            marker = ws.contact_part(family, tests)
            world = contact_probe(config, tests)  # what warm_up_contacts warms up
            if not jit.precompiled([marker]):
                _contact_leaves_beside(world, marker)
            world.warm_up()
        else:
            warm_up_bodies(config, blocks=kind == 'blocks')
        jit.mark_precompiled(marker)
        took[name] = time.perf_counter() - start
        if progress is not None:
            progress(name, took[name])
    return took


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _contact_leaves_beside(world, name: str) -> None:
    """With two cores or more, the first group of the collision world's longest kernels
    (``world_step.LEAF_GROUPS``) compiled in a child beside this process, which compiles the
    others; then ``world.warm_up()`` loads them (about a third less time to wait on two
    cores). A child that fails costs nothing but the time: what it did not cache, the
    warm-up compiles (its output goes where this process's does). One core, or no cache to
    share: nothing here (the warm-up compiles them all, one after the other).

    The two processes never compile one kernel at the same time: numba's cache index is
    read, extended and written back without a lock, and two processes saving two overloads
    of one kernel at once could leave an index naming the other's code. So ``world``, the
    probe world of the collision part ``name`` (``contact_probe``), is built before (building
    it compiles a few step kernels, which the child then loads), and the groups share no
    kernel."""
    if (_cores() < 2 or not jit.compiling() or jit.interpreted()
            or jit.cache_directory() is None):
        return
    first, *rest = ws.LEAF_GROUPS
    child = _python_m('--parent', str(os.getpid()), '--leaves', first, '--part', name,
                      out=None)
    try:
        for group in rest:
            world.compile_leaves(group)
    except BaseException:
        child.terminate()  # what it cached so far stays valid
        raise
    finally:
        child.wait()


def _python_m(*args, out):
    """``python -m rb_sim_ros.sim.precompile args`` in a child (same interpreter, environment
    and cache: this very package, run from the directory holding it since python -m puts the
    working directory first on the path, and first on PYTHONPATH too); its output and errors
    into ``out`` (None: this process's)."""
    here = str(jit.PACKAGE.parent)
    path = os.pathsep.join([here] + ([os.environ['PYTHONPATH']]
                                     if os.environ.get('PYTHONPATH') else []))
    return subprocess.Popen([sys.executable, '-m', 'rb_sim_ros.sim.precompile', *args],
                            cwd=here, stdin=subprocess.DEVNULL, stdout=out,
                            stderr=subprocess.STDOUT, env=dict(os.environ, PYTHONPATH=path))


class Background:
    """``python -m rb_sim_ros.sim.precompile`` in a child process (same interpreter,
    environment and cache), its output kept for a failure's message."""

    def __init__(self, names) -> None:
        self.parts = list(names)
        self.started = time.monotonic()
        self._out = tempfile.TemporaryFile()
        self._child = _python_m('--parent', str(os.getpid()), '--part', *self.parts,
                                out=self._out)
        self.pid = self._child.pid

    def poll(self) -> str | None:
        """None while it runs; then '' if every kernel is in the cache, else why not (one
        line)."""
        code = self._child.poll()
        if code is None:
            return None
        if code == 0 and jit.precompiled(self.parts):
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
        return self.poll() or ''  # (None only while it runs)

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


def _part_name(name: str) -> str:
    """``--part``'s check: a part's name (``part``), else argparse's one-line error."""
    try:
        part(name)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return name


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m rb_sim_ros.sim.precompile',
        description="Compile the simulator's kernels into the compilation cache, so that "
                    'the first start of a node loads them instead of compiling them.')
    parser.add_argument('--parent', type=int, default=0, metavar='PID',
                        help='exit when the process PID is gone (a node compiling in the '
                             'background)')
    parser.add_argument('--integrator', nargs='+', metavar='NAME',
                        choices=sorted(multistep.METHODS),
                        help='only the kernels of these integrators (default: every family)')
    parser.add_argument('--no-contact', action='store_true',
                        help='not the collision world (a run without colliders)')
    parser.add_argument('--part', nargs='+', type=_part_name, metavar='PART',
                        help=f'exactly these parts: {", ".join(PARTS)}, or a collision part '
                             'with the contact tests of some pairs of shapes alone, as '
                             "'contact-two-step:sphere-sphere+sphere-plane' (pairs of "
                             f'{", ".join(nk.KIND_NAMES)})')
    parser.add_argument('--leaves', choices=ws.LEAF_GROUPS, metavar='GROUP',
                        help="only this group of the collision world's kernels, for the "
                             'collision part given (a part compiled in two processes: '
                             f'{", ".join(ws.LEAF_GROUPS)})')
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if args.parent and args.parent != os.getppid():
        parser.error(f'--parent: process {args.parent} is not the parent of this one')
    if args.parent:
        threading.Thread(target=_exit_with, args=(args.parent,), daemon=True).start()
    if args.leaves:
        if (len(args.part or ()) != 1 or part(args.part[0])[0] != 'contact' or args.no_contact
                or args.integrator):
            parser.error('--leaves: with one collision --part, and no --integrator or '
                         '--no-contact')
        _, family, tests = part(args.part[0])
        contact_probe(Config(integrator=FAMILY_METHODS[family]), tests).compile_leaves(
            args.leaves)
        return 0
    names = args.part or parts(args.integrator, not args.no_contact)
    where = jit.cache_directories()
    print(f'rb_sim_ros: compiling {len(names)} kernel parts into the first writable of '
          f'{", ".join(str(w) for w in where)}', flush=True)
    took = precompile(names, lambda name, s: print(
        f'rb_sim_ros: {name}: compiled or loaded in {s:.1f} s', flush=True))
    print(f'rb_sim_ros: kernels compiled or loaded in {sum(took.values()):.1f} s', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
