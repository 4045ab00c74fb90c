# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The one place kernels are compiled: ``kernel`` and ``parallel_kernel`` (numba).

A kernel is a plain Python function over float64/int64 arrays and floats. Compiled with
``numba.njit``; with ``NUMBA_DISABLE_JIT=1`` in the environment the very same functions run in
the interpreter, and ``test/core/test_kernels.py`` checks that both give the same bits. Never
``fastmath``: it lets LLVM reorder and fuse (a*b + c as one FMA) floating-point operations, and a
recording would no longer replay bit for bit against the interpreter or another machine.

Cache. Compiled code is cached on disk (``cache=True``) so that only the first start compiles.
numba keys its cache on the modification time of the file holding the compiled function, not
on the files of the functions it calls, so an edit of a helper in another module would keep
serving stale machine code. Our kernels are therefore cached by ``_SourceHashLocator``: one
stamp, a hash of every module of the layers that hold kernels (core and contact, with their
packages), so any edit
there recompiles them all. The cache lives in the package's ``__pycache__/numba``; where that
is read-only (an installed tree) in the user's cache directory
(``$XDG_CACHE_HOME/rb_sim_ros/numba``); ``NUMBA_CACHE_DIR`` overrides both.

Two tiers. A process can run every kernel in the interpreter for a while (``run_interpreted``)
and go back to the compiled ones (``run_compiled``): the node does so on a first start, while a
child process compiles (``sim/precompile.py``). It swaps each module global of the package that
names a kernel for the kernel's own Python function (as NUMBA_DISABLE_JIT=1 does at import), so
the bits are the same in either tier, and nothing compiles in this process meanwhile.
``precompile`` leaves a marker in the cache (``precompiled``) for each part of the kernels
(a family of methods, with or without contact) once that part is there; a kernel is compiled
the first time a run calls it, so a run compiles what it uses and nothing else.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import linecache
import os
from pathlib import Path
import sys
import tempfile
import threading

# Intel's SVML, where numba finds it (conda's icc_rt), would let LLVM vectorise sin and cos
# with its own routines, whose last bits are not libm's: a block's lanes (step_kernel) would no
# longer give a body the bits of its step alone. Off, unless numba was imported before us.
os.environ.setdefault('NUMBA_DISABLE_INTEL_SVML', '1')

import numba  # noqa: E402
from numba.core import caching, cgutils, errors, types  # noqa: E402
from numba.core.dispatcher import Dispatcher  # noqa: E402
from numba.core.registry import cpu_target  # noqa: E402
from numba.extending import intrinsic, overload  # noqa: E402
import numpy as np  # noqa: E402

PACKAGE = Path(__file__).resolve().parent.parent
# The layers whose modules hold kernels: the text of every module in them is the cache's stamp.
KERNEL_LAYERS = ('core', 'contact')

_OPTIONS = dict(cache=True, fastmath=False, error_model='python', nogil=True)


# Every kernel made here, by id(): its Python function by the compiled one and the other way
# round (by id, so that no module global's own __hash__ or __eq__ runs in a swap).
_PY_FUNCS: dict = {}
_KERNELS: dict = {}
_tier = threading.RLock()
_interpreted = False
# How many times the tier changed (run_interpreted, run_compiled): what was made for a tier
# (jit.entry_point's) is good while this stays the same.
swaps = 0


def _made(compiled):
    """Register a new kernel; in a module imported while interpreted, its Python function (which
    ``run_compiled`` rebinds as it does the others)."""
    py_func = getattr(compiled, 'py_func', None)
    if py_func is None:  # NUMBA_DISABLE_JIT=1: the function itself
        return compiled
    with _tier:
        _PY_FUNCS[id(compiled)] = (compiled, py_func)
        _KERNELS[id(py_func)] = (py_func, compiled)
        return py_func if _interpreted else compiled


def kernel(function):
    """Compile ``function`` (serial)."""
    return _made(numba.njit(**_OPTIONS)(function))


def inline_kernel(function):
    """Compile ``function`` into each kernel that calls it (numba's inline='always'): for the
    stages of a step that take the world's arrays as one named tuple, which a call would
    otherwise pass member by member, with a reference count for each."""
    return _made(numba.njit(inline='always', **_OPTIONS)(function))


