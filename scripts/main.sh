#!/usr/bin/env bash
# Sets up, builds, and runs the main job: the paper's gear (Table 1, Fig. 4(c) conditions),
# written to out/park2010/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
./build/release/geardyn run cases/park2010.toml --out out/park2010
