"""geardyn from Python: the same cases, runs and sweeps as the command line.

    import geardyn
    case = geardyn.Case(speed={"shaft_frequency_hz": 100})   # or Case.from_toml(path)
    case["mesh.backlash_um"], case.with_({"mesh.backlash_um": 150})
    r = geardyn.run(case)                    # r.t, r.delta_bar, r.force_bar, r.velocity, r.contact
    r.summary["regime"]
    s = geardyn.sweep(case, param="speed.shaft_frequency_hz", values=range(1500, 3501, 50))
    s.to_xarray(), s.to_pandas(), s.save("sweep.nc")         # labelled, NetCDF; runs too
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
           "save", "load", "SweepResult", "TrainRunResult", "modes", "UnusedSettingWarning"]


class NumericalError(RuntimeError):
    """A run did not complete (divergence, Newton-Raphson not converging); the message says why."""


class UnusedSettingWarning(UserWarning):
    """A case key that was set but that the case's form or method does not read, as the command
    line's "geardyn: warning: ... not used" says it (docs/case-files.md, "Settings a case does
    not use"); the result's summary lists them too ("unused_settings")."""


def _warn_unused(case, stacklevel=4, exact_engine=False):
    """Warns of each setting of `case` that it does not use (called by the functions that take
    a case, so that the warning points at the user's call); with exact_engine (orbit,
    continuation, stability), also of solver.method and a Newmark step, which they do not use."""
    import warnings

    if not isinstance(case, Case):
        return  # the call refuses it with its own message
    for line in case._unused_settings(exact_engine):
        warnings.warn(line, UnusedSettingWarning, stacklevel=stacklevel)


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
    if isinstance(value, dict):  # an inline table: an element of a train
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
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


def _case_document(keys):
    """Case(**keys) of a gear train as one case file's text, or None for the other forms (called
    by the extension): a train's form and its elements only make sense together, so they are
    read as one document rather than key by key."""
    pairs = _flat(keys)
    if not any(k == "train" or k.startswith("train.") or (k, v) == ("model.form", "train")
               for k, v in pairs):
        return None
    top, sections = [], {}
    for k, v in pairs:
        section, _, leaf = k.rpartition(".")
        if section:
            sections.setdefault(section, []).append(f"{leaf} = {_toml_value(v)}")
        else:
            top.append(f"{leaf} = {_toml_value(v)}")
    text = "\n".join(top) + "\n"
    for section, lines in sections.items():
        text += f"\n[{section}]\n" + "\n".join(lines) + "\n"
    return text


def _set(self, key, value):
    """Sets a case key in place, as ``--set key=value`` does, and returns the case.

    Parameters
    ----------
    key : str
        A dotted key, e.g. ``"speed.shaft_frequency_hz"`` (docs/case-files.md, unit in the name).
    value : number, str, bool, list or NumPy array

    Returns
    -------
    Case
        The case itself; `with_` returns a changed copy instead.
    """
    text = _toml_value(value)
    self.set_toml(key, text, f'set("{key}", {text})')
    return self


def _with(self, changes=None, **keys):
    """A copy of the case with keys changed; the case itself is left as it is.

    Parameters
    ----------
    changes : dict, optional
        Dotted keys (``{"mesh.backlash_um": 150}``) or sections (``{"mesh": {...}}``).
    **keys
        Sections as keywords: ``with_(mesh={"backlash_um": 150})``.

    Returns
    -------
    Case
    """
    c = self.copy()
    for k, v in _flat(dict(changes or {}, **keys)):
        text = _toml_value(v)
        c.set_toml(k, text, f'with_({{"{k}": {text}}})')
    return c


def _to_dict(self):
    """Every key of the case.

    Returns
    -------
    dict
        Nested by section (``d["mesh"]["backlash_um"]``), each value in the unit its name ends
        with; ``Case.from_dict`` reads it back to an equal case.
    """
    import tomllib

    return tomllib.loads(self.to_toml())


def _getitem(self, key):
    """The value of one key: ``case["mesh.backlash_um"]``.

    Parameters
    ----------
    key : str
        A dotted key; an array element as ``"model.stiffness_harmonics[0][0]"``.

    Returns
    -------
    float, int, str, bool or list
        In the unit the key's name ends with.

    Raises
    ------
    KeyError
        The case has no such key.
    """
    import re

    node = self.to_dict()
    path = re.findall(r"[^.\[\]]+|\[\d+\]", key)
    try:
        for part in path:
            node = node[int(part[1:-1])] if part.startswith("[") else node[part]
    except (KeyError, IndexError, TypeError):
        if key in _UNWRITTEN_DEFAULTS:
            return _UNWRITTEN_DEFAULTS[key]
        raise KeyError(f"{key}: not a key of this case (docs/case-files.md lists them)") from None
    return node


def _form(case):
    """The case's model.form, read from its TOML text without parsing all of it (a study asks
    it once a sample)."""
    import re

    m = re.search(r'^\[model\]\n(?:[^\[\n]*\n)*?form = "(\w+)"', case.to_toml(), re.M)
    return m.group(1) if m else case["model.form"]


