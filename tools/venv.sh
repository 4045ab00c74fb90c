# Sourced by the other tools: create or reuse ./.venv and install a requirements file into it.
# pip runs only when the requirements (or this package's setup files) changed since last time.
# Usage: . tools/venv.sh requirements-test.txt
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
req=${1:-requirements.txt}
venv=${RB_SIM_VENV:-$root/.venv}
# Two set-up commands started at once (a test run beside the simulator) set up one at a time:
# the second waits on the lock, then finds the venv made and the stamp current.
mkdir -p "$venv"
exec {rb_sim_lock}>"$venv/.rb_sim_ros.lock"
flock "$rb_sim_lock"
if [ ! -x "$venv/bin/python" ]; then
  echo "[rb_sim_ros] creating $venv (a few seconds)" >&2
  python3 -m venv "$venv"
fi
# pip's output goes to its log only; on a failure its last lines are shown, and where the rest is.
rb_sim_pip() {
  if ! "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
      --log "$venv/.rb_sim_ros-pip.log" "$@" >"$venv/.rb_sim_ros-pip.out" 2>&1; then
    tail -n 15 "$venv/.rb_sim_ros-pip.out" >&2
    echo "[rb_sim_ros] pip install $* failed (its log: $venv/.rb_sim_ros-pip.log)" >&2
    return 1
  fi
}
stamp="$venv/.rb_sim_ros-$(basename "$req").stamp"
want=$(cat "$root"/requirements*.txt "$root/setup.py" "$root/setup.cfg" | sha256sum | cut -c1-16)
# A file whose requirements include $req (test > bench > runtime) satisfies it too.
case "$(basename "$req")" in
  requirements.txt) covers="requirements.txt requirements-bench.txt requirements-viz.txt
    requirements-test.txt" ;;
  requirements-viz.txt) covers="requirements-viz.txt requirements-test.txt" ;;
  requirements-bench.txt) covers="requirements-bench.txt requirements-test.txt" ;;
  *) covers="$(basename "$req")" ;;
esac
rb_sim_current() {
  local c
  for c in $covers; do
    [ "$(cat "$venv/.rb_sim_ros-$c.stamp" 2>/dev/null || true)" = "$want" ] && return 0
  done
  return 1
}
if ! rb_sim_current; then
  case "$(basename "$req")" in
    requirements-test.txt) took="about 3 min the first time" ;;
    *) took="about 1 min the first time" ;;
  esac
  echo "[rb_sim_ros] installing $req into $venv ($took; pip's log:" \
    "$venv/.rb_sim_ros-pip.log)" >&2
  rb_sim_pip -r "$root/$req"
  rb_sim_pip --no-deps -e "$root"
  echo "$want" > "$stamp"
fi
. "$root/tools/build_msgs.sh"
exec {rb_sim_lock}>&-
# Keep ROS traffic on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
export PATH="$venv/bin:$PATH"
# The ROS wheels install their share/ (ament index, .msg files) into the venv's prefix.
export AMENT_PREFIX_PATH="$venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
PY="$venv/bin/python"
