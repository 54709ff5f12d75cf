#!/usr/bin/env bash
# Sets up, builds, and runs the main job: the paper's study (Figs. 4-6 of Park 2010) reproduced,
# with its report and figures in results/park2010/ (open report.html).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --tool
./build/release/geardyn reproduce park2010 --out results/park2010
