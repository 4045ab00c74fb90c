#!/usr/bin/env bash
# Run the whole test suite (creates or reuses .venv first). Extra arguments go to pytest.
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements-test.txt
cd "$root"
exec "$PY" -m pytest -q "$@" test
