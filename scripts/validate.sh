#!/usr/bin/env bash
# Long validations (pytest marker "validation"), left out of the default suite.
# Hopper (seed 003): tests/test_hopper_validation.py, about 27 minutes on 2 cores.
# Streams (seed 000): tests/test_stream_validation.py, about 8 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pytest -m validation "$@"
