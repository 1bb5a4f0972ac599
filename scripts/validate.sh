#!/usr/bin/env bash
# Long validations (pytest marker "validation"), left out of the default suite.
# Hopper (seed 003): tests/test_hopper_validation.py, about 18 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pytest -m validation "$@"
