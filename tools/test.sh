#!/usr/bin/env bash
# Run the test suite (creates or reuses .venv first).
#   ./tools/test.sh           the ROS user's path (tools/colcon_check.sh): colcon build, the
#                             installed simulator publishing, then the whole suite once, by
#                             `colcon test` on both cores (pytest-xdist), and colcon test-result
#   ./tools/test.sh ARGS...   pytest ARGS on the suite, here (e.g. -k convergence, -m 'not slow'),
#                             or on the tests ARGS name (e.g. test/contact, one layer's tests)
# Compiled kernels are cached in $NUMBA_CACHE_DIR (default .venv/numba-cache), so a later run
# of unchanged sources loads them; the installed package the node tests start is shared too
# (test/support/ros_harness.py shared_install).
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements-test.txt
cd "$root"
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-$venv/numba-cache}
if [ $# -gt 0 ]; then
  named=
  for arg in "$@"; do
    case $arg in test/*) named=1 ;; esac
  done
  if [ -n "$named" ]; then
    exec "$PY" -m pytest -q "$@"
  fi
  exec "$PY" -m pytest -q "$@" test
fi
. "$root/tools/colcon_check.sh"