def _from_dict(keys):
    """A case from a dict of keys; the keys not given keep their defaults.

    Parameters
    ----------
    keys : dict
        Dotted (``{"speed.shaft_frequency_hz": 100}``) or nested by section
        (``{"speed": {"shaft_frequency_hz": 100}}``), as `Case.to_dict` gives.

    Returns
    -------
    Case

    Raises
    ------
    InputError
        A key that does not exist or a value out of range.
    """
    return Case(**keys)


for _f, _name in ((_set, "set"), (_with, "with_"), (_to_dict, "to_dict"),
                  (_getitem, "__getitem__"), (_from_dict, "from_dict")):
    _f.__name__, _f.__qualname__ = _name, f"Case.{_name}"
Case.set = _pythonic()(_set)
Case.with_ = _pythonic()(_with)
Case.to_dict = _to_dict
Case.__getitem__ = _getitem
Case.from_dict = staticmethod(_from_dict)
Case.__hash__ = None


def geometry(case, mesh=""):
    """The derived gear geometry, as `geardyn geometry --json`.

    Parameters
    ----------
    case : Case
    mesh : str
        Of a gear train: the external mesh whose gear pair is read (default: the first), as
        ``--mesh``; a name given for another form is refused.

    Returns
    -------
    dict
        Diameters and distances in mm, angles in deg, inertias in kg m^2, the equivalent mass
        in kg, contact ratios, and ``warnings`` (docs/outputs.md).
    """
    return _json.loads(_geardyn._geometry_json(case, mesh))


def stiffness(case, mesh=""):
    """The mesh stiffness from the gear data, as `geardyn stiffness --json`.

    Parameters
    ----------
    case : Case
    mesh : str
        Of a gear train: the mesh whose gear pair is read (default: the first), as ``--mesh``;
        an internal mesh's is its pinion in its ring.

    Returns
    -------
    dict
        ``iso6336`` (c' and c_gamma in N/(mm um), the mesh stiffness in N/m), ``energy``
        (mean, min, max in N/m, the kept harmonics as [k_ai / k_m, phase in deg]) and
        ``cycle``: arrays ``position`` (fraction of a mesh cycle) and ``total_n_per_m`` (N/m).
    """
    text, arrays = _geardyn._stiffness(case, mesh)
    out = _json.loads(text)
    out["cycle"] = arrays
    return out


def _summary(self):
    return _json.loads(self._summary_json)


RunResult.summary = property(_summary, doc="The reading as a dict with the keys of summary.json "
                                           "(docs/outputs.md gives each one's unit).")


# Keys a case's text leaves out at their default because the default is chosen per case (a
# train's default method may take dopri5, which the run reports): read as the default's name.
_UNWRITTEN_DEFAULTS = {"solver.method": "exact"}

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
    """Runs a case, as `geardyn run`.

    Parameters
    ----------
    case : Case
        The case (its [solver] sets the method, window and output interval).
    progress : callable or True, optional
        ``progress(fraction)``, fraction done in [0, 1], called now and then; a false return
        stops the run and returns what was computed (``r.ok`` is False). True: a tqdm bar.

    Returns
    -------
    RunResult or TrainRunResult
        ``t`` (s), ``delta_bar`` (delta / b), ``force_bar`` (F / (b k_m)), ``velocity`` (m/s)
        and ``contact`` (1 drive side, 0 separated, -1 back side) as NumPy arrays that point
        into the result; ``summary`` (the keys of summary.json); ``events`` (arrays). A case
        with ``model.form = "train"`` gives a `TrainRunResult`, and so does one with
        ``"coupled"``, which runs as its train form (bodies "pinion" and "wheel", mesh "mesh",
        bearings "pinion_bearing" and "wheel_bearing", shafts "drive_shaft" and "load_shaft").

    Raises
    ------
    InputError
        Bad input, with the key, the value and what is allowed.
    NumericalError
        The run did not complete (divergence, no progress); the message says why.
    KeyboardInterrupt
        Ctrl-C; ``.result`` holds the run up to where it stopped.
    """
    _warn_unused(case)
    if progress is True:
        def callback(fraction, _bar=_progress(True, 100, "%")):
            return _bar(round(100 * fraction))
    else:
        callback = _progress(progress)
    form = _form(case)
    if form in ("train", "coupled"):
        text, arrays, interrupted = _geardyn._run_train(case, callback)
        r = TrainRunResult(_json.loads(text), arrays)
        if interrupted:
            raise _interrupted(r, "run")
        if not r.ok and "cancelled" not in r.summary["termination"]:
            raise NumericalError(f"numerical failure ({r.summary['termination']}): "
                                 f"{r.summary['message']}")
        return r
    r, interrupted = _geardyn._run(case, callback)
    if interrupted:
        raise _interrupted(r, "run")
    if not r.ok and "cancelled" not in r._failure:
        raise NumericalError(f"numerical failure ({r._failure})")
    return r


