# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""MCAP recordings that ROS 2 tools read: a non-blocking writer, a reader, recovery.

A recording is one MCAP file as ``ros2 bag record -s mcap`` (Jazzy) writes it: profile ``ros2``,
messages in ``cdr`` (rclpy's own serialisation), one ``ros2msg`` schema per type with the full
dependency text of the installed .msg files, channel metadata ``offered_qos_profiles`` (Jazzy's
YAML) and ``topic_type_hash`` (RIHS01), and at the end rosbag2's bag information (metadata
``rosbag2``). Chunks are zstd-compressed, indexed and small, and each goes to the OS when
finished, so a killed writer leaves a file readable up to its last chunk; ``recover`` finalises
such a file. Timestamps are integer nanoseconds, always passed in.

Modules: ``writer`` (RecordingWriter), ``reader`` (RecordingReader), ``recover``, ``schemas``
(type names, schema text, type hashes), ``qos`` (offered_qos_profiles), ``bag_info`` (rosbag2's
bag information, metadata.yaml), ``errors``.
"""

from rb_sim_ros.recording.bag_info import write_rosbag2_metadata
from rb_sim_ros.recording.errors import ReaderError, RecordingError, WriterError
from rb_sim_ros.recording.qos import offered_qos_profiles
from rb_sim_ros.recording.reader import (message_class, RawMessage, RecordedMessage,
                                         RecordingReader, TopicInfo)
from rb_sim_ros.recording.recover import recover
from rb_sim_ros.recording.schemas import schema_text, type_hash, type_name_of
from rb_sim_ros.recording.writer import RecordingWriter

__all__ = [
    'message_class', 'offered_qos_profiles', 'RawMessage', 'ReaderError', 'RecordedMessage',
    'RecordingError', 'RecordingReader', 'RecordingWriter', 'recover', 'schema_text',
    'TopicInfo', 'type_hash', 'type_name_of', 'write_rosbag2_metadata', 'WriterError',
]
