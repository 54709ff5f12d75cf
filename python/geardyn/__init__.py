"""geardyn from Python: the same cases, runs and sweeps as the command line.

    import geardyn
    case = geardyn.Case(speed={"shaft_frequency_hz": 100})   # or Case.from_toml(path)
    case["mesh.backlash_um"], case.with_({"mesh.backlash_um": 150})
    r = geardyn.run(case)                    # r.t, r.delta_bar, r.force_bar, r.velocity, r.contact
    r.summary["regime"]
    s = geardyn.sweep(case, param="speed.shaft_frequency_hz", values=range(1500, 3501, 50))
    geardyn.to_xarray(s), geardyn.save(s, "sweep.nc")        # labelled, NetCDF
    o = geardyn.orbit(case)                  # the periodic orbit, its Floquet multipliers
    b = geardyn.continuation(case, "speed.shaft_frequency_hz", 1500, 3500)  # with bifurcations

Errors arrive as geardyn.InputError (a ValueError) with the command line's messages, and a
numerical failure of a run as geardyn.NumericalError.
"""
import json as _json
import math as _math

from ._version import __version__  # noqa: F401

try:
    import numpy as _numpy  # noqa: F401
except ImportError as _e:  # pragma: no cover - depends on the interpreter
    raise ImportError(
        "geardyn needs NumPy, which this interpreter does not have. On Debian: "
        "`apt-get install python3-numpy`, and in a virtual environment create it with "
        "`python3 -m venv --system-site-packages` so that Debian's NumPy is seen") from _e
try:
    from ._geardyn import Case, InputError, RunResult  # noqa: F401
    from . import _geardyn
except ImportError as _e:  # pragma: no cover - depends on the installation
    raise ImportError(
        f"geardyn's compiled part does not load in this interpreter ({_e}). It is built for "
        "the interpreter that ran `pip install --no-build-isolation .` (or for /usr/bin/python3 "
        "in the build tree); reinstall with this one") from _e

__all__ = ["__version__", "Case", "InputError", "NumericalError", "RunResult", "geometry",
           "stiffness", "run", "sweep", "orbit", "continuation", "stability", "plot", "to_xarray",
           "save", "load"]


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
    if hasattr(value, "tolist"):  # a NumPy scalar or array
        return _toml_value(value.tolist())
    raise InputError(f"{value!r}: a case value must be a number, string, bool, list or NumPy "
                     "array")


def _pythonic(renames=None):
    """A decorator: an InputError raised inside speaks of the function's arguments, not of the
    command line's options (`--settle-periods = 0` becomes `settle_periods = 0`, `--set k=v:`
    becomes `k = v:`); `renames` maps option names that differ (points -> len(values))."""
    import functools
    import re

    def rename(message):
        message = re.sub(r"--set ([^=\s]+)=([^:]*):", r"\1 = \2:", message)
        message = re.sub(r"--param(2?) (\S+) at ", r"param\1 = \2 at ", message)

        def option(m):
            name = m.group(1).replace("-", "_")
            return (renames or {}).get(name, name)

        return re.sub(r"--([a-z][a-z0-9-]*)", option, message)

    def wrap(f):
        @functools.wraps(f)
        def inner(*args, **kwargs):
            try:
                return f(*args, **kwargs)
            except InputError as e:
                raise InputError(rename(str(e))) from None

        return inner

    return wrap


def _floats(name, values):
    """A 1-D sequence of numbers as a list of floats; InputError naming the argument otherwise."""
    a = _numpy.asarray(values, dtype=object)
    if a.ndim != 1:
        raise InputError(f"{name}: must be a 1-D sequence of numbers, got shape {a.shape}")
    try:
        return [float(v) for v in a]
    except (TypeError, ValueError):
        raise InputError(f"{name}: must be numbers, got {list(a)[:5]!r}") from None


def _flat(keys, prefix=""):
    """(dotted key, value) pairs of a mapping whose values may be sections' mappings."""
    out = []
    for k, v in keys.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out += _flat(v, name + ".")
        else:
            out.append((name, v))
    return out


def _case_overrides(keys):
    """Case(**keys)'s (key, TOML text) pairs (called by the extension)."""
    return [(k, _toml_value(v)) for k, v in _flat(keys)]


