"""Studies (geardyn.study, docs/studies.md): designs seeded and stratified, bad input named,
the store written as samples complete and resumed without recomputing, and a Dask cluster of
two worker processes giving the in-process result bit for bit, a worker killed or not."""
import os
import threading

import numpy as np
import pytest
import scipy.stats

import geardyn

# A short window keeps each sample cheap; the study's logic does not depend on it.
CASE = geardyn.Case.default().set("solver.duration_s", 0.004)
INPUTS = {
    "mesh.backlash_um": {"distribution": "uniform", "lower": 80, "upper": 120},
    "load.fluctuation_ratio": {"distribution": "truncated_normal", "mean": 0.25, "std": 0.05,
                               "lower": 0.1, "upper": 0.4},
}
OUTPUTS = ("impacts", "dynamic_factor", "max_force_bar", "rattle", "separated_fraction")


def same_outputs(a, b):
    for k in OUTPUTS:
        np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)
    for k in INPUTS:
        np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)


def test_a_design_is_its_seeds_and_a_latin_hypercube_fills_every_stratum():
    d1 = geardyn.design(CASE, INPUTS, 50, "lhs", seed=7)
    d2 = geardyn.design(CASE, INPUTS, 50, "lhs", seed=7)
    d3 = geardyn.design(CASE, INPUTS, 50, "lhs", seed=8)
    for k in INPUTS:
        np.testing.assert_array_equal(d1[k], d2[k])
        assert not np.array_equal(d1[k], d3[k])
    # One sample in each of the 50 equiprobable strata of each input.
    u = (d1["mesh.backlash_um"] - 80) / 40
    assert sorted(np.floor(u * 50).astype(int)) == list(range(50))
    tn = scipy.stats.truncnorm((0.1 - 0.25) / 0.05, (0.4 - 0.25) / 0.05, 0.25, 0.05)
    assert sorted(np.floor(tn.cdf(d1["load.fluctuation_ratio"]) * 50).astype(int)) == \
        list(range(50))
    # A grid is the full factorial, variants as listed.
    g = geardyn.design(CASE, {"mesh.backlash_um": [50, 100], "speed.shaft_frequency_hz":
                              [100, 200, 300]}, method="grid")
    assert len(g["mesh.backlash_um"]) == 6 and set(g["speed.shaft_frequency_hz"]) == \
        {100, 200, 300}
    v = geardyn.design(CASE, [{"mesh.backlash_um": 60}, {"mesh.backlash_um": 90}],
                       method="variants")
    assert list(v["mesh.backlash_um"]) == [60, 90]


def test_a_scipy_frozen_distribution_and_a_correlation_are_taken():
    d = geardyn.design(CASE, {"mesh.backlash_um": scipy.stats.uniform(80, 40),
                              "load.fluctuation_ratio": {"distribution": "uniform",
                                                         "lower": 0.1, "upper": 0.4}},
                       400, "monte_carlo", seed=1, correlation=[[1, 0.8], [0.8, 1]])
    assert np.all((d["mesh.backlash_um"] >= 80) & (d["mesh.backlash_um"] <= 120))
    rho = scipy.stats.spearmanr(d["mesh.backlash_um"], d["load.fluctuation_ratio"])[0]
    assert abs(rho - 0.8) < 0.06


@pytest.mark.parametrize("inputs, kwargs, words", [
    ({"mesh.nonsense_um": {"distribution": "uniform", "lower": 1, "upper": 2}}, {},
     ["mesh.nonsense_um"]),
    ({"mesh.backlash_um": {"distribution": "normal", "mean": 100, "std": 30}}, {},
     ["inputs.mesh.backlash_um", "reaches", "Truncate"]),
    ({"model.form": {"distribution": "uniform", "lower": 1, "upper": 2}}, {},
     ["model.form"]),
    ({"mesh.backlash_um": {"distribution": "gamma", "k": 2}}, {},
     ["inputs.mesh.backlash_um.distribution", "gamma", "uniform"]),
    ({"mesh.backlash_um": {"distribution": "uniform", "lower": 80}}, {},
     ["inputs.mesh.backlash_um", "missing upper"]),
    # A key this case does not read would give every sample the same run.
    ({"model.zeta": {"distribution": "uniform", "lower": 0.01, "upper": 0.1}}, {},
     ["inputs.model.zeta: the study would vary a key this case does not read",
      "only \"nondimensional\" reads model.zeta"]),
    # A sweep analysis's key: unknown, or not read by the case.
    (INPUTS, {"analysis": {"kind": "sweep", "param": "speed.rpm", "values": [1, 2]}},
     ["analysis.param = 'speed.rpm'"]),
    (INPUTS, {"analysis": {"kind": "sweep", "param": "model.omega", "values": [1, 2]}},
     ["analysis.param = 'model.omega': the study would vary a key this case does not read"]),
    (INPUTS, {"method": "halton"}, ["method = 'halton'", "lhs"]),
    (INPUTS, {"samples": 0}, ["samples = 0"]),
    (INPUTS, {"executor": "tcp://127.0.0.1:9"}, ["cannot reach the Dask scheduler"]),
])
def test_bad_input_is_named_and_nothing_is_written(tmp_path, inputs, kwargs, words):
    store = tmp_path / "store"
    args = dict(samples=4, method="lhs", store=store)
    args.update(kwargs)
    with pytest.raises(ValueError) as e:
        geardyn.study(CASE, inputs, **args)
    for w in words:
        assert w in str(e.value), str(e.value)
    assert not store.exists()


