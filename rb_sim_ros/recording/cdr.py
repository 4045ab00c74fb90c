# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A CDR serialiser for rclpy messages, generated per message type: the bytes rclpy's
``serialize_message`` makes, faster for the small fixed messages a recording is made of
(rclpy's conversion to C reads every field through Python first).

    encode = encoder(Odometry)     # None: a type this module does not handle (use rclpy)
    data = encode(msg)

The bytes are XCDR1 little endian (the encapsulation ROS 2 uses, 00 01 00 00), each value
aligned to its size counted from after that header, strings as a uint32 length with their
terminating NUL, sequences as a uint32 count. rclpy leaves padding bytes as they were in its
buffer; here they are zeros, so the same message is always the same bytes. A string is cut at
its first NUL, as rclpy's conversion to C cuts it. Types with wide strings (or a long double)
are not handled (``encoder`` returns None). The source of each encoder is generated from the
type's rosidl description (``SLOT_TYPES``): values in a row go through one ``struct`` call,
arrays of numbers through numpy's bytes.
"""

from __future__ import annotations

import array
import importlib
import struct
from typing import Any, Callable

import numpy as np
from rosidl_parser import definition as d

HEADER = b'\x00\x01\x00\x00'
_ZEROS = bytes(8)
# rosidl basic type -> (struct code, size); size is also its alignment
_BASIC = {
    'boolean': ('?', 1), 'octet': ('B', 1), 'char': ('B', 1), 'uint8': ('B', 1),
    'int8': ('b', 1), 'uint16': ('H', 2), 'int16': ('h', 2), 'uint32': ('I', 4),
    'int32': ('i', 4), 'uint64': ('Q', 8), 'int64': ('q', 8), 'float': ('f', 4),
    'double': ('d', 8), 'float32': ('f', 4), 'float64': ('d', 8),
    'short': ('h', 2), 'unsigned short': ('H', 2), 'long': ('i', 4),
    'unsigned long': ('I', 4), 'long long': ('q', 8), 'unsigned long long': ('Q', 8),
}
_cache: dict[type, Callable[[Any], bytes] | None] = {}


class _Unsupported(Exception):
    pass


def encoder(msg_type: type) -> Callable[[Any], bytes] | None:
    """The serialiser of rclpy message class ``msg_type`` (a function of a message to its
    bytes), or None for a type it cannot make (a wide string...)."""
    try:
        return _cache[msg_type]
    except KeyError:
        pass
    try:
        source = _Generator().source(msg_type)
    except _Unsupported:
        _cache[msg_type] = None
        return None
    scope: dict[str, Any] = {'_pack': struct.pack, '_ZEROS': _ZEROS, '_numbers': _numbers,
                             '_text': _text, '_octets': _octets,
                             '_ndarray': np.ndarray, '_F8': np.dtype('<f8')}
    exec(compile(source, f'<cdr encoder of {msg_type.__name__}>', 'exec'), scope)  # noqa: S102
    encode = scope['encode']

    def serialise(msg, _encode=encode) -> bytes:
        out = bytearray(HEADER)
        _encode(msg, out)
        return bytes(out)
    serialise.source = source  # type: ignore[attr-defined] # (to read what was generated)
    _cache[msg_type] = serialise
    return serialise


def _text(value: str) -> bytes:
    """A string's bytes as rclpy hands them to C: UTF-8, cut at the first NUL, its NUL, after
    its length (the few short ones a recording repeats, frame ids, kept)."""
    data = _texts.get(value)
    if data is None:
        data = value.encode()
        cut = data.find(b'\0')
        if cut >= 0:
            data = data[:cut]
        data = struct.pack('<I', len(data) + 1) + data + b'\0'
        if len(value) <= 256 and len(_texts) < 1024:
            _texts[value] = data
    return data


_texts: dict[str, bytes] = {}


def _numbers(value, code: str, count: int | None) -> bytes:
    """The bytes of an array of numbers (a numpy array, an array.array or a list), ``count``
    of them if the array is fixed."""
    dtype = np.dtype('?' if code == '?' else '<' + code)
    if isinstance(value, np.ndarray) and value.dtype == dtype and value.ndim == 1:
        data = value.tobytes()
    else:
        data = np.asarray(value, dtype=dtype).tobytes()
    if count is not None and len(data) != count * dtype.itemsize:
        raise ValueError(f'an array of {count} values has {len(data) // dtype.itemsize}')
    return data


def _octets(value, count: int | None) -> bytes:
    """The bytes of an array of octets, chars or uint8 (rclpy holds them as bytes, a list of
    one-byte bytes, a list of ints or a numpy array)."""
    if isinstance(value, (bytes, bytearray)) or \
            isinstance(value, array.array) and value.itemsize == 1:
        data = bytes(value)
    elif isinstance(value, np.ndarray):
        data = value.astype(np.uint8).tobytes()
    else:
        data = bytes(v[0] if isinstance(v, bytes) else v for v in value)
    if count is not None and len(data) != count:
        raise ValueError(f'an array of {count} values has {len(data)}')
    return data


class _Generator:
    """The Python source of a type's encoder: one function, nested messages inlined."""

    def __init__(self) -> None:
        self.locals = 0  # local names made so far (each one new)

    def source(self, msg_type: type) -> str:
        lines: list[str] = []
        body = _Body(self, lines)
        body.modulus = 8  # (a message starts the data: offset 0)
        body.message('m', msg_type)
        return 'def encode(m, out):\n' + '\n'.join('    ' + line for line in lines or ['pass'])


class _Body:
    """The lines of one encoder: runs of values packed at once, alignment known statically
    where it can be (the offset modulo ``modulus`` is ``residue``), else computed."""

    def __init__(self, generator: _Generator, lines: list[str]) -> None:
        self.generator = generator
        self.lines = lines
        self.codes: list[str] = []
        self.values: list[str] = []
        # (a sequence's item starts at an offset not known)
        self.modulus, self.residue = 1, 0

    def message(self, expr: str, msg_type: type, top: bool = True) -> None:
        slots = [s for s in getattr(msg_type, '__slots__', ()) if s != '_check_fields']
        types = getattr(msg_type, 'SLOT_TYPES', None)
        if types is None or len(types) != len(slots):
            raise _Unsupported(msg_type)
        if not slots:  # an empty message: rosidl's one uint8 member
            self.basic('0', 'uint8')
        for slot, slot_type in zip(slots, types):
            self.field(f'{expr}.{slot[1:]}', slot_type)
        if top:
            self.flush()

    def field(self, expr: str, t) -> None:
        if isinstance(t, d.BasicType):
            self.basic(expr, t.typename)
        elif isinstance(t, d.AbstractWString):
            raise _Unsupported(t)
        elif isinstance(t, d.AbstractString):
            self.align(4)
            self.flush()
            self.lines.append(f'out += _text({expr})')
            self.modulus, self.residue = 1, 0
        elif isinstance(t, d.NamespacedType):
            self.nested(expr, t)
        elif isinstance(t, d.AbstractNestedType):  # arrays and sequences
            self.flush()
            self.array(expr, t)
        else:
            raise _Unsupported(t)

    def basic(self, expr: str, typename: str) -> None:
        try:
            code, size = _BASIC[typename]
        except KeyError:
            raise _Unsupported(typename) from None
        if typename == 'char' or typename == 'octet':  # rclpy: bytes of one or an int
            expr = f'(({expr})[0] if isinstance({expr}, bytes) else ({expr}))'
        self.align(size)
        self.codes.append(code)
        self.values.append(expr)
        self.residue = (self.residue + size) % self.modulus

    def align(self, size: int) -> None:
        """Pad to ``size``: in the run if the offset is known well enough, else at run time."""
        if size <= self.modulus:
            pad = -self.residue % size
            if pad:
                self.codes.append(f'{pad}x')
                self.residue = (self.residue + pad) % self.modulus
            return
        self.flush()
        self.lines.append(f'out += _ZEROS[:-(len(out) - 4) % {size}]')
        self.modulus, self.residue = size, 0

    def flush(self) -> None:
        if self.codes:
            values = ', '.join(self.values)
            self.lines.append(f"out += _pack('<{''.join(self.codes)}'"
                              + (f', {values})' if values else ')'))
        self.codes, self.values = [], []

    def nested(self, expr: str, t) -> None:
        """A nested message, inlined (a run of values goes on across it); one of several
        fields bound to a local name first (each field is then one attribute away)."""
        msg_type = _class_of(t)
        if '.' in expr and len(getattr(msg_type, 'SLOT_TYPES', ())) > 1:
            self.generator.locals += 1
            local = f'_{self.generator.locals}_{expr.rsplit(".", 1)[1]}'
            # (before the run in progress is packed: reads have no effects, the run goes on)
            self.lines.append(f'{local} = {expr}')
            expr = local
        self.message(expr, msg_type, top=False)

    def array(self, expr: str, t) -> None:
        item = t.value_type
        count = t.size if isinstance(t, d.Array) else None
        if isinstance(item, d.BasicType):
            code, size = _BASIC.get(item.typename, (None, 0))
            if code is None:
                raise _Unsupported(item)
            self.flush()
            self.lines.append(f'_a = {expr}')
            if count is None:  # a sequence: its length, then its items aligned if it has any
                self.basic('len(_a)', 'uint32')
                self.flush()
                if size > 4:
                    self.lines.append(f'if len(_a): out += _ZEROS[:-(len(out) - 4) % {size}]')
            else:
                self.align(size)
                self.flush()
            if item.typename in ('char', 'octet', 'uint8'):  # bytes, or ints, or bytes of one
                self.lines.append(f'out += _octets(_a, {count})')
            elif code == 'd' and count is not None:  # (the covariances: numpy's bytes)
                self.lines.append(f'out += _a.tobytes() if type(_a) is _ndarray and '
                                  f'_a.dtype is _F8 and _a.size == {count} else '
                                  f"_numbers(_a, 'd', {count})")
            else:
                self.lines.append(f"out += _numbers(_a, '{code}', {count})")
            # (from an offset aligned to the item's size, whole items keep it aligned; an
            # empty sequence ends after its length, at a multiple of 4)
            self.modulus, self.residue = (size if count is not None else min(size, 4)), 0
            return
        if count is None:
            self.basic(f'len({expr})', 'uint32')
            self.flush()
        self.generator.locals += 1
        name = f'_item{self.generator.locals}'  # (its own: a sequence may nest another)
        self.lines.append(f'for {name} in {expr}:')
        inner = _Body(self.generator, [])
        inner.field(name, item)
        inner.flush()
        self.lines.extend('    ' + line for line in inner.lines or ['pass'])
        self.modulus, self.residue = 1, 0


def _class_of(t) -> type:
    """The rclpy class of a rosidl NamespacedType."""
    module = importlib.import_module('.'.join(t.namespaces))
    return getattr(module, t.name)
