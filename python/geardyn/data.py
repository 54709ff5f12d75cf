"""Results as labelled tables: xarray Datasets of runs and sweeps, saved to and loaded from
NetCDF (Debian's python3-xarray and python3-netcdf4).

    ds = geardyn.to_xarray(geardyn.sweep(case, "speed.shaft_frequency_hz", values))
    ds["pp_delta_bar"].sel(direction="up")     # dimensions: direction, (param2,) param
    ds.to_dataframe()                           # pandas
    geardyn.save(ds, "sweep.nc"); geardyn.load("sweep.nc")   # exact round trip
"""
import json

import numpy as np

# Units of the sweep's and run's columns (attributes "units" and "long_name").
_COLUMNS = {
    "settled": ("1", "1 when the predicted distance to the periodic response met the tolerance"),
    "period_multiple": ("1", "the response's period in system periods (0: not settled)"),
    "steady_error": ("1", "predicted distance to the periodic response, in b and b w_n"),
    "mean_delta_bar": ("1", "mean of delta / b"),
    "rms_delta_bar": ("1", "RMS of delta / b"),
    "pp_delta_bar": ("1", "peak-to-peak delta / b"),
    "min_delta_bar": ("1", "minimum of delta / b"),
    "mean_force_bar": ("1", "mean of F / (b k_m)"),
    "rms_force_bar": ("1", "RMS of F / (b k_m)"),
    "pp_force_bar": ("1", "peak-to-peak F / (b k_m)"),
    "max_force_bar": ("1", "maximum of F / (b k_m)"),
    "separated_fraction": ("1", "fraction of the time separated"),
    "impacts_per_period": ("1/period", "impacts per system period"),
    "double_sided": ("1", "1 when back-side contact occurred"),
    "dynamic_factor": ("1", "max F_G over the static mesh force (NaN without mean load)"),
    "settle_periods": ("period", "system periods run before the measurement kept"),
    "delta_bar": ("1", "delta / b"),
    "force_bar": ("1", "F / (b k_m)"),
    "velocity": ("m/s", "delta', the velocity along the line of action"),
    "contact": ("1", "1 drive side, 0 separated, -1 back side"),
}
# A gear train sweep's columns per mesh (sweep.hpp's kMeshColumns), over the dimension mesh.
_MESH_COLUMNS = {
    "mean_delta_bar": ("1", "mean of (d - e) / b"),
    "rms_delta_bar": ("1", "RMS of (d - e) / b"),
    "pp_delta_bar": ("1", "peak-to-peak (d - e) / b"),
    "min_delta_bar": ("1", "minimum of (d - e) / b"),
    "max_force_n": ("N", "largest mesh force"),
    "dynamic_factor": ("1", "largest mesh force over the static one (NaN: none)"),
    "separated_fraction": ("1", "fraction of the time separated"),
    "impacts_per_period": ("1/period", "impacts per system period"),
    "backside_impacts_per_period": ("1/period", "back-side impacts per system period"),
}
# A train's load-sharing groups' columns (sweep.csv's <group>_<name>).
_GROUP_COLUMNS = {
    "load_sharing_factor": ("1", "n max F / sum F over the measurement (NaN: no load)"),
    "lost_contact": ("1", "the group's meshes that left their drive flank"),
}
# A train's bearing clearance directions' columns (sweep.csv's <bearing>_<axis>_<name>).
_CLEARANCE_COLUMNS = {
    "clearance_impacts_per_period": ("1/period", "impacts on the clearance's edges per period"),
    "clearance_inside_fraction": ("1", "fraction of the time inside the clearance"),
}
# A train's shaft and bearing quantities' columns (sweep.csv's <part>_<quantity>_<name>).
_PART_COLUMNS = {
    "part_peak": ("N or N m", "largest magnitude of the quantity (its name's unit: _n N, _nm N m)"),
    "part_factor": ("1", "that over its static value (NaN: none or negligible)"),
}
_UNIT_SUFFIXES = {"_hz": "Hz", "_um": "um", "_mm": "mm", "_deg": "deg", "_s": "s", "_nm": "N m",
                  "_n_per_m": "N/m", "_kg_m3": "kg/m^3", "_gpa": "GPa"}


