# Sourced by tools/test.sh: the ROS user's path, with colcon from PyPI. Builds this package in
# a colcon workspace (--symlink-install), sources install/setup.bash, compiles the kernels
# into $NUMBA_CACHE_DIR once, starts
# lib/rb_sim_ros/simulator from the install tree and waits for its first pose, then runs the
# whole suite once with `colcon test` (on ${RB_SIM_ROS_TEST_WORKERS:-2} pytest-xdist workers)
# and reports it with `colcon test-result --verbose`. Needs $venv, $root and $PY (venv.sh).
ws=$(mktemp -d "${TMPDIR:-/tmp}/rb_sim_ros_ws.XXXXXX")
trap 'rm -rf "$ws"' EXIT
mkdir -p "$ws/src"
ln -s "$root" "$ws/src/rb_sim_ros"
echo "[rb_sim_ros] colcon build in $ws" >&2
(
  cd "$ws"
  colcon --log-base log build --symlink-install --event-handlers console_cohesion+ \
    >"$ws/build.log" 2>&1 || { cat "$ws/build.log"; exit 1; }
  set +u  # the setup scripts read unset variables
  . install/setup.bash
  set -u
  # Once, before the workers start: every kernel part into the shared cache, which the
  # workers, the nodes and replays they start, and the test installs load (a --symlink-install
  # tree is this checkout; the tests' installs are seeded from it, test/support/ros_harness.py).
  start=$SECONDS
  echo "[rb_sim_ros] compiling the kernels into $NUMBA_CACHE_DIR (about 6-10 min on 2 cores the first" \
    "time, seconds once cached; log: $ws/precompile.log)" >&2
  "$PY" -m rb_sim_ros.sim.precompile >"$ws/precompile.log" 2>&1 \
    || { cat "$ws/precompile.log"; exit 1; }
  echo "[rb_sim_ros] kernels ready in $((SECONDS - start)) s" >&2
  ROS_DOMAIN_ID=$((RANDOM % 100 + 1)) "$PY" "$root/tools/probe_installed.py" \
    install/rb_sim_ros/lib/rb_sim_ros/simulator
  echo "[rb_sim_ros] colcon test" >&2
  colcon --log-base log test --packages-select rb_sim_ros --event-handlers console_direct+ \
    --pytest-args -p no:cacheprovider -n "${RB_SIM_ROS_TEST_WORKERS:-2}" --durations=25
  colcon --log-base log test-result --verbose
)
