# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Print, as JSON, a SHA-256 of everything ``narrow_kernels.collide_pairs`` writes for the
pairs stored in an .npz file (arrays pair_a, pair_b, kinds, geoms, centres, rotations,
margins): test_narrow_phase.py runs it compiled and with NUMBA_DISABLE_JIT=1 and compares.

Every NaN is hashed as the one quiet NaN: IEEE 754 leaves the sign and payload of a NaN result
to the machine (x86 gives an invalid operation's NaN a sign bit and passes on an operand's NaN,
and LLVM may swap the operands of + and *), and the set has bad poses whose contacts are NaN.
Every other value is hashed to the bit."""

import hashlib
import json
import sys
import types

import numpy as np

from rb_sim_ros.contact import narrow_kernels

INPUTS = ('pair_a', 'pair_b', 'kinds', 'geoms', 'centres', 'rotations', 'margins')


def fingerprint(path: str) -> dict:
    with np.load(path) as data:
        inputs = [np.array(data[name], order='C') for name in INPUTS]
        # the pool of what kinds keep beyond their rows (sets written before it have none)
        inputs.insert(4, np.array(data['pool'], order='C') if 'pool' in data else np.zeros(0))
    rows = len(inputs[0]) * narrow_kernels.MAX_CONTACTS_PER_PAIR
    outputs = (np.zeros((rows, 3)), np.zeros((rows, 3)), np.zeros(rows),
               np.zeros(rows, dtype=np.int64), np.zeros(rows, dtype=np.int64))
    count = narrow_kernels.collide_pairs(*inputs, *outputs)
    digest = hashlib.sha256(str(count).encode())
    for array in outputs:
        out = np.array(array[:count])
        if out.dtype.kind == 'f':
            out[np.isnan(out)] = np.nan
        digest.update(out.tobytes())
    return {'count': int(count), 'sha256': digest.hexdigest(),
            'compiled': not isinstance(narrow_kernels.collide_pairs, types.FunctionType)}


if __name__ == '__main__':
    print(json.dumps(fingerprint(sys.argv[1])))
