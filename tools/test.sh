#!/usr/bin/env bash
# Run the whole test suite (creates or reuses .venv first). Extra arguments go to pytest.
# Without them, the ROS user's path is checked after it too (tools/colcon_check.sh): colcon
# build, the installed simulator, colcon test.
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements-test.txt
cd "$root"
if [ $# -gt 0 ]; then
  exec "$PY" -m pytest -q "$@" test
fi
"$PY" -m pytest -q test
. "$root/tools/colcon_check.sh"
