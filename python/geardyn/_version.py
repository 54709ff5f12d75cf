"""geardyn's version: the one place it is written (CMake, pip and `geardyn --version` read it)."""
__version__ = "0.1.0"