def _key_units(key):
    for suffix, unit in _UNIT_SUFFIXES.items():
        if key.endswith(suffix):
            return unit
    return "1"


def _sweep_dataset(s, param, param2=None):
    import xarray as xr

    values = np.unique(s["value"])
    directions = [d for d in ("up", "down") if d in s["direction"]]
    dims = ["direction"] + (["param2"] if param2 else []) + ["param"]
    values2 = np.unique(s["value2"]) if param2 else None
    shape = [len(directions)] + ([len(values2)] if param2 else []) + [len(values)]
    index = []
    for i, d in enumerate(s["direction"]):
        at = [directions.index(d)]
        if param2:
            at.append(int(np.searchsorted(values2, s["value2"][i])))
        at.append(int(np.searchsorted(values, s["value"][i])))
        index.append(tuple(at))
    data = {}
    for name, (units, long_name) in _COLUMNS.items():
        if name not in s:
            continue
        a = np.full(shape, np.nan)
        for i, at in enumerate(index):
            a[at] = s[name][i]
        data[name] = (dims, a, {"units": units, "long_name": long_name})
    meshes = s.get("meshes")
    if meshes:
        # A gear train: each mesh's column over a further dimension `mesh`.
        for name, (units, long_name) in _MESH_COLUMNS.items():
            key = "mesh_" + name
            if key not in s:
                continue
            a = np.full(shape + [len(meshes)], np.nan)
            for i, at in enumerate(index):
                a[at] = s[key][i]
            data[key] = (dims + ["mesh"], a, {"units": units, "long_name": long_name})
        per_mesh = np.full(shape + [len(meshes)], "", dtype=object)
        for i, at in enumerate(index):
            per_mesh[at] = s["mesh_regime"][i]
        data["mesh_regime"] = (dims + ["mesh"], per_mesh.astype(str),
                               {"long_name": "each mesh's none, transient or sustained"})
    # The bearing clearance directions over a dimension `clearance`, the load-sharing groups
    # (a sun's planets, a ring's) over `group`.
    clearances, groups, parts = s.get("clearances"), s.get("load_sharing"), s.get("parts")
    for items, columns, dim in ((clearances, _CLEARANCE_COLUMNS, "clearance"),
                                (groups, _GROUP_COLUMNS, "group"),
                                (parts, _PART_COLUMNS, "part")):
        for name, (units, long_name) in (columns.items() if items else ()):
            a = np.full(shape + [len(items)], np.nan)
            for i, at in enumerate(index):
                a[at] = s[name][i]
            data[name] = (dims + [dim], a, {"units": units, "long_name": long_name})
    regime = np.full(shape, "", dtype=object)
    for i, at in enumerate(index):
        regime[at] = s["regime"][i]
    data["regime"] = (dims, regime.astype(str), {"long_name": "none, transient or sustained"})
    strobe = s.get("strobe")
    if strobe is not None and len(strobe["point"]):
        # One sample per system period of each point's measurement, NaN-padded to the
        # longest (a failed point has none).
        counts = np.bincount(strobe["point"], minlength=len(index))
        width = int(counts.max())
        rank = np.zeros(len(strobe["point"]), dtype=int)
        seen = {}
        for i, p in enumerate(strobe["point"]):
            rank[i] = seen.get(p, 0)
            seen[p] = rank[i] + 1
        nd = s.get("form") == "nondimensional"
        for name, units, long_name in (
                ("delta_bar", "1", "delta / b once per system period"),
                ("velocity_m_s", "1" if nd else "m/s", "delta' once per system period"),
                ("force_bar", "1", "F / (b k_m) once per system period")):
            a = np.full(shape + [width], np.nan)
            for i, p in enumerate(strobe["point"]):
                a[index[p] + (rank[i],)] = strobe[name][i]
            data["strobe_" + name] = (dims + ["strobe"], a,
                                      {"units": units, "long_name": long_name})
    coords = {"direction": directions,
              "param": ("param", values, {"units": _key_units(param), "long_name": param})}
    if param2:
        coords["param2"] = ("param2", values2, {"units": _key_units(param2), "long_name": param2})
    if meshes:
        coords["mesh"] = ("mesh", list(meshes), {"long_name": "the train's meshes"})
    if clearances:
        coords["clearance"] = ("clearance", list(clearances),
                               {"long_name": "a bearing clearance's direction"})
    if parts:
        coords["part"] = ("part", list(parts),
                          {"long_name": "a shaft's or bearing's quantity: <part>_<quantity>"})
    if groups:
        coords["group"] = ("group", list(groups),
                           {"long_name": "a gear sharing its load among two or more meshes"})
    attrs = {"geardyn": "sweep", "param": param, "jumps": json.dumps(s.get("jumps", [])),
             "hysteresis": json.dumps(s.get("hysteresis", [])),
             "unsettled_ranges": json.dumps(s.get("unsettled_ranges", [])),
             "period_s": s.get("period_s", np.nan),
             "period_units": "tau" if s.get("form") == "nondimensional" else "s",
             "cancelled": int(bool(s.get("cancelled", False)))}
    if param2:
        attrs["param2"] = param2
    if meshes:
        attrs["mesh_read"] = s.get("mesh", meshes[0])
    if s.get("period_note"):
        attrs["period_note"] = s["period_note"]
    if s.get("steadiness"):
        attrs["steadiness"] = s["steadiness"]
    attrs["impact_onsets"] = json.dumps(s.get("impact_onsets", []))
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _nondimensional(case_toml):
    """True when a case (as TOML) is in the non-dimensional form: times in tau, velocities in
    b omega_n."""
    import tomllib

    return tomllib.loads(case_toml).get("model", {}).get("form") == "nondimensional"