def parallel_kernel(function):
    """Compile ``function`` with ``numba.prange`` loops run on every core: only for loops over
    independent bodies, never across a sweep whose order matters."""
    return _made(numba.njit(parallel=True, **_OPTIONS)(function))


def compiled(function):
    """The compiled kernel of ``function`` (a kernel, or its Python function in the
    interpreted tier), whatever the tier; ``function`` itself without numba's compiler."""
    with _tier:
        pair = _KERNELS.get(id(function))
        return pair[1] if pair is not None and pair[0] is function else function


def entry_point(function, *args):
    """What to call for ``function(*args)`` many times with arguments of exactly these types:
    a kernel's compiled entry for their signature (compiled or loaded from the cache now),
    called without numba's dispatch, which costs about 0.7 us a call (more than a resting
    world's step); ``function`` itself when it is not a kernel (the interpreted tier). The
    entry checks nothing: it unboxes its arguments by the signature it was made for, so
    arguments of other types (another dtype, layout or number of dimensions, a read-only
    array, a float for an int) are read as if they were those, which corrupts memory. Call it
    only with arrays that stay the types they were (made by their owner, never rebound to
    others), as ``BodyStore.one`` and ``CollisionWorld._call`` do."""
    if not isinstance(function, Dispatcher):
        return function
    return function.compile(tuple(numba.typeof(a) for a in args))


def borrowed(array):
    """``array`` itself, seen by compiled code as a view that does not own it: the same data,
    shape, strides and type, without its reference count (numba's meminfo). Every array a
    kernel binds to a name, passes to a call or takes from a container is counted up and down
    again, each count an atomic instruction: in a world's step those counts took more time
    than its arithmetic (a ball rolling on a plane: 57% of a step, bench/contact_step_bench.py).
    The counts of a borrowed array cost a test of a null pointer. Only for an array that its
    owner keeps alive for as long as the view is used, and that is never stored into a
    container that outlives the call, nor returned: the arrays of the record a world step is
    handed, for that call (``world_step.world_of``), and scratch a kernel carves from arrays
    it made, whose owners it passes to ``keep_alive`` on every path after the views' last use
    (numba frees an array after its owner's last use on each path: an early return too).
    The interpreted tier returns ``array``."""
    return array


@intrinsic
def _borrowed(typingctx, array):
    if not isinstance(array, types.Array):
        return None

    def codegen(context, builder, signature, args):
        view = context.make_array(array)(context, builder, value=args[0])
        view.meminfo = cgutils.get_null_value(view.meminfo.type)
        view.parent = cgutils.get_null_value(view.parent.type)
        return view._getvalue()
    return array(array), codegen


@overload(borrowed, jit_options=dict(fastmath=False, error_model='python'))
def _borrowed_overload(array):
    if isinstance(array, types.Array):
        return lambda array: _borrowed(array)
    return None


def stack_empty(rows, width, dtype):
    """``np.empty(rows)`` (``width`` 0) or ``np.empty((rows, width))`` of ``dtype``
    (np.float64, np.int64 or np.bool_), ``rows`` and ``width`` int constants (globals or
    literals). Compiled, the array lives in the stack frame of the function that calls this
    (or of the kernel an inline kernel calling it is inlined into): no allocation, no
    reference count (a null meminfo, as ``borrowed``), made once per call of that function
    even when written in a loop. For small scratch arrays a contact test makes per pair: a
    pile's step made a thousand, malloc and free among its heaviest costs. The array must not
    outlive the call: never returned, stored in a container, or kept from one iteration of a
    loop to the next (each iteration gets the same memory). Uninitialised, as np.empty."""
    return np.empty(rows if width == 0 else (rows, width), dtype=dtype)