def _set(self, key, value):
    """Sets a case key in place, as --set key=value does, and returns the case:
    case.set("speed.shaft_frequency_hz", 100). Prefer `with_`, which returns a copy."""
    self.set_toml(key, _toml_value(value))
    return self


def _with(self, changes=None, **keys):
    """A copy with keys changed: case.with_({"mesh.backlash_um": 150}) or
    case.with_(mesh={"backlash_um": 150}); the case itself is left as it is."""
    c = self.copy()
    for k, v in _flat(dict(changes or {}, **keys)):
        c.set_toml(k, _toml_value(v))
    return c


def _to_dict(self):
    """Every key of the case as nested dicts, in the units of the case file."""
    import tomllib

    return tomllib.loads(self.to_toml())


def _getitem(self, key):
    """The value of a dotted key, e.g. case["mesh.backlash_um"] or
    case["model.stiffness_harmonics[0][0]"]; KeyError when the case has no such key."""
    import re

    node = self.to_dict()
    path = re.findall(r"[^.\[\]]+|\[\d+\]", key)
    try:
        for part in path:
            node = node[int(part[1:-1])] if part.startswith("[") else node[part]
    except (KeyError, IndexError, TypeError):
        raise KeyError(f"{key}: not a key of this case (docs/case-files.md lists them)") from None
    return node


def _from_dict(keys):
    """A case from a dict of keys: dotted ({"speed.shaft_frequency_hz": 100}) or nested by
    section ({"speed": {"shaft_frequency_hz": 100}}); the rest are the defaults."""
    return Case(**keys)


Case.set = _pythonic()(_set)
Case.with_ = _pythonic()(_with)
Case.to_dict = _to_dict
Case.__getitem__ = _getitem
Case.from_dict = staticmethod(_from_dict)
Case.__hash__ = None


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


def _progress(progress, total=None, unit="it"):
    """A progress argument as a callable: None, a callable, or True for a tqdm bar (Debian's
    python3-tqdm) over `total` (None: the callable's second argument gives it)."""
    if progress is None or callable(progress):
        return progress
    if progress is not True:
        raise InputError(f"progress = {progress!r}: must be None, True or a callable")
    try:
        from tqdm import tqdm
    except ImportError as e:
        raise ImportError("progress=True needs tqdm (Debian: apt-get install python3-tqdm)") \
            from e
    bar = tqdm(total=total, unit=unit)

    def update(done, of=None):
        if of is not None and bar.total != of:
            bar.total = of
        bar.n = done
        bar.refresh()
        if of is not None and done >= of:
            bar.close()
        return True

    return update


@_pythonic()
def run(case, progress=None):
    """Runs a case (the GIL is released meanwhile). The arrays t, delta_bar, force_bar,
    velocity and contact point into the result without copies. `progress(fraction)` is called
    now and then (True: a tqdm bar); a false return stops the run and returns what was
    computed (r.ok False). Ctrl-C stops it and raises KeyboardInterrupt with the partial
    result as .result. A numerical failure raises NumericalError."""
    if progress is True:
        def callback(fraction, _bar=_progress(True, 100, "%")):
            return _bar(round(100 * fraction))
    else:
        callback = _progress(progress)
    r, interrupted = _geardyn._run(case, callback)
    if interrupted:
        raise _interrupted(r, "run")
    if not r.ok and "cancelled" not in r._failure:
        raise NumericalError(f"numerical failure ({r._failure})")
    return r


@_pythonic({"points": "len(values)", "from": "values", "to": "values", "points2": "len(values2)", "from2": "values2", "to2": "values2"})
def sweep(case, param, values, direction="both", settle_periods=20, measure_periods=10,
          max_settle_periods=200, threads=0, progress=None, param2=None, values2=()):
    """Sweeps `param` over `values` (ascending up, descending down), as `geardyn sweep`; with
    `param2` and `values2` a map (a sweep along `param` at each value of `param2`, "value2"
    giving it). Returns a dict of NumPy arrays per column (direction and regime as lists),
    "jumps" and "cancelled". `progress(done, total)` is called after each point (True: a tqdm
    bar); a false return stops the sweep after the points under way, the completed ones kept.
    Ctrl-C does the same and raises KeyboardInterrupt with the completed points as .result."""
    r = _geardyn._sweep(case, param, _floats("values", values), direction, settle_periods,
                        measure_periods, max_settle_periods, threads,
                        _progress(progress, unit="point"), param2 or "",
                        _floats("values2", values2))
    r["param"] = param
    if param2:
        r["param2"] = param2
    if r["interrupted"]:
        raise _interrupted(r, "sweep")
    return r