class TrainRunResult:
    """A run of a gear train (``model.form = "train"``, or a coupled case run as its train form;
    docs/outputs.md, "Gear trains").

    Attributes
    ----------
    summary : dict
        The keys of the command line's summary.json: ``meshes``, one reading per mesh (regime,
        impacts, forces in N, dynamic factors), ``bodies`` with their speeds.
    bodies, meshes : list of str
        The bodies' and the meshes' names, in the case's order.
    coordinates : list of str
        The state's coordinates with their units: each body's rotation (``<body>_rad``), then
        each planar body's centre (``<body>_x_m``, ``<body>_y_m``; ``<body>_line_m`` along the
        line of action for one held to it), a spatial body's followed by
        its axial displacement and tilts (``<body>_z_m``, ``<body>_tx_rad``, ``<body>_ty_rad``).
    t : numpy.ndarray
        Sample times, s.
    theta, rate : numpy.ndarray
        Samples x bodies: each body's rotation about its nominal one (rad) and its rate (rad/s).
    q, q_rate : numpy.ndarray
        Samples x coordinates: the whole state (rad and m) and its rates.
    deflection_bar, force, contact : numpy.ndarray
        Samples x meshes: (d - e) / b, the mesh force (N) and the contact state (1 drive side,
        0 separated, -1 back side).
    deflection_rate : numpy.ndarray
        Samples x meshes: d' - e' (m/s), the rate of (d - e).
    shafts, bearings : list of str
        The shafts' and the bearings' names.
    shaft_torque : numpy.ndarray
        Samples x shafts: each shaft's torque (N m, positive when its first body leads).
    bearing_force : numpy.ndarray
        Samples x bearings x 2: each bearing's force on the ground in x and y (N).
    bearing_axial : numpy.ndarray
        Samples x bearings x 3: a spatial body's bearing's axial force (N) and moments about x
        and y (N m); an axial body's (dof "axial") its axial force, its moments nan; nan for a
        bearing of any other body.
    joints : list of str
        The joints read as parts (a clutch damper's), by name.
    joint_force, joint_deformation : numpy.ndarray
        Samples x joints: each one's force (a damper's torque, N m) and its x (a damper's twist,
        rad).
    events : dict
        Every contact change located, as the one-degree run's: ``t_s`` (s), ``part`` (a mesh's
        name, a bearing clearance direction's, ``<bearing>_x`` or ``_y``, or a joint's), ``kind``
        (impact, backside_impact, separation) and ``velocity_m_s`` (the part's rate there: a
        mesh's d' - e', a clearance's centre velocity along it), as events.csv.
    ok : bool
        Whether the run completed.
    """

    def __init__(self, summary, arrays):
        self._write = arrays.get("write")
        self.summary = summary
        self.bodies = [b["name"] for b in summary["bodies"]]
        self.meshes = [m["name"] for m in summary["meshes"]]
        self.coordinates = list(summary["coordinates"])
        n, nq = len(self.bodies), len(self.coordinates)
        self.t = arrays["t"]
        self.q = arrays["state"][:, :nq]
        self.q_rate = arrays["state"][:, nq:]
        self.theta = self.q[:, :n]
        self.rate = self.q_rate[:, :n]
        self.deflection_bar = arrays["deflection_bar"]
        self.force = arrays["force"]
        self.contact = arrays["contact"]
        self.deflection_rate = arrays["deflection_rate"]
        self.shafts = [x["name"] for x in summary["shafts"]]
        self.bearings = [x["name"] for x in summary["bearings"]]
        ns = len(self.shafts)
        self.shaft_torque = arrays["parts"][:, :ns]
        # Each bearing's x and y force, then an axial or spatial body's axial force and a spatial
        # body's tilt moments (nan where a body has none).
        nt, nb = len(self.t), len(self.bearings)
        self.bearing_force = _numpy.empty((nt, nb, 2))
        self.bearing_axial = _numpy.full((nt, nb, 3), _numpy.nan)
        k = ns
        for j, b in enumerate(summary["bearings"]):
            self.bearing_force[:, j, :] = arrays["parts"][:, k:k + 2]
            k += 2
            has = sum(f"max_{q}" in b for q in ("axial_force_n", "moment_x_nm", "moment_y_nm"))
            self.bearing_axial[:, j, :has] = arrays["parts"][:, k:k + has]
            k += has
        # Each joint read as a part (a clutch damper): its force and its x.
        self.joints = [x["name"] for x in summary.get("joints", [])]
        self.joint_force = arrays["parts"][:, k:k + 2 * len(self.joints):2]
        self.joint_deformation = arrays["parts"][:, k + 1:k + 2 * len(self.joints):2]
        self.events = arrays["events"]
        self.ok = summary["termination"] == "completed"

    def write(self, directory):
        """Writes the run's files as `geardyn run --out` does (docs/outputs.md, "Gear trains").

        Parameters
        ----------
        directory : str or path-like
            Created if needed; summary.json, timeseries.csv, events.csv and case.toml are
            written into it. Only these files are replaced, together; the folder's other files
            stay (docs/outputs.md).

        Returns
        -------
        list of str
            Files of an earlier run written here that were changed since and so kept.

        Raises
        ------
        RuntimeError
            A file of one of these names is in the folder but geardyn did not write it there, or
            it was changed since: nothing is written. Or the result was unpickled (sent from
            another process, a Dask worker's): the run's files are written where it ran, and
            `save` writes its Dataset anywhere.
        """
        if self._write is None:
            raise RuntimeError("TrainRunResult.write: this result was unpickled and holds no "
                               "run to write; write it in the process that ran it, or save() "
                               "its Dataset")
        import os
        return self._write(os.fspath(directory))

    def __getstate__(self):
        # The run behind write() stays in the process that ran it.
        return dict(self.__dict__, _write=None)

    def __repr__(self):
        parts = ", ".join(f"{m['name']} {m['regime']} ({m['impacts']} impacts)"
                          for m in self.summary["meshes"])
        return f"<geardyn.TrainRunResult {len(self.bodies)} bodies: {parts}>"

    def to_xarray(self):
        """The run as a labelled Dataset.

        Returns
        -------
        xarray.Dataset
            Dimensions t (s), body, coordinate and mesh (their names); theta and rate (t x
            body), q and q_rate (t x coordinate, rad or m as the name says, and their rates),
            deflection_bar, force (N), contact and deflection_rate (m/s) (t x mesh); per mesh
            its readings
            (mean_stiffness_n_per_m, backlash_m, impacts, separated_fraction, dynamic_factor, ...)
            and those of its steady part
            (steady_impacts, steady_regime, steady_max_force_n, steady_rms_force_n, ...) as
            variables along mesh;
            the summary (JSON) as an attribute, where "steady" says where the part starts and
            why; ``layout_phase`` (cycles) along mesh with ``train.mesh_phase = "layout"``;
            where gears share their load among two or more meshes, a dimension group (the
            summary's labels) with ``load_sharing_static_factor``, ``load_sharing_factor``
            (steady part) and ``load_sharing_factor_with_startup``.
        """
        import xarray as xr
        meshes = self.summary["meshes"]
        per_mesh = {k: ("mesh", [_nan_if_none(m[k]) for m in meshes])
                    for k in ("mesh_frequency_hz", "mean_stiffness_n_per_m", "backlash_m",
                              "impacts", "backside_impacts", "separations",
                              "separated_fraction", "max_force_n", "min_force_n",
                              "max_impact_velocity_m_s", "mean_force_n", "rms_force_n",
                              "mean_deflection_bar", "rms_deflection_bar",
                              "static_force_n", "dynamic_factor", "dynamic_factor_with_startup")}
        per_mesh["regime"] = ("mesh", [m["regime"] for m in meshes])
        if meshes and "layout_phase" in meshes[0]:  # train.mesh_phase = "layout"
            per_mesh["layout_phase"] = ("mesh", [m["layout_phase"] for m in meshes],
                                        {"units": "cycles"})
        # The steady part (summary "steady": where it starts and why) per mesh.
        for k in ("impacts", "separated_fraction", "max_force_n", "min_force_n",
                  "max_impact_velocity_m_s", "mean_force_n", "rms_force_n"):
            per_mesh["steady_" + k] = ("mesh", [m["steady"][k] for m in meshes])
        per_mesh["steady_regime"] = ("mesh", [m["steady"]["regime"] for m in meshes])
        # The load-sharing groups (a sun's planets, a ring's) along group.
        groups = self.summary.get("load_sharing", [])
        per_group = {"load_sharing_" + k: ("group", [_nan_if_none(g[k]) for g in groups])
                     for k in ("static_factor", "factor", "factor_with_startup")}
        return xr.Dataset(
            dict({"theta": (("t", "body"), self.theta, {"units": "rad"}),
                  "rate": (("t", "body"), self.rate, {"units": "rad/s"}),
                  "q": (("t", "coordinate"), self.q),
                  "q_rate": (("t", "coordinate"), self.q_rate),
                  "deflection_bar": (("t", "mesh"), self.deflection_bar,
                                     {"long_name": "(d - e) / b"}),
                  "force": (("t", "mesh"), self.force, {"units": "N"}),
                  "contact": (("t", "mesh"), self.contact),
                  "deflection_rate": (("t", "mesh"), self.deflection_rate,
                                      {"units": "m/s", "long_name": "d' - e'"})}, **per_mesh,
                 **(per_group if groups else {})),
            coords={"t": ("t", self.t, {"units": "s"}), "body": self.bodies,
                    "coordinate": self.coordinates, "mesh": self.meshes,
                    **({"group": [g["label"] for g in groups]} if groups else {})},
            attrs={"summary": _json.dumps(self.summary)})


