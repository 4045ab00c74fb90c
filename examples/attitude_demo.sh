#!/usr/bin/env bash
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# The attitude controller in closed loop with the simulator, recorded, verified and plotted:
#   examples/attitude_demo.sh [OUT_DIR]     (default: attitude_demo/)
# Starts the simulator (inertia 0.1, 0.2, 0.3 kg m^2, paused until the controller is up) and
# examples/attitude_controller.py on a private ROS domain, runs 8 s of sim time in real time,
# stops both (the recording is finalised), then replay --verify and --plot the recording.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# The node, the controller, replay and its plots: the runtime and the picture packages,
# not the test suite's peers (MuJoCo, Drake, Ray).
. "$root/tools/venv.sh" requirements-viz.txt
out=${1:-attitude_demo}
mkdir -p "$out"
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$((100 + RANDOM % 100))}
inertia='[0.1, 0.2, 0.3]'
"$PY" -m rb_sim_ros.ros.simulator_node --ros-args -p "inertia:=$inertia" \
  -p "record:=$out/run.mcap" -p record_overwrite:=true -p start_paused:=true &
sim=$!
"$PY" "$root/examples/attitude_controller.py" --ros-args -p "inertia:=$inertia" \
  -p 'target_rpy:=[0.3, -0.2, 1.2]' &
ctl=$!
trap 'kill -INT $ctl $sim 2>/dev/null || true' EXIT
# Unpause once the controller listens to odom (the simulator's own count is not ours to see:
# give discovery a few seconds), then 8 s of sim time in real time.
sleep 5
"$PY" - <<'PY'
import rclpy
from std_srvs.srv import SetBool
rclpy.init()
node = rclpy.create_node('attitude_demo')
client = node.create_client(SetBool, 'pause')
if not client.wait_for_service(timeout_sec=30):
    raise SystemExit('attitude_demo: the simulator did not come up')
future = client.call_async(SetBool.Request(data=False))
rclpy.spin_until_future_complete(node, future, timeout_sec=30)
rclpy.shutdown()
PY
sleep 8
kill -INT $ctl $sim
wait $sim || true
trap - EXIT
"$PY" -m rb_sim_ros.offline.replay --verify "$out/run.mcap"
"$PY" -m rb_sim_ros.offline.replay --plot "$out/run.mcap" --out "$out"
