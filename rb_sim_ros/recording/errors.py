# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""One error class per direction; every message names the file (or type) and what is wrong."""

from __future__ import annotations


class RecordingError(Exception):
    """Base of the two errors below, for callers that handle both alike."""


class WriterError(RecordingError):
    """A recording cannot be written: the path exists, a type is not installed, misuse..."""


class ReaderError(RecordingError):
    """A file is not a readable ROS 2 recording: missing, foreign, corrupt or undecodable."""
