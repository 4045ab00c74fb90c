# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""rosbag2's bag information (metadata version 9, Jazzy): in the MCAP file and as metadata.yaml.

``ros2 bag record`` (MCAP storage) ends a file with a metadata record named ``rosbag2`` whose key
``serialized_metadata`` holds the bag information as YAML; a bag directory holds the same
information in ``metadata.yaml`` under ``rosbag2_bagfile_information``. Jazzy's ``ros2 bag``
opens a bare .mcap file without metadata.yaml; readers that need a bag directory (rosbags'
``rosbag2.Reader`` on a directory, older ``ros2 bag``) get one from ``write_rosbag2_metadata``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
import functools
import os
from pathlib import Path

import yaml

from rb_sim_ros.recording.errors import WriterError
from rb_sim_ros.recording.reader import RecordingReader

VERSION = 9
METADATA_NAME = 'rosbag2'
METADATA_KEY = 'serialized_metadata'
_EMPTY_START = 2**63 - 1  # rosbag2's starting time of a bag without messages
# libyaml's safe loader and dumper where PyYAML has them (faster than PyYAML's Python ones)
_Loader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_Dumper = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a recording: its type, offered QoS (YAML text), type hash and count."""

    topic: str
    type_name: str
    offered_qos_profiles: str
    type_hash: str
    message_count: int
    serialization_format: str = 'cdr'


def _profiles(text: str) -> list:
    """The QoS profiles of a topic's YAML text (parsed once per text: a sweep's worker closes
    a recording of the same topics every run), a copy of its own."""
    return copy.deepcopy(_parsed_profiles(text))


@functools.lru_cache(maxsize=256)
def _parsed_profiles(text: str) -> list:
    try:
        profiles = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError:  # a foreign writer's; rosbag2 would not read it either
        return []
    return profiles if isinstance(profiles, list) else []


def bag_information(file_name: str, topics: list[TopicSummary], start_ns: int | None,
                    end_ns: int | None, ros_distro: str | None = None) -> dict:
    """rosbag2's BagMetadata (version 9) of one MCAP file, as a dict for YAML.

    ``start_ns``/``end_ns``: log times of the first and last message (integer nanoseconds), or
    None without messages. ``compression_format`` stays empty: it names rosbag2's own file or
    message compression, not the MCAP chunk compression (as ``ros2 bag record -s mcap`` writes
    it). ``ros_distro`` defaults to $ROS_DISTRO, else 'jazzy'.
    """
    count = sum(t.message_count for t in topics)
    start = _EMPTY_START if start_ns is None else int(start_ns)
    duration = 0 if start_ns is None or end_ns is None else int(end_ns) - int(start_ns)
    return {
        'version': VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': count,
        'topics_with_message_count': [{
            'topic_metadata': {
                'name': t.topic,
                'type': t.type_name,
                'serialization_format': t.serialization_format,
                'offered_qos_profiles': _profiles(t.offered_qos_profiles),
                'type_description_hash': t.type_hash,
            },
            'message_count': t.message_count,
        } for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [file_name],
        'files': [{
            'path': file_name,
            'starting_time': {'nanoseconds_since_epoch': start},
            'duration': {'nanoseconds': duration},
            'message_count': count,
        }],
        'custom_data': None,
        'ros_distro': ros_distro or os.environ.get('ROS_DISTRO') or 'jazzy',
    }


def dump(info: dict) -> str:
    """YAML text of a bag information dict (block style, keys in rosbag2's order)."""
    return yaml.dump(info, Dumper=_Dumper, sort_keys=False, default_flow_style=False)


def write_rosbag2_metadata(mcap_path: str | os.PathLike, overwrite: bool = False) -> Path:
    """Write ``metadata.yaml`` next to a complete recording, making its folder a rosbag2 bag.

    Returns the path written. Refuses (WriterError) to overwrite an existing metadata.yaml
    unless ``overwrite``, and to describe a truncated recording (``recover`` it first); raises
    ReaderError if ``mcap_path`` is not a readable recording.
    """
    reader = RecordingReader(mcap_path)
    if reader.truncated:
        raise WriterError(f'{reader.path}: truncated ({reader.truncation}); recover() it into a '
                          'complete file first')
    source = Path(reader.path)
    target = source.parent / 'metadata.yaml'
    topics = [TopicSummary(topic, info.type_name, info.offered_qos_profiles,
                           info.type_hash or '', info.message_count, info.message_encoding)
              for topic, info in reader.topics.items()]
    info = bag_information(source.name, topics, reader.start_time_ns, reader.end_time_ns)
    text = dump({'rosbag2_bagfile_information': info})
    try:
        with open(target, 'w' if overwrite else 'x', encoding='utf-8') as f:
            f.write(text)
    except FileExistsError:
        raise WriterError(f'{target}: exists; refusing to overwrite it (overwrite=True to '
                          'replace it)') from None
    except OSError as e:
        raise WriterError(f'{target}: cannot write: {e.strerror}') from None
    return target
