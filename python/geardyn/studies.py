"""Studies over populations of cases (docs/studies.md): a base case, inputs drawn from
distributions (OpenTURNS) or laid on a grid, an analysis per sample, run in-process or on Dask,
kept in a store as samples complete, resumable, as an xarray Dataset over ``sample``.

    ds = geardyn.study(case, {"mesh.backlash_um": {"distribution": "uniform",
                                                   "lower": 80, "upper": 120}},
                       samples=200, method="lhs", seed=1, store="out/backlash")

Every sample is computed by the same function from the base case and its own inputs alone, so
a sample's result does not depend on the executor, the number of workers or the batch size.
"""
import hashlib
import json
import math
import pathlib
from collections.abc import Mapping

import numpy as np

from .data import _COLUMNS, write_atomically

_METHODS = ("monte_carlo", "lhs", "sobol", "saltelli", "grid", "variants")
_STORE_SPEC = "study.json"
_BATCHES = "batches"


class StudyError(ValueError):
    """Bad study input: the message names the input as written, its value and what is
    allowed."""


# ---- inputs ---------------------------------------------------------------------------------

def _ot():
    first = "openturns" not in __import__("sys").modules
    try:
        import openturns as ot
    except ImportError as e:  # pragma: no cover - installed by scripts/setup.sh
        raise ImportError("studies need OpenTURNS (Debian: apt-get install python3-openturns)") \
            from e
    if first:
        _python_sigint()
    return ot


def _python_sigint():
    """Puts Python's SIGINT handler back in place of OpenTURNS's, which its import and its
    objects' calls install and which aborts the process on Ctrl-C outside them: Ctrl-C then
    stops a study as elsewhere."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.getsignal(signal.SIGINT))


# A distribution written as a dict (a study file's [inputs."key"] table): its name and the
# parameters each needs, as OpenTURNS takes them.
_DISTRIBUTION_PARAMETERS = {
    "uniform": ("lower", "upper"),
    "normal": ("mean", "std"),
    "truncated_normal": ("mean", "std", "lower", "upper"),
    "lognormal": ("mean", "std"),
    "discrete": ("values",),
}


def _distribution(key, spec):
    """An OpenTURNS distribution from what the user gave for `key`: an OpenTURNS distribution,
    a SciPy frozen distribution, or a dict {"distribution": name, parameters...}."""
    ot = _ot()
    if isinstance(spec, ot.DistributionImplementation) or isinstance(spec, ot.Distribution):
        return ot.Distribution(spec)
    if hasattr(spec, "ppf") and hasattr(spec, "dist"):  # a SciPy frozen distribution
        return ot.Distribution(ot.SciPyDistribution(spec.dist)) if not spec.args and \
            not spec.kwds else ot.Distribution(_scipy_frozen(spec))
    if not isinstance(spec, dict) or "distribution" not in spec:
        raise StudyError(f"inputs.{key} = {spec!r}: must be an OpenTURNS distribution, a SciPy "
                         f"frozen distribution or a table with 'distribution' = one of "
                         f"{', '.join(_DISTRIBUTION_PARAMETERS)}")
    name = spec["distribution"]
    if name not in _DISTRIBUTION_PARAMETERS:
        raise StudyError(f"inputs.{key}.distribution = {name!r}: must be one of "
                         f"{', '.join(_DISTRIBUTION_PARAMETERS)}")
    needed = _DISTRIBUTION_PARAMETERS[name]
    missing = [p for p in needed if p not in spec]
    extra = [p for p in spec if p not in needed and p not in ("distribution", "weights")]
    if missing or extra:
        raise StudyError(f"inputs.{key} ({name}): needs {', '.join(needed)}"
                         + (f"; missing {', '.join(missing)}" if missing else "")
                         + (f"; not used: {', '.join(extra)}" if extra else ""))
    p = {k: spec[k] for k in needed}
    try:
        if name == "uniform":
            return ot.Distribution(ot.Uniform(float(p["lower"]), float(p["upper"])))
        if name == "normal":
            return ot.Distribution(ot.Normal(float(p["mean"]), float(p["std"])))
        if name == "truncated_normal":
            return ot.Distribution(ot.TruncatedNormal(float(p["mean"]), float(p["std"]),
                                                      float(p["lower"]), float(p["upper"])))
        if name == "lognormal":
            return ot.Distribution(ot.LogNormalMuSigma(float(p["mean"]), float(p["std"]))
                                   .getDistribution())
        values = [float(v) for v in p["values"]]
        weights = [float(w) for w in spec.get("weights", [1.0] * len(values))]
        if len(weights) != len(values):
            raise StudyError(f"inputs.{key}.weights: {len(weights)} weights for "
                             f"{len(values)} values")
        return ot.Distribution(ot.UserDefined([[v] for v in values], weights))
    except (TypeError, ValueError, RuntimeError) as e:
        if isinstance(e, StudyError):
            raise
        raise StudyError(f"inputs.{key} ({name}, {p}): {e}") from None


def _scipy_frozen(frozen):
    """A SciPy frozen distribution with its parameters, through its quantile function."""
    ot = _ot()

    class _Frozen(ot.PythonDistribution):
        def __init__(self):
            super().__init__(1)

        def getRange(self):
            lo, hi = frozen.support()
            lo = frozen.ppf(1e-12) if not math.isfinite(lo) else lo
            hi = frozen.ppf(1 - 1e-12) if not math.isfinite(hi) else hi
            return ot.Interval([float(lo)], [float(hi)])

        def computeCDF(self, x):
            return float(frozen.cdf(x[0]))

        def computeQuantile(self, p, tail=False):
            return [float(frozen.ppf(1 - p if tail else p))]

        def getRealization(self):
            return [float(frozen.ppf(ot.RandomGenerator.Generate()))]

    return ot.Distribution(_Frozen())


def _check_against_case(case, key, distribution):
    """Refuses a distribution whose range reaches values the key does not allow (a normal
    backlash can go negative): the base case's own check, at both ends of the range."""
    r = distribution.getRange()
    for end in (r.getLowerBound()[0], r.getUpperBound()[0]):
        try:
            case.with_({key: float(end)})
        except Exception as e:  # InputError (a ValueError) from the case reader
            raise StudyError(
                f"inputs.{key}: the distribution reaches {end:.6g} (its range "
                f"[{r.getLowerBound()[0]:.6g}, {r.getUpperBound()[0]:.6g}]), which the key "
                f"refuses: {e}. Truncate it (truncated_normal) or bound it (uniform); geardyn "
                "does not clip samples silently") from None


