# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Command lines of the executables: ROS arguments apart, bad ones refused without a traceback."""

from __future__ import annotations

import argparse
import sys

from rclpy.utilities import remove_ros_args


def non_ros_args(argv: list[str], prog: str) -> list[str]:
    """The arguments after the program name that are not ROS arguments (--ros-args ...).

    A malformed ROS argument (say ``-p inertia:=[1, 0.5]``, whose items are not all of one
    type) ends the program with rcl's explanation and exit status 2.
    """
    try:
        return remove_ros_args(argv)[1:]
    except Exception as e:  # rclpy raises RCLInvalidROSArgsError, a pybind11 type
        print(f'{prog}: invalid ROS arguments: {e}', file=sys.stderr)
        sys.exit(2)


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr ('prog: what') and exit status 2,
    the one parser of every command line tool of the package."""

    def error(self, message: str):
        print(f'{self.prog}: {message}', file=sys.stderr)
        sys.exit(2)
