# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Type names, ``ros2msg`` schema text and type hashes, from the installed interface files.

The schema text is built exactly as rosbag2 (Jazzy, ``LocalMessageDefinitionSource``) builds
it: the type's .msg file verbatim, then for each type it uses, depth first and each once, a
line of 80 '=', a line ``MSG: pkg/Type`` and that type's .msg file verbatim; the types a file
uses are taken in sorted order. The type hash (REP-2011, ``RIHS01_<hex>``) is the one rosidl
generated next to the .msg file (``<Type>.json``), which is what the rmw reports for a topic and
what ``ros2 bag record`` stores as ``topic_type_hash``.

Installed files are found under ``share/<pkg>/msg/`` of, in order: the prefixes on
AMENT_PREFIX_PATH (as ament_index does), the prefix the message package's Python module is
installed in (a venv or /opt/ros/<distro>), and ``sys.prefix``.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import os
from pathlib import Path
import re
import sys

from rb_sim_ros.recording.errors import WriterError

SEPARATOR = '=' * 80
# rosbag2's regular expression for the field types of a .msg file, and its primitive types
# (plus 'wstring', which rosbag2 Jazzy lacks and would look up as a message).
_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
PRIMITIVES = frozenset({'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16',
                        'uint16', 'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'})
_MAX_DEPTH = 50  # rosbag2's limit on nesting
_NAME = re.compile(r'^([a-zA-Z][a-zA-Z0-9_]*)/(?:(msg)/)?([a-zA-Z][a-zA-Z0-9_]*)$')


def type_name_of(msg_type: type) -> str:
    """'pkg/msg/Type' of an rclpy message class; WriterError if it is not one."""
    module = getattr(msg_type, '__module__', '') or ''
    parts = module.split('.')
    if (not isinstance(msg_type, type) or len(parts) < 2 or parts[1] != 'msg'
            or not hasattr(msg_type, 'get_fields_and_field_types')
            or not hasattr(type(msg_type), '_TYPE_SUPPORT')):
        raise WriterError(f'{msg_type!r} is not an rclpy message class (such as '
                          'geometry_msgs.msg.PoseStamped)')
    return f'{parts[0]}/msg/{msg_type.__name__}'


def split_type_name(type_name: str) -> tuple[str, str]:
    """(package, Type) of 'pkg/msg/Type' or 'pkg/Type'; ValueError for anything else."""
    match = _NAME.match(type_name)
    if match is None:
        raise ValueError(f"'{type_name}' is not a message type name like 'pkg/msg/Type'")
    return match.group(1), match.group(3)


def _prefixes(package: str) -> list[Path]:
    prefixes = [Path(p) for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.origin:
        # <prefix>/lib/pythonX.Y/site-packages/<pkg>/__init__.py (pip, venv, colcon) or
        # <prefix>/local/lib/pythonX.Y/dist-packages/<pkg>/__init__.py (Debian's ROS packages)
        prefixes.extend(list(Path(os.path.abspath(spec.origin)).parents)[3:6])
    prefixes.append(Path(sys.prefix))
    return prefixes


@functools.lru_cache(maxsize=None)
def interface_file(type_name: str) -> Path:
    """The installed ``share/<pkg>/msg/<Type>.msg`` of 'pkg/msg/Type' (or 'pkg/Type').

    Refuses (WriterError) a malformed name or a type with no such file installed.
    """
    try:
        package, name = split_type_name(type_name)
    except ValueError as e:
        raise WriterError(str(e)) from None
    searched = []
    for prefix in _prefixes(package):
        path = prefix / 'share' / package / 'msg' / f'{name}.msg'
        if path.is_file():
            return path
        searched.append(str(path.parent))
    raise WriterError(f'no installed {name}.msg for {type_name} (looked in '
                      f'{", ".join(dict.fromkeys(searched))}; set AMENT_PREFIX_PATH to the '
                      'install prefix that has it)')


def _dependencies(text: str, package: str) -> list[str]:
    """The non-primitive field types a .msg text uses, as 'pkg/Type', sorted (as rosbag2)."""
    deps = set()
    for match in _FIELD_TYPE.finditer(text):
        name = match.group(1)
        if name in PRIMITIVES:
            continue
        deps.add(name if '/' in name else f'{package}/{name}')
    return sorted(deps)


@functools.lru_cache(maxsize=None)
def schema_text(type_name: str) -> str:
    """The ``ros2msg`` schema of 'pkg/msg/Type': rosbag2's full text with every nested type.

    Refuses (WriterError) a type whose .msg file, or one of whose nested types' .msg files, is
    not installed.
    """
    seen: set[str] = set()

    def text_of(name: str, depth: int) -> str:
        if depth <= 0:
            raise WriterError(f'{type_name}: nesting deeper than {_MAX_DEPTH} types')
        text = interface_file(name).read_text(encoding='utf-8')
        out = [text]
        for dep in _dependencies(text, split_type_name(name)[0]):
            if dep not in seen:
                seen.add(dep)
                out.append(f'\n{SEPARATOR}\nMSG: {dep}\n')
                out.append(text_of(dep, depth - 1))
        return ''.join(out)

    return text_of(type_name, _MAX_DEPTH)


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str | None:
    """REP-2011 hash 'RIHS01_<64 hex>' of 'pkg/msg/Type' from the ``<Type>.json`` beside the
    .msg file the schema is made of, or None if rosidl left none there."""
    try:
        path = interface_file(type_name).with_suffix('.json')
        hashes = json.loads(path.read_text(encoding='utf-8'))['type_hashes']
    except (WriterError, OSError, ValueError, KeyError, TypeError):
        return None
    package, name = split_type_name(type_name)
    full = f'{package}/msg/{name}'
    for entry in hashes:
        if isinstance(entry, dict) and entry.get('type_name') == full:
            value = entry.get('hash_string')
            return value if isinstance(value, str) and value.startswith('RIHS') else None
    return None
