"""The `geardyn` command that pip installs: runs the command-line tool built with the package."""
import os
import pathlib
import sys


def main():
    """Replaces this process by the bundled `geardyn` binary with the same arguments."""
    exe = pathlib.Path(__file__).with_name("_bin") / "geardyn"
    if not exe.is_file():
        sys.exit(f"geardyn: the command-line tool is missing from the package ({exe}); "
                 "reinstall with `pip install --no-build-isolation .`")
    os.execv(str(exe), [str(exe), *sys.argv[1:]])