def _nan_if_none(x):
    return float("nan") if x is None else x


@_pythonic()
def modes(case):
    """The modes of a gear train, or of a pair's form as its train, as `geardyn modes --json`.

    Parameters
    ----------
    case : Case
        A case of any form: ``model.form = "train"``, or a pair's form read as its train
        (``geardyn train-form``): ``"coupled"`` (bodies ``pinion`` and ``wheel``, held to the
        line of action with dof 3 and 6, bearings ``pinion_bearing`` and ``wheel_bearing``,
        with its shafts ``motor`` and ``load``), ``"gear_pair"`` and ``"nondimensional"`` (the
        rigid rotation and the contact mode, at the one-degree model's natural frequency; in
        the non-dimensional form a second is a tau).

    Returns
    -------
    dict
        ``bodies`` (the shape's columns: each body's rotation by its name, then each planar
        body's centre as ``<body>_x``, ``<body>_y`` (``<body>_line`` held to its line), a
        spatial body's followed by ``<body>_z``, ``<body>_tx``, ``<body>_ty``),
        ``frequency_hz`` (ascending; a freely turning train's first is its rigid rotation, 0),
        ``multiplicity`` (how many modes share each frequency), ``damping_ratio`` (each mode's,
        phi^H C phi / (2 w); 0 in a rigid motion), ``type`` (a planetary set's "rotational",
        "translational", "planet" or "mixed", read from the shape; "" in a train without
        pins), ``shape`` (modes x those columns, mass-normalised; complex, a whirl, with
        ``train.frame_terms``), ``mesh_energy``, ``shaft_energy`` and ``bearing_energy`` (by
        name: the strain energy fraction in each mode), ``bearing_energy_parts`` (by bearing
        name, by direction ``x``, ``y`` and, where it has them, ``axial``, ``tilt_x``,
        ``tilt_y``), and ``damped``: the damped eigenvalues' frequencies and damping ratios
        (one row each, ascending; the rigid motions' left out).

    Raises
    ------
    InputError
        Bad input.
    """
    _warn_unused(case)
    import numpy as np
    j = _json.loads(_geardyn._train_modes(case))
    ms = j["modes"]

    def by_name(key):
        return {k: np.array([m[key][k] for m in ms]) for k in (ms[0][key] if ms else {})}

    return {"bodies": list(ms[0]["shape"]) if ms else [],
            "frequency_hz": np.array([m["frequency_hz"] for m in ms]),
            "multiplicity": np.array([m["multiplicity"] for m in ms]),
            "damping_ratio": np.array([m["damping_ratio"] for m in ms]),
            "type": [m.get("type", "") for m in ms],
            "shape": np.array([list(m["shape"].values()) for m in ms]) +
            (1j * np.array([list(m["shape_imag"].values()) for m in ms])
             if ms and "shape_imag" in ms[0] else 0),
            "mesh_energy": by_name("mesh_energy"),
            "shaft_energy": by_name("shaft_energy"),
            "bearing_energy": by_name("bearing_energy"),
            "joint_energy": by_name("joint_energy"),
            "bearing_energy_parts": {
                b: {d: np.array([m["bearing_energy_parts"][b][d] for m in ms]) for d in dirs}
                for b, dirs in (ms[0]["bearing_energy_parts"].items() if ms else ())},
            "damped": np.array([[d["frequency_hz"], d["damping_ratio"]]
                                for d in j["damped_eigenvalues"]]).reshape(-1, 2)}


