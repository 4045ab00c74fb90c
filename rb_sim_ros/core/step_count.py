# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The one check of a step count taken by every stepper (Stepper, BatchStepper, the world)."""

from __future__ import annotations

# Clocks count steps in int64: a call may take at most 2^62 steps, so that a clock plus one
# call's steps stays below 2^63 for any run that could end in the lifetime of a machine.
MAX_STEPS = 2 ** 62


def check_steps(n) -> None:
    """ValueError unless ``n`` is a Python int from 0 to MAX_STEPS."""
    if not isinstance(n, int) or isinstance(n, bool) or not 0 <= n <= MAX_STEPS:
        # repr of a huge int is slow (and refused past 4300 digits): name its size instead.
        text = (repr(n)[:40] if not isinstance(n, int) or abs(n) < 10 ** 30
                else f'an int of {n.bit_length()} bits')
        raise ValueError(f'n must be an int from 0 to 2^62, got {text}')