@pytest.mark.parametrize("text, words", [
    ("my notes", "study.json there is no study's record"),
    ('{"fingerprint": "another"}', "it holds another study"),
])
def test_a_store_that_holds_no_record_of_this_study_is_left_as_it_is(tmp_path, text, words):
    store = tmp_path / "store"
    store.mkdir()
    (store / "study.json").write_text(text)
    with pytest.raises(ValueError, match=f"store {store}: ") as e:
        geardyn.study(CASE, INPUTS, samples=4, store=store)
    assert words in str(e.value), str(e.value)
    assert (store / "study.json").read_text() == text
    assert sorted(p.name for p in store.iterdir()) == ["study.json"]


def test_an_interrupted_study_resumes_with_only_the_missing_samples(tmp_path):
    full = geardyn.study(CASE, INPUTS, samples=12, seed=2, batch_size=3)
    assert full.attrs["samples_computed"] == 12
    store = tmp_path / "store"
    (tmp_path / "store").mkdir()
    (store / "mine.txt").write_text("mine")

    def stop_after_six(done, total):
        if done >= 6:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as e:
        geardyn.study(CASE, INPUTS, samples=12, seed=2, batch_size=3, store=store,
                      progress=stop_after_six)
    partial = e.value.result
    assert partial.attrs["samples_computed"] == 6
    stored = {f: f.stat().st_mtime_ns for f in (store / "batches").glob("samples_*.nc")}
    assert len(stored) == 2
    # The same study again without resume is refused; another study in the store too.
    with pytest.raises(ValueError, match="resume"):
        geardyn.study(CASE, INPUTS, samples=12, seed=2, store=store)
    with pytest.raises(ValueError, match="another study"):
        geardyn.study(CASE, INPUTS, samples=12, seed=3, store=store, resume=True)
    resumed = geardyn.study(CASE, INPUTS, samples=12, seed=2, batch_size=4, store=store,
                            resume=True)
    assert resumed.attrs["samples_computed"] == 6
    same_outputs(resumed, full)
    assert {f: f.stat().st_mtime_ns for f in stored} == stored  # not written again
    assert (store / "mine.txt").read_text() == "mine"
    # Each sample once across the store's files.
    covered = []
    for f in (store / "batches").glob("samples_*.nc"):
        first, last = (int(x) for x in f.stem.split("_")[1:3])
        covered += range(first, last + 1)
    assert sorted(covered) == list(range(12))


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c, distributed.Client(c) as client:
        yield client


def test_two_dask_workers_give_the_in_process_result_bit_for_bit(cluster, tmp_path):
    local = geardyn.study(CASE, INPUTS, samples=16, method="sobol", seed=4)
    for batch in (1, 5):
        dask = geardyn.study(CASE, INPUTS, samples=16, method="sobol", seed=4,
                             executor=cluster, batch_size=batch, store=tmp_path / str(batch))
        same_outputs(dask, local)
    # And through the scheduler's address, as geardyn-study --scheduler gives it.
    addr = cluster.scheduler.address
    same_outputs(geardyn.study(CASE, INPUTS, samples=16, method="sobol", seed=4,
                               executor=addr), local)


def test_a_maps_rows_as_dask_tasks_give_the_in_process_map_bit_for_bit(cluster):
    ks = geardyn.Case(model={"form": "nondimensional", "force_alternating": 0.02})
    omegas, zetas = np.linspace(0.8, 1.1, 7), [0.04, 0.05, 0.06]
    kw = dict(param2="model.zeta", values2=zetas, max_settle_periods=60)
    local = geardyn.sweep(ks, "model.omega", omegas, threads=1, **kw)
    seen = []
    dask = geardyn.sweep(ks, "model.omega", omegas, executor=cluster,
                         progress=lambda done, total: seen.append((done, total)) or True, **kw)

    def same(a, b):
        assert a.keys() == b.keys()
        for key, v in a.items():
            if isinstance(v, dict):
                same(v, b[key])
            elif isinstance(v, np.ndarray):
                assert v.dtype == b[key].dtype and np.array_equal(
                    v, b[key], equal_nan=v.dtype.kind == "f"), key
            else:
                assert v == b[key], key

    same(dict(dask), dict(local))
    assert len(dask["value"]) == 42 and seen[0] == (0, 42) and seen[-1] == (42, 42)
    assert [h["value2"] for h in dask["hysteresis"]] == sorted(h["value2"] for h in
                                                              dask["hysteresis"])
    # A one-dimensional sweep runs as one task, here through the scheduler's address.
    one = geardyn.sweep(ks, "model.omega", omegas, max_settle_periods=60)
    same(dict(geardyn.sweep(ks, "model.omega", omegas, max_settle_periods=60,
                            executor=cluster.scheduler.address)), dict(one))