def _interrupted(result, what):
    """KeyboardInterrupt with the work done so far attached as .result."""
    e = KeyboardInterrupt(f"{what} interrupted; the work done so far is in .result")
    e.result = result
    return e


@_pythonic()
def orbit(case, periods=1, segments=0, settle_periods=100, tolerance=1e-10, max_iterations=40,
          state=None):
    """The periodic orbit of period `periods` system periods, as `geardyn orbit`: Newton on
    the stroboscopic map with the exact engine's Jacobian (multiple shooting on `segments`,
    default one per period), from `state` = (delta in m, delta' in m/s) at t = 0 or from
    `settle_periods` of simulation. Returns a dict: converged, message, period_s (s; tau in the
    non-dimensional form), state, floquet_multipliers (complex array, largest first),
    monodromy, stable, impacts_per_period, min_delta_bar, max_delta_bar, max_force_bar,
    sequence (the contact events of one period) and more. Not converging is reported in
    "converged" and "message", not raised."""
    return _orbit_dict(_geardyn._orbit(case, periods, segments, settle_periods, tolerance,
                                       max_iterations,
                                       None if state is None else [float(x) for x in state]))


def _orbit_dict(text):
    """An orbit's JSON (the command line's) as a dict, its vectors and matrices as arrays."""
    import numpy as np

    o = _json.loads(text)
    o["state"] = np.array(o["state"])
    o["floquet_multipliers"] = np.array([complex(re, im) for re, im in o["floquet_multipliers"]])
    o["monodromy"] = np.array(o["monodromy"])
    return o


@_pythonic({"from": "from_"})
def continuation(case, param, from_, to, periods=1, segments=0, settle_periods=100, step=0.01,
                 max_step=0.02, max_points=5000, follow_period_doubling=False, progress=None):
    """Follows the branch of periodic orbits in the numeric case key `param` from `from_` to
    `to` by pseudo-arclength continuation, as `geardyn continue`. Returns a dict of NumPy
    arrays, one entry per point (param, stable, x_a = (max - min)/2 of delta/b,
    min_delta_bar, max_delta_bar, max_force_bar, impacts_per_period, max_multiplier, delta_m,
    velocity_m_s, branch, periods, multipliers), "bifurcations" (a list of dicts: type, param,
    branch, detail, x_a and "orbit", the orbit there as `orbit` returns it), completed, message. `progress(param, points)` is
    called after each point (True: a tqdm bar over the range); a false return stops. Ctrl-C
    stops within one point and raises
    KeyboardInterrupt with the points so far in its .result."""
    if progress is True:
        def callback(p, n, _bar=_progress(True, 1000, "\u2030")):
            return _bar(round(1000 * min(1.0, abs(p - from_) / abs(to - from_))))
    else:
        callback = _progress(progress)
    r = _geardyn._continuation(case, param, float(from_), float(to), periods, segments,
                               settle_periods, step, max_step, max_points,
                               follow_period_doubling, callback)
    for b in r["bifurcations"]:
        b["orbit"] = _orbit_dict(b["orbit"])
    if r["interrupted"]:
        raise _interrupted(r, "continuation")
    return r


@_pythonic({"points": "len(values)", "from": "values", "to": "values", "points2": "len(values2)", "from2": "values2", "to2": "values2"})
def stability(case, param, values, param2=None, values2=()):
    """The Floquet stability of the motion in permanent contact (the Mathieu-Hill problem of
    the mesh stiffness) at each value of `param` (a chart: at each pair with `param2`), as
    `geardyn stability`. Returns a dict of arrays (param, [param2,] stable, max_multiplier,
    multipliers) and "boundaries": [{param, [param2,] type}] located where a multiplier
    crosses the unit circle (type fold at +1, period_doubling at -1, neimark_sacker)."""
    r = _geardyn._stability(case, param, _floats("values", values), param2 or "",
                            _floats("values2", values2), None)
    if r["interrupted"]:
        raise _interrupted(r, "stability")
    return r


from . import plot  # noqa: E402,F401
from .data import load, save, to_xarray  # noqa: E402,F401
