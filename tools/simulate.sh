#!/usr/bin/env bash
# Start the simulator node on its built-in default body (what `ros2 run rb_sim_ros simulator`
# does on a ROS 2 install). Extra arguments go to the node, e.g. --ros-args -p dt:=0.0005
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements.txt
exec "$PY" -m rb_sim_ros.ros.simulator_node "$@"