def test_a_trains_map_reads_every_mesh_on_a_mesh_dimension_in_process_and_on_dask(cluster):
    # The idler train's two meshes swept in speed at two backlashes of the second: each mesh's columns are a
    # (points, meshes) array, the point's own statistics are the mesh read's, the Dataset has a
    # mesh dimension and the table each mesh's columns; the rows on Dask give the same map bit
    # for bit.
    c = geardyn.Case.from_toml(os.path.join(os.environ.get("GEARDYN_SOURCE_DIR", "."), "cases",
                                            "idler_train.toml"))
    kw = dict(direction="up", param2="train.mesh[1].backlash_um", values2=[30, 50], mesh="out")
    local = geardyn.sweep(c, "train.reference_speed_hz", [30, 50], threads=1, **kw)
    assert local["meshes"] == ["in", "out"] and local["mesh"] == "out"
    assert local["mesh_pp_delta_bar"].shape == (4, 2)
    np.testing.assert_array_equal(local["pp_delta_bar"], local["mesh_pp_delta_bar"][:, 1])
    assert np.all(local["mesh_pp_delta_bar"][:, 0] != local["mesh_pp_delta_bar"][:, 1])
    ds = local.to_xarray()
    assert ds["mesh_max_force_n"].dims == ("direction", "param2", "param", "mesh")
    assert ds["mesh_max_force_n"].attrs["units"] == "N"
    assert list(ds["mesh"].values) == ["in", "out"] and ds.attrs["mesh_read"] == "out"
    assert float(ds["mesh_max_force_n"].sel(mesh="in", param=50, param2=50)[0]) == \
        local["mesh_max_force_n"][3, 0]
    table = local.to_pandas()
    np.testing.assert_array_equal(table["out_pp_delta_bar"].values, table["pp_delta_bar"].values)
    dask = geardyn.sweep(c, "train.reference_speed_hz", [30, 50], executor=cluster, **kw)
    assert dask["meshes"] == local["meshes"] and dask["mesh_regime"] == local["mesh_regime"]
    for key in ("mesh_pp_delta_bar", "mesh_max_force_n", "mesh_impacts_per_period"):
        np.testing.assert_array_equal(dask[key], local[key], err_msg=key)
    with pytest.raises(geardyn.InputError, match='mesh = "middle": the train has no mesh'):
        geardyn.sweep(c, "train.reference_speed_hz", [30], mesh="middle")


