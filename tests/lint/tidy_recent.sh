#!/usr/bin/env bash
# The test command's short clang-tidy: the C++ sources (src/, reference/, apps/) of the newest
# commit that changed any, at most MAX of them; src/support/output_folder.cpp (the code that
# guards the user's files) when git cannot say. scripts/lint.sh checks every source.
#
#   tidy_recent.sh CLANG_TIDY BUILD_DIR SOURCE_DIR [MAX]
set -euo pipefail
tidy=$1 build=$2 source=$3 max=${4:-3}
cd "$source"
files=()
if git rev-parse --git-dir >/dev/null 2>&1; then
  while IFS= read -r f; do
    [[ -f $f ]] && files+=("$f")
  done < <(git log -1 --format= --name-only --diff-filter=AM -- 'src/*.cpp' 'reference/*.cpp' \
           'apps/*.cpp' |
           head -n "$max")
fi
((${#files[@]})) || files=(src/support/output_folder.cpp)
echo "clang-tidy on: ${files[*]}"
# One file a run: clang-tidy 14 has crashed (bugprone-argument-comment) on the second of two
# files that each pass alone.
for f in "${files[@]}"; do
  "$tidy" --quiet -p "$build" "$f"
done
