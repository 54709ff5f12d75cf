#!/usr/bin/env bash
# clang-tidy (.clang-tidy: bugs, performance, naming) on every C++ source, one CTest test each:
# about 30 CPU-minutes, so not part of scripts/test.sh, whose clang_tidy_recent checks the
# sources of the newest commit that changed any and whose clang_format checks every file.
#
#   bash scripts/lint.sh [CTEST ARGS...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
ctest --preset lint "$@"
