#!/usr/bin/env bash
# Sets up, builds and runs every test (unit, numeric, command line).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
ctest --preset release
