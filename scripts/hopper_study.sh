#!/usr/bin/env bash
# Seed 003 hopper study: sweeps, Beverloo and sigmoid fits, v_g(h), report.md.
#   scripts/hopper_study.sh [OUT_DIR]          reduced version (about 30 min on 2 cores)
#   scripts/hopper_study.sh --full [OUT_DIR]   full version (see docs/hopper_study.md for cost)
set -euo pipefail
REDUCED=True
if [[ "${1:-}" == "--full" ]]; then REDUCED=False; shift; fi
OUT="${1:-hopper_study}"
python - "$OUT" "$REDUCED" <<'PY'
import sys
from grainflow.studies.hopper_study import reproduce
report = reproduce(sys.argv[1], reduced=sys.argv[2] == "True")
print(f"report: {report}")
PY
