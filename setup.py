"""pip's build of geardyn: the extension `geardyn._geardyn` and the command-line tool, built by
the project's CMake (no network: the build requirements are Debian packages, see
scripts/setup.sh). The metadata is in pyproject.toml."""
import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


class CMakeBuild(build_ext):
    """Configures and builds the `_geardyn` and `geardyn_cli` targets, then copies the
    extension and the tool (as geardyn/_bin/geardyn) into the package.

    With GEARDYN_CMAKE_BUILD_DIR set to an existing CMake build of these sources (the Python
    module on, as the release preset has it), that build's two targets are brought up to date
    and packaged instead: the test suite's install test packages the build it tests rather than
    compiling everything a second time (scripts/check_install.sh builds from source)."""

    def build_extension(self, ext):
        given = os.environ.get("GEARDYN_CMAKE_BUILD_DIR")
        build = pathlib.Path(given).resolve() if given else \
            pathlib.Path(self.build_temp).resolve() / "cmake"
        build.mkdir(parents=True, exist_ok=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 2))
        configure = [
            "cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
            "-DGEARDYN_BUILD_PYTHON=ON", "-DGEARDYN_BUILD_TESTS=OFF", "-DGEARDYN_BUILD_BENCH=OFF",
            f"-DPYTHON_EXECUTABLE={sys.executable}",
        ]
        try:
            if not given:
                subprocess.run(configure, check=True)
            subprocess.run(["cmake", "--build", str(build), "--target", "_geardyn", "geardyn_cli",
                            "-j", jobs], check=True)
        except FileNotFoundError:
            sys.exit("geardyn: building needs cmake and a C++ compiler; on Debian run "
                     "`bash scripts/setup.sh --deps-only` first")
        except subprocess.CalledProcessError as e:
            sys.exit(f"geardyn: the CMake build failed ({e}); the libraries it needs are "
                     "installed by `bash scripts/setup.sh --deps-only`")
        built = next((build / "python" / "geardyn").glob("_geardyn*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(built, target)
        tool = target.parent / "_bin" / "geardyn"
        tool.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(build / "geardyn", tool)


setup(ext_modules=[Extension("geardyn._geardyn", sources=[])], cmdclass={"build_ext": CMakeBuild})