# ---- the design ---------------------------------------------------------------------------

def design(case, inputs, samples=None, method="lhs", seed=0, correlation=None):
    """The inputs of every sample, as a dict key -> NumPy array (the study's design).

    Parameters
    ----------
    case : Case
        The base case: each key must be a numeric key of it.
    inputs : dict
        key -> distribution (``method`` monte_carlo, lhs or sobol), key -> list of values
        (``grid``: the full factorial), or a list of dicts key -> value (``variants``).
    samples : int
        How many samples to draw (distributions only).
    method : str
        monte_carlo, lhs (Latin hypercube), sobol (Sobol' low-discrepancy), saltelli (the
        pick-freeze design of Sobol' indices: samples x (inputs + 2) runs; `sobol_indices`
        reads it), grid or variants.
    seed : int
        The seed of OpenTURNS's generator: the same seed, the same samples.
    correlation : array-like, optional
        A correlation matrix between the inputs in their order (a normal copula; Spearman's
        rank correlation as OpenTURNS's NormalCopula takes it from it).
    """
    if method not in _METHODS:
        raise StudyError(f"method = {method!r}: must be one of {', '.join(_METHODS)}")
    for k in ({k for v in inputs for k in v} if isinstance(inputs, (list, tuple))
              else inputs):
        _check_key(case, k)
    if method == "variants":
        if not isinstance(inputs, (list, tuple)) or not inputs:
            raise StudyError("method = 'variants': inputs must be a non-empty list of dicts")
        keys = sorted({k for v in inputs for k in v})
        missing = [i for i, v in enumerate(inputs) if set(v) != set(keys)]
        if missing:
            raise StudyError(f"variants {missing}: each variant must set the same keys "
                             f"({', '.join(keys)})")
        out = {k: np.array([float(v[k]) for v in inputs]) for k in keys}
    elif method == "grid":
        keys = list(inputs)
        axes = [np.asarray(inputs[k], dtype=float) for k in keys]
        mesh = np.meshgrid(*axes, indexing="ij")
        out = {k: m.ravel() for k, m in zip(keys, mesh)}
    else:
        ot = _ot()
        if not isinstance(samples, int) or samples < 1:
            raise StudyError(f"samples = {samples!r}: must be a whole number >= 1")
        keys = list(inputs)
        marginals = [_distribution(k, inputs[k]) for k in keys]
        for k, d in zip(keys, marginals):
            _check_against_case(case, k, d)
        joint = ot.ComposedDistribution(marginals)
        if correlation is not None:
            r = np.asarray(correlation, dtype=float)
            if r.shape != (len(keys), len(keys)):
                raise StudyError(f"correlation: a {len(keys)} x {len(keys)} matrix is needed "
                                 f"(one row per input), not {r.shape}")
            joint = ot.ComposedDistribution(
                marginals, ot.NormalCopula(ot.NormalCopula.GetCorrelationFromSpearmanCorrelation(
                    ot.CorrelationMatrix(len(keys), r.ravel().tolist()))))
        ot.RandomGenerator.SetSeed(int(seed))
        if method == "monte_carlo":
            x = ot.MonteCarloExperiment(joint, samples).generate()
        elif method == "lhs":
            x = ot.LHSExperiment(joint, samples).generate()
        elif method == "sobol":
            x = ot.LowDiscrepancyExperiment(ot.SobolSequence(len(keys)), joint, samples,
                                            False).generate()
        else:
            if correlation is not None:
                raise StudyError("method = 'saltelli': Sobol' indices need independent inputs "
                                 "(no correlation)")
            x = ot.SobolIndicesExperiment(joint, samples, False).generate()
        x = np.array(x)
        out = {k: x[:, i] for i, k in enumerate(keys)}
    for k, v in out.items():
        if not np.all(np.isfinite(v)):
            raise StudyError(f"inputs.{k}: a value is not a finite number")
        if method in ("grid", "variants"):
            for value in np.unique(v):
                try:
                    case.with_({k: float(value)})
                except ValueError as e:
                    raise StudyError(f"inputs.{k} = {value:g}: {e}") from None
    # Each input must change something: at the corners of the inputs' ranges the case reads it.
    ends = [{k: float(np.min(v)) for k, v in out.items()},
            {k: float(np.max(v)) for k, v in out.items()}]
    for k in out:
        corners = [[(k, end[k])] + [(j, other[j]) for j in out if j != k]
                   for end in ends for other in ends]
        try:
            why = case._unread_study_key(corners)
        except ValueError as e:
            raise StudyError(f"inputs.{k}: {e}") from None
        if why:
            raise StudyError(f"inputs.{k}: the study would vary a key this case does not read: "
                             f"{why}")
    return out


