# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The core: rotations (so3), bodies, states and wrenches (rigid_body), the world-frame Euler
equations of Thm 1 (euler_dynamics), the multistep method of Proof 3 (multistep), and the
steppers that take it (stepper: one body; batch: many), and the compiled kernels they run
(step_kernel, rotation_kernels; jit compiles them with numba). numpy and numba only; imports
nothing else of this package."""
