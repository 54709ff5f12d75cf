"""pip's build of geardyn: the extension `geardyn._geardyn` and the command-line tool, built by
the project's CMake (no network: the build requirements are Debian packages, see
scripts/setup.sh). The metadata is in pyproject.toml."""
import hashlib
import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def build_base():
    """Where pip's build writes: a cache folder per source folder, outside it (the folder a
    user installs from is left as it was, and installing again rebuilds only what changed)."""
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache")
    return cache / "geardyn" / ("build-" + hashlib.sha256(str(ROOT).encode()).hexdigest()[:12])


def progress_stream():
    """Where the build's progress goes: the terminal when there is one (pip shows a build
    backend's output only with -v), else standard error."""
    try:
        return open("/dev/tty", "w")
    except OSError:
        return sys.stderr


def run_with_progress(command, what, out):
    """Runs `command`, writing its progress lines ("[ 42%] ...") to `out` as
    "geardyn: <what> 42%"; its whole output goes to standard output (pip -v shows it). A failed
    command raises CalledProcessError with its last lines."""
    tail = []
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          bufsize=1) as p:
        for line in p.stdout:
            sys.stdout.write(line)
            tail = (tail + [line])[-30:]
            m = re.match(r"\[\s*(\d+)%\]", line)
            if m:
                out.write(f"\rgeardyn: {what} {m.group(1)}%")
                out.flush()
    out.write("\n")
    out.flush()
    if p.returncode != 0:
        raise subprocess.CalledProcessError(p.returncode, command, output="".join(tail))


class CMakeBuild(build_ext):
    """Configures and builds the `_geardyn` and `geardyn_cli` targets, then copies the
    extension and the tool (as geardyn/_bin/geardyn) into the package.

    With GEARDYN_CMAKE_BUILD_DIR set to an existing CMake build of these sources (the Python
    module on, as the release preset has it), that build's two targets are brought up to date
    and packaged instead: the test suite's install test packages the build it tests rather than
    compiling everything a second time (scripts/check_install.sh builds from source)."""

    def build_extension(self, ext):
        given = os.environ.get("GEARDYN_CMAKE_BUILD_DIR")
        build = pathlib.Path(given).resolve() if given else build_base() / "cmake"
        build.mkdir(parents=True, exist_ok=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 2))
        configure = [
            "cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
            "-DGEARDYN_BUILD_PYTHON=ON", "-DGEARDYN_BUILD_TESTS=OFF", "-DGEARDYN_BUILD_BENCH=OFF",
            f"-DPYTHON_EXECUTABLE={sys.executable}",
        ]
        out = progress_stream()
        try:
            if not given:
                out.write(f"geardyn: configuring the CMake build in {build}\n")
                subprocess.run(configure, check=True)
            run_with_progress(["cmake", "--build", str(build), "--target", "_geardyn",
                               "geardyn_cli", "-j", jobs],
                              f"building the extension and the tool on {jobs} cores", out)
        except FileNotFoundError:
            sys.exit("geardyn: building needs cmake and a C++ compiler; on Debian run "
                     "`bash scripts/setup.sh --deps-only` first")
        except subprocess.CalledProcessError as e:
            sys.exit(f"geardyn: the CMake build failed ({e}); the libraries it needs are "
                     f"installed by `bash scripts/setup.sh --deps-only`\n{e.output or ''}")
        built = next((build / "python" / "geardyn").glob("_geardyn*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(built, target)
        tool = target.parent / "_bin" / "geardyn"
        tool.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(build / "geardyn", tool)


setup(ext_modules=[Extension("geardyn._geardyn", sources=[])], cmdclass={"build_ext": CMakeBuild},
      options={"build": {"build_base": str(build_base())}})