def _check_swept(case, param, values):
    """A sweep analysis's key and values, before any sample runs or any file is written: a key
    the case takes at the least and the largest value, and reads there."""
    try:
        v = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise StudyError(f"analysis.values: {values!r} is not a list of numbers") from None
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise StudyError(f"analysis.values: {values!r}: at least one value, every one finite")
    ends = (float(v.min()), float(v.max()))
    for x in ends:
        try:
            case.with_({param: x})
        except (ValueError, KeyError) as e:
            raise StudyError(f"analysis.param = {param!r} at {x:g}: {e}") from None
    why = case._unread_study_key([[(param, x)] for x in ends])
    if why:
        raise StudyError(f"analysis.param = {param!r}: the study would vary a key this case does "
                         f"not read: {why}")


def _check_key(case, key):
    """An input must be a numeric key of the base case."""
    try:
        value = case[key]
    except KeyError:
        raise StudyError(f"inputs.{key}: not a key of the base case (docs/case-files.md lists "
                         "them)") from None
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise StudyError(f"inputs.{key}: not a numeric key (it holds {value!r})")


# ---- the analyses -------------------------------------------------------------------------

def _evaluate(case, keys, values, analysis):
    """One sample of an orbit or sweep study: the base case with its inputs set, analysed. A
    sample whose analysis fails numerically keeps NaN outputs and its reason (a study does not
    stop for one sample)."""
    import geardyn

    c = case.with_({k: float(v) for k, v in zip(keys, values)})
    try:
        if analysis["kind"] == "orbit":
            o = geardyn.orbit(c, periods=analysis.get("periods", 1))
            return {"converged": float(o["converged"]), "stable": float(o["stable"]),
                    "max_multiplier": float(o["max_multiplier"])}, ""
        s = geardyn.sweep(c, analysis["param"], analysis["values"],
                          direction=analysis.get("direction", "both"), threads=1)
        return _sweep_outputs(s), ""
    except geardyn.NumericalError as e:
        return {}, str(e)


def _sweep_outputs(s):
    """A frequency response read: its peak and where, its jumps, the width of its hysteresis
    (up and down sweeps apart) and the range where it rattles."""
    x = np.asarray(s["value"], dtype=float)
    force = np.asarray(s["max_force_bar"], dtype=float)
    impacts = np.asarray(s["impacts_per_period"], dtype=float)
    rattling = x[impacts > 0]
    i = int(np.nanargmax(force))
    return {"peak_max_force_bar": float(force[i]), "peak_at": float(x[i]),
            "jumps": float(len(s["jumps"])),
            "hysteresis_width": float(sum(h["to_value"] - h["from_value"]
                                          for h in s["hysteresis"])),
            "rattle_from": float(rattling.min()) if rattling.size else float("nan"),
            "rattle_to": float(rattling.max()) if rattling.size else float("nan")}