def test_a_planetary_sets_load_sharing_per_point_and_per_sample(cluster):
    # The shipped stage swept in speed at two pin errors of planet 1: each load-sharing group's
    # factor is a (points, groups) array, on a group dimension of the Dataset and as
    # sweep.csv's columns in the table; the rows on Dask give the same bit for bit. A study over
    # the pin error keeps each group's factor per sample, the run's own reading.
    c = geardyn.Case.from_toml(os.path.join(os.environ.get("GEARDYN_SOURCE_DIR", "."), "cases",
                                            "planetary_set.toml"))
    kw = dict(direction="up", param2="train.planet_pin_errors_um[0][1]", values2=[0, 20],
              measure_periods=2)
    local = geardyn.sweep(c, "train.reference_speed_hz", [10, 20], threads=1, **kw)
    assert local["load_sharing"] == ["sun", "ring"]
    assert local["load_sharing_factor"].shape == (4, 2)
    even, off = local["load_sharing_factor"][:2], local["load_sharing_factor"][2:]
    assert np.all(np.abs(even - 1) < 2e-3) and np.all(off > 1.08)
    assert np.all(local["lost_contact"] == 0)
    ds = local.to_xarray()
    assert ds["load_sharing_factor"].dims == ("direction", "param2", "param", "group")
    assert list(ds["group"].values) == ["sun", "ring"]
    assert float(ds["load_sharing_factor"].sel(group="ring", param=20, param2=20)[0]) == \
        local["load_sharing_factor"][3, 1]
    table = local.to_pandas()
    np.testing.assert_array_equal(table["sun_load_sharing_factor"].values,
                                  local["load_sharing_factor"][:, 0])
    dask = geardyn.sweep(c, "train.reference_speed_hz", [10, 20], executor=cluster, **kw)
    assert dask["load_sharing"] == local["load_sharing"]
    np.testing.assert_array_equal(dask["load_sharing_factor"], local["load_sharing_factor"])
    # A bearing clearance's columns over a dimension `clearance`.
    loose = geardyn.sweep(c.with_({"train.bearing[0].clearance_um": 5}),
                          "train.body[0].eccentricity_um", [0, 10], direction="up",
                          measure_periods=2, threads=1)
    assert loose["clearances"] == ["sun_bearing_x", "sun_bearing_y"]
    cd = loose.to_xarray()["clearance_impacts_per_period"]
    assert cd.dims == ("direction", "param", "clearance")
    assert float(cd.sel(param=0, clearance="sun_bearing_x")[0]) == 0
    assert float(cd.sel(param=10, clearance="sun_bearing_x")[0]) > 0
    assert "sun_bearing_y_inside_fraction" in loose.to_pandas()
    short = c.with_({"solver.duration_s": 0.002})
    st = geardyn.study(short, {"train.planet_pin_errors_um[0][1]": {
                           "distribution": "uniform", "lower": 0, "upper": 30}},
                       samples=3, seed=1, outputs=["sun.load_sharing_static_factor",
                                                   "sun.load_sharing_factor_with_startup"])
    for i in range(3):
        err = float(st["train.planet_pin_errors_um[0][1]"][i])
        r = geardyn.run(short.with_({"train.planet_pin_errors_um[0][1]": err}))
        assert float(st["sun.load_sharing_static_factor"][i]) == \
            r.summary["load_sharing"][0]["static_factor"]
    assert st["sun.load_sharing_static_factor"].attrs["units"] == "1"


def test_a_worker_killed_mid_study_has_its_samples_computed_elsewhere(cluster, tmp_path):
    local = geardyn.study(CASE, INPUTS, samples=40, seed=5)
    killed = []

    def kill_one(done, total):
        if done >= 4 and not killed:
            worker = sorted(cluster.scheduler_info()["workers"])[0]
            killed.append(worker)
            def kill():
                try:
                    cluster.run(os._exit, 1, workers=[worker])
                except OSError:  # the worker dies before it answers
                    pass
            threading.Thread(target=kill, daemon=True).start()

    ds = geardyn.study(CASE, INPUTS, samples=40, seed=5, executor=cluster, batch_size=2,
                       store=tmp_path / "s", progress=kill_one)
    assert killed
    same_outputs(ds, local)
    covered = []
    for f in (tmp_path / "s" / "batches").glob("samples_*.nc"):
        first, last = (int(x) for x in f.stem.split("_")[1:3])
        covered += range(first, last + 1)
    assert sorted(covered) == list(range(40))


# The contact natural frequency f_n = C sqrt(k_m / w): the equivalent mass is proportional to
# the face width w (the blanks' inertias), so its statistics and Sobol' indices over uniform
# k_m and w are closed forms (docs/studies.md).
K = (1.8e8, 2.8e8)
W = (15.0, 25.0)
NATURAL = geardyn.Case.default().set("solver.duration_s", 1e-4)


def natural_frequency_constant():
    r = geardyn.run(NATURAL)
    return r.summary["derived"]["natural_frequency_hz"] / np.sqrt(
        NATURAL["mesh.mean_stiffness_n_per_m"] / NATURAL["gear.face_width_mm"])


def uniform_moments():
    (a, b), (c, d) = K, W
    e_sqrt_k = 2 / 3 * (b ** 1.5 - a ** 1.5) / (b - a)
    e_k = (a + b) / 2
    e_isqrt_w = 2 * (np.sqrt(d) - np.sqrt(c)) / (d - c)
    e_iw = np.log(d / c) / (d - c)
    return e_sqrt_k, e_k, e_isqrt_w, e_iw


INPUTS_KW = {"mesh.mean_stiffness_n_per_m": {"distribution": "uniform", "lower": K[0],
                                             "upper": K[1]},
             "gear.face_width_mm": {"distribution": "uniform", "lower": W[0], "upper": W[1]}}


