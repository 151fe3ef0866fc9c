#!/bin/bash
# Runs experiments/hypotheses.yaml with 20 master seeds (the spec's own and 1..19) into
# outputs/seed_counts/seed-<S>/ and counts, with count.py, in how many of them Table 16's
# ordering and each hypothesis verdict hold. Resumable (the job store); about 15 s a seed on
# 2 cores. Usage: reproduction/seed_counts/run.sh [BINARY]
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${1:-${CARGO_TARGET_DIR:-$HOME/.cache/isar-clutter/target}/release/isar-clutter}
seeds=(20200501 $(seq 1 19))
for s in "${seeds[@]}"; do
  "$BIN" run experiments/hypotheses.yaml --seed "$s" --out "outputs/seed_counts/seed-$s" --no-report --quiet
done
PY=${PYTHON:-.venv/bin/python}
"$PY" reproduction/seed_counts/count.py outputs/seed_counts/seed-*
