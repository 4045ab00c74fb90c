# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The ``offered_qos_profiles`` channel metadata, as rosbag2 on Jazzy writes it.

rosbag2 (metadata version 9, Jazzy) stores a YAML list with one mapping per offered profile,
policies by their rmw names and durations as ``{sec, nsec}``::

    - history: keep_last
      depth: 10
      reliability: reliable
      durability: volatile
      deadline:
        sec: 9223372036
        nsec: 854775807
      ...

A profile is given as an rclpy ``QoSProfile`` or a small dict with the keys of ``DEFAULT`` (any
subset; durations in integer nanoseconds, ``None`` or 0 meaning unspecified). Unspecified
durations and ``system_default`` policies are stored as the values the rmw reports for them
(infinite; keep_last, reliable, volatile, automatic), which is what ``ros2 bag record`` stores
for such a publisher.
"""

from __future__ import annotations

from typing import Any, Mapping

from rb_sim_ros.recording.errors import WriterError

# RMW_DURATION_INFINITE as rosbag2 writes it.
INFINITE = (9223372036, 854775807)
DEFAULT: dict[str, Any] = {
    'history': 'keep_last', 'depth': 10, 'reliability': 'reliable', 'durability': 'volatile',
    'deadline_ns': None, 'lifespan_ns': None, 'liveliness': 'automatic',
    'liveliness_lease_duration_ns': None, 'avoid_ros_namespace_conventions': False,
}
POLICIES = {
    'history': ('keep_last', 'keep_all'),
    'reliability': ('reliable', 'best_effort', 'best_available'),
    'durability': ('volatile', 'transient_local', 'best_available'),
    'liveliness': ('automatic', 'manual_by_topic', 'best_available'),
}
_SYSTEM_DEFAULT = {'history': 'keep_last', 'reliability': 'reliable', 'durability': 'volatile',
                   'liveliness': 'automatic'}
_DURATIONS = ('deadline', 'lifespan', 'liveliness_lease_duration')


def _from_rclpy(profile: Any) -> dict[str, Any]:
    out = {name: getattr(profile, name).name.lower() for name in POLICIES}
    out['depth'] = profile.depth
    for name in _DURATIONS:
        out[f'{name}_ns'] = getattr(profile, name).nanoseconds
    out['avoid_ros_namespace_conventions'] = profile.avoid_ros_namespace_conventions
    return out


def _profile(qos: Mapping[str, Any] | Any | None, where: str) -> dict[str, Any]:
    if qos is None:
        given: Mapping[str, Any] = {}
    elif isinstance(qos, Mapping):
        given = qos
    elif all(hasattr(qos, name) for name in ('history', 'depth', 'reliability', 'deadline')):
        given = _from_rclpy(qos)
    else:
        raise WriterError(f'{where}: QoS {qos!r} is neither a dict nor an rclpy QoSProfile')
    unknown = set(given) - set(DEFAULT)
    if unknown:
        raise WriterError(f'{where}: unknown QoS keys {sorted(unknown)}; known: '
                          f'{", ".join(DEFAULT)}')
    profile = {**DEFAULT, **given}
    for name, allowed in POLICIES.items():
        value = _SYSTEM_DEFAULT[name] if profile[name] == 'system_default' else profile[name]
        if value not in allowed:
            raise WriterError(f'{where}: QoS {name} {profile[name]!r} is not one of '
                              f'{", ".join(allowed)} (or system_default)')
        profile[name] = value
    depth = profile['depth']
    if isinstance(depth, bool) or not isinstance(depth, int) or depth < 0:
        raise WriterError(f'{where}: QoS depth {depth!r} is not a non-negative integer')
    for name in _DURATIONS:
        ns = profile[f'{name}_ns']
        if ns is not None and (isinstance(ns, bool) or not isinstance(ns, int) or ns < 0):
            raise WriterError(f'{where}: QoS {name}_ns {ns!r} is not a non-negative integer '
                              '(nanoseconds) or None')
    if not isinstance(profile['avoid_ros_namespace_conventions'], bool):
        raise WriterError(f'{where}: QoS avoid_ros_namespace_conventions is not a bool')
    return profile


def _duration(name: str, ns: int | None) -> str:
    sec, nsec = INFINITE if not ns else divmod(ns, 1_000_000_000)
    return f'  {name}:\n    sec: {sec}\n    nsec: {nsec}\n'


def offered_qos_profiles(qos: Any = None, where: str = 'QoS') -> str:
    """The ``offered_qos_profiles`` YAML text of one profile (or a list of profiles).

    ``qos``: None (``DEFAULT``: keep_last 10, reliable, volatile), a dict with keys of
    ``DEFAULT``, an rclpy ``QoSProfile``, or a list of those. Refuses (WriterError, naming
    ``where``) unknown keys, unknown policy names and negative or non-integer values.
    """
    profiles = qos if isinstance(qos, (list, tuple)) else [qos]
    parts = []
    for one in profiles:
        p = _profile(one, where)
        parts.append(f'- history: {p["history"]}\n'
                     f'  depth: {p["depth"]}\n'
                     f'  reliability: {p["reliability"]}\n'
                     f'  durability: {p["durability"]}\n'
                     + _duration('deadline', p['deadline_ns'])
                     + _duration('lifespan', p['lifespan_ns'])
                     + f'  liveliness: {p["liveliness"]}\n'
                     + _duration('liveliness_lease_duration', p['liveliness_lease_duration_ns'])
                     + '  avoid_ros_namespace_conventions: '
                     f'{"true" if p["avoid_ros_namespace_conventions"] else "false"}\n')
    return ''.join(parts).rstrip('\n')  # yaml-cpp's Dump ends without a newline
