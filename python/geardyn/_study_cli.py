"""The `geardyn-study` command that pip installs: a study file (TOML) run in this process or on
Dask, kept in DIR/store as samples complete, the result in DIR/study.nc and its report (statistics,
interactive figures) in DIR/report.html (docs/studies.md).

    geardyn-study SPEC.toml --out DIR [--workers N | --scheduler ADDRESS] [--resume]

Exit codes as geardyn's: 0 done, 1 a failure, 2 bad input (the message names the key of the
study file, its value and what is allowed; nothing is written), 130 interrupted (what was
computed stays in the store; --resume continues).
"""
import argparse
import asyncio
import concurrent.futures
import pathlib
import sys
import tomllib

_TOP = {"case": "a case file, relative to the study file (default: the default case)",
        "samples": "how many samples (distributions)",
        "method": "monte_carlo, lhs, sobol, grid or variants",
        "seed": "the sampling seed (default 0)",
        "batch_size": "samples a task",
        "correlation": "a correlation matrix between the inputs, in their order",
        "set": "a table of fixed case keys",
        "analysis": "a table: kind = run, sweep or orbit, and its settings",
        "inputs": "a table of inputs: key -> distribution table (or list of values for grid)",
        "variants": "an array of tables, each a variant's keys (method = variants)",
        "limits": "a table output -> limit: the report's exceedance probabilities",
        "outputs": "the outputs to keep (default: all the analysis gives)"}


def _fail(message, code=2):
    print(f"geardyn-study: error: {message}", file=sys.stderr)
    sys.exit(code)


def load_spec(path):
    """The study file as study() arguments: (case, kwargs)."""
    import geardyn

    path = pathlib.Path(path)
    try:
        spec = tomllib.loads(path.read_text())
    except OSError as e:
        _fail(f"{path}: cannot read it ({e.strerror})")
    except tomllib.TOMLDecodeError as e:
        _fail(f"{path}: not TOML: {e}")
    unknown = [k for k in spec if k not in _TOP]
    if unknown:
        _fail(f"{path}: {', '.join(unknown)}: not a study key; the keys are: "
              + "; ".join(f"{k} ({v})" for k, v in _TOP.items()))
    try:
        case = (geardyn.Case.from_toml(path.parent / spec["case"]) if "case" in spec
                else geardyn.Case.default())
        for k, v in spec.get("set", {}).items():
            case.set(k, v)
    except ValueError as e:
        _fail(f"{path}: {e}")
    method = spec.get("method", "lhs")
    inputs = spec.get("variants") if method == "variants" else spec.get("inputs", {})
    kwargs = dict(inputs=inputs, samples=spec.get("samples"), method=method,
                  seed=spec.get("seed", 0), analysis=spec.get("analysis"),
                  batch_size=spec.get("batch_size"), correlation=spec.get("correlation"),
                  outputs=spec.get("outputs"))
    return case, kwargs, spec.get("limits", {})


# The files geardyn-study writes into --out beside its store, as one set.
_WRITTEN = ("study.nc", "report.html")


def main(argv=None):
    import geardyn

    p = argparse.ArgumentParser(prog="geardyn-study", description=__doc__.split("\n\n")[0])
    p.add_argument("spec", help="the study file (TOML)")
    p.add_argument("--out", required=True, help="output folder: store/, study.nc")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="a local Dask cluster of N worker processes")
    where.add_argument("--scheduler", help="a running Dask scheduler's address")
    p.add_argument("--resume", action="store_true", help="continue the study in --out")
    a = p.parse_args(argv)
    if a.workers is not None and a.workers < 1:
        _fail(f"--workers {a.workers}: must be 1 or more")
    case, kwargs, limits = load_spec(a.spec)
    out = pathlib.Path(a.out)
    # Checked before the work, as the commit checks again: a file of the user's under one of
    # these names is never replaced (docs/outputs.md).
    foreign = geardyn._geardyn._foreign_files(str(out), list(_WRITTEN))
    if foreign:
        _fail(f"--out {out}: {', '.join(foreign)} there not written by geardyn, or changed "
              "since it was: geardyn-study writes under these names and never replaces a file "
              f"it did not write; move {'it' if len(foreign) == 1 else 'them'} away, or give "
              "another folder")
    client = cluster = None
    try:
        if a.workers:
            from dask.distributed import Client, LocalCluster

            cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1,
                                   dashboard_address=None)
            client = Client(cluster)
        executor = client or a.scheduler
        ds = geardyn.study(case, executor=executor, store=out / "store", resume=a.resume,
                           progress=True, **kwargs)
    except KeyboardInterrupt as e:
        done = getattr(e, "result", None)
        kept = int(done.attrs["samples_computed"]) if done is not None else 0
        print(f"geardyn-study: interrupted: {kept} samples computed now are kept in "
              f"{out / 'store'}; --resume continues", file=sys.stderr)
        return 130
    except ValueError as e:
        _fail(str(e))
    except (OSError, TimeoutError, asyncio.CancelledError, concurrent.futures.CancelledError) as e:
        # The scheduler or the cluster was lost (killed, unreachable): the batches stored stay.
        print(f"geardyn-study: error: the Dask executor failed ({type(e).__name__}: {e}); the "
              f"samples computed are kept in {out / 'store'}; --resume continues",
              file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    from .studies import report

    def stage(folder):
        ds.to_netcdf(pathlib.Path(folder) / _WRITTEN[0])
        report(ds, pathlib.Path(folder) / _WRITTEN[1], limits=limits)

    try:
        geardyn._geardyn._write_set(str(out), "geardyn-study", stage)
    except RuntimeError as e:
        print(f"geardyn-study: error: {e}; the samples are kept in {out / 'store'}",
              file=sys.stderr)
        return 1
    failed = int((ds["failure"] != "").sum()) if "failure" in ds else 0
    print(f"geardyn-study: {ds.sizes['sample']} samples ({ds.attrs['samples_computed']} "
          f"computed now, {failed} failed) in {out / 'study.nc'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
