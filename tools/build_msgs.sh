# Sourced by tools/venv.sh: build the message packages of tools/msgs (those ROS 2 Jazzy's PyPI
# wheels lack: tf2_msgs) into the venv with the rosidl wheels, once; a stamp of their sources
# says when to build again. A failed build is a warning, not an error: the simulator then runs
# without what needs them (/tf) and says so.
msgs_stamp="$venv/.rb_sim_ros-msgs.stamp"
msgs_want=$(cd "$root" && cat requirements-msgs.txt $(find tools/msgs -type f | sort) \
  | sha256sum | cut -c1-16)
if [ "$(cat "$msgs_stamp" 2>/dev/null || true)" != "$msgs_want" ]; then
  msgs_log="$venv/.rb_sim_ros-msgs.log"
  echo "[rb_sim_ros] building the message packages of tools/msgs into $venv, once" \
    "(about 1-2 min; log: $msgs_log)" >&2
  msgs_ok=yes
  # Each step ends the build on failure: errexit does not hold in a subshell tested by ||.
  # Its output goes to the log; fd 3 is the terminal, for one line per step.
  (
    echo "[rb_sim_ros]   installing the rosidl generator wheels (about 30 s)" >&3
    "$venv/bin/python" -m pip install --disable-pip-version-check \
      -r "$root/requirements-msgs.txt" || exit 1
    command -v cmake >/dev/null || "$venv/bin/python" -m pip install \
      --disable-pip-version-check cmake || exit 1
    # The packages build side by side: configuring and generating are single-threaded, and
    # each compiles on every core (tf2_msgs is done in seconds, simulation_interfaces then has
    # them all to itself).
    pids=()
    for pkg in "$root"/tools/msgs/*/; do
      name=$(basename "$pkg")
      echo "[rb_sim_ros]   generating and compiling $name (about 1 min; log:" \
        "$venv/.rb_sim_ros-msgs-$name.log)" >&3
      build="$venv/.rb_sim_ros-build/$name"
      (
        rm -rf "$build"
        PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv" \
          cmake -S "$pkg" -B "$build" -DCMAKE_INSTALL_PREFIX="$venv" -DBUILD_TESTING=OFF \
          -DPython3_EXECUTABLE="$venv/bin/python" -DCMAKE_BUILD_TYPE=Release || exit 1
        PATH="$venv/bin:$PATH" cmake --build "$build" -j "$(nproc)" || exit 1
        PATH="$venv/bin:$PATH" cmake --install "$build" || exit 1
      ) >"$venv/.rb_sim_ros-msgs-$name.log" 2>&1 &
      pids+=($!)
    done
    failed=0
    for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
    cat "$venv"/.rb_sim_ros-msgs-*.log
    [ "$failed" = 0 ] || exit 1
  ) 3>&2 >"$msgs_log" 2>&1 || msgs_ok=no
  if [ "$msgs_ok" = yes ]; then
    echo "$msgs_want" > "$msgs_stamp"
    echo "[rb_sim_ros] message packages built (log: $msgs_log)" >&2
  else
    echo "[rb_sim_ros] WARNING: building tools/msgs failed (see $msgs_log); the simulator" \
      "runs without /tf" >&2
  fi
fi