class _BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C inside a batch, holding the samples it completed as `_batch` returns them."""

    def __init__(self, done):
        super().__init__()
        self.done = done


def _batch(case, keys, first, values, analysis):
    """A task: samples first, first + 1, ... (values: one row per sample). Returns
    (first, outputs as dict of lists, failures as list of str). A run's samples, of any form,
    go to the library in one call (study_sample.hpp: no samples kept, a pair form's mesh
    stiffness computed once when no input changes it; Ctrl-C raises _BatchInterrupted with
    the samples done); an orbit's and a sweep's through the Python functions."""
    from . import _geardyn

    if analysis.get("kind", "run") == "run":
        outputs, failures, done, interrupted = _geardyn._run_batch(
            case, list(keys), np.asarray(values, dtype=float).reshape(len(values), len(keys)))
        result = first, {k: v.tolist() for k, v in outputs.items()}, list(failures)
        if interrupted:
            raise _BatchInterrupted(result)
        return result
    results = [_evaluate(case, keys, row, analysis) for row in values]
    names = sorted({k for out, _ in results for k in out})
    outputs = {k: [out.get(k, float("nan")) for out, _ in results] for k in names}
    return first, outputs, [why for _, why in results]


# ---- the store ----------------------------------------------------------------------------

def _spec(case, design_, analysis, method, seed):
    """What identifies a study: its base case, design and analysis. A store holds one."""
    h = hashlib.sha256()
    h.update(case.to_toml().encode())
    h.update(json.dumps(analysis, sort_keys=True).encode())
    for k in design_:
        h.update(k.encode())
        h.update(np.ascontiguousarray(design_[k], dtype="<f8").tobytes())
    return {"format": "geardyn study store 1", "fingerprint": h.hexdigest(), "method": method,
            "seed": seed, "samples": int(len(next(iter(design_.values())))),
            "inputs": list(design_), "analysis": analysis, "case": case.to_toml()}


class _Store:
    """A folder holding one study: study.json (what it is), batches/ (one NetCDF file per
    completed batch, samples first..last). Only these names are written; the folder's other
    files are left alone."""

    def __init__(self, path, spec, resume):
        self.path = pathlib.Path(path)
        self.batches = self.path / _BATCHES
        spec_file = self.path / _STORE_SPEC
        if spec_file.exists():
            try:
                held = json.loads(spec_file.read_text())
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
                raise StudyError(
                    f"store {self.path}: {_STORE_SPEC} there is no study's record ({e}); "
                    "geardyn never replaces a file it did not write: give another store, or "
                    "move it away") from None
            if not isinstance(held, dict) or held.get("fingerprint") != spec["fingerprint"]:
                raise StudyError(
                    f"store {self.path}: it holds another study (its base case, inputs or "
                    "analysis differ); give another store, or remove this one")
            if not resume and any(self.batches.glob("samples_*.nc")):
                raise StudyError(
                    f"store {self.path}: it holds this study's samples already; resume=True "
                    "(geardyn-study --resume) continues it")
        else:
            self.batches.mkdir(parents=True, exist_ok=True)
            text = json.dumps(spec, indent=1) + "\n"
            write_atomically(spec_file, lambda name: pathlib.Path(name).write_text(text),
                             ".json.tmp")
        self.batches.mkdir(parents=True, exist_ok=True)

    def done(self):
        """The sample indices stored."""
        out = set()
        for f in self.batches.glob("samples_*.nc"):
            first, last = (int(x) for x in f.stem.split("_")[1:3])
            out.update(range(first, last + 1))
        return out

    def write(self, ds):
        first, last = int(ds["sample"][0]), int(ds["sample"][-1])
        write_atomically(self.batches / f"samples_{first:08d}_{last:08d}.nc", ds.to_netcdf,
                         ".nc.tmp")

    def read(self):
        import xarray as xr

        parts = []
        for f in sorted(self.batches.glob("samples_*.nc")):
            with xr.open_dataset(f) as d:
                parts.append(d.load())
        return parts


def _batch_dataset(first, outputs, failures):
    import xarray as xr

    n = len(failures)
    data = {k: ("sample", np.asarray(v, dtype=float)) for k, v in outputs.items()}
    data["failure"] = ("sample", np.array(failures, dtype=object))
    return xr.Dataset(data, coords={"sample": np.arange(first, first + n)})


# ---- the study ----------------------------------------------------------------------------

# Units of the outputs a run or sweep keeps (attributes "units" and "long_name"): the columns
# of a sweep's table where they are the same reading (data._COLUMNS), the study's own here.
_OUTPUT_UNITS = {
    **{k: _COLUMNS[k] for k in ("separated_fraction", "max_force_bar", "dynamic_factor")},
    "impacts": ("1", "impacts in the window"),
    "backside_impacts": ("1", "back-side impacts in the window"),
    "separations": ("1", "separations in the window"),
    "max_delta_bar": ("1", "maximum of delta / b"),
    "max_impact_velocity_m_s": ("m/s", "largest impact velocity"),
    "max_impact_velocity": ("1", "largest impact velocity over b w_n"),
    "dynamic_factor_with_startup": ("1", "max F_G over the static mesh force, whole window"),
    "max_force_n": ("N", "largest mesh force"),
    "rattle": ("1", "1 when the regime is sustained rattle"),
    "natural_frequency_hz": ("Hz", "the contact natural frequency at the mean stiffness"),
    "load_sharing_static_factor": ("1", "n max F / sum F at the static state"),
    "load_sharing_factor": ("1", "largest n max F / sum F, steady part"),
    "load_sharing_factor_with_startup": ("1", "largest n max F / sum F, whole window"),
    "converged": ("1", "1 when the orbit was found"),
    "stable": ("1", "1 when the orbit is stable"),
    "max_multiplier": ("1", "largest Floquet multiplier modulus"),
    "peak_max_force_bar": ("1", "peak of the sweep's max F / (b k_m)"),
    "peak_at": ("(the swept key's unit)", "where the peak is"),
    "jumps": ("1", "jumps of the response"),
    "hysteresis_width": ("(the swept key's unit)", "width of the values where up and down "
                                                   "sweeps differ"),
    "rattle_from": ("(the swept key's unit)", "lowest swept value with impacts"),
    "rattle_to": ("(the swept key's unit)", "highest swept value with impacts"),
}


def _dataset(design_, parts, spec, computed):
    import xarray as xr

    from .data import _key_units

    n = spec["samples"]
    ds = xr.Dataset(coords={"sample": np.arange(n)})
    for k, v in design_.items():
        ds[k] = ("sample", np.asarray(v, dtype=float), {"units": _key_units(k) or "1",
                                                        "long_name": f"input {k}"})
    if parts:
        out = xr.concat(parts, dim="sample").sortby("sample")
        out = out.reindex(sample=np.arange(n))
        for k in out.data_vars:
            ds[k] = out[k]
            reading = k.rsplit(".", 1)[-1]  # a train's "<mesh>.impacts", the coupled "mesh."
            if reading in _OUTPUT_UNITS:
                units, long_name = _OUTPUT_UNITS[reading]
                prefix = k[:-len(reading)]
                ds[k].attrs.update(units=units,
                                   long_name=f"{prefix[:-1]}: {long_name}" if prefix else long_name)
    ds.attrs.update(method=spec["method"], seed=spec["seed"], inputs=json.dumps(spec["inputs"]),
                    analysis=json.dumps(spec["analysis"]), case=spec["case"],
                    fingerprint=spec["fingerprint"], samples_computed=computed)
    return ds


def _analysis_of(analysis):
    """The analysis as a dict: None (a run), the kind's name ("run", "sweep", "orbit"), or a
    mapping as a study file's [analysis] table writes it; anything else is refused naming the
    argument."""
    if analysis is None:
        return {"kind": "run"}
    if isinstance(analysis, str):
        return {"kind": analysis}
    if isinstance(analysis, Mapping):
        return dict(analysis)
    raise StudyError(f"analysis = {analysis!r}: must be the analysis's kind (\"run\", "
                     f"\"sweep\" or \"orbit\") or a dict such as {{\"kind\": \"sweep\", "
                     f"\"param\": key, \"values\": [...]}}")


def study(case, inputs, samples=None, method="lhs", seed=0, analysis=None, executor=None,
          store=None, resume=False, batch_size=None, correlation=None, progress=None,
          outputs=None):
    """Runs a study: the base case at every sample of a design, each analysed.

    Parameters
    ----------
    case : Case
        The base case.
    inputs, samples, method, seed, correlation
        The design (see `design`).
    analysis : str or dict, optional
        ``"run"`` or ``{"kind": "run"}`` (the default: the run's readings), ``{"kind": "sweep", "param":
        key, "values": [...]}`` (the frequency response's peak, jumps, rattle range) or
        ``{"kind": "orbit"}`` (converged, stable, largest multiplier).
    executor : None, dask.distributed.Client or str
        None: in this process. A Dask client, or a scheduler's address: batches of samples as
        Dask tasks.
    store : str or path, optional
        A folder: each batch is written there as it completes (NetCDF), so that an interrupted
        study continues with ``resume=True``, computing only the samples missing.
    batch_size : int, optional
        Samples a task (default: about four tasks a worker, at most 64 samples).
    progress : None, True or callable
        ``progress(done, total)`` in samples; True: a tqdm bar.
    outputs : list of str, optional
        The outputs to keep (default: all the analysis gives; docs/studies.md lists them).

    Returns
    -------
    xarray.Dataset
        Over ``sample``: each input and output a variable with its units; ``failure`` (the
        reason, empty when the sample's analysis succeeded). Ctrl-C raises KeyboardInterrupt
        with the samples done so far in ``.result`` (and kept in the store).
    """
    from . import _interrupted, _progress, _warn_unused

    _warn_unused(case, stacklevel=3)

    analysis = _analysis_of(analysis)
    if analysis.get("kind", "run") not in ("run", "sweep", "orbit"):
        raise StudyError(f"analysis.kind = {analysis['kind']!r}: must be run, sweep or orbit")
    if analysis.get("kind") == "sweep" and ("param" not in analysis or "values" not in analysis):
        raise StudyError("analysis (sweep): needs 'param' and 'values'")
    if analysis.get("kind") == "sweep":
        _check_swept(case, analysis["param"], analysis["values"])
    design_ = design(case, inputs, samples, method, seed, correlation)
    _python_sigint()  # OpenTURNS's objects, gone with design(), leave their own handler
    keys = list(design_)
    spec = _spec(case, design_, analysis, method, seed)
    n = spec["samples"]
    client, own = _client(executor)  # an unreachable scheduler is refused before any write
    try:
        st = _Store(store, spec, resume) if store is not None else None
    except BaseException:
        if own:
            client.close()
        raise
    done = st.done() if st else set()
    missing = [i for i in range(n) if i not in done]
    parts = st.read() if st else []
    rows = np.column_stack([design_[k] for k in keys]) if keys else np.zeros((n, 0))
    callback = _progress(progress, total=n, unit="sample")
    computed = 0

    def stored(first, outputs, failures):
        nonlocal computed
        b = _batch_dataset(first, outputs, failures)
        if st:
            st.write(b)
        parts.append(b)
        computed += len(failures)
        if callback:
            callback(len(done) + computed, n)

    workers = max(1, len(client.scheduler_info()["workers"])) if client else 1
    size = batch_size or max(1, min(64, math.ceil(len(missing) / (4 * workers))))
    batches = _runs(missing, size)
    if callback:
        callback(len(done), n)
    try:
        if client is None:
            for first, count in batches:
                try:
                    stored(*_batch(case, keys, first, rows[first:first + count], analysis))
                except _BatchInterrupted as e:
                    if e.done[2]:  # the batch's samples completed before Ctrl-C are kept
                        stored(*e.done)
                    raise
        else:
            from dask.distributed import as_completed

            futures = [client.submit(_batch, case, keys, first, rows[first:first + count],
                                     analysis, key=f"geardyn-study-{spec['fingerprint'][:16]}-"
                                                   f"{first}-{count}", pure=False, retries=2)
                       for first, count in batches]
            try:
                for f in as_completed(futures):
                    stored(*f.result())
            except BaseException:
                client.cancel(futures)
                raise
    except KeyboardInterrupt:
        raise _interrupted(_kept(_dataset(design_, parts, spec, computed), outputs, keys),
                           "study") from None
    finally:
        if own:
            client.close()
    return _kept(_dataset(design_, parts, spec, computed), outputs, keys)


def _kept(ds, outputs, keys):
    """The Dataset with the inputs, the named outputs and the failures."""
    if outputs is None:
        return ds
    have = [k for k in ds.data_vars if k not in keys and k != "failure"]
    unknown = [k for k in outputs if k not in have]
    if unknown and have:
        raise StudyError(f"outputs: {', '.join(unknown)}: not an output of this analysis; it "
                         f"gives {', '.join(have)}")
    return ds[list(keys) + [k for k in outputs if k in have] + ["failure"]]


def _runs(indices, size):
    """The missing samples as (first, count) batches of consecutive indices, at most `size`."""
    out = []
    for i in indices:
        if out and out[-1][0] + out[-1][1] == i and out[-1][1] < size:
            out[-1] = (out[-1][0], out[-1][1] + 1)
        else:
            out.append((i, 1))
    return out


def _client(executor):
    """(client or None, whether this study made it)."""
    if executor is None:
        return None, False
    try:
        from dask.distributed import Client
    except ImportError as e:  # pragma: no cover - installed by scripts/setup.sh
        raise ImportError("a Dask executor needs dask.distributed (Debian: apt-get install "
                          "python3-distributed)") from e
    if isinstance(executor, Client):
        return executor, False
    if isinstance(executor, str):
        try:
            return Client(executor, timeout="10s"), True
        except (OSError, TimeoutError) as e:
            raise StudyError(f"executor = {executor!r}: cannot reach the Dask scheduler there "
                             f"({e})") from None
    raise StudyError(f"executor = {executor!r}: must be None, a dask.distributed.Client or a "
                     "scheduler address")


# ---- statistics ---------------------------------------------------------------------------

def statistics(ds, outputs=None, limits=None, quantiles=(0.05, 0.5, 0.95), confidence=0.95):
    """The statistics of a study's outputs, each with its confidence interval.

    Parameters
    ----------
    ds : xarray.Dataset
        A study's result.
    outputs : list of str, optional
        Default: every output.
    limits : dict, optional
        output -> limit: the probability that the output exceeds it (``{"rattle": 0.5}`` is
        P(rattle), ``{"dynamic_factor": 2}`` P(dynamic factor > 2)).
    quantiles : sequence of float
    confidence : float
        The intervals' level.

    Returns
    -------
    dict
        output -> ``n`` (samples with a value; failed samples are left out and counted as
        ``failed``), ``mean`` and ``mean_interval`` (Student's t), ``std``, ``quantiles``
        {q: (value, (lower, upper))} (distribution-free, from the order statistics),
        ``exceedance`` {limit: (probability, (lower, upper))} (Clopper-Pearson).

    Notes
    -----
    A design other than Monte Carlo (lhs, sobol) gives smaller errors than these intervals,
    which assume independent samples: they are then conservative.
    """
    import scipy.stats

    inputs = set(json.loads(ds.attrs.get("inputs", "[]")))
    names = outputs or [k for k in ds.data_vars if k not in inputs and k != "failure"]
    out = {}
    for k in names:
        if k not in ds:
            raise StudyError(f"output {k!r}: not in this study (it has "
                             f"{', '.join(v for v in ds.data_vars if v not in inputs)})")
        x = np.asarray(ds[k].values, dtype=float)
        ok = x[np.isfinite(x)]
        n = ok.size
        r = {"n": n, "failed": int(x.size - n)}
        if n >= 2:
            m, sd = float(ok.mean()), float(ok.std(ddof=1))
            half = scipy.stats.t.ppf(0.5 + confidence / 2, n - 1) * sd / math.sqrt(n)
            r.update(mean=m, mean_interval=(m - half, m + half), std=sd)
            xs = np.sort(ok)
            qs = {}
            for q in quantiles:
                # The order statistics X_(l) <= x_q <= X_(u) with binomial coverage.
                lo = int(scipy.stats.binom.ppf((1 - confidence) / 2, n, q))
                hi = int(scipy.stats.binom.ppf(0.5 + confidence / 2, n, q)) + 1
                qs[q] = (float(np.quantile(ok, q)),
                         (float(xs[max(lo, 1) - 1]) if lo >= 1 else -math.inf,
                          float(xs[hi - 1]) if hi <= n else math.inf))
            r["quantiles"] = qs
        if limits and k in limits:
            hits = int((ok > limits[k]).sum())
            ci = scipy.stats.binomtest(hits, n).proportion_ci(confidence, "exact") if n else None
            r["exceedance"] = {limits[k]: (hits / n if n else math.nan,
                                           (ci.low, ci.high) if ci else (math.nan, math.nan))}
        out[k] = r
    return out


def sobol_indices(ds, output, confidence=0.95):
    """Sobol' first-order and total indices of one output, with bootstrap intervals, from a
    study with ``method = "saltelli"`` (OpenTURNS's Saltelli estimator).

    Returns
    -------
    dict
        input -> {"first": (value, (lower, upper)), "total": (value, (lower, upper))}.
    """
    ot = _ot()
    if ds.attrs.get("method") != "saltelli":
        raise StudyError(f"Sobol' indices need a study with method = 'saltelli', not "
                         f"{ds.attrs.get('method')!r}")
    keys = json.loads(ds.attrs["inputs"])
    y = np.asarray(ds[output].values, dtype=float)
    if not np.all(np.isfinite(y)):
        raise StudyError(f"output {output!r}: {int((~np.isfinite(y)).sum())} samples failed; "
                         "Sobol' indices need every sample")
    n = y.size // (len(keys) + 2)
    x = ot.Sample(np.column_stack([ds[k].values for k in keys]).tolist())
    algo = ot.SaltelliSensitivityAlgorithm(x, ot.Sample(y.reshape(-1, 1).tolist()), n)
    algo.setBootstrapSize(200)
    algo.setConfidenceLevel(confidence)
    ot.RandomGenerator.SetSeed(0)  # the bootstrap's: the same study, the same intervals
    first, total = algo.getFirstOrderIndices(), algo.getTotalOrderIndices()
    fi, ti = algo.getFirstOrderIndicesInterval(), algo.getTotalOrderIndicesInterval()
    return {k: {"first": (first[i], (fi.getLowerBound()[i], fi.getUpperBound()[i])),
                "total": (total[i], (ti.getLowerBound()[i], ti.getUpperBound()[i]))}
            for i, k in enumerate(keys)}


# ---- the report ---------------------------------------------------------------------------

def report(ds, path, outputs=None, limits=None):
    """Writes a study's report: one HTML file with the statistics and interactive figures
    (plotly, its script inlined: it works offline): each output's histogram and distribution
    function, its scatter against each input, and the Sobol' indices of a saltelli study.

    Parameters
    ----------
    ds : xarray.Dataset
        A study's result.
    path : str or path
        The HTML file (written through a temporary file and a rename).
    outputs : list of str, optional
        Default: every output that varies.
    limits : dict, optional
        output -> limit, as `statistics` takes them.
    """
    import html

    import plotly.graph_objects as go
    import plotly.io as pio

    keys = json.loads(ds.attrs["inputs"])
    names = outputs or [k for k in ds.data_vars if k not in keys and k != "failure"
                        and np.nanstd(np.asarray(ds[k].values, dtype=float)) > 0]
    stats = statistics(ds, names, limits)
    parts = [f"<h1>geardyn study: {len(ds['sample'])} samples, method {ds.attrs['method']}, "
             f"seed {ds.attrs['seed']}</h1>",
             f"<p>Inputs: {html.escape(', '.join(keys))}. Analysis: "
             f"{html.escape(ds.attrs['analysis'])}. Intervals at 95 %.</p>",
             "<table id='statistics'><tr><th>output</th><th>n</th><th>failed</th><th>mean "
             "[interval]</th><th>std</th><th>5 % / 50 % / 95 % quantiles [intervals]</th>"
             "<th>exceedance</th></tr>"]
    for k in names:
        s = stats[k]
        q = "; ".join(f"{v:.6g} [{lo:.6g}, {hi:.6g}]" for v, (lo, hi) in
                      s.get("quantiles", {}).values())
        ex = "; ".join(f"P({k} > {lim:g}) = {p:.4g} [{lo:.4g}, {hi:.4g}]"
                       for lim, (p, (lo, hi)) in s.get("exceedance", {}).items())
        mean = (f"{s['mean']:.6g} [{s['mean_interval'][0]:.6g}, {s['mean_interval'][1]:.6g}]"
                if "mean" in s else "")
        parts.append(f"<tr><td>{html.escape(k)}</td><td>{s['n']}</td><td>{s['failed']}</td>"
                     f"<td>{mean}</td><td>{s.get('std', float('nan')):.6g}</td><td>{q}</td>"
                     f"<td>{html.escape(ex)}</td></tr>")
    parts.append("</table>")
    figures = []
    for k in names:
        y = np.asarray(ds[k].values, dtype=float)
        units = ds[k].attrs.get("units", "")
        f = go.Figure()
        f.add_trace(go.Histogram(x=y, name="histogram", histnorm="probability density"))
        ys = np.sort(y[np.isfinite(y)])
        f.add_trace(go.Scatter(x=ys, y=np.arange(1, ys.size + 1) / ys.size, name="CDF",
                               yaxis="y2", mode="lines"))
        f.update_layout(title=f"{k} ({units})", xaxis_title=f"{k} ({units})",
                        yaxis_title="density", yaxis2=dict(title="CDF", overlaying="y",
                                                           side="right", range=[0, 1]))
        figures.append(f)
        for x in keys:
            g = go.Figure(go.Scatter(x=ds[x].values, y=y, mode="markers", name=k))
            g.update_layout(title=f"{k} against {x}",
                            xaxis_title=f"{x} ({ds[x].attrs.get('units', '')})",
                            yaxis_title=f"{k} ({units})")
            figures.append(g)
        if ds.attrs.get("method") == "saltelli":
            idx = sobol_indices(ds, k)
            b = go.Figure()
            for which in ("first", "total"):
                v = [idx[x][which][0] for x in keys]
                err = [idx[x][which][1][1] - idx[x][which][0] for x in keys]
                err_minus = [idx[x][which][0] - idx[x][which][1][0] for x in keys]
                b.add_trace(go.Bar(x=keys, y=v, name=f"{which} order" if which == "first"
                                   else "total", error_y=dict(type="data", array=err,
                                                               arrayminus=err_minus)))
            b.update_layout(title=f"Sobol' indices of {k}", yaxis_title="index")
            figures.append(b)
    for i, f in enumerate(figures):
        parts.append(pio.to_html(f, full_html=False, include_plotlyjs=(i == 0)))
    text = ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            "<title>geardyn study</title><style>body{font-family:sans-serif;margin:2em}"
            "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:0.3em}"
            "</style></head><body>\n" + "\n".join(parts) + "\n</body></html>\n")
    write_atomically(path, lambda name: pathlib.Path(name).write_text(text), ".html.tmp")