_SWEEP_NAMES = {"points": "len(values)", "from": "values", "to": "values",
                "points2": "len(values2)", "from2": "values2", "to2": "values2"}


@_pythonic(_SWEEP_NAMES)
def sweep(case, param, values, direction="both", settle_periods=0, measure_periods=10,
          max_settle_periods=200, steady_tolerance=1e-6, start="static", threads=0,
          progress=None, param2=None, values2=(), executor=None, mesh=None):
    """Sweeps a case key up and down, as `geardyn sweep`; with `param2`, a map.

    Each point continues from the previous one's end state, settles period by period until
    its predicted distance to the periodic response is under `steady_tolerance`, and is then
    measured (docs/sweeps.md).

    Parameters
    ----------
    case : Case
        The base case.
    param : str
        The swept key, e.g. ``"speed.shaft_frequency_hz"`` (in the key's unit).
    values : sequence of float
        Its values (swept ascending up, descending down).
    direction : {"both", "up", "down"}
    settle_periods, measure_periods, max_settle_periods : int
        System periods T0 always run before steadiness is judged, measured once steady
        (rounded up to whole response periods), and at most before a point is flagged not
        settled.
    steady_tolerance : float
        The distance to the periodic response on the section t = k T0 under which a point is
        steady, in b (delta) and b w_n (delta').
    start : {"static", "case"}
        Where the up and the down sweep start: static contact (jumps and hysteresis show) or
        the case's ``solver.initial``.
    threads : int
        Worker threads (0: all cores).
    progress : callable or True, optional
        ``progress(done, total)`` after each point; a false return stops the sweep (the points
        under way are dropped, the completed ones kept). True: a tqdm bar.
    param2 : str, optional
        A second key: a sweep along `param` at each of its `values2` (a map).
    values2 : sequence of float
    executor : None, dask.distributed.Client or str
        Where a map's rows run: None in this process (on `threads`), or a Dask client or
        scheduler address, one task a row (each row's up and down sweeps are sequences, so a
        row is the unit of work). The result equals the in-process map bit for bit; a lost
        worker's row is run again elsewhere. A one-dimensional sweep runs as one task.
    mesh : str, optional
        A gear train's mesh (its name) that the point's own statistics, strobe and jumps read;
        None: the first. Every mesh is read beside it (the ``mesh_*`` arrays).

    Returns
    -------
    SweepResult
        A dict: one NumPy array per column (``value``, ``value2`` for a map, ``pp_delta_bar``
        and the other statistics of delta / b and F / (b k_m), ``separated_fraction``,
        ``impacts_per_period`` per system period, ``settled``, ``settle_periods``,
        ``period_multiple`` (the response's period in T0, 0 when not settled),
        ``steady_error`` (its predicted distance, b), ``dynamic_factor``; for a gear train
        (and a coupled case, which sweeps as its train) ``meshes`` (their names), ``mesh``
        (the one read) and one (points,
        meshes) array per mesh column of sweep.csv: ``mesh_pp_delta_bar``,
        ``mesh_max_force_n``, ``mesh_dynamic_factor``, ``mesh_impacts_per_period``, ... and
        ``mesh_regime`` (a list per point); where gears share their load among two or
        more meshes (a planetary set), ``load_sharing`` (the groups' labels) and (points,
        groups) arrays ``load_sharing_factor`` (n max F / sum F over the measurement) and
        ``lost_contact`` (the group's meshes that left their drive flank); with bearing
        clearances ``clearances`` (``<bearing>_x``, ``_y``) and (points, clearances) arrays
        ``clearance_impacts_per_period`` and ``clearance_inside_fraction``; with shafts or
        bearings ``parts`` (``<part>_<quantity>``: ``pinion_bearing_force_y_n``,
        ``drive_shaft_torque_nm``, ...) and (points, parts) arrays ``part_peak`` (the largest
        magnitude, N or N m) and ``part_factor`` (that over the static value); ``period_note``
        when the train is quasi-periodic), ``steadiness`` (how a point was judged steady),
        ``impact_onsets`` (each sequence's first point with impacts: dicts with
        ``direction``, ``value`` and the ``meshes`` that strike),
        ``direction``, ``regime`` and ``failure`` (why a point failed,
        else "") as lists; ``strobe``: flat arrays ``point`` (the index of the point each
        sample belongs to), ``delta_bar``, ``velocity_m_s`` (m/s), ``force_bar``, one sample
        per system period of the measurement; ``jumps`` and ``hysteresis`` (dicts with
        ``from_value``, ``to_value`` and ``unsettled``: whether they read a point that did not
        settle), ``unsettled_ranges`` (dicts with ``direction``, ``from_value``, ``to_value``
        and ``points``: each run of consecutive points that did not settle, read as they are),
        ``period_s``, ``cancelled``, ``param``
        (``param2``). Its ``to_xarray()``, ``to_pandas()`` and ``save(path)`` label it.

    Raises
    ------
    InputError
        Bad input, naming the argument or key.
    KeyboardInterrupt
        Ctrl-C; ``.result`` holds the completed points.
    """
    _warn_unused(case)
    options = dict(direction=direction, settle_periods=settle_periods,
                   measure_periods=measure_periods, max_settle_periods=max_settle_periods,
                   steady_tolerance=steady_tolerance, start=start, mesh=mesh)
    if executor is not None:
        return _sweep_on(executor, case, param, values, options, param2, values2, progress)
    r = _geardyn._sweep(case, param, _floats("values", values), direction, settle_periods,
                        measure_periods, max_settle_periods, steady_tolerance, start, threads,
                        _progress(progress, unit="point"), param2 or "",
                        _floats("values2", values2), mesh or "")
    r = SweepResult(r, param=param)
    if param2:
        r["param2"] = param2
    if r["interrupted"]:
        raise _interrupted(r, "sweep")
    return r


