# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Everything ROS: the node's parameters, message <-> event conversions, body ports, markers,
diagnostics, the recorder, and the executables (simulator_node, send_wrench, replay). Imports
sim, contact, core and recording."""