@intrinsic(prefer_literal=True)
def _stack_empty(typingctx, rows, width, dtype):
    if not (isinstance(rows, types.IntegerLiteral) and isinstance(width, types.IntegerLiteral)
            and isinstance(dtype, types.NumberClass | types.DType)):
        return None
    n_rows, n_width = rows.literal_value, width.literal_value
    if n_rows <= 0 or n_width < 0:
        return None
    kind = dtype.dtype
    result = types.Array(kind, 1 if n_width == 0 else 2, 'C')

    def codegen(context, builder, signature, args):
        element = context.get_data_type(kind)
        size = context.get_abi_sizeof(element)
        count = n_rows * max(n_width, 1)
        data = cgutils.alloca_once(builder, element, size=count)  # the entry block: once
        shape = [n_rows] if n_width == 0 else [n_rows, n_width]
        strides = [size] if n_width == 0 else [n_width * size, size]
        array = context.make_array(result)(context, builder)
        context.populate_array(
            array, data=data,
            shape=cgutils.pack_array(builder, [context.get_constant(types.intp, v)
                                               for v in shape]),
            strides=cgutils.pack_array(builder, [context.get_constant(types.intp, v)
                                                 for v in strides]),
            itemsize=context.get_constant(types.intp, size), meminfo=None)
        return array._getvalue()
    return result(rows, width, dtype), codegen


# inline='always': numba inlines this into its caller's IR, so that the alloca is in the
# caller's frame (a function of its own would hand back memory of a frame that has ended:
# right only while LLVM happened to inline it; NUMBA_OPT=0 read garbage).
@overload(stack_empty, prefer_literal=True, inline='always',
          jit_options=dict(fastmath=False, error_model='python'))
def _stack_empty_overload(rows, width, dtype):
    if not (isinstance(rows, types.IntegerLiteral) and isinstance(width, types.IntegerLiteral)):
        raise errors.TypingError('stack_empty: rows and width must be int constants')
    return lambda rows, width, dtype: _stack_empty(rows, width, dtype)


def keep_alive(*arrays) -> None:
    """Nothing, but a use of ``arrays`` where it is called: numba frees an array after its last
    use in a function, so a function that works on ``borrowed`` views of arrays it made calls
    this after the views' last use."""


@overload(keep_alive, jit_options=dict(fastmath=False, error_model='python'))
def _keep_alive_overload(*arrays):
    return lambda *arrays: None


def made_global(space: dict, name: str, make):
    """``space[name]`` (a module's globals), made by ``make()`` (which makes a kernel, as
    ``kernel`` does) the first time: for kernels made on demand (one for each constant a
    factory bakes in), so that a tier swap finds them like the others. Under the lock the
    swaps take: a kernel made as the tier changes is bound to the new tier's function."""
    with _tier:
        if name not in space:
            space[name] = make()
        return space[name]


def literal_entry(entry):
    """Make a plain Python function ``f(value, ...)`` one that calls the kernel
    ``entry(value)`` with the other arguments: a kernel made for that value (``made_global``,
    a constant baked in), with a cache entry of its own. Called from a kernel with a constant
    ``value`` (an int literal: a global, or a closure's constant), the call is typed as a call
    of that kernel; from Python, in either tier, ``entry(value)`` is looked up and called.
    Unlike a kernel taking the value as a literal argument, whose overloads for every value
    share one cache index (which two processes compiling two values at once could leave
    naming the other's code), each value's kernel has its own index."""
    def decorate(function):
        name = function.__name__

        @functools.wraps(function)
        def call(value, *args):
            return entry(value)(*args)

        def typer(value, *args):
            if not isinstance(value, types.IntegerLiteral):
                raise errors.TypingError(f'{name}: its first argument must be an int constant '
                                         f"(a global or a closure's constant), got {value}")
            target = entry(value.literal_value)

            def impl(value, *args):
                return target(*args)
            return impl

        overload(call, jit_options=dict(fastmath=False, error_model='python'))(typer)
        return call
    return decorate


def generated_kernel(space: dict, name: str, source: str, inline: bool = True):
    """The kernel (``inline_kernel``, or ``kernel``) of the function ``name`` that ``source``
    defines, written by a module from a table (a dispatch over shape kinds or pairs of them)
    and run in that module's globals ``space``, where it is left bound to ``name`` (so that a
    tier swap finds it). Its text is kept for tracebacks and numba's messages; its cache entry
    is named after the module and ``name``."""
    filename = f'{space["__name__"]}.{name}'
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    exec(compile(source, filename, 'exec'), space)
    made = (inline_kernel if inline else kernel)(space[name])
    space[name] = made
    return made


def compile_for(function, *examples) -> None:
    """Compile (or load from the cache) the kernel ``function`` for the numba types of the
    values ``examples``, as a call with them would, without calling it; nothing while the
    kernels run interpreted. For a compile shared among processes (``sim/precompile.py``):
    the types must be those its caller passes it, or this compiles an overload nobody calls."""
    if interpreted() or not hasattr(function, 'compile'):
        return
    function.compile(tuple(numba.typeof(e) for e in examples))