def test_statistics_of_an_analytic_output_hold_their_exact_values_and_shrink_as_one_over_sqrt_n():
    C = natural_frequency_constant()
    e_sqrt_k, _, e_isqrt_w, _ = uniform_moments()
    exact_mean = C * e_sqrt_k * e_isqrt_w
    half = {}
    for n in (64, 256):
        ds = geardyn.study(NATURAL, INPUTS_KW, samples=n, method="monte_carlo", seed=11)
        s = geardyn.statistics(ds, ["natural_frequency_hz"])["natural_frequency_hz"]
        lo, hi = s["mean_interval"]
        assert lo < exact_mean < hi, (n, lo, exact_mean, hi)
        half[n] = (hi - lo) / 2
    assert 1.6 < half[64] / half[256] < 2.5  # sqrt(256 / 64) = 2
    # Quantiles with one input: f_q = C sqrt(k_q / w), k_q = a + q (b - a).
    one = geardyn.study(NATURAL, {"mesh.mean_stiffness_n_per_m": INPUTS_KW[
        "mesh.mean_stiffness_n_per_m"]}, samples=200, method="monte_carlo", seed=3)
    s = geardyn.statistics(one, ["natural_frequency_hz"],
                           limits={"natural_frequency_hz": 2600.0})["natural_frequency_hz"]
    w = NATURAL["gear.face_width_mm"]
    for q, (value, (lo, hi)) in s["quantiles"].items():
        exact = C * np.sqrt((K[0] + q * (K[1] - K[0])) / w)
        assert lo <= exact <= hi, (q, lo, exact, hi)
    # P(f_n > 2600 Hz) = P(k > w (2600 / C)^2).
    p = (K[1] - w * (2600.0 / C) ** 2) / (K[1] - K[0])
    prob, (lo, hi) = s["exceedance"][2600.0]
    assert lo <= p <= hi, (lo, p, hi)


def test_sobol_indices_of_an_analytic_output_hold_their_exact_values():
    C = natural_frequency_constant()
    e_sqrt_k, e_k, e_isqrt_w, e_iw = uniform_moments()
    var = C ** 2 * (e_k * e_iw - e_sqrt_k ** 2 * e_isqrt_w ** 2)
    v_k = C ** 2 * (e_k - e_sqrt_k ** 2) * e_isqrt_w ** 2
    v_w = C ** 2 * e_sqrt_k ** 2 * (e_iw - e_isqrt_w ** 2)
    exact = {"mesh.mean_stiffness_n_per_m": (v_k / var, 1 - v_w / var),
             "gear.face_width_mm": (v_w / var, 1 - v_k / var)}
    ds = geardyn.study(NATURAL, INPUTS_KW, samples=300, method="saltelli", seed=1)
    assert ds.sizes["sample"] == 300 * 4
    idx = geardyn.sobol_indices(ds, "natural_frequency_hz")
    for k, (first, total) in exact.items():
        for which, value in (("first", first), ("total", total)):
            est, (lo, hi) = idx[k][which]
            assert lo <= value <= hi, (k, which, lo, value, hi)
    with pytest.raises(ValueError, match="saltelli"):
        geardyn.sobol_indices(geardyn.study(NATURAL, INPUTS_KW, samples=4), "natural_frequency_hz")


def study_command(tmp_path, head):
    """`geardyn-study` of a study file with `head` and one input, the backlash, into OUT."""
    import sys

    spec = tmp_path / "s.toml"
    spec.write_text(head + '\n[inputs."mesh.backlash_um"]\ndistribution = "uniform"\n'
                    'lower = 80\nupper = 120\n')
    out = tmp_path / "out"
    return [sys.executable, "-m", "geardyn._study_cli", str(spec), "--out", str(out)], out


def test_the_study_command_writes_its_store_data_and_a_report_that_renders(tmp_path):
    import subprocess
    import sys

    cmd, out = study_command(tmp_path, 'samples = 12\nmethod = "lhs"\nseed = 1\n[set]\n'
                             '"solver.duration_s" = 0.004\n[limits]\nrattle = 0.5')
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "12 samples (12 computed now, 0 failed)" in r.stdout
    r2 = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert r2.returncode == 0 and "(0 computed now" in r2.stdout, r2.stdout + r2.stderr
    import xarray as xr
    with xr.open_dataset(out / "study.nc") as ds:
        assert ds.sizes["sample"] == 12 and "rattle" in ds
    # Rendered by a real browser: plotly's script ran (its SVG is in the page), no error.
    page = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                           "--enable-logging=stderr", "--v=0", "--dump-dom",
                           (out / "report.html").as_uri()], capture_output=True, text=True,
                          timeout=120)
    assert page.returncode == 0
    assert page.stdout.count('class="main-svg"') >= 3
    assert "Uncaught" not in page.stderr
    assert "id=\"statistics\"" in page.stdout or "id='statistics'" in page.stdout
    # Bad input: a key the study file does not have, named; exit 2; nothing written.
    bad = tmp_path / "bad.toml"
    bad.write_text("samples = 4\nsample_count = 3\n")
    r3 = subprocess.run([sys.executable, "-m", "geardyn._study_cli", str(bad), "--out",
                         str(tmp_path / "bad")], capture_output=True, text=True)
    assert r3.returncode == 2 and "sample_count: not a study key" in r3.stderr, r3.stderr
    assert not (tmp_path / "bad").exists()
    # A report of the user's under our name: refused before any work, the folder as it was;
    # once geardyn's own report is changed by the user, the same.
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.html").write_text("my report")
    r4 = subprocess.run(cmd[:-1] + [str(mine)], capture_output=True, text=True)
    assert r4.returncode == 2, r4.stderr
    assert f"--out {mine}: report.html there not written by geardyn" in r4.stderr, r4.stderr
    assert sorted(p.name for p in mine.iterdir()) == ["report.html"]
    assert (mine / "report.html").read_text() == "my report"
    with open(out / "report.html", "a") as f:
        f.write("<!-- my note -->")
    r5 = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert r5.returncode == 2 and "report.html there not written by geardyn" in r5.stderr
    assert (out / "report.html").read_text().endswith("<!-- my note -->")


