#!/usr/bin/env bash
# Regenerate docs/benchmarks.md and docs/img/ (creates or reuses .venv with the benchmark
# peers: scipy, mujoco, matplotlib, tqdm). Extra arguments go to bench/run.py (--quick, --out).
set -euo pipefail
. "$(dirname "$0")/venv.sh" requirements-bench.txt
cd "$root"
exec "$PY" bench/run.py "$@"