def _sweep_task(case, param, values, options, param2, value2):
    """One map row (or a whole one-dimensional sweep) on a worker, on one thread."""
    rows = {} if value2 is None else {"param2": param2, "values2": [value2]}
    return dict(sweep(case, param, values, threads=1, **options, **rows))


def _merged_rows(parts, param, param2):
    """Rows swept apart, as one sweep of them all in row order (the in-process map's order)."""
    out = {}
    first = parts[0]
    for key, v in first.items():
        if key == "strobe":
            strobe, offset = {}, 0
            for p in parts:
                for k, a in p["strobe"].items():
                    strobe.setdefault(k, []).append(a + offset if k == "point" else a)
                offset += len(p["value"])
            out[key] = {k: _numpy.concatenate(a) for k, a in strobe.items()}
        elif key in ("meshes", "load_sharing", "clearances", "parts"):
            out[key] = v  # the train's mesh and group names, the same in every row
        elif isinstance(v, _numpy.ndarray):
            out[key] = _numpy.concatenate([p[key] for p in parts])
        elif isinstance(v, list):
            out[key] = [x for p in parts for x in p[key]]
        elif key in ("cancelled", "interrupted"):
            out[key] = any(p[key] for p in parts)
        else:
            out[key] = v
    r = SweepResult(out, param=param)
    if param2:
        r["param2"] = param2
    return r


def _sweep_on(executor, case, param, values, options, param2, values2, progress):
    """sweep() with its rows as Dask tasks; progress hears the points of the rows done."""
    from dask.distributed import as_completed

    from . import studies

    values = _floats("values", values)
    rows = list(_floats("values2", values2)) if param2 else [None]
    if param2 and not rows:
        raise InputError("values2: a map needs at least one value")
    callback = _progress(progress, unit="point")
    per_row = len(values) * (2 if options["direction"] == "both" else 1)
    total = per_row * len(rows)
    client, own = studies._client(executor)
    futures = {client.submit(_sweep_task, case, param, values, options, param2, v, pure=False,
                             retries=2): i for i, v in enumerate(rows)}
    done = {}
    cancelled = False
    try:
        if callback:
            callback(0, total)
        for f in as_completed(list(futures)):
            done[futures[f]] = f.result()
            if callback and callback(len(done) * per_row, total) is False:
                cancelled = True
                break
    except KeyboardInterrupt:
        client.cancel(list(futures))
        result = _merged_rows([done[i] for i in sorted(done)], param, param2) if done else {}
        raise _interrupted(result, "sweep") from None
    finally:
        if cancelled:
            client.cancel(list(futures))
        if own:
            client.close()
    r = _merged_rows([done[i] for i in sorted(done)], param, param2)
    r["cancelled"] = r["cancelled"] or cancelled
    return r