def _run_dataset(r):
    import xarray as xr

    nd = _nondimensional(r.case_toml)
    data = {}
    for name in ("delta_bar", "force_bar", "velocity", "contact"):
        units, long_name = _COLUMNS[name]
        if nd and name == "velocity":
            units, long_name = "1", "d delta_bar / d tau"
        data[name] = ("t", np.array(getattr(r, name)), {"units": units, "long_name": long_name})
    t_attrs = {"units": "1", "long_name": "tau"} if nd else {"units": "s", "long_name": "time"}
    return xr.Dataset(data, coords={"t": ("t", np.array(r.t), t_attrs)},
                      attrs={"geardyn": "run", "summary": r._summary_json,
                             "case": r.case_toml})


class SweepResult(dict):
    """What `geardyn.sweep` returns: a dict of per-point arrays (see `sweep`) that also
    labels itself. Picklable (a plain dict underneath)."""

    def to_xarray(self):
        """The sweep as a labelled Dataset.

        Returns
        -------
        xarray.Dataset
            As `geardyn.to_xarray` gives it: dimensions direction, (param2,) param; units in
            each variable's attributes.
        """
        return to_xarray(self)

    def to_pandas(self):
        """The sweep as a table.

        Returns
        -------
        pandas.DataFrame
            Indexed by direction, (param2,) and param; a column per statistic, and for a
            gear train each mesh's as ``<mesh>_<statistic>``, each load-sharing group's
            as ``<group>_load_sharing_factor``, each shaft's and bearing's quantity as
            ``<part>_<quantity>_peak`` and ``_factor`` (sweep.csv's names); the strobe
            samples stay in `to_xarray()`.
        """
        ds = self.to_xarray()
        df = ds.drop_dims([d for d in ("strobe", "mesh", "group", "clearance", "part")
                           if d in ds.dims]).to_dataframe()
        for name, v in ds.data_vars.items():
            if "mesh" in v.dims:
                for m in ds["mesh"].values:
                    df[f"{m}_{name[len('mesh_'):]}"] = v.sel(mesh=m).to_series()
            if "group" in v.dims:
                for g in ds["group"].values:
                    df[f"{g}_{name}"] = v.sel(group=g).to_series()
            if "clearance" in v.dims:
                for c in ds["clearance"].values:
                    df[f"{c}_{name[len('clearance_'):]}"] = v.sel(clearance=c).to_series()
            if "part" in v.dims:
                for q in ds["part"].values:
                    df[f"{q}_{name[len('part_'):]}"] = v.sel(part=q).to_series()
        return df

    def __reduce__(self):
        return (SweepResult, (dict(self),))