def compiling() -> bool:
    """Whether kernels are compiled in this process (not NUMBA_DISABLE_JIT=1)."""
    return not numba.config.DISABLE_JIT  # type: ignore[attr-defined]


def interpreted() -> bool:
    """Whether this process's kernels run in the interpreter now (``run_interpreted``)."""
    return _interpreted or not compiling()


def run_interpreted() -> None:
    """From now on every kernel runs in the interpreter, with the bits of the compiled one,
    until ``run_compiled``: no call compiles meanwhile. Only for a process that imported every
    module of the package it will use (the layers import nothing deferred)."""
    global _interpreted, swaps
    with _tier:
        _swap(_PY_FUNCS)
        _interpreted = True
        swaps += 1


def run_compiled() -> None:
    """Back to the compiled kernels (the next call of each loads or compiles it)."""
    global _interpreted, swaps
    with _tier:
        _swap(_KERNELS)
        _interpreted = False
        swaps += 1


def _swap(by: dict) -> None:
    """Rebind every global of the package's modules found in ``by`` to what it maps to (a
    module imported while interpreted, too)."""
    for name, module in list(sys.modules.items()):
        if module is None or not (name == 'rb_sim_ros' or name.startswith('rb_sim_ros.')):
            continue
        space = vars(module)
        for key, value in list(space.items()):
            pair = by.get(id(value))
            if pair is not None and pair[0] is value:
                space[key] = pair[1]


prange = numba.prange


def literal_switch(cases: dict):
    """Make a plain Python function ``f(choice, ...)`` one that kernels call with a constant
    ``choice`` (an int literal: a global, or a closure's constant): there the call
    compiles ``cases[choice]`` alone (a function of the same signature, compiled into the
    caller), not every case ``f`` would run. In the interpreter ``f`` itself runs, which must
    do what ``cases[choice]`` does."""
    def decorate(function):
        name = function.__name__

        @functools.wraps(function)  # numba reads the overload's signature through it
        def typer(choice, *args):
            if not isinstance(choice, types.IntegerLiteral):
                raise errors.TypingError(f'{name}: its first argument must be an int constant '
                                         f"(a global or a closure's constant), got {choice}")
            case = cases.get(choice.literal_value)
            if case is None:
                raise errors.TypingError(f'{name}: no case {choice.literal_value}')
            return case

        overload(function, jit_options=dict(fastmath=False, error_model='python'))(typer)
        return function
    return decorate


def literal_gate(needed: int, absent):
    """Make a plain Python function ``f(tests, ...)`` one whose body kernels compile only where
    it can run: called from a kernel with a constant ``tests`` (an int literal: a global, or a
    closure's constant, handed down as an argument), the call compiles ``f`` when ``tests``
    holds every bit of ``needed``, else a function returning ``absent`` (nothing of ``f``'s
    body, nor of what it calls). In the interpreter, and from Python, the same: ``absent``
    unless ``tests`` holds ``needed``, else ``f``. For a dispatch whose cases a run may never
    meet (the contact tests of the pairs of shapes a scene does not have). numba wants the
    first parameter of both named alike: ``f``'s must be ``tests``."""
    def decorate(function):
        name = function.__name__
        if function.__code__.co_varnames[:1] != ('tests',):
            raise TypeError(f'literal_gate: the first parameter of {name} must be named tests')

        @functools.wraps(function)
        def gate(tests, *args):
            if tests & needed != needed:
                return absent
            return function(tests, *args)

        def nothing(tests, *args):
            return absent

        @functools.wraps(function)  # numba reads the overload's signature through it
        def typer(tests, *args):
            if not isinstance(tests, types.IntegerLiteral):
                raise errors.TypingError(f'{name}: its first argument must be an int constant '
                                         f"(a global or a closure's constant), got {tests}")
            return function if tests.literal_value & needed == needed else nothing

        overload(gate, jit_options=dict(fastmath=False, error_model='python'))(typer)
        return gate
    return decorate


# A constant passed from one kernel to another is typed as a literal, and numba compiles the
# callee once more for every literal value it meets (a big kernel twice, for True and False):
# kernels pass bool(True), int(1), float(0.0) instead, which are typed as plain values.