def _interrupted(result, what):
    """KeyboardInterrupt with the work done so far attached as .result."""
    e = KeyboardInterrupt(f"{what} interrupted; the work done so far is in .result")
    e.result = result
    return e


@_pythonic()
def orbit(case, periods=1, segments=0, settle_periods=100, tolerance=1e-10, max_iterations=40,
          state=None, starts=16):
    """The periodic orbit of a case, as `geardyn orbit` (docs/orbits.md).

    Newton's method on the stroboscopic map with the exact engine's Jacobian (saltation at
    every impact), on `segments` shooting segments.

    Parameters
    ----------
    case : Case
    periods : int
        The orbit's period in system periods T0 (the common period of the excitations).
    segments : int
        Shooting segments (0: one per period).
    settle_periods : int
        System periods simulated for the first guess (when `state` is None).
    tolerance : float
        Newton's tolerance on the scaled residual (delta / b, delta' / (b w_n)).
    max_iterations : int
    state : sequence of float, optional
        First guess on the section t = 0: delta (m) and delta' (m/s); for a gear train, and a
        coupled case (``model.form = "coupled"``, found on its train), its unknowns (the free
        coordinates, then their rates, SI, in the order of ``coordinates``: a found orbit's
        ``unknowns``).
    starts : int
        Settled states Newton starts from at most (when `state` is None and `settle_periods`
        > 0): when Newton fails from one, it starts again from the state one orbit period
        later. A rattle that settles on a chaotic motion passes near its unstable orbits at
        some periods only.

    Returns
    -------
    dict
        ``converged`` and ``message`` (not converging is reported here, not raised),
        ``period_s`` (s; tau in the non-dimensional form), ``state`` (m, m/s; for a gear train
        and a coupled case every body's, with ``unknowns`` in ``coordinates`` order,
        ``modulo_rotation``, per mesh its ``impacts_per_period`` and exact extremes in
        ``meshes`` and per clearance direction its counts in ``clearances``),
        ``floquet_multipliers`` (complex, largest first), ``monodromy``, ``stable``; for the
        one-degree forms ``impacts_per_period``, ``min_delta_bar``, ``max_delta_bar``,
        ``max_force_bar``, ``sequence`` (the contact events of one period) and more.
    """
    _warn_unused(case, exact_engine=True)
    return _orbit_dict(_geardyn._orbit(case, periods, segments, settle_periods, tolerance,
                                       max_iterations,
                                       None if state is None else [float(x) for x in state],
                                       starts))


def _orbit_dict(text):
    """An orbit's JSON (the command line's) as a dict, its vectors and matrices as arrays."""
    import numpy as np

    o = _json.loads(text)
    o["state"] = np.array(o["state"])
    if "unknowns" in o:  # a gear train's
        o["unknowns"] = np.array(o["unknowns"])
    o["floquet_multipliers"] = np.array([complex(re, im) for re, im in o["floquet_multipliers"]])
    o["monodromy"] = np.array(o["monodromy"])
    return o


@_pythonic({"from": "from_"})
def continuation(case, param, from_, to, periods=1, segments=0, settle_periods=100, step=0.01,
                 max_step=0.02, max_points=5000, follow_period_doubling=False, progress=None,
                 mesh=None, starts=16):
    """Follows a branch of periodic orbits in a case key, as `geardyn continue`.

    Pseudo-arclength continuation from the orbit at `from_`; folds, period doublings,
    Neimark-Sacker bifurcations and grazings are located along the way (docs/orbits.md).

    Parameters
    ----------
    case : Case
    param : str
        A numeric case key (an array element as ``"model.stiffness_harmonics[0][0]"``).
    from_, to : float
        The range of the key, in its unit.
    periods, segments, settle_periods, starts : int
        As for `orbit` (the first orbit's).
    step, max_step : float
        First and largest arclength step (scaled state, key over its range).
    max_points : int
        Points at most on each branch.
    follow_period_doubling : bool
        Switch to the period-doubled branch at each period doubling and follow it.
    progress : callable or True, optional
        ``progress(param, points)`` after each point; a false return stops. True: a tqdm bar
        over the range.
    mesh : str, optional
        A gear train's mesh whose amplitude, forces and impacts the points read (``--mesh``;
        default the first); every mesh's contacts mark grazings whichever is read.

    Returns
    -------
    dict
        ``mesh``: the train's mesh read (a coupled case's too; "" for the one-degree forms).
        One NumPy array per point: ``param``, ``stable``, ``x_a`` ((max - min) / 2 of
        delta / b), ``min_delta_bar``, ``max_delta_bar``, ``max_force_bar``,
        ``impacts_per_period``, ``max_multiplier``, the state on the section (``delta_m`` (m)
        and ``velocity_m_s`` (m/s); a train's and a coupled case's unknowns, e.g.
        ``wheel_rad``, ``pinion_line_m``, ..., ``wheel_rad_s``, ...), ``branch``, ``periods``, ``multipliers`` (the two largest);
        ``bifurcations`` (dicts: type, param, branch, detail, x_a and ``orbit`` as `orbit`
        returns it, or None where it could not be read again); ``completed``, ``cancelled``,
        ``message``.

    Raises
    ------
    InputError
        A key that is not numeric, a bad range.
    KeyboardInterrupt
        Ctrl-C (looked for every 0.05 s); ``.result`` holds the points so far.
    """
    _warn_unused(case, exact_engine=True)
    if progress is True:
        def callback(p, n, _bar=_progress(True, 1000, "\u2030")):
            return _bar(round(1000 * min(1.0, abs(p - from_) / abs(to - from_))))
    else:
        callback = _progress(progress)
    r = _geardyn._continuation(case, param, float(from_), float(to), periods, segments,
                               settle_periods, step, max_step, max_points,
                               follow_period_doubling, callback, mesh or "", starts)
    for b in r["bifurcations"]:
        # None where the located orbit could not be read again (its flow failed).
        b["orbit"] = _orbit_dict(b["orbit"]) if b["orbit"] else None
    if r["interrupted"]:
        raise _interrupted(r, "continuation")
    return r