def _run_to_xarray(r):
    """The run as a labelled Dataset.

    Returns
    -------
    xarray.Dataset
        Dimension t (s); delta_bar, force_bar, velocity (m/s), contact with their units;
        the summary (JSON) and the case (TOML) as attributes.
    """
    return _run_dataset(r)


def _run_to_pandas(r):
    """The run's samples as a table.

    Returns
    -------
    pandas.DataFrame
        Indexed by t (s); columns delta_bar, force_bar, velocity (m/s) and contact.
    """
    return _run_dataset(r).to_dataframe()


def _result_save(result, path):
    """Writes the result as NetCDF.

    Parameters
    ----------
    path : str or path-like
        The file; `geardyn.load(path)` reads back a Dataset identical to `to_xarray()`.
    """
    save(result, path)


_result_save.__name__ = "save"
SweepResult.save = _result_save


def _jsonable(x):
    """json.dumps's default: an array as its list, a complex number as [re, im]."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, complex):
        return [x.real, x.imag]
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"{type(x).__name__} is not JSON serializable")


def _points_dataset(d, param=None, param2=None):
    """A continuation's branch or a stability chart (a dict of per-point arrays) along point."""
    import xarray as xr

    n = len(d["param"])
    variables, attrs = {}, {}
    for k, v in d.items():
        if isinstance(v, np.ndarray) and v.shape[:1] == (n,):
            if np.iscomplexobj(v):  # NetCDF has no complex numbers: re and im apart
                variables[k + "_re"] = (("point", "multiplier"), v.real)
                variables[k + "_im"] = (("point", "multiplier"), v.imag)
            else:
                variables[k] = (("point",) + tuple(f"{k}_{i}" for i in range(v.ndim - 1)), v)
        elif isinstance(v, (list, dict)):
            attrs[k] = json.dumps(v, default=_jsonable)
        elif isinstance(v, (bool, np.bool_)):
            attrs[k] = int(v)
        else:
            attrs[k] = v
    if param:
        attrs["param_key"] = param
    if param2:
        attrs["param2_key"] = param2
    return xr.Dataset(variables, coords={"point": np.arange(n)}, attrs=attrs)


