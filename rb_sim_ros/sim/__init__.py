# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A run: its configuration, the events that change it at a step, ``Simulation`` (the one
clock), and YAML scenes. Imports contact and core; no ROS."""
