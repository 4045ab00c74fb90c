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


def interrupt_in(error: BaseException) -> BaseException | None:
    """The KeyboardInterrupt (or SystemExit) that ``error`` was raised from, if any.

    A signal that arrives while rclpy's C++ converts a message runs its Python handler
    there; pybind11 then raises a TypeError ("Unable to convert function return value")
    *from* the KeyboardInterrupt. Callers that catch ``Exception`` around such a call
    re-raise what this returns, so that Ctrl-C stays Ctrl-C, not a bad message."""
    seen = set()
    e: BaseException | None = error
    while e is not None and id(e) not in seen:
        if not isinstance(e, Exception):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None