@_pythonic(_SWEEP_NAMES)
def stability(case, param, values, param2=None, values2=()):
    """The Floquet stability of permanent contact, as `geardyn stability` (docs/orbits.md).

    The Mathieu-Hill problem of the mesh stiffness: the monodromy of the contact region over
    the stiffness period at each value, boundaries located where a multiplier crosses the unit
    circle. A coupled case (``model.form = "coupled"``) gives all its 2n multipliers.

    Parameters
    ----------
    case : Case
    param : str
        The case key along which to look.
    values : sequence of float
    param2 : str, optional
        A second key: a chart over both.
    values2 : sequence of float

    Returns
    -------
    dict
        Arrays ``param`` (and ``param2``), ``stable``, ``max_multiplier``, ``multipliers``;
        ``boundaries``: dicts with ``param`` (``param2``) and ``type`` (fold at +1,
        period_doubling at -1, neimark_sacker).
    """
    _warn_unused(case, exact_engine=True)
    r = _geardyn._stability(case, param, _floats("values", values), param2 or "",
                            _floats("values2", values2), None)
    if r["interrupted"]:
        raise _interrupted(r, "stability")
    return r


class Validation:
    """What `geardyn validate` reports (docs/validation.md): one row per compared quantity.

    Attributes
    ----------
    passed : bool
        Every check ran and every row passed.
    quick : bool
    rows : list of dict
        ``check``, ``quantity``, ``value``, ``reference``, ``source``, ``cited``, ``error``
        (None when the check could not run), ``measure``, ``tolerance``, ``passed``.
    checks : list of dict
        ``id`` (the anchor in docs/validation.md), ``title``, ``quick``.
    failures : list of dict
        The rows that failed.
    """

    def __init__(self, text, table, html):
        j = _json.loads(text)
        self.passed = j["passed"]
        self.quick = j["quick"]
        self.cancelled = j["cancelled"]
        self.wall_time_s = j["wall_time_s"]
        self.checks = j["checks"]
        self.rows = j["rows"]
        self.failures = [r for r in self.rows if not r["passed"]]
        self._table, self._html = table, html

    def __str__(self):
        return self._table

    def __repr__(self):
        return (f"<geardyn.Validation: {len(self.rows)} rows, {len(self.failures)} failed"
                f"{', quick' if self.quick else ''}>")

    def _repr_html_(self):
        return self._html


def validate(quick=False, out=None, progress=None):
    """Runs geardyn's validation with this installed library, as `geardyn validate`.

    Every check compares geardyn's values with references computed independently or cited;
    docs/validation.md describes each one.

    Parameters
    ----------
    quick : bool
        The quick set (fewer cases per check).
    out : str or path, optional
        A folder for validation.md, validation.html and validation.json (only those files are
        written there; the folder's other files are left alone).
    progress : None, True or callable
        ``progress(done, total)`` between checks (a false return stops); True: a tqdm bar.

    Returns
    -------
    Validation
        Its ``passed`` says whether every row passed; ``print()`` shows the table, and a
        notebook the HTML report. Ctrl-C raises KeyboardInterrupt with the checks done in
        ``.result``.
    """
    text, table, html, interrupted = _geardyn._validate(
        bool(quick), _progress(progress, unit="check"), "" if out is None else str(out))
    v = Validation(text, table, html)
    if interrupted:
        raise _interrupted(v, "validation")
    return v


from . import plot  # noqa: E402,F401
from .data import SweepResult, load, save, to_xarray  # noqa: E402,F401
from .studies import StudyError, design, sobol_indices, statistics, study  # noqa: E402,F401
from .studies import report as study_report  # noqa: E402,F401
from .data import _result_save, _run_to_pandas, _run_to_xarray  # noqa: E402

for _f, _name in ((_run_to_xarray, "to_xarray"), (_run_to_pandas, "to_pandas")):
    _f.__name__, _f.__qualname__ = _name, f"RunResult.{_name}"
RunResult.to_xarray = _run_to_xarray
RunResult.to_pandas = _run_to_pandas
RunResult.save = _result_save
TrainRunResult.save = _result_save
