# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""YAML from an untrusted file: plain data, bounded, and one error class for every refusal.

``load(text)`` returns what ``yaml.safe_load`` would for an ordinary file (dicts, lists,
strings, ints, floats, bools and None), or raises ``YamlError`` (a ValueError) carrying the
path in the document (``('bodies', 3, 'inertia')``), the line and the reason. It builds the
values itself from the parser's events, with an explicit stack instead of recursion, and
refuses, as it meets them:

* aliases (``*name``): one alias to a collection can stand for any number of copies of it
  (the "billion laughs"), and nothing a scene needs is shorter with one;
* mapping keys that are not strings, and a key given twice in one mapping (``yaml.safe_load``
  keeps the last one silently);
* explicit or implicit types other than null, bool, int, float and str (timestamps,
  ``!!binary``, ``!!set``, ``!!python/...``), and merge keys (``<<``);
* more than ``max_depth`` nested collections, more than ``max_nodes`` values in all, a scalar
  longer than ``MAX_SCALAR`` characters (a long digit string costs quadratic time as an int)
  and more than one document.

Plain scalars resolve as in YAML 1.1 (``yes`` is true), except that a float's exponent needs no
decimal point (``1e-3`` is a float, as in YAML 1.2 and JSON, not a string). Anchors are
allowed (they do nothing without an alias). The parser is libyaml's when PyYAML
has it (``yaml.CSafeLoader``), else PyYAML's own; both produce events one by one, so an input
is refused as soon as it crosses a bound, whatever follows.
"""

from __future__ import annotations

import re
from typing import Any, Sequence

import yaml
from yaml import events
from yaml.constructor import SafeConstructor
from yaml.nodes import ScalarNode
from yaml.resolver import Resolver

MAX_DEPTH = 16
MAX_NODES = 1_000_000
MAX_SCALAR = 4096

_PARSER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_TAG = 'tag:yaml.org,2002:'
_SEQ_TAGS = {None, '!', _TAG + 'seq'}
_MAP_TAGS = {None, '!', _TAG + 'map'}
_CONSTRUCTOR = SafeConstructor()
_SCALARS = {_TAG + 'null': _CONSTRUCTOR.construct_yaml_null,
            _TAG + 'bool': _CONSTRUCTOR.construct_yaml_bool,
            _TAG + 'int': _CONSTRUCTOR.construct_yaml_int,
            _TAG + 'float': _CONSTRUCTOR.construct_yaml_float,
            _TAG + 'str': _CONSTRUCTOR.construct_yaml_str}


class _Resolver(Resolver):
    """YAML 1.1's implicit types, with floats as YAML 1.2 (and JSON) write them too: an
    exponent needs no decimal point and no sign (``1e-3``, ``1e308``, ``2E5``), where
    PyYAML alone reads those as strings."""


_FLOAT = _TAG + 'float'
_Resolver.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag != _FLOAT]
    for first, resolvers in Resolver.yaml_implicit_resolvers.items()}
_Resolver.add_implicit_resolver(_FLOAT, re.compile(r"""^(?:
    [-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X), list('-+0123456789.'))
_RESOLVER = _Resolver()
_VALUE_EVENTS = {events.ScalarEvent, events.SequenceStartEvent, events.MappingStartEvent,
                 events.AliasEvent}


class YamlError(ValueError):
    """Refused YAML: ``reason``, at ``path`` (keys and indices from the document's root) and
    ``line`` (1-based; 0 when unknown)."""

    def __init__(self, reason: str, path: Sequence[Any] = (), line: int = 0) -> None:
        super().__init__(reason if not line else f'{reason} (line {line})')
        self.reason, self.path, self.line = reason, tuple(path), line


def _line(event: Any) -> int:
    mark = getattr(event, 'start_mark', None)
    return mark.line + 1 if mark is not None else 0


def _short(text: str, limit: int = 40) -> str:
    """``text`` quoted with its non-ASCII and control characters escaped, at most ``limit``
    characters of it."""
    return ascii(text[:limit]) + ('...' if len(text) > limit else '')


