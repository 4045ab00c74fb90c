# Sourced by tools/venv.sh: build the message packages of tools/msgs (those ROS 2 Jazzy's PyPI
# wheels lack: tf2_msgs) into the venv with the rosidl wheels, once; a stamp of their sources
# says when to build again. A failed build is a warning, not an error: the simulator then runs
# without what needs them (/tf) and says so.
msgs_stamp="$venv/.rb_sim_ros-msgs.stamp"
msgs_want=$(cd "$root" && cat requirements-msgs.txt $(find tools/msgs -type f | sort) \
  | sha256sum | cut -c1-16)
if [ "$(cat "$msgs_stamp" 2>/dev/null || true)" != "$msgs_want" ]; then
  echo "[rb_sim_ros] building tools/msgs into $venv (about 2 min the first time)" >&2
  msgs_log="$venv/.rb_sim_ros-msgs.log"
  msgs_ok=yes
  # Each step ends the build on failure: errexit does not hold in a subshell tested by ||.
  (
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
      -r "$root/requirements-msgs.txt" || exit 1
    command -v cmake >/dev/null || "$venv/bin/python" -m pip install --quiet \
      --disable-pip-version-check cmake || exit 1
    for pkg in "$root"/tools/msgs/*/; do
      name=$(basename "$pkg")
      build="$venv/.rb_sim_ros-build/$name"
      rm -rf "$build"
      PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv" \
        cmake -S "$pkg" -B "$build" -DCMAKE_INSTALL_PREFIX="$venv" -DBUILD_TESTING=OFF \
        -DPython3_EXECUTABLE="$venv/bin/python" -DCMAKE_BUILD_TYPE=Release || exit 1
      PATH="$venv/bin:$PATH" cmake --build "$build" -j 2 || exit 1
      PATH="$venv/bin:$PATH" cmake --install "$build" || exit 1
    done
  ) >"$msgs_log" 2>&1 || msgs_ok=no
  if [ "$msgs_ok" = yes ]; then
    echo "$msgs_want" > "$msgs_stamp"
  else
    echo "[rb_sim_ros] WARNING: building tools/msgs failed (see $msgs_log); the simulator" \
      "runs without /tf" >&2
  fi
fi
