#!/usr/bin/env bash
# `pip install --no-build-isolation .` into a fresh virtual environment that sees Debian's
# NumPy (--system-site-packages), from a copy of the sources, without network: then the
# package imports from outside the source tree with its metadata, version, type stubs and the
# `geardyn` and `geardyn-study` commands, and the installed validation passes (as the README
# shows it). Usage:
# install_test.sh SOURCE_DIR [BUILD_DIR]
# With BUILD_DIR (the test suite passes its own build), pip packages that build's extension and
# tool instead of compiling them again; without it (scripts/check_install.sh), pip builds from
# the sources as a user's `pip install .` does.
set -euo pipefail
src="$1"
if [[ -n "${2:-}" ]]; then
  export GEARDYN_CMAKE_BUILD_DIR="$2"
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir "$work/src"
tar -C "$src" --exclude=./build --exclude=./out --exclude=./results --exclude=./.git \
  --exclude='*.egg-info' -cf - . | tar -C "$work/src" -xf -
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
# pip's build goes to a cache outside the sources (here the test's own, removed with it).
before="$(cd "$work/src" && find . | sort)"
XDG_CACHE_HOME="$work/cache" PIP_NO_INDEX=1 CMAKE_BUILD_PARALLEL_LEVEL=2 \
  "$work/venv/bin/pip" install --no-build-isolation -q "$work/src"
# The folder installed from is left as it was, but for setuptools' metadata (*.egg-info).
after="$(cd "$work/src" && find . -not -path '*.egg-info*' | sort)"
if [[ "$before" != "$after" ]]; then
  echo "pip install wrote into the folder it installs from:"
  diff <(echo "$before") <(echo "$after") || true
  exit 1
fi
test -d "$work/cache/geardyn"
cd "$work"
"$work/venv/bin/python" - "$work/venv" <<'PY'
import importlib.metadata
import pathlib
import sys

import geardyn

pkg = pathlib.Path(geardyn.__file__).parent
assert str(pkg).startswith(sys.argv[1]), pkg  # the installed copy, not the sources
assert importlib.metadata.version("geardyn") == geardyn.__version__
assert (pkg / "py.typed").is_file() and (pkg / "_geardyn.pyi").is_file()
r = geardyn.run(geardyn.Case.default().set("solver.duration_s", 0.002))
assert r.ok and len(r.t) > 10
from geardyn.bearings import BallBearing  # the pure-Python modules are installed too
assert BallBearing(9, 9.525, 46.0, 4.89, 4.953).radial(356.0)[1] > 0
v = geardyn.validate(quick=True)
assert v.passed, str(v)
print("installed geardyn", geardyn.__version__, "at", pkg)
PY
version="$("$work/venv/bin/python" -c 'import geardyn; print(geardyn.__version__)')"
test "$("$work/venv/bin/geardyn" --version)" = "geardyn $version"
"$work/venv/bin/geardyn" run --set solver.duration_s=0.002 >/dev/null
(cd "$work" && "$work/venv/bin/geardyn" validate --quick --out validation >/dev/null)
test -s "$work/validation/validation.html"
printf 'samples = 4\n[set]\n"solver.duration_s" = 0.002\n[inputs."mesh.backlash_um"]\ndistribution = "uniform"\nlower = 80\nupper = 120\n' > "$work/s.toml"
"$work/venv/bin/geardyn-study" "$work/s.toml" --out "$work/study" >/dev/null 2>&1
test -s "$work/study/study.nc" && test -s "$work/study/report.html"
echo "pip install: ok"
