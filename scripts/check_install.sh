#!/usr/bin/env bash
# `pip install .` from the sources into a fresh virtual environment, as a user does it: the
# extension and the tool compiled by pip's own CMake build (a second full build, about 10
# minutes on 2 cores), then the same checks as the test suite's python_install, which packages
# the test build instead. Not part of scripts/test.sh.
#
#   bash scripts/check_install.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --deps-only
bash tests/python/install_test.sh "$PWD"
