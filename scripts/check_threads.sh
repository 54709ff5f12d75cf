#!/usr/bin/env bash
# The ThreadSanitizer build (the "threads" preset): the library, the command line and the tests
# of the code that runs on several threads (the thread pool of sweeps, maps and the paper
# study, and the CSV rows written in blocks on threads), run with the race detector. A race in
# anything they reach fails the script, with both threads' stacks. Long (a build of its own,
# the tests several times slower than in the release build); not part of scripts/test.sh.
#
#   bash scripts/check_threads.sh                            # the threaded tests, whole
#   bash scripts/check_threads.sh --gtest_filter='Sweep*'    # GoogleTest's own arguments
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --deps-only
cmake --preset threads
threaded=(parallel_test output_test sweep_test train_sweep_test reproduce_test cli_test)
cmake --build --preset threads --target geardyn_cli "${threaded[@]}"
failed=()
for t in "${threaded[@]}"; do
  echo "== $t"
  TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" "build/threads/tests/$t" \
    --gtest_brief=1 "$@" || failed+=("$t")
done
if ((${#failed[@]})); then
  echo "check_threads: failed: ${failed[*]}" >&2
  exit 1
fi
echo "check_threads: ${#threaded[@]} test programs, no race found"
