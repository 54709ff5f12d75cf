#!/usr/bin/env bash
# Installs what geardyn needs from Debian's packages (run as root; a no-op when all are there),
# then configures and builds the optimised preset (not with --deps-only; the command alone
# with --tool).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake pkg-config clang-format clang-tidy
  libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev libboost-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libfftw3-dev libeigen3-dev gnuplot-nox
  python3-dev pybind11-dev python3-numpy python3-matplotlib python3-pytest
  python3-venv python3-pip python3-setuptools python3-tqdm python3-xarray python3-netcdf4
  python3-pandas python3-nbclient python3-nbformat python3-ipykernel
  chromium python3-dask python3-distributed python3-openturns python3-plotly python3-scipy
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --deps-only: the packages alone (the debug check builds its own preset); --tool: the command
# alone (the main job), not the tests, benchmarks and Python module.
[[ "${1:-}" == "--deps-only" ]] && exit 0
cmake --preset release >/dev/null
if [[ "${1:-}" == "--tool" ]]; then
  cmake --build --preset release --target geardyn_cli
else
  cmake --build --preset release
fi
