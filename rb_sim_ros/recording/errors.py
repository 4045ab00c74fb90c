# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""One error class per direction; every message names the file (or type) and what is wrong."""

from __future__ import annotations


class RecordingError(ValueError):
    """Base of the two errors below, for callers that handle both alike.

    A ValueError, so that a program that refuses bad input with ``except ValueError`` (the
    simulator's start-up, given a bad ``record`` path) prints one line, not a traceback."""


class WriterError(RecordingError):
    """A recording cannot be written: the path exists, a type is not installed, misuse..."""


class ReaderError(RecordingError):
    """A file is not a readable ROS 2 recording: missing, foreign, corrupt or undecodable."""