def test_a_trains_element_key_is_an_input_and_each_mesh_is_read():
    c = geardyn.Case.from_toml(os.path.join(os.environ.get("GEARDYN_SOURCE_DIR", "."), "cases",
                                            "loose_gear_rattle.toml"))
    c.set("solver.duration_s", 0.05)
    ds = geardyn.study(c, {"train.drag[0].constant_nm": {"distribution": "uniform",
                                                          "lower": 0.1, "upper": 0.4}},
                       samples=4, seed=1)
    assert ds["train.drag[0].constant_nm"].attrs["units"] == "N m"
    assert ds["rattle.impacts"].attrs["long_name"] == "rattle: impacts in the window"
    # Each sample's reading is that of its own run.
    for i in (0, 3):
        r = geardyn.run(c.with_({"train.drag[0].constant_nm":
                                 float(ds["train.drag[0].constant_nm"][i])}))
        assert ds["rattle.impacts"][i] == r.summary["meshes"][0]["impacts"]


def test_a_clutch_dampers_key_is_an_input_and_its_run_is_read_as_any_element():
    # The loose gear behind a clutch damper: its idle spring an input; each sample's reading is
    # its own run's, whose result names the damper's torque and twist.
    c = geardyn.Case.from_toml(os.path.join(os.environ.get("GEARDYN_SOURCE_DIR", "."), "cases",
                                            "loose_gear_damper.toml")).with_(
        {"solver.duration_s": 0.2})
    key = "train.damper[0].free_play_stiffness_n_m_per_rad"
    ds = geardyn.study(c, {key: {"distribution": "uniform", "lower": 1.5, "upper": 3}},
                       samples=3, seed=4)
    for i in range(3):
        r = geardyn.run(c.with_({key: float(ds[key][i])}))
        assert ds["rattle.impacts"][i] == r.summary["meshes"][0]["impacts"]
        assert r.joints == ["clutch"]
        twist = r.theta[:, r.bodies.index("engine")] - r.theta[:, r.bodies.index("input")]
        np.testing.assert_allclose(r.joint_deformation[:, 0], twist, rtol=0, atol=1e-12)


def test_a_trains_study_on_two_dask_workers_is_the_in_process_one_bit_for_bit(cluster):
    # A train's samples run in the library's batch on the workers as in this process.
    c = geardyn.Case.from_toml(os.path.join(os.environ.get("GEARDYN_SOURCE_DIR", "."), "cases",
                                            "loose_gear_rattle.toml")).with_(
        {"solver.duration_s": 0.05})
    inputs = {"train.drag[0].constant_nm": {"distribution": "uniform", "lower": 0.1,
                                            "upper": 0.4}}
    local = geardyn.study(c, inputs, samples=6, seed=2)
    dask = geardyn.study(c, inputs, samples=6, seed=2, executor=cluster, batch_size=2)
    assert "rattle.impacts" in local and local["rattle.rattle"].sum() > 0
    for k in local.data_vars:
        if k != "failure":
            np.testing.assert_array_equal(dask[k].values, local[k].values, err_msg=k)


def test_a_samples_readings_are_those_of_its_own_run():
    # The gear pair's samples go to the library in one call per batch, with the stiffness
    # shared: each sample's readings equal, to the last bit, geardyn.run's of its own case.
    ds = geardyn.study(CASE.with_({"mesh.stiffness_source": "energy"}), INPUTS, samples=5,
                       seed=9, batch_size=5)
    for i in range(5):
        r = geardyn.run(CASE.with_({"mesh.stiffness_source": "energy"})
                        .with_({k: float(ds[k][i]) for k in INPUTS}))
        s = r.summary
        expected = {k: s[k] for k in ("impacts", "backside_impacts", "separations",
                                      "separated_fraction", "max_force_bar", "max_delta_bar",
                                      "max_impact_velocity_m_s", "dynamic_factor",
                                      "dynamic_factor_with_startup")}
        expected["rattle"] = 1.0 if s["regime"] == "sustained" else 0.0
        expected["natural_frequency_hz"] = s["derived"]["natural_frequency_hz"]
        for k, v in expected.items():
            np.testing.assert_equal(float(ds[k][i]), np.nan if v is None else float(v),
                                    err_msg=f"sample {i}: {k}")


