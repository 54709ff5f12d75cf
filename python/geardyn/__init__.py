"""geardyn from Python: the same cases, runs and sweeps as the command line.

    import geardyn
    case = geardyn.Case.default()            # or geardyn.Case.from_toml("cases/park2010.toml")
    case.set("speed.shaft_frequency_hz", 100)
    r = geardyn.run(case)                    # r.t, r.delta_bar, r.force_bar, r.velocity, r.contact
    r.summary["regime"]
    s = geardyn.sweep(case, param="speed.shaft_frequency_hz", values=range(1500, 3501, 50))

Errors arrive as geardyn.InputError (a ValueError) with the command line's messages, and a
numerical failure of a run as geardyn.NumericalError.
"""
import json as _json
import math as _math

from ._geardyn import Case, InputError, RunResult  # noqa: F401
from . import _geardyn

__all__ = ["Case", "InputError", "NumericalError", "RunResult", "geometry", "stiffness", "run",
           "sweep", "plot"]


class NumericalError(RuntimeError):
    """A run did not complete (divergence, Newton-Raphson not converging); the message says why."""


def _toml_value(value):
    """A Python value in TOML value syntax."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if _math.isnan(value):
            return "nan"
        if _math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if hasattr(value, "item"):  # a NumPy scalar
        return _toml_value(value.item())
    raise InputError(f"{value!r}: a case value must be a number, string, bool or list")


def _set(self, key, value):
    """Sets a case key, as --set key=value does: case.set("speed.shaft_frequency_hz", 100)."""
    self.set_toml(key, _toml_value(value))
    return self


Case.set = _set


def geometry(case):
    """The derived geometry, as `geardyn geometry --json`."""
    return _json.loads(_geardyn._geometry_json(case))


def stiffness(case):
    """ISO 6336-1 and the energy method, as `geardyn stiffness --json`, with the energy method's
    curve over one mesh cycle under "cycle" (arrays "position" and "total_n_per_m")."""
    text, arrays = _geardyn._stiffness(case)
    out = _json.loads(text)
    out["cycle"] = arrays
    return out


def _summary(self):
    return _json.loads(self._summary_json)


RunResult.summary = property(_summary, doc="The reading, with the keys of summary.json.")


def run(case):
    """Runs a case (the GIL is released meanwhile). The arrays t, delta_bar, force_bar,
    velocity and contact point into the result without copies."""
    r = _geardyn._run(case)
    if not r.ok:
        raise NumericalError(f"numerical failure ({r._failure})")
    return r


def sweep(case, param, values, direction="both", settle_periods=20, measure_periods=10,
          max_settle_periods=200, threads=0):
    """Sweeps `param` over `values` (ascending up, descending down), as `geardyn sweep`. Returns
    a dict of NumPy arrays per column (direction and regime as lists), and "jumps"."""
    return _geardyn._sweep(case, param, [float(v) for v in values], direction, settle_periods,
                           measure_periods, max_settle_periods, threads)


from . import plot  # noqa: E402,F401
