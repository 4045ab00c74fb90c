# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The offline tools, a wing apart from the live node (as rosbags stands apart from rosbag2's
player): ``replay`` (read and check a recording, verify it by simulating it again, play it,
recover a cut one, plot and render it) and ``sweep`` (many runs of a scene, varied, on local
processes or Ray). They share the node's configuration and messages (``ros.node_config``,
``ros.ros_messages``, ``ros.node_recorder``), never its executable; the live node imports
nothing of them.

    ros2 run rb_sim_ros replay --verify run.mcap     # python -m rb_sim_ros.offline.replay
    ros2 run rb_sim_ros sweep scene.yaml --vary ...  # python -m rb_sim_ros.offline.sweep
"""