def test_every_forms_samples_go_to_the_library_and_read_as_their_own_runs():
    # The non-dimensional form (its velocity in b w_n; no natural frequency, its unit of time)
    # and the coupled pair (its train's mesh "mesh") run in the library's batch as the gear
    # pair does: each sample's readings are those of geardyn.run of its own case, bit for bit.
    src = os.environ.get("GEARDYN_SOURCE_DIR", ".")
    ks = geardyn.Case.from_toml(os.path.join(src, "cases", "kahraman_singh.toml"))
    inputs = {"model.force_alternating": {"distribution": "uniform", "lower": 0.05,
                                          "upper": 0.15}}
    ds = geardyn.study(ks, inputs, samples=3, seed=3)
    assert "natural_frequency_hz" not in ds and "max_impact_velocity_m_s" not in ds
    for i in range(3):
        s = geardyn.run(ks.with_({"model.force_alternating":
                                  float(ds["model.force_alternating"][i])})).summary
        for k in ("impacts", "separated_fraction", "max_force_bar", "max_delta_bar",
                  "max_impact_velocity", "dynamic_factor", "dynamic_factor_with_startup"):
            assert float(ds[k][i]) == s[k], (i, k)
        assert float(ds["rattle"][i]) == (s["regime"] == "sustained")
    assert ds["max_impact_velocity"].attrs["units"] == "1"
    coupled = geardyn.Case.from_toml(os.path.join(src, "cases", "park2010_coupled.toml")) \
        .with_({"solver.duration_s": 0.004})
    dc = geardyn.study(coupled, {"mesh.backlash_um": {"distribution": "uniform", "lower": 80,
                                                      "upper": 120}}, samples=2, seed=4)
    for i in range(2):
        m = geardyn.run(coupled.with_({"mesh.backlash_um": float(dc["mesh.backlash_um"][i])})) \
            .summary["meshes"][0]
        for k in ("impacts", "separations", "separated_fraction", "max_force_n",
                  "dynamic_factor", "dynamic_factor_with_startup"):
            np.testing.assert_equal(float(dc["mesh." + k][i]),
                                    np.nan if m[k] is None else m[k], err_msg=f"{i} {k}")


def test_ctrl_c_inside_a_batch_keeps_the_samples_it_completed(tmp_path, monkeypatch):
    # Ctrl-C while a batch of 5 runs its third sample: the two done are stored and kept in the
    # result; resuming computes the other ten alone and gives the uninterrupted study.
    from geardyn import _geardyn

    full = geardyn.study(CASE, INPUTS, samples=12, seed=6, batch_size=5)
    batch = _geardyn._run_batch
    calls = []

    def stopped_at_third(case, keys, rows, progress=None):
        def stop(done, total):
            if done == 2:
                raise KeyboardInterrupt
        calls.append(len(rows))
        return batch(case, keys, rows, stop)

    monkeypatch.setattr(_geardyn, "_run_batch", stopped_at_third)
    with pytest.raises(KeyboardInterrupt) as e:
        geardyn.study(CASE, INPUTS, samples=12, seed=6, batch_size=5, store=tmp_path / "s")
    assert calls == [5]
    assert e.value.result.attrs["samples_computed"] == 2
    assert [f.name for f in (tmp_path / "s" / "batches").iterdir()] == ["samples_00000000_00000001.nc"]
    monkeypatch.setattr(_geardyn, "_run_batch", batch)
    resumed = geardyn.study(CASE, INPUTS, samples=12, seed=6, batch_size=5,
                            store=tmp_path / "s", resume=True)
    assert resumed.attrs["samples_computed"] == 10
    same_outputs(resumed, full)


def test_the_outputs_kept_are_those_named():
    ds = geardyn.study(CASE, INPUTS, samples=3, outputs=["rattle", "dynamic_factor"])
    assert set(ds.data_vars) == set(INPUTS) | {"rattle", "dynamic_factor", "failure"}
    with pytest.raises(ValueError, match="dynamic_factr: not an output"):
        geardyn.study(CASE, INPUTS, samples=3, outputs=["dynamic_factr"])


