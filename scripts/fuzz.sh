#!/usr/bin/env bash
# Fuzzes the case reader and the --set parser (fuzz/case_reader_fuzz.cpp) with libFuzzer,
# AddressSanitizer and UndefinedBehaviorSanitizer, built with clang. Long; not part of
# scripts/test.sh, whose fuzz_case_reader_short replays the same target over 200000
# deterministic mutations of fuzz/corpus. New inputs libFuzzer finds go to build/fuzz/corpus; a
# crash is written as build/fuzz/crash-* and the run stops.
#
#   bash scripts/fuzz.sh [SECONDS]      (default 600)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --deps-only
if ! command -v clang++ >/dev/null 2>&1; then
  apt-get install -y -qq --no-install-recommends clang >/dev/null
fi
cmake -S . -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer" \
  -DGEARDYN_FUZZ=ON -DGEARDYN_BUILD_TESTS=OFF -DGEARDYN_BUILD_BENCH=OFF -DGEARDYN_BUILD_PYTHON=OFF
cmake --build build/fuzz --target case_reader_fuzz -j2
mkdir -p build/fuzz/corpus
cp -n fuzz/corpus/* build/fuzz/corpus/
cd build/fuzz
UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  ./case_reader_fuzz -max_total_time="${1:-600}" -max_len=65536 -timeout=10 corpus
