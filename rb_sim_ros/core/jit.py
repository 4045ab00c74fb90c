# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The one place kernels are compiled: ``kernel`` and ``parallel_kernel`` (numba).

A kernel is a plain Python function over float64/int64 arrays and floats. Compiled with
``numba.njit``; with ``NUMBA_DISABLE_JIT=1`` in the environment the very same functions run in
the interpreter, and ``test/test_kernels.py`` checks that both give the same bits. Never
``fastmath``: it lets LLVM reorder and fuse (a*b + c as one FMA) floating-point operations, and a
recording would no longer replay bit for bit against the interpreter or another machine.

Cache. Compiled code is cached on disk (``cache=True``) so that only the first start compiles.
numba keys its cache on the modification time of the file holding the compiled function, not
on the files of the functions it calls, so an edit of a helper in another module would keep
serving stale machine code. Our kernels are therefore cached by ``_SourceHashLocator``: one
stamp, a hash of every module of the layers that hold kernels (core and contact), so any edit
there recompiles them all. The cache lives in the package's ``__pycache__/numba``; where that
is read-only (an installed tree) in the user's cache directory
(``$XDG_CACHE_HOME/rb_sim_ros/numba``); ``NUMBA_CACHE_DIR`` overrides both.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
import tempfile

# Intel's SVML, where numba finds it (conda's icc_rt), would let LLVM vectorise sin and cos
# with its own routines, whose last bits are not libm's: a block's lanes (step_kernel) would no
# longer give a body the bits of its step alone. Off, unless numba was imported before us.
os.environ.setdefault('NUMBA_DISABLE_INTEL_SVML', '1')

import numba  # noqa: E402
from numba.core import caching  # noqa: E402

PACKAGE = Path(__file__).resolve().parent.parent
# The layers whose modules hold kernels: the text of every module in them is the cache's stamp.
KERNEL_LAYERS = ('core', 'contact')

_OPTIONS = dict(cache=True, fastmath=False, error_model='python', nogil=True)


def kernel(function):
    """Compile ``function`` (serial)."""
    return numba.njit(**_OPTIONS)(function)


def inline_kernel(function):
    """Compile ``function`` into each kernel that calls it (numba's inline='always'): for the
    stages of a step that take the world's arrays as one named tuple, which a call would
    otherwise pass member by member, with a reference count for each."""
    return numba.njit(inline='always', **_OPTIONS)(function)


def parallel_kernel(function):
    """Compile ``function`` with ``numba.prange`` loops run on every core: only for loops over
    independent bodies, never across a sweep whose order matters."""
    return numba.njit(parallel=True, **_OPTIONS)(function)


prange = numba.prange

# A constant passed from one kernel to another is typed as a literal, and numba compiles the
# callee once more for every literal value it meets (a big kernel twice, for True and False):
# kernels pass bool(True), int(1), float(0.0) instead, which are typed as plain values.


def kernel_sources() -> list[Path]:
    """Every module of the kernel layers, in a fixed order."""
    return sorted(f for layer in KERNEL_LAYERS for f in (PACKAGE / layer).glob('*.py'))


def source_stamp() -> str:
    """A hash of every module of the kernel layers (names and text)."""
    digest = hashlib.sha256()
    for path in kernel_sources():
        digest.update(str(path.relative_to(PACKAGE)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:20]


def cache_directories() -> list[Path]:
    """Where the cache may live, in order of preference: ``$NUMBA_CACHE_DIR/rb_sim_ros`` when
    that is set (numba's own variable), else the package's, else the user's cache."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        return [Path(os.environ['NUMBA_CACHE_DIR']) / 'rb_sim_ros']
    user = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    return [PACKAGE / '__pycache__' / 'numba', user / 'rb_sim_ros' / 'numba']


class _SourceHashLocator(caching._CacheLocator):
    """numba's cache locator for rb_sim_ros kernels (see the module's docstring)."""

    _stamp = None

    def __init__(self, py_func, path: Path) -> None:
        self._lineno = py_func.__code__.co_firstlineno
        self._path = path

    def get_cache_path(self) -> str:
        return str(self._path)

    def get_source_stamp(self):
        if _SourceHashLocator._stamp is None:
            _SourceHashLocator._stamp = source_stamp()
        return _SourceHashLocator._stamp

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not getattr(py_func, '__module__', '').startswith('rb_sim_ros.'):
            return None
        for path in cache_directories():
            try:
                path.mkdir(parents=True, exist_ok=True)
                tempfile.TemporaryFile(dir=path).close()
            except OSError:
                continue
            return cls(py_func, path)
        return None  # nowhere writable: numba's own locators decide (or compile every time)


_locators = getattr(getattr(caching, 'CacheImpl', None), '_locator_classes', None)
if isinstance(_locators, list) and _SourceHashLocator not in _locators:
    _locators.insert(0, _SourceHashLocator)
