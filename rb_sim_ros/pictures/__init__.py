# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Pictures of a run (plots of its states, a video of its bodies), from what a recording
holds: no ROS here, so they draw on a machine with none (test_layers keeps it so)."""
