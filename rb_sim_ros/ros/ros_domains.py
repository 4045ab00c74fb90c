# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""ROS domain ids held by one process each on this machine: parallel closed loops (a
campaign's workers over DDS, the test suite's runs) never hear each other. A process holds its
id for its lifetime by a lock on a file in the temporary directory; with
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST the traffic stays on this machine too."""

from __future__ import annotations

import fcntl
import os
from pathlib import Path
import random
import tempfile

# Fast DDS's default ports stay below the ephemeral range for ids 0..101; 0 is everyone's
# default, so it is never taken.
DOMAIN_IDS = range(1, 102)
_reserved: tuple[int, object] | None = None


def lock_path(domain_id: int) -> Path:
    return Path(tempfile.gettempdir()) / f'rb_sim_ros_test_domain_{domain_id}.lock'


def reserve() -> int:
    """A ROS domain id no other process using this module holds, for this process's lifetime:
    the first id, from a random start, whose lock file this process locks. RuntimeError if
    every one is held."""
    global _reserved
    if _reserved is not None:
        return _reserved[0]
    ids = list(DOMAIN_IDS)
    start = random.Random().randrange(len(ids))
    for domain_id in ids[start:] + ids[:start]:
        try:
            f = open(lock_path(domain_id), 'a')
        except OSError:  # e.g. another user's file in a sticky /tmp: theirs, then
            continue
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            continue
        _reserved = (domain_id, f)  # the open file holds the lock
        return domain_id
    raise RuntimeError(f'every ROS domain id in {DOMAIN_IDS} is held by another process')


def environment(base=None) -> dict:
    """``base`` (default: this process's environment) on this process's own domain, its
    discovery kept on this machine."""
    env = dict(os.environ if base is None else base)
    env['ROS_DOMAIN_ID'] = str(reserve())
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    return env
