# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Start an installed simulator executable and wait (at most 300 s) for its first pose on this
ROS domain; exit 0 if it came and the simulator then stopped cleanly on SIGINT, else 1.

    python tools/probe_installed.py install/rb_sim_ros/lib/rb_sim_ros/simulator
"""

import signal
import subprocess
import sys
import time

from geometry_msgs.msg import PoseStamped
import rclpy


def main(executable: str) -> int:
    rclpy.init()
    node = rclpy.create_node('rb_sim_install_probe')
    poses = []
    node.create_subscription(PoseStamped, 'pose', poses.append, 10)
    sim = subprocess.Popen([executable])
    try:
        end = time.monotonic() + 300.0
        while not poses and time.monotonic() < end and sim.poll() is None:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        sim.send_signal(signal.SIGINT)
        try:
            code = sim.wait(60)
        except subprocess.TimeoutExpired:
            sim.kill()
            code = sim.wait()
        node.destroy_node()
        rclpy.shutdown()
    ok = bool(poses) and code == 0
    print(f'[rb_sim_ros] installed simulator: {"a pose received" if poses else "no pose"}, '
          f'exit status {code}', file=sys.stderr)
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main(sys.argv[1]))