def _scalar(event: events.ScalarEvent, stack: list, seen: dict) -> Any:
    """The value of a scalar; ``seen`` keeps those of untagged ones by text and style (keys
    and common numbers recur: each is resolved once)."""
    key = (event.value, event.implicit[0]) if event.tag is None else None
    if key is not None and key in seen:
        return seen[key]
    if len(event.value) > MAX_SCALAR:
        raise YamlError(f'a value of {len(event.value)} characters (at most {MAX_SCALAR})',
                        _path(stack), _line(event))
    tag = event.tag
    if tag is None or tag == '!':
        tag = _RESOLVER.resolve(ScalarNode, event.value, event.implicit)
    construct = _SCALARS.get(tag)
    if construct is None:
        what = ('merge keys (<<) are' if tag == _TAG + 'merge'
                else f'values of type {_short(str(tag))} are')
        raise YamlError(f'{what} not allowed (only null, booleans, numbers and strings)',
                        _path(stack), _line(event))
    try:
        value = construct(ScalarNode(tag, event.value))
    except (ValueError, ArithmeticError) as e:
        raise YamlError(f'cannot read {_short(event.value)} as a {tag[len(_TAG):]}: {e}',
                        _path(stack), _line(event)) from None
    if key is not None:
        seen[key] = value  # immutable: None, a bool, an int, a float or a str
    return value


def _path(stack: list) -> list:
    """Keys and indices from the root down to the value being read."""
    path = []
    for container, key in stack:
        if type(container) is list:
            path.append(len(container))
        elif key is not None:
            path.append(key)
    return path


def load(text: str, max_depth: int = MAX_DEPTH, max_nodes: int = MAX_NODES) -> Any:
    """The single document of ``text`` as plain Python data (None if it is empty); YamlError
    for anything refused (see the module docstring) or malformed."""
    stack: list[list] = []  # each open collection: [container, the key awaiting its value]
    root: Any = None
    nodes = documents = 0
    seen: dict = {}
    parser = None
    try:
        parser = _PARSER(text)  # PyYAML's own reader checks the characters here
        while parser.check_event():
            event = parser.get_event()
            kind = type(event)
            if kind is events.SequenceEndEvent or kind is events.MappingEndEvent:
                value = stack.pop()[0]
            elif kind in _VALUE_EVENTS:
                nodes += 1
                if nodes > max_nodes:
                    raise YamlError(f'more than {max_nodes} values', _path(stack),
                                    _line(event))
                top: list = stack[-1] if stack else [None, 0]  # (no container awaits a key)
                awaiting_key = top[1] is None and type(top[0]) is dict
                if kind is events.AliasEvent:
                    anchor = ascii(str(event.anchor)[:40])[1:-1]
                    raise YamlError(f'aliases (*{anchor}) are not allowed', _path(stack),
                                    _line(event))
                if kind is events.ScalarEvent:
                    value = _scalar(event, stack, seen)
                    if awaiting_key:
                        if type(value) is not str:
                            raise YamlError(f'keys must be strings, got {value!r}',
                                            _path(stack), _line(event))
                        if value in top[0]:
                            raise YamlError('given twice in one mapping',
                                            _path(stack) + [value], _line(event))
                        top[1] = value
                        continue
                else:  # the start of a sequence or a mapping
                    if awaiting_key:
                        raise YamlError('keys must be strings, got a collection',
                                        _path(stack), _line(event))
                    is_map = kind is events.MappingStartEvent
                    if event.tag not in (_MAP_TAGS if is_map else _SEQ_TAGS):
                        raise YamlError(f'values of type {_short(str(event.tag))} are not '
                                        'allowed (only mappings and lists)', _path(stack),
                                        _line(event))
                    if len(stack) >= max_depth:
                        raise YamlError(f'nested more than {max_depth} deep', _path(stack),
                                        _line(event))
                    stack.append([{} if is_map else [], None])
                    continue
            else:  # stream and document boundaries
                if kind is events.DocumentStartEvent:
                    documents += 1
                    if documents > 1:
                        raise YamlError('more than one document (---)', [], _line(event))
                continue
            # A complete value: into its container, or the document itself.
            if not stack:
                root = value
                continue
            top = stack[-1]
            if type(top[0]) is list:
                top[0].append(value)
            else:
                top[0][top[1]] = value
                top[1] = None
    except yaml.YAMLError as e:
        mark = getattr(e, 'problem_mark', None) or getattr(e, 'context_mark', None)
        problem = getattr(e, 'problem', None) or str(e).split('\n', 1)[0]
        raise YamlError(f'not valid YAML: {problem}', _path(stack),
                        mark.line + 1 if mark is not None else 0) from None
    finally:
        if parser is not None:
            parser.dispose()
    return root
