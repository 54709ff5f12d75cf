"""Samples per second of a study (docs/performance.md, "Studies"): a run study of the paper's
gear over 20 ms and a sweep study, in this process and on 1 and 2 Dask worker processes, the
overhead of a Dask task (batches of 1 sample against batches of 32), and a run study of the
shipped loose-gear train (its samples in the library's batch, as every form's) against its runs
by geardyn.run one by one and the library's own time for those runs.

    PYTHONPATH=build/release/python python3 bench/study_throughput.py
"""
import pathlib
import time

import geardyn

RUN = geardyn.Case.default().set("solver.duration_s", 0.02)
INPUTS = {"mesh.backlash_um": {"distribution": "uniform", "lower": 80, "upper": 120},
          "load.fluctuation_ratio": {"distribution": "uniform", "lower": 0.1, "upper": 0.4}}
LOOSE = geardyn.Case.from_toml(str(pathlib.Path(__file__).parent.parent / "cases"
                                   / "loose_gear_rattle.toml"))
LOOSE_INPUTS = {"train.speed[0].acceleration_harmonics[0][0]":
                {"distribution": "uniform", "lower": 200, "upper": 320}}
SWEEP = {"kind": "sweep", "param": "speed.shaft_frequency_hz",
         "values": [1500 + 50 * i for i in range(21)], "direction": "up"}


ROUNDS = 3  # the in-process comparisons: the best of this many rounds, their columns interleaved


def timed(**kw):
    t = time.perf_counter()
    ds = geardyn.study(RUN, INPUTS, seed=1, **kw)
    return time.perf_counter() - t, ds.sizes["sample"]


def line(what, seconds, n):
    print(f"{what:<46} {n:5d} samples {seconds:7.2f} s {n / seconds:8.1f} samples/s "
          f"{1e3 * seconds / n:7.2f} ms/sample")


def one_by_one(case, inputs, n):
    """geardyn.run of a study's n cases in turn: (seconds, the sum of their wall_time_s)."""
    d = geardyn.design(case, inputs, n, "lhs", seed=1)
    t, own = time.perf_counter(), 0.0
    for i in range(n):
        own += geardyn.run(case.with_({k: float(v[i]) for k, v in d.items()})) \
            .summary.get("wall_time_s", 0.0)
    return time.perf_counter() - t, own


def study_against_runs(what, case, inputs, n):
    """A run study of n samples against the same cases by geardyn.run one by one: the best of
    ROUNDS rounds of each, the two measured in turn in every round (one machine, one moment)."""
    geardyn.study(case, inputs, samples=4, seed=1)  # the first plans and imports, once
    study, runs, own = float("inf"), float("inf"), float("inf")
    for _ in range(ROUNDS):
        t = time.perf_counter()
        geardyn.study(case, inputs, samples=n, seed=1)
        study = min(study, time.perf_counter() - t)
        r, o = one_by_one(case, inputs, n)
        runs, own = min(runs, r), min(own, o)
    line(f"{what} run study, in-process", study, n)
    line("the same cases by geardyn.run, one by one", runs, n)
    line("  of which the library's runs (wall_time_s)", own, n)
    print(f"  study / geardyn.run {study / runs:.2f}, study / the library's runs {study / own:.2f}")


def main():
    from dask.distributed import Client, LocalCluster

    timed(samples=8)  # imports (OpenTURNS, xarray) and the first plans, once
    study_against_runs("gear pair", RUN, INPUTS, 200)
    line("sweep study (21 points), in-process", *timed(samples=8, analysis=SWEEP))
    study_against_runs("loose-gear train", LOOSE, LOOSE_INPUTS, 64)
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None) as c, \
                Client(c) as client:
            timed(samples=8, executor=client)  # warm the workers (imports)
            line(f"run study, {workers} Dask worker(s)", *timed(samples=200, executor=client))
            line(f"sweep study, {workers} Dask worker(s)",
                 *timed(samples=8, analysis=SWEEP, executor=client))
            if workers == 1:
                one, n = timed(samples=64, executor=client, batch_size=1)
                many, _ = timed(samples=64, executor=client, batch_size=32)
                print(f"Dask task overhead: {1e3 * (one - many) / (64 - 2):.2f} ms a task "
                      f"(64 samples in 64 tasks {one:.2f} s, in 2 tasks {many:.2f} s)")


if __name__ == "__main__":
    main()
