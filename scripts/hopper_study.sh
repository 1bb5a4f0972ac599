#!/usr/bin/env bash
# Seed 003 hopper study: sweeps, Beverloo and sigmoid fits, v_g(h), report.md.
#   scripts/hopper_study.sh [OUT_DIR]          reduced version (about 30 min on 2 cores)
#   scripts/hopper_study.sh --full [OUT_DIR]   full version (see docs/hopper_study.md for cost)
set -euo pipefail
FULL=()
if [[ "${1:-}" == "--full" ]]; then FULL=(--full); shift; fi
exec grainflow study hopper -o "${1:-hopper_study}" "${FULL[@]}"