def kernel_sources() -> list[Path]:
    """Every module of the kernel layers, in a fixed order."""
    return sorted(f for layer in KERNEL_LAYERS for f in (PACKAGE / layer).rglob('*.py'))


def source_stamp() -> str:
    """A hash of every module of the kernel layers (names and text)."""
    digest = hashlib.sha256()
    for path in kernel_sources():
        digest.update(str(path.relative_to(PACKAGE)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:20]


_stamp: str | None = None


def process_stamp() -> str:
    """``source_stamp`` as this process first read it: what numba's cache keys this process's
    kernels on (an edit while it runs is the next process's)."""
    global _stamp
    if _stamp is None:
        _stamp = source_stamp()
    return _stamp


def cache_directories() -> list[Path]:
    """Where the cache may live, in order of preference: ``$NUMBA_CACHE_DIR/rb_sim_ros`` when
    that is set (numba's own variable), else the package's, else the user's cache."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        return [Path(os.environ['NUMBA_CACHE_DIR']) / 'rb_sim_ros']
    user = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    return [PACKAGE / '__pycache__' / 'numba', user / 'rb_sim_ros' / 'numba']


def cache_directory() -> Path | None:
    """The first writable of ``cache_directories`` (created), where the kernels are cached;
    None if none is."""
    for path in cache_directories():
        try:
            path.mkdir(parents=True, exist_ok=True)
            tempfile.TemporaryFile(dir=path).close()
        except OSError:
            continue
        return path
    return None


def _marker(part: str) -> Path | None:
    """The file ``precompile`` leaves once the kernels of ``part`` (a name it chooses: a
    family of methods, with or without contact) are in the cache: named after the part and
    what keys numba's cache (this source, numba's and Python's versions, this machine's CPU)."""
    where = cache_directory()
    if where is None:
        return None
    # (numba's target context: its magic tuple is the triple, CPU name and features)
    machine = repr(cpu_target.target_context.codegen().magic_tuple())
    key = hashlib.sha256(f'{process_stamp()} {numba.__version__} {sys.implementation.cache_tag} '
                         f'{machine}'.encode())
    # (':' is not allowed in a Windows file name: '=' in its place)
    return where / f'precompiled-{part.replace(":", "=")}-{key.hexdigest()[:20]}'


def marked_parts(prefix: str) -> list[str]:
    """The parts whose names start with ``prefix`` that ``mark_precompiled`` marked, for these
    sources, this numba and this machine, in the cache this process uses (sorted)."""
    probe = _marker('')
    if probe is None:
        return []
    head, key = 'precompiled-', probe.name.rsplit('-', 1)[1]
    found = []
    for path in probe.parent.glob(f'{head}{glob.escape(prefix.replace(":", "="))}*-{key}'):
        found.append(path.name[len(head):-len(key) - 1].replace('=', ':'))
    return sorted(found)


def precompiled(parts) -> bool:
    """Whether ``mark_precompiled`` ran for each of ``parts``, for these sources, this numba
    and this machine, in the cache this process uses: their kernels load rather than compile."""
    markers = [_marker(part) for part in parts]
    return all(m is not None and m.is_file() for m in markers)


def mark_precompiled(part: str) -> None:
    """Say that the kernels of ``part`` are in the cache (``precompile``, once they are)."""
    marker = _marker(part)
    if marker is not None:
        marker.write_text(f'numba {numba.__version__}\n')


class _SourceHashLocator(caching._CacheLocator):
    """numba's cache locator for rb_sim_ros kernels (see the module's docstring)."""

    def __init__(self, py_func, path: Path) -> None:
        self._lineno = py_func.__code__.co_firstlineno
        self._path = path

    def get_cache_path(self) -> str:
        return str(self._path)

    def get_source_stamp(self):
        return process_stamp()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not getattr(py_func, '__module__', '').startswith('rb_sim_ros.'):
            return None
        path = cache_directory()
        # None: nowhere writable, numba's own locators decide (or compile every time)
        return None if path is None else cls(py_func, path)


_locators = getattr(getattr(caching, 'CacheImpl', None), '_locator_classes', None)
if isinstance(_locators, list) and _SourceHashLocator not in _locators:
    _locators.insert(0, _SourceHashLocator)
