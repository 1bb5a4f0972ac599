#!/usr/bin/env bash
# Seed 003 hopper study on the authors' conventions (the second pass): sweeps, free / fixed /
# bounded Beverloo fits, beta(lambda), report.md. Extra arguments go to `grainflow study`
# (e.g. --scheduler ADDR, --convention grainflow for the first pass).
#   scripts/hopper_study.sh [OUT_DIR] [ARGS]          reduced version (about 30 min on 2 cores)
#   scripts/hopper_study.sh --full [OUT_DIR] [ARGS]   full version (docs/hopper_study.md: cost)
set -euo pipefail
FULL=()
if [[ "${1:-}" == "--full" ]]; then FULL=(--full); shift; fi
OUT="${1:-hopper_study}"
shift || true
exec grainflow study hopper -o "$OUT" "${FULL[@]}" "$@"
