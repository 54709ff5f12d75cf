#!/usr/bin/env bash
# Measures what docs/performance.md reports, on this machine: the benchmarks against plain
# Boost.Odeint programs (bench/), and the commands a user types on the shipped cases, each with
# its wall time and largest resident memory (GNU time). About 15 minutes on 2 cores; run it on
# an otherwise idle machine, after `bash scripts/setup.sh` (which builds the benchmarks).
#
#   bash scripts/performance.sh [--commands-only] [OUT]    # default OUT: out/performance
#
# OUT/commands.md gets a table row per command; OUT/<bench>.txt each benchmark's own report.
set -euo pipefail
cd "$(dirname "$0")/.."
only_commands=false
if [[ "${1:-}" == "--commands-only" ]]; then only_commands=true; shift; fi
out="${1:-out/performance}"
mkdir -p "$out"
g=build/release/geardyn
b=build/release/bench
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
export PYTHONPATH="$PWD/build/release/python" MPLBACKEND=Agg

{
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(date -u +%Y-%m-%d)"
  echo
  echo "| command | wall s | max RSS MB |"
  echo "|---|---|---|"
} > "$out/commands.md"

# One command, timed: its row in commands.md.
timed() {
  local what="$*"
  /usr/bin/time -f "%e %M" -o "$scratch/time" "$@" > "$scratch/out" 2>&1 || {
    echo "performance: failed: $what"; cat "$scratch/out"; exit 1; }
  read -r wall rss < "$scratch/time"
  # As the README writes it: `geardyn`, `geardyn-study`, a folder DIR.
  what="$(sed -E "s#$scratch/[a-z0-9_]+#DIR#g; s#build/release/geardyn#geardyn#; s#/usr/bin/python3 -m geardyn._study_cli#geardyn-study#" <<< "$what")"
  printf '| `%s` | %s | %d |\n' "$what" "$wall" $((rss / 1024)) >> "$out/commands.md"
  echo "$what: $wall s"
}

echo "== the user's commands"
timed $g reproduce park2010 --out "$scratch/park2010"
timed $g run cases/park2010.toml --out "$scratch/run_pair"
timed $g run cases/two_stage_reducer.toml --out "$scratch/run_reducer"
timed $g run cases/two_stage_reducer.toml --out "$scratch/run_reducer_plot" --plot
timed $g modes cases/two_stage_reducer.toml --out "$scratch/modes_reducer"
timed $g sweep cases/two_stage_reducer.toml --param train.reference_speed_hz --from 20 --to 150 \
  --points 40 --out "$scratch/sweep_reducer"
timed $g run cases/planetary_set.toml --out "$scratch/run_planetary"
timed $g run cases/wind_turbine_grc750.toml --out "$scratch/run_wt"
timed $g run cases/wind_turbine_grc750.toml --out "$scratch/run_wt_plot" --plot
timed $g sweep cases/wind_turbine_grc750.toml --param train.reference_speed_hz --from 10 --to 45 \
  --points 15 --out "$scratch/sweep_wt"
timed /usr/bin/python3 -m geardyn._study_cli studies/wind_turbine_pin_errors.toml \
  --out "$scratch/study_wt" --workers 2
timed $g continue cases/park2010.toml --param speed.shaft_frequency_hz --from 1000 --to 3000 \
  --out "$scratch/continue_pair" --no-figures
timed $g stability cases/park2010.toml --param speed.shaft_frequency_hz --from 500 --to 3000 \
  --points 200
timed $g validate --out "$scratch/validate"
timed $g validate --quick --out "$scratch/validate_quick"

if $only_commands; then echo "performance: written to $out/commands.md"; exit 0; fi
echo "== the benchmarks"
$b/work_precision --repeat 3 > "$out/work_precision.txt"
$b/work_precision --windows --repeat 2 > "$out/work_precision_windows.txt"
$b/ks_sweep --repeat 3 > "$out/ks_sweep.txt"
$b/train_work_precision --repeat 3 > "$out/train_work_precision_reducer.txt"
$b/train_work_precision --repeat 3 --case cases/planetary_set.toml \
  > "$out/train_work_precision_planetary.txt"
$b/train_work_precision --case cases/wind_turbine_grc750.toml --window 1 --repeat 3 \
  > "$out/train_work_precision_wind_turbine.txt"
$b/coupled_work_precision --repeat 3 > "$out/coupled_work_precision.txt"
$b/user_paths --repeat 3 > "$out/user_paths.txt"
$b/user_paths --repeat 5 --one-degree > "$out/user_paths_one_degree.txt"
/usr/bin/python3 bench/study_throughput.py > "$out/study_throughput.txt"
echo "performance: written to $out/"