def test_the_analysis_is_taken_as_a_user_writes_it():
    by_name = geardyn.study(CASE, INPUTS, samples=2, analysis="run", outputs=["rattle"])
    by_dict = geardyn.study(CASE, INPUTS, samples=2, analysis={"kind": "run"}, outputs=["rattle"])
    assert by_name.identical(by_dict)
    with pytest.raises(geardyn.StudyError, match=r"analysis = \['run'\]: must be the analysis's kind"):
        geardyn.study(CASE, INPUTS, samples=2, analysis=["run"])


def test_a_sweep_study_reads_each_samples_frequency_response():
    values = list(np.linspace(1500, 3500, 11))
    analysis = {"kind": "sweep", "param": "speed.shaft_frequency_hz", "values": values}
    case = geardyn.Case.default()
    ds = geardyn.study(case, {"mesh.backlash_um": [80, 120]}, method="grid", analysis=analysis)
    for i, b in enumerate((80, 120)):
        s = geardyn.sweep(case.with_({"mesh.backlash_um": b}), analysis["param"], values)
        f = np.asarray(s["max_force_bar"])
        assert ds["peak_max_force_bar"][i] == f.max()
        assert ds["peak_at"][i] == np.asarray(s["value"])[f.argmax()]
        assert ds["jumps"][i] == len(s["jumps"])
        rattling = np.asarray(s["value"])[np.asarray(s["impacts_per_period"]) > 0]
        assert ds["rattle_from"][i] == rattling.min() and ds["rattle_to"][i] == rattling.max()


def test_ctrl_c_stops_the_study_command_keeping_the_store_and_resume_completes_it(tmp_path):
    import signal
    import subprocess
    import time

    cmd, out = study_command(tmp_path, 'samples = 400\nbatch_size = 4\n[set]\n'
                             '"solver.duration_s" = 0.02')
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    batches = out / "store" / "batches"
    deadline = time.time() + 60
    while time.time() < deadline and len(list(batches.glob("samples_*.nc"))) < 2:
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "--resume continues" in err
    files = list(batches.glob("samples_*.nc"))
    assert sorted(f.name for f in batches.iterdir() if not f.name.startswith("samples_")) == []
    assert 2 <= len(files) < 100
    # The samples kept: whole batches, and those of the batch Ctrl-C stopped that completed.
    kept = sum(int(f.stem.split("_")[2]) - int(f.stem.split("_")[1]) + 1 for f in files)
    assert not (out / "study.nc").exists()
    r = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"({400 - kept} computed now" in r.stdout, r.stdout


def test_a_killed_scheduler_stops_the_study_command_keeping_the_store_and_resume_completes_it(
        tmp_path):
    import json
    import subprocess
    import sys
    import time

    # A scheduler and a worker of their own, as on a cluster; the scheduler is killed once two
    # batches are stored.
    info = tmp_path / "scheduler.json"
    python = [sys.executable, "-m"]  # the test's interpreter, which imports geardyn
    scheduler = subprocess.Popen(
        python + ["distributed.cli.dask_scheduler", "--scheduler-file", str(info), "--port", "0",
                  "--dashboard-address", ":0", "--no-show"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = None
    try:
        deadline = time.time() + 60
        address = None
        while address is None and time.time() < deadline:
            try:
                address = json.loads(info.read_text())["address"]
            except (OSError, ValueError, KeyError):  # not written yet
                time.sleep(0.05)
        worker = subprocess.Popen(
            python + ["distributed.cli.dask_worker", "--scheduler-file", str(info),
                      "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cmd, out = study_command(tmp_path, 'samples = 40\nbatch_size = 2\n[set]\n'
                                 '"solver.duration_s" = 0.02')
        # The client gives up on a lost scheduler after its reconnection timeout (Dask's
        # default 30 s; 2 s here).
        env = dict(os.environ, DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="2s")
        p = subprocess.Popen(cmd + ["--scheduler", address], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env)
        batches = out / "store" / "batches"
        while time.time() < deadline and len(list(batches.glob("samples_*.nc"))) < 2:
            time.sleep(0.05)
        scheduler.kill()
        _, err = p.communicate(timeout=120)
    finally:
        for proc in (scheduler, worker):
            if proc is not None:
                proc.kill()
                proc.wait()
    assert p.returncode == 1, err
    assert "the Dask executor failed" in err and "--resume continues" in err, err
    kept = len(list(batches.glob("samples_*.nc")))
    assert 2 <= kept < 20
    assert not (out / "study.nc").exists()
    r = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"({40 - 2 * kept} computed now" in r.stdout, r.stdout


def test_a_grid_value_the_key_refuses_is_named_before_any_sample_runs(tmp_path):
    with pytest.raises(ValueError, match=r"inputs.mesh.backlash_um = -5"):
        geardyn.study(CASE, {"mesh.backlash_um": [50, -5]}, method="grid",
                      store=tmp_path / "s")
    assert not (tmp_path / "s").exists()
