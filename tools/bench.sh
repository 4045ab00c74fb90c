#!/usr/bin/env bash
# Regenerate docs/benchmarks.md and docs/img/ (creates or reuses .venv with the benchmark
# peers: scipy, mujoco, matplotlib, tqdm): python -m bench.run from the repository root. Extra
# arguments go to it (--quick, --out).
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements-bench.txt
cd "$root"
exec "$PY" -m bench.run "$@"
