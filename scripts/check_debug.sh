#!/usr/bin/env bash
# The debug build: assertions of the public contracts on, AddressSanitizer and
# UndefinedBehaviorSanitizer, every test but the lint ones. Long (a debug build with sanitizers
# runs the tests several times slower than the release build); not part of scripts/test.sh. The
# Python package's test is left out: the interpreter is not built with the sanitizers.
#
#   bash scripts/check_debug.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --deps-only
cmake --preset debug
cmake --build --preset debug
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  ctest --preset debug -LE lint -E python_package "$@"
