# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Start the rb_sim_ros simulator, optionally recording and with RViz.

    ros2 launch rb_sim_ros sim.launch.py
    ros2 launch rb_sim_ros sim.launch.py scene_file:=/path/scene.yaml record:=run.mcap rviz:=true

Parameters come from ``params_file`` (default: the installed config/params.yaml, every
parameter at its default); ``scene_file`` and ``record`` override it when given (non-empty), so
that a params file's own scene_file or record is kept when they are not.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

# The simulator's parameters this file sets (each must be one of the node's own).
NODE_PARAMETERS = ('scene_file', 'record')


def node_overrides(values: dict) -> dict:
    """The launch arguments of NODE_PARAMETERS that were given (non-empty), as parameters."""
    return {name: values[name] for name in NODE_PARAMETERS if values.get(name, '') != ''}


def _simulator(context) -> list:
    values = {name: LaunchConfiguration(name).perform(context) for name in NODE_PARAMETERS}
    overrides = node_overrides(values)
    return [Node(package='rb_sim_ros', executable='simulator', name='rb_sim', output='screen',
                 parameters=[LaunchConfiguration('params_file'),
                             *([overrides] if overrides else [])])]


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory('rb_sim_ros')
    arguments = [
        DeclareLaunchArgument('params_file', default_value=os.path.join(
            share, 'config', 'params.yaml'), description='YAML of the node parameters'),
        DeclareLaunchArgument('scene_file', default_value='',
                              description="a scene YAML; empty: the params file's, else one body"),
        DeclareLaunchArgument('record', default_value='',
                              description='an MCAP file to record the run to; empty: the '
                              "params file's, else none"),
        DeclareLaunchArgument('rviz', default_value='false', description='start RViz too'),
    ]
    simulator = OpaqueFunction(function=_simulator)
    rviz = Node(
        package='rviz2', executable='rviz2', name='rviz2',
        arguments=['-d', os.path.join(share, 'rviz', 'rb_sim.rviz')],
        condition=IfCondition(LaunchConfiguration('rviz')))
    return LaunchDescription([*arguments, simulator, rviz])