def to_xarray(result, param=None, param2=None):
    """A run, a sweep (or map), a continuation's branch or a stability chart as an
    xarray.Dataset.

    Parameters
    ----------
    result : RunResult, TrainRunResult or dict
        What `geardyn.run`, `geardyn.sweep`, `geardyn.continuation` or `geardyn.stability`
        returned (a TrainRunResult: its own `TrainRunResult.to_xarray`).
    param, param2 : str, optional
        The swept keys (taken from the sweep's dict when not given; a branch's or a chart's
        dict holds their values only, so given here they are recorded as its attributes).

    Returns
    -------
    xarray.Dataset
        A sweep: dimensions ``direction`` (up, down), ``param2`` for a map, ``param``; each
        column a variable with ``units`` and ``long_name``; the strobe (one sample per
        system period of each point's measurement) as ``strobe_delta_bar``,
        ``strobe_velocity_m_s`` and ``strobe_force_bar`` over a further dimension ``strobe``;
        the jumps, the hysteresis intervals and the runs of points that did not settle as
        the JSON attributes ``jumps``, ``hysteresis`` and ``unsettled_ranges``, the system
        period as ``period_s``. A run: dimension ``t`` (s), variables delta_bar, force_bar, velocity (m/s)
        and contact, attributes ``summary`` (JSON) and ``case`` (TOML). A continuation's
        branch or a stability chart: dimension ``point``, each per-point array a variable
        (``param``, ``stable``, ...), the complex multipliers as ``multipliers_re`` and
        ``multipliers_im`` over ``point`` and ``multiplier``, the lists (``bifurcations``,
        ``boundaries``) as JSON attributes (an array as a list, a complex number as [re, im])
        and the rest (``completed``, ``message``, ...) as
        attributes, a flag as 0 or 1.
    """
    from . import TrainRunResult

    if isinstance(result, TrainRunResult):  # a train's own Dataset, along mesh and body
        return result.to_xarray()
    if isinstance(result, dict):
        if "stable" in result and isinstance(result.get("param"), np.ndarray):
            return _points_dataset(result, param, param2)
        if "value" not in result or "direction" not in result:
            raise ValueError(
                "to_xarray and save take a run, a sweep or a map, a continuation's branch or a "
                f"stability chart; this dict is none (its keys: {', '.join(result)})")
        param = param or result.get("param")
        param2 = param2 or result.get("param2")
        if param is None:
            raise ValueError("to_xarray: a sweep dict needs param= (the swept key)")
        return _sweep_dataset(result, param, param2)
    return _run_dataset(result)


def save(result, path):
    """Writes a run, a sweep, a continuation's branch, a stability chart or their Dataset
    (`to_xarray`) as NetCDF.

    Parameters
    ----------
    result : RunResult, TrainRunResult, dict or xarray.Dataset
    path : str or path-like
        The file written; `load` reads back an identical Dataset. It is written under a
        temporary name in the same folder and moved into place whole, so a failure leaves an
        earlier file of that name as it was.
    """
    ds = result if hasattr(result, "to_netcdf") else to_xarray(result)
    write_atomically(path, ds.to_netcdf, ".nc.tmp")


def write_atomically(path, write, suffix):
    """Writes a file whole or not at all: `write(name)` writes it under a temporary name in the
    same folder (suffix `suffix`), which then takes the mode a file created in place gets (0666
    less the umask, not the temporary file's 0600) and is moved onto `path`. A failure removes
    the temporary file and leaves an earlier file at `path` as it was. Ctrl-C during the write
    is held back until the file is in place or removed (then KeyboardInterrupt is raised; a
    write that failed raises its own error instead), so that an interrupted study or save never
    leaves a partial or stray file."""
    import os
    import tempfile

    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    with _interrupts_held():
        fd, tmp = tempfile.mkstemp(prefix=".geardyn-", suffix=suffix, dir=folder)
        os.close(fd)
        try:
            write(tmp)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.remove(tmp)
            raise


class _interrupts_held:
    """Holds Ctrl-C (SIGINT) back inside the block and raises KeyboardInterrupt at its end if
    one came. Only the main thread receives signals, and a handler not installed from Python
    cannot be put back: elsewhere the block runs as it is."""

    def __enter__(self):
        import signal
        import threading

        self.received = False
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.getsignal(signal.SIGINT)
            if previous is not None:
                self.previous = signal.signal(signal.SIGINT, self._receive)
        return self

    def _receive(self, signum, frame):
        self.received = True

    def __exit__(self, kind, value, traceback):
        import signal

        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        if self.received and kind is None:
            raise KeyboardInterrupt
        return False


def load(path):
    """Reads what `save` wrote.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    xarray.Dataset

    Raises
    ------
    ValueError
        When `path` is no NetCDF file (a case file names `geardyn.Case.from_toml`).
    """
    import os

    import xarray as xr

    try:
        with xr.open_dataset(path) as ds:
            return ds.load()
    except ValueError as e:  # xarray found no reader for the file
        name = os.fspath(path)
        case = name.endswith(".toml")
        raise ValueError(
            f"geardyn.load({name!r}): reads the NetCDF file geardyn.save writes, and this is "
            + ("a case file: read it with geardyn.Case.from_toml" if case else "none")
        ) from e
