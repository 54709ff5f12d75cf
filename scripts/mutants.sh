#!/usr/bin/env bash
# Breaks one element of the sources on purpose and checks that `geardyn validate` fails exactly
# the checks whose references do not pass through it. Each mutant is a change of the code, made
# in a copy of the work tree (the files git does not ignore) and built there (the command line
# alone, a few minutes on 2 cores a mutant): the product holds no switch for it. Not part of
# scripts/test.sh; the test command's short version is tests/validation_test.cpp, which builds
# its broken case itself.
#
#   bash scripts/mutants.sh [NAME...]      (no name: every mutant below)
#
# Exit 0 when every mutant fails the checks it should and no other, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

# name | file | the line as written | the line broken | the checks that must fail
mutants=(
  "gear_pair_damping_sign|src/model/model.cpp|  p.damping_n_s_per_m = 2.0 * c.mesh.damping_ratio *|  p.damping_n_s_per_m = -2.0 * c.mesh.damping_ratio *|"
  "pair_train_damping_sign|src/model/train_presets.cpp|  m.damping_ratio = c.mesh.damping_ratio;|  m.damping_ratio = -c.mesh.damping_ratio;|"
)
# The checks each must fail, as a sorted comma-separated list. The one-degree model is a
# reference only: broken, it fails the checks that compare with it (train_pair, pair_forms, and
# coupled_rigid, whose coupled model is built on its parameters), and the user's path passes.
# The pair's train (train_form_of) is the user's path for the pair forms: broken, it fails every
# check of a pair form's response against a closed form, the paper or the one-degree model;
# train_pair, which writes the pair as a train case itself, passes.
declare -A expected=(
  [gear_pair_damping_sign]="coupled_rigid,pair_forms,train_pair"
  [pair_train_damping_sign]="contact_response,pair_forms,paper_dopri5,paper_findings,te_response"
)

wanted=("$@")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
for m in "${mutants[@]}"; do
  IFS='|' read -r name file line broken _ <<<"$m"
  if ((${#wanted[@]})) && [[ ! " ${wanted[*]} " == *" $name "* ]]; then continue; fi
  echo "mutant $name: $file"
  rm -rf "$work/src" "$work/build" && mkdir -p "$work/src"
  git ls-files -z --cached --others --exclude-standard | tar --null -T - -cf - | tar -xf - -C "$work/src"
  # The line must be there once, as written: a mutant that no longer applies is a failure.
  if [[ $(grep -cxF -- "$line" "$work/src/$file") != 1 ]]; then
    echo "  its line is not in $file once as written: update scripts/mutants.sh"
    status=1
    continue
  fi
  python3 - "$work/src/$file" "$line" "$broken" <<'EOF'
import sys
path, line, broken = sys.argv[1:]
text = open(path).read().split("\n")
text[text.index(line)] = broken
open(path, "w").write("\n".join(text))
EOF
  if ! { cmake -S "$work/src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
          -DGEARDYN_BUILD_TESTS=OFF -DGEARDYN_BUILD_BENCH=OFF -DGEARDYN_BUILD_PYTHON=OFF &&
        cmake --build "$work/build" --target geardyn_cli -j"$(nproc)"; } >"$work/build.log" 2>&1; then
    tail -20 "$work/build.log"
    echo "  the mutant does not build"
    status=1
    continue
  fi
  "$work/build/geardyn" validate --json >"$work/validate.json" || true
  failing=$(python3 - "$work/validate.json" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))
print(",".join(sorted({r["check"] for r in j["rows"] if not r["passed"]})))
EOF
)
  if [[ $failing == "${expected[$name]}" ]]; then
    echo "  caught by exactly: $failing"
  else
    echo "  failing:  ${failing:-none}"
    echo "  expected: ${expected[$name]}"
    status=1
  fi
done
exit $status
