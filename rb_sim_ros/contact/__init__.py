# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Contact (Proof 2, docs/collisions.md): body descriptions and contact settings (bodies),
shapes, broad phase, narrow phase, the impulse solver, and the collision world that steps
bodies that touch. Imports the core only."""
