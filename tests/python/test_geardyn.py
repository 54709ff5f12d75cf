"""geardyn from Python: the same results as the command line, zero-copy arrays, errors as
exceptions, the GIL released, and the example."""
import json
import math
import os
import pathlib
import pickle
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import geardyn

CLI = os.environ["GEARDYN_CLI"]
SOURCE = pathlib.Path(os.environ["GEARDYN_SOURCE_DIR"])


def cli(*args, check=True):
    return subprocess.run([CLI, *args], capture_output=True, text=True, check=check)


def test_run_gives_the_command_lines_results(tmp_path):
    cli("run", str(SOURCE / "cases/park2010.toml"), "--set", "speed.shaft_frequency_hz=100",
        "--set", "solver.duration_s=0.02", "--out", str(tmp_path / "cli"))
    case = geardyn.Case.from_toml(SOURCE / "cases/park2010.toml")
    case.set("speed.shaft_frequency_hz", 100).set("solver.duration_s", 0.02)
    r = geardyn.run(case)
    r.write(str(tmp_path / "py"))
    for name in ("timeseries.csv", "events.csv", "case.toml"):
        assert (tmp_path / "py" / name).read_text() == (tmp_path / "cli" / name).read_text(), name
    from_cli = json.loads((tmp_path / "cli" / "summary.json").read_text())
    for key, value in from_cli.items():
        if key != "wall_time_s":
            assert r.summary[key] == value, key
    assert r.summary["regime"] == "transient"


def test_arrays_point_into_the_result_without_copies():
    case = geardyn.Case.default().set("solver.duration_s", 0.005)
    r = geardyn.run(case)
    for name in ("t", "delta_bar", "force_bar", "velocity", "contact"):
        a = getattr(r, name)
        assert not a.flags.owndata, name
        assert np.shares_memory(a, getattr(r, name)), name  # the same buffer every time
        assert len(a) == len(r.t)
    assert r.contact.dtype == np.int32
    delta = r.delta_bar
    del r  # the array keeps the result alive
    assert np.isfinite(delta).all()


def test_errors_are_exceptions_with_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[mesh]\nbacklash_um = -5\n")
    with pytest.raises(geardyn.InputError) as e:
        geardyn.Case.from_toml(bad)
    out = cli("run", str(bad), check=False)
    assert out.returncode == 2
    assert out.stderr.strip() == "geardyn: error: " + str(e.value)
    with pytest.raises(ValueError, match="unknown key 'speed.rpm'"):
        geardyn.Case.default().set("speed.rpm", 3)
    with pytest.raises(geardyn.InputError, match="direction"):
        geardyn.sweep(geardyn.Case.default(), "model.omega", [1.0], direction="sideways")


def test_numerical_failure_is_an_exception():
    case = geardyn.Case.default().set("load.torque_nm", 1e307).set("load.fluctuation_ratio", 1e300)
    with pytest.raises(geardyn.NumericalError, match="non-finite"):
        geardyn.run(case)


def test_geometry_and_stiffness_match_the_command_line():
    case = geardyn.Case.default()
    assert geardyn.geometry(case) == json.loads(cli("geometry", "--json").stdout)
    s = geardyn.stiffness(case)
    assert {k: v for k, v in s.items() if k != "cycle"} == json.loads(
        cli("stiffness", "--json").stdout)
    assert len(s["cycle"]["position"]) == 256
    assert s["cycle"]["total_n_per_m"].mean() == pytest.approx(s["energy"]["mean_n_per_m"])
    # A train's mesh: its gear pair, as --mesh reads it (the default [gear] is no train's).
    reducer = SOURCE / "cases" / "two_stage_reducer.toml"
    train = geardyn.Case.from_toml(reducer)
    stage2 = geardyn.geometry(train, mesh="stage2")
    assert stage2 == json.loads(cli("geometry", str(reducer), "--mesh", "stage2", "--json").stdout)
    assert stage2 != geardyn.geometry(train)
    s2 = geardyn.stiffness(train, mesh="stage2")
    assert {k: v for k, v in s2.items() if k != "cycle"} == json.loads(
        cli("stiffness", str(reducer), "--mesh", "stage2", "--json").stdout)
    with pytest.raises(geardyn.InputError, match="the train has no mesh of that name"):
        geardyn.stiffness(train, mesh="stage3")
    with pytest.raises(geardyn.InputError, match="names a gear train's mesh"):
        geardyn.geometry(case, mesh="stage2")
    # An internal mesh: its pinion in its ring, as --mesh reads it; it has no external geometry.
    turbine = SOURCE / "cases" / "wind_turbine_grc750.toml"
    wt = geardyn.Case.from_toml(turbine)
    ring = geardyn.stiffness(wt, mesh="ring_planet1")
    assert {k: v for k, v in ring.items() if k != "cycle"} == json.loads(
        cli("stiffness", str(turbine), "--mesh", "ring_planet1", "--json").stdout)
    with pytest.raises(geardyn.InputError, match="is internal: its geometry is no external"):
        geardyn.geometry(wt, mesh="ring_planet1")


def test_sweep_returns_columns_and_finds_the_jump():
    case = geardyn.Case.default().set("model.form", "nondimensional")
    case.set("model.zeta", 0.05).set("model.force_mean", 0.1).set("model.force_alternating", 0.1)
    case.set("solver.initial", "static")
    s = geardyn.sweep(case, param="model.omega", values=np.linspace(0.3, 1.5, 61))
    assert isinstance(s["rms_force_bar"], np.ndarray)
    assert len(s["value"]) == 122 and s["direction"].count("up") == 61
    assert any(j["direction"] == "up" for j in s["jumps"])
    # Each sequence's first point with impacts, as the command line prints it, and how the
    # points were judged steady.
    assert [x["direction"] for x in s["impact_onsets"]] == ["up", "down"]
    for onset in s["impact_onsets"]:
        mine = [i for i, d in enumerate(s["direction"]) if d == onset["direction"]]
        first = next(i for i in mine if s["impacts_per_period"][i] > 0)
        assert s["value"][first] == onset["value"]
    assert "predicted distance to the periodic response" in s["steadiness"]


def test_the_gil_is_released_during_a_run():
    case = (geardyn.Case.default().set("solver.method", "newmark")
            .set("solver.time_step_s", 1e-9).set("solver.duration_s", 0.01))
    done = threading.Event()
    worker = threading.Thread(target=lambda: (geardyn.run(case), done.set()))
    ticks = 0
    worker.start()
    while not done.is_set():
        ticks += 1  # the main thread runs Python while the run integrates
        time.sleep(0.001)
    worker.join()
    assert ticks > 20


def test_plots(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    r = geardyn.run(geardyn.Case.default().set("solver.duration_s", 0.005))
    geardyn.plot.run(r).savefig(tmp_path / "run.png")
    # The phase portrait: delta / b against delta', the steady part over the whole run.
    fig = geardyn.plot.phase(r)
    whole, steady = fig.axes[0].get_lines()[:2]
    part = r.t >= r.summary["steady"]["from_s"]
    assert 0 < part.sum() < len(r.t)
    assert np.array_equal(whole.get_xdata(), r.delta_bar)
    assert np.array_equal(whole.get_ydata(), r.velocity)
    assert np.array_equal(steady.get_xdata(), r.delta_bar[part])
    assert np.array_equal(steady.get_ydata(), r.velocity[part])
    assert fig.axes[0].get_ylabel() == "delta' (m/s)"
    s = geardyn.sweep(geardyn.Case.default().set("model.form", "nondimensional"), "model.omega",
                      [0.8, 1.0, 1.2])
    geardyn.plot.frequency_response(s, "Omega").savefig(tmp_path / "fr.png")
    assert (tmp_path / "run.png").stat().st_size > 1000
    assert (tmp_path / "fr.png").stat().st_size > 1000


def test_a_run_figure_shows_only_what_happened():
    import matplotlib
    matplotlib.use("Agg")

    def labels(case):
        legend = geardyn.plot.run(geardyn.run(case)).axes[0].get_legend()
        return [] if legend is None else [t.get_text() for t in legend.get_texts()]

    assert labels(geardyn.Case(solver={"duration_s": 0.005})) == ["separated"]
    # In permanent contact from the start: nothing shaded, no legend.
    assert labels(geardyn.Case(solver={"duration_s": 0.002, "initial": "static"},
                               load={"fluctuation_ratio": 0.0})) == []


def test_a_coupled_run_figure_is_its_trains(tmp_path):
    # A coupled case runs as its train form: its figure is a train's, the mesh, then its shafts
    # and bearings, each named as the train names them.
    import matplotlib
    matplotlib.use("Agg")
    path = SOURCE / "cases/park2010_coupled.toml"
    case = geardyn.Case.from_toml(path).with_({"solver.duration_s": 0.005,
                                               "shafts.end_inertia_kg_m2": [0.0, 0.3]})
    r = geardyn.run(case)
    fig = geardyn.plot.run(r)  # dispatches on the result
    legends = [t.get_text() for a in fig.axes if a.get_legend()
               for t in a.get_legend().get_texts()]
    assert any("load_shaft" in x for x in legends), legends
    assert not any("drive_shaft" in x for x in legends), legends
    assert any("pinion_bearing" in x for x in legends), legends
    # The helical pair with dof 12 moves along its axis: its bearings' axial forces, last.
    assert [a.get_title() for a in fig.axes if a.get_title()][-1] == "axial bearing forces"
    assert legends[-2:] == ["bearing pinion_bearing axial (N)", "bearing wheel_bearing axial (N)"]
    planar = geardyn.plot.run(geardyn.run(case.with_({"model.dof": 3})))
    assert "axial bearing forces" not in [a.get_title() for a in planar.axes]


def test_the_example_reproduces_fig4c(tmp_path):
    out = subprocess.run([sys.executable, str(SOURCE / "examples/reproduce_fig4c.py"), "--out",
                          str(tmp_path / "fig4c.png")], capture_output=True, text=True,
                         check=True)
    assert "regime sustained" in out.stdout
    assert (tmp_path / "fig4c.png").stat().st_size > 10000


def test_version_is_the_command_lines():
    out = cli("--version")
    assert out.stdout.strip() == f"geardyn {geardyn.__version__}"


def test_a_missing_numpy_gives_a_clear_import_error():
    code = "import sys; sys.modules['numpy'] = None; import geardyn"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode != 0
    assert "geardyn needs NumPy" in out.stderr
    assert "--system-site-packages" in out.stderr


def test_a_case_is_built_read_and_copied_the_python_way():
    c = geardyn.Case(speed={"shaft_frequency_hz": 100}, **{"mesh.backlash_um": 150})
    assert c["speed.shaft_frequency_hz"] == 100
    assert c["mesh.backlash_um"] == 150
    assert c == geardyn.Case.from_dict({"speed.shaft_frequency_hz": 100,
                                        "mesh": {"backlash_um": 150}})
    assert c != geardyn.Case()
    d = c.with_({"solver.method": "dopri5"})  # text bare, a copy: c is left as it was
    assert d["solver.method"] == "dopri5" and c["solver.method"] == "exact"
    assert geardyn.Case.from_dict(c.to_dict()) == c  # the dict round trip
    h = c.with_(mesh={"stiffness_source": "harmonics", "stiffness_harmonics": [[0.1, 30]]})
    assert h["mesh.stiffness_harmonics[0][1]"] == 30
    with pytest.raises(KeyError, match="speed.rpm"):
        c["speed.rpm"]
    with pytest.raises(geardyn.InputError, match="mesh.backlash_um"):
        geardyn.Case(mesh={"backlash_um": -1})
    with pytest.raises(TypeError):
        {c}  # equal cases compare by value, so a case is not hashable


def test_a_case_pickles_exactly():
    import pickle

    c = geardyn.Case.from_toml(SOURCE / "cases/park2010.toml").with_(
        {"speed.shaft_frequency_hz": 1234.5678901234567})
    back = pickle.loads(pickle.dumps(c))
    assert back == c
    assert back.name == c.name and back.directory == c.directory
    assert back["speed.shaft_frequency_hz"] == 1234.5678901234567
    r1, r2 = geardyn.run(c.with_({"solver.duration_s": 0.002})), \
        geardyn.run(back.with_({"solver.duration_s": 0.002}))
    assert np.array_equal(r1.delta_bar, r2.delta_bar)


def test_a_run_pickles_exactly_and_writes_the_same_files(tmp_path):
    import pickle

    # A run with impacts and separations (events, a last separation, a dynamic factor) and a
    # transmission error, one in the non-dimensional form, and one without load at rest
    # (neither of the optional readings).
    cases = (geardyn.Case(solver={"duration_s": 0.005},
                          mesh={"transmission_error_um": [[0.5, 0], [0.1, 30]]}),
             geardyn.Case(model={"form": "nondimensional"}, solver={"duration_s": 60.0}),
             geardyn.Case(load={"torque_nm": 0.0}, solver={"duration_s": 0.002,
                                                          "initial": "static"}))
    readings = []
    for case in cases:
        r = geardyn.run(case)
        readings.append((r.summary["impacts"] > 0, r.summary["dynamic_factor"] is None))
        back = pickle.loads(pickle.dumps(r))
        for name in ("t", "delta_bar", "force_bar", "velocity", "contact"):
            assert np.array_equal(getattr(back, name), getattr(r, name)), name
        assert back.summary == r.summary
        for k in ("t_s", "velocity_m_s"):
            assert np.array_equal(back.events[k], r.events[k])
        assert back.events["kind"] == r.events["kind"]
        assert back.case_toml == r.case_toml and back.ok == r.ok
        r.write(str(tmp_path / "a"))
        back.write(str(tmp_path / "b"))
        for f in sorted((tmp_path / "a").iterdir()):
            if f.name == ".geardyn-files.json":  # the manifest: when each file was written
                continue
            assert f.read_bytes() == (tmp_path / "b" / f.name).read_bytes(), f.name
        for f in (tmp_path / "a").iterdir():
            f.unlink()
    assert readings == [(True, False), (True, False), (False, True)]


def test_results_label_themselves_and_sweeps_pickle(tmp_path):
    import pickle

    case, key, values = _ks_sweep_args(5)
    s = geardyn.sweep(case, key, values)
    assert isinstance(s, geardyn.SweepResult) and isinstance(s, dict)
    back = pickle.loads(pickle.dumps(s))
    assert type(back) is geardyn.SweepResult
    assert back.keys() == s.keys()

    def same(a, b):
        if isinstance(a, dict):
            return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        if isinstance(a, np.ndarray):
            return type(b) is np.ndarray and np.array_equal(a, b, equal_nan=True)
        return a == b

    assert same(dict(back), dict(s))
    assert s.to_xarray().identical(geardyn.to_xarray(s))
    df = s.to_pandas()
    assert df.index.names == ["direction", "param"] and len(df) == 2 * 5
    assert df.loc[("up", values[0]), "pp_delta_bar"] == s["pp_delta_bar"][0]
    s.save(tmp_path / "s.nc")
    assert geardyn.load(tmp_path / "s.nc").identical(s.to_xarray())

    r = geardyn.run(geardyn.Case(solver={"duration_s": 0.002}))
    rf = r.to_pandas()
    assert np.array_equal(rf.index.values, r.t) and np.array_equal(rf["delta_bar"], r.delta_bar)
    r.save(tmp_path / "r.nc")
    assert geardyn.load(tmp_path / "r.nc").identical(r.to_xarray())
    # A case file given to load is named as one, and what reads it.
    (tmp_path / "c.toml").write_text(r.case_toml)
    with pytest.raises(ValueError, match=r"a case file: read it with geardyn.Case.from_toml"):
        geardyn.load(tmp_path / "c.toml")
    (tmp_path / "c.txt").write_text("not a dataset")
    with pytest.raises(ValueError, match=r"the NetCDF file geardyn.save writes, and this is none"):
        geardyn.load(tmp_path / "c.txt")


def _ks_sweep_args(points):
    case = geardyn.Case(model={"form": "nondimensional", "force_alternating": 0.02},
                        solver={"initial": "static"})
    return case, "model.omega", np.linspace(0.5, 1.5, points)


def test_a_sweep_reports_progress_and_a_false_return_stops_it():
    case, key, values = _ks_sweep_args(41)
    seen = []
    s = geardyn.sweep(case, key, values, direction="up", threads=1,
                      progress=lambda done, total: seen.append((done, total)) or done < 10)
    assert s["cancelled"]
    assert len(s["value"]) == 10
    assert seen[:3] == [(1, 41), (2, 41), (3, 41)]
    full = geardyn.sweep(case, key, values, direction="up", threads=1)
    assert not full["cancelled"] and len(full["value"]) == 41
    assert np.array_equal(s["pp_delta_bar"], full["pp_delta_bar"][:10])  # the same points


def test_ctrl_c_stops_a_sweep_within_a_second_with_its_points():
    import signal

    case, key, values = _ks_sweep_args(4001)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt) as e:
        geardyn.sweep(case, key, values, direction="up", threads=1)
    elapsed = time.monotonic() - start
    timer.join()
    assert elapsed < 1.5, elapsed  # 0.5 s until the signal, then under a second
    done = e.value.result
    assert 0 < len(done["value"]) < 4001
    assert np.array_equal(done["value"], values[:len(done["value"])])


def test_a_run_reports_progress_and_ctrl_c_keeps_the_partial_run():
    import signal

    case = geardyn.Case(solver={"duration_s": 2.0, "method": "newmark"})
    fractions = []
    r = geardyn.run(case.with_({"solver.duration_s": 0.05}),
                    progress=lambda f: fractions.append(f) or True)
    assert r.ok and fractions and all(0 <= f <= 1 for f in fractions)
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt) as e:
        geardyn.run(case)
    timer.join()
    assert time.monotonic() - start < 1.5
    partial = e.value.result
    assert not partial.ok and 0 < partial.t[-1] < 2.0


def test_a_map_from_python_is_the_command_lines(tmp_path):
    cli("sweep", "--set", 'model.form="nondimensional"', "--param", "model.omega", "--from",
        "0.8", "--to", "1.2", "--points", "5", "--param2", "model.force_alternating", "--from2",
        "0.02", "--to2", "0.05", "--points2", "2", "--direction", "up", "--no-figures",
        "--out", str(tmp_path))
    rows = (tmp_path / "sweep.csv").read_text().splitlines()[1:]
    case = geardyn.Case(model={"form": "nondimensional"})
    m = geardyn.sweep(case, "model.omega", np.linspace(0.8, 1.2, 5), direction="up",
                      param2="model.force_alternating", values2=[0.02, 0.05])
    assert len(m["value"]) == len(rows) == 10
    assert sorted(set(m["value2"])) == [0.02, 0.05]
    from_cli = sorted((float(r.split(",")[4]), float(r.split(",")[2]), float(r.split(",")[9]))
                      for r in rows)
    from_py = sorted(zip(m["value2"], m["value"], m["pp_delta_bar"]))
    for a, b in zip(from_cli, from_py):
        assert a[:2] == pytest.approx(b[:2], abs=1e-12)
        assert a[2] == b[2]  # sweep.csv writes the shortest exact digits


def test_a_sweep_and_a_run_as_datasets_save_and_load_exactly(tmp_path):
    case, key, values = _ks_sweep_args(21)
    s = geardyn.sweep(case, key, values)
    ds = geardyn.to_xarray(s)
    assert ds["pp_delta_bar"].dims == ("direction", "param")
    assert list(ds["direction"].values) == ["up", "down"]
    assert ds["param"].attrs["long_name"] == key
    assert ds["pp_force_bar"].attrs["units"] == "1"
    up = ds["pp_delta_bar"].sel(direction="up").values
    order = np.argsort(s["value"][np.array(s["direction"]) == "up"])
    assert np.array_equal(up, s["pp_delta_bar"][np.array(s["direction"]) == "up"][order])
    assert json.loads(ds.attrs["jumps"]) == s["jumps"]
    geardyn.save(s, tmp_path / "sweep.nc")
    back = geardyn.load(tmp_path / "sweep.nc")
    assert back.identical(ds)  # values, coordinates and attributes, exactly
    assert len(s.to_pandas()) == 2 * 21  # pandas: a row per point

    r = geardyn.run(geardyn.Case(solver={"duration_s": 0.002}))
    rd = geardyn.to_xarray(r)
    assert rd["velocity"].attrs["units"] == "m/s" and rd["t"].attrs["units"] == "s"
    geardyn.save(r, tmp_path / "run.nc")
    rb = geardyn.load(tmp_path / "run.nc")
    assert rb.identical(rd)
    assert np.array_equal(rb["delta_bar"].values, r.delta_bar)
    assert json.loads(rb.attrs["summary"]) == r.summary
    assert geardyn.Case.from_dict(__import__("tomllib").loads(rb.attrs["case"])) == \
        geardyn.Case(solver={"duration_s": 0.002})


def test_a_map_is_a_dataset_over_both_keys():
    case = geardyn.Case(model={"form": "nondimensional"})
    m = geardyn.sweep(case, "model.omega", np.linspace(0.8, 1.2, 5), direction="up",
                      param2="model.force_alternating", values2=[0.02, 0.05])
    ds = geardyn.to_xarray(m)
    assert ds["pp_delta_bar"].dims == ("direction", "param2", "param")
    assert ds["pp_delta_bar"].shape == (1, 2, 5)
    assert not np.isnan(ds["pp_delta_bar"].values).any()


def test_numpy_values_are_case_values():
    c = geardyn.Case().with_({"mesh.stiffness_source": "harmonics",
                              "mesh.stiffness_harmonics": np.array([[0.05, 0.0], [0.02, 90.0]]),
                              "speed.shaft_frequency_hz": np.float64(250.0)})
    assert c["mesh.stiffness_harmonics"] == [[0.05, 0.0], [0.02, 90.0]]
    assert c["speed.shaft_frequency_hz"] == 250.0
    with pytest.raises(geardyn.InputError, match="stiffness_harmonics"):
        geardyn.Case().with_({"mesh.stiffness_harmonics": np.zeros(3)})


def test_a_runs_events_are_arrays_as_events_csv_has_them(tmp_path):
    r = geardyn.run(geardyn.Case(solver={"duration_s": 0.01}))
    e = r.events
    r.write(str(tmp_path))
    rows = (tmp_path / "events.csv").read_text().splitlines()[1:]
    assert len(e["t_s"]) == len(e["kind"]) == len(e["velocity_m_s"]) == len(rows) > 0
    assert [row.split(",")[1] for row in rows] == e["kind"]
    assert np.allclose([float(row.split(",")[0]) for row in rows], e["t_s"], rtol=1e-9)


def test_a_setting_the_case_does_not_use_is_warned_of_at_the_users_call():
    # As the command line's "geardyn: warning: ... not used", for every function that takes a
    # case, pointing at the caller's line; a case that uses all it sets warns of nothing.
    import warnings

    pair = geardyn.Case(model={"zeta": 0.1}).with_({"solver.duration_s": 0.002})
    reducer = geardyn.Case.from_toml(SOURCE / "cases/two_stage_reducer.toml").with_(
        {"solver.duration_s": 0.002, "speed.shaft_frequency_hz": 10})
    slow = geardyn.Case().with_({"speed.shaft_frequency_hz": 10})  # an orbit in contact
    calls = [
        ("model.zeta = 0.1 (Case(...)): not used", lambda: geardyn.run(pair)),
        ("model.zeta = 0.1", lambda: geardyn.sweep(pair, "speed.shaft_frequency_hz", [900.0])),
        ("model.zeta = 0.1", lambda: geardyn.stability(pair, "mesh.damping_ratio", [0.05, 0.1])),
        ("speed.shaft_frequency_hz = 10.0 (with_({\"speed.shaft_frequency_hz\": 10})): not used",
         lambda: geardyn.modes(reducer)),
        ("model.zeta = 0.1", lambda: geardyn.study(
            pair, {"mesh.backlash_um": {"distribution": "uniform", "lower": 80, "upper": 120}},
            samples=2)),
        # An orbit is shot with the exact engine whatever the method (the command line's words).
        ('solver.method = "newmark" (with_({"solver.method": "newmark"})): not used: periodic '
         "orbits, their continuation and stability charts are computed with the exact engine",
         lambda: geardyn.orbit(slow.with_({"solver.method": "newmark"}))),
    ]
    for words, call in calls:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            call()
        unused = [w for w in seen if issubclass(w.category, geardyn.UnusedSettingWarning)]
        assert unused and words in str(unused[0].message), [str(w.message) for w in seen]
        assert unused[0].filename == __file__, unused[0].filename
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        geardyn.run(geardyn.Case().with_({"solver.duration_s": 0.002}))
        geardyn.run(slow.with_({"solver.method": "newmark", "solver.duration_s": 0.002}))
    assert not [w for w in seen if issubclass(w.category, geardyn.UnusedSettingWarning)]


def test_errors_speak_of_the_python_arguments():
    case, key, values = _ks_sweep_args(5)
    with pytest.raises(geardyn.InputError, match=r"^measure_periods = 0") as e:
        geardyn.sweep(case, key, values, measure_periods=0)
    assert "--" not in str(e.value)
    with pytest.raises(geardyn.InputError, match="values: must be a 1-D sequence"):
        geardyn.sweep(case, key, [[0.5, 0.6], [0.7, 0.8]])
    with pytest.raises(geardyn.InputError, match="values: must be numbers"):
        geardyn.sweep(case, key, ["a", "b"])
    # Each key's origin is the call that gave it, named once: no --set, no line of a text the
    # user never saw.
    with pytest.raises(geardyn.InputError,
                       match=r'^with_\(\{"mesh.backlash_um": -1\}\): mesh.backlash_um = -1: must'):
        geardyn.Case().with_({"mesh.backlash_um": -1})
    with pytest.raises(geardyn.InputError,
                       match=r'^set\("mesh.backlash_um", -1\): mesh.backlash_um = -1: must'):
        geardyn.Case().set("mesh.backlash_um", -1)
    with pytest.raises(geardyn.InputError, match=r"^Case\(\.\.\.\): mesh.backlash_um = -1: must"):
        geardyn.Case(mesh={"backlash_um": -1})
    train = {"reference_speed_hz": 50, "body": [{"name": "a", "inertia_kg_m2": 1}]}
    with pytest.raises(geardyn.InputError,
                       match=r"^Case\(\.\.\.\): train.reference_speed_hz = \"fast\": must"):
        geardyn.Case(model={"form": "train"}, train=dict(train, reference_speed_hz="fast"))
    with pytest.raises(geardyn.InputError, match=r"^periods = 0"):
        geardyn.orbit(case, periods=0)
    with pytest.raises(geardyn.InputError, match=r"from_ = 1, to = 1"):
        geardyn.continuation(case, key, 1.0, 1.0)


def test_every_public_function_and_attribute_is_documented():
    import inspect

    def sections(obj):
        doc = inspect.getdoc(obj) or ""
        return {s for s in ("Parameters", "Returns") if f"{s}\n---" in doc}

    undocumented = []
    for name in geardyn.__all__:
        obj = getattr(geardyn, name)
        if inspect.isfunction(obj) and not sections(obj):
            undocumented.append(name)
    for cls in (geardyn.Case, geardyn.RunResult, geardyn.SweepResult, geardyn.TrainRunResult):
        for name, obj in vars(cls).items():
            if name.startswith("_") and name not in ("__init__", "__getitem__"):
                continue
            if cls in (geardyn.RunResult, geardyn.TrainRunResult) and name == "__init__":
                continue  # made by run(), not by users
            if isinstance(obj, property):
                if not (obj.__doc__ or "").strip():
                    undocumented.append(f"{cls.__name__}.{name}")
            elif callable(obj) or isinstance(obj, staticmethod):
                if not sections(getattr(cls, name)):
                    undocumented.append(f"{cls.__name__}.{name}")
    for name in ("run", "frequency_response", "branch"):
        if sections(getattr(geardyn.plot, name)) != {"Parameters", "Returns"}:
            undocumented.append(f"plot.{name}")
    assert undocumented == []


def test_a_sweeps_strobe_jumps_and_hysteresis_are_the_command_lines(tmp_path):
    case, key, values = _ks_sweep_args(21)
    cli("sweep", "--set", "model.form=nondimensional", "--set", "model.force_alternating=0.02",
        "--set", "solver.initial=static", "--param", key, "--from", "0.5", "--to", "1.5",
        "--points", "21", "--no-figures", "--out", str(tmp_path))
    # The command line's grid (from + i step, exact in sweep.csv), so that the numbers agree.
    grid = [float(r.split(",")[2]) for r in
            (tmp_path / "sweep.csv").read_text().splitlines()[1:] if r.startswith("up,")]
    assert grid == pytest.approx(list(values), abs=1e-15)
    s = geardyn.sweep(case, key, grid)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert s["jumps"] and s["hysteresis"]  # this sweep has both
    assert s["jumps"] == summary["jumps"] and s["hysteresis"] == summary["hysteresis"]
    assert s["unsettled_ranges"] == summary["unsettled_ranges"]
    assert all(not j["unsettled"] for j in s["jumps"]) == (not s["unsettled_ranges"])
    # The files name the period in tau in this form; Python keeps the SI names, the units in
    # the Dataset's attributes.
    assert s["period_s"] == summary["period_tau"] and s["form"] == "nondimensional"
    assert s.to_xarray().attrs["period_units"] == "tau"
    assert s.to_xarray()["strobe_velocity_m_s"].attrs["units"] == "1"
    rows = [r.split(",") for r in (tmp_path / "strobe.csv").read_text().splitlines()[1:]]
    st = s["strobe"]
    assert len(rows) == len(st["point"]) == 2 * 21 * 10
    for i, r in enumerate(rows):
        p = st["point"][i]
        assert (r[0], float(r[1])) == (s["direction"][p], s["value"][p])
        assert [float(x) for x in r[4:7]] == [st["delta_bar"][i], st["velocity_m_s"][i],
                                              st["force_bar"][i]]
    ds = s.to_xarray()
    up = ds["strobe_delta_bar"].sel(direction="up")
    assert up.shape == (21, 10)
    assert np.array_equal(up.values.ravel(), st["delta_bar"][: 21 * 10])
    assert json.loads(ds.attrs["hysteresis"]) == s["hysteresis"]
    assert json.loads(ds.attrs["unsettled_ranges"]) == s["unsettled_ranges"]


def test_the_coupled_model_from_python_is_the_command_lines(tmp_path):
    path = SOURCE / "cases/park2010_coupled.toml"
    case = geardyn.Case.from_toml(path).with_({"solver.duration_s": 0.005})
    r = geardyn.run(case)  # as its train form: the train's result, the case's form kept
    assert isinstance(r, geardyn.TrainRunResult) and r.ok
    assert r.summary["form"] == "coupled" and r.summary["dof"] == 12
    cli("run", str(path), "--set", "solver.duration_s=0.005", "--out", str(tmp_path))
    summary = json.loads((tmp_path / "summary.json").read_text())
    for s in (summary, r.summary):
        s.pop("wall_time_s")
    assert r.summary == summary
    assert r.bodies == ["pinion", "wheel"] and r.meshes == ["mesh"]
    assert r.q.shape == (len(r.t), 12) and r.coordinates[2] == "pinion_x_m"
    rows = (tmp_path / "timeseries.csv").read_text().splitlines()
    last = [float(x) for x in rows[-1].split(",")]
    assert last[0] == pytest.approx(r.t[-1], abs=1e-15)
    assert last[1:13] == pytest.approx(list(r.q[-1]), rel=1e-9, abs=1e-18)
    assert r.shafts == []  # no shafts in this case

    # A drive shaft to a motor: a body "motor" and its shaft, its torque the summary's extremes.
    rs = geardyn.run(case.with_({"shafts.end_inertia_kg_m2": [0.05, 0.0]}))
    assert rs.ok and rs.bodies == ["pinion", "wheel", "motor"] and rs.shafts == ["drive_shaft"]
    assert rs.shaft_torque.max() <= rs.summary["shafts"][0]["max_torque_nm"]
    assert rs.shaft_torque.max() > 0.9 * rs.summary["shafts"][0]["max_torque_nm"]

    # Its modes are its train's, as the command line's: the rigid rotation and 11 elastic modes,
    # each one's strain energy whole over the mesh and the bearings' directions.
    m = geardyn.modes(case)
    out = json.loads(cli("modes", str(path), "--json").stdout)
    assert list(m["frequency_hz"]) == [x["frequency_hz"] for x in out["modes"]]
    assert m["shape"].shape == (12, 12) and m["frequency_hz"][0] == 0.0
    assert m["bodies"][:4] == ["pinion", "wheel", "pinion_x", "pinion_y"]
    parts = m["bearing_energy_parts"]
    assert set(parts["pinion_bearing"]) == {"x", "y", "axial", "tilt_x", "tilt_y"}
    total = m["mesh_energy"]["mesh"] + sum(e for b in parts.values() for e in b.values())
    assert total[1:] == pytest.approx(np.ones(11), abs=1e-12)
    assert m["damped"].shape == (11, 2)
    assert m["damped"][:, 0] == pytest.approx(m["frequency_hz"][1:], rel=1e-3)
    # The coupled orbit from Python is the command line's, found on its train: six unknowns
    # (modulo the rigid rotation), every body's state (eight).
    o = geardyn.orbit(case.with_({"model.dof": 3}))
    out = json.loads(cli("orbit", str(path), "--set", "model.dof=3", "--json").stdout)
    assert o["converged"] and out["converged"] and not o["stable"] and o["model"] == "train"
    assert o["unknowns"].shape == (6,) and o["monodromy"].shape == (6, 6)
    assert o["state"].shape == (8,)
    assert o["unknowns"] == pytest.approx(np.array(out["unknowns"]), rel=1e-12, abs=1e-18)
    assert abs(o["floquet_multipliers"][0]) == pytest.approx(out["max_multiplier"], rel=1e-12)
    with pytest.raises(geardyn.InputError, match="this train takes 6"):
        geardyn.orbit(case.with_({"model.dof": 3}), state=[0.0, 0.0])
    # The one-degree pair's modes are its train's: the rigid rotation and the contact mode at
    # the one-degree model's natural frequency.
    m = geardyn.modes(geardyn.Case())
    assert len(m["bodies"]) == 2 and m["frequency_hz"][0] == 0.0
    one = geardyn.run(geardyn.Case().with_({"solver.duration_s": 1e-3}))
    f_n = one.summary["derived"]["natural_frequency_hz"]
    assert m["frequency_hz"][1] == pytest.approx(f_n, rel=1e-12)
    # A coupled sweep (as its train) has the command line's bearing columns, per part along a
    # dimension in xarray and under sweep.csv's names in pandas.
    s = geardyn.sweep(case, "speed.shaft_frequency_hz", [2000.0, 2500.0], direction="up")
    cli("sweep", str(path), "--param", "speed.shaft_frequency_hz", "--from", "2000", "--to",
        "2500", "--points", "2", "--direction", "up", "--no-figures", "--out",
        str(tmp_path / "sweep"))
    rows = (tmp_path / "sweep" / "sweep.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert s["meshes"] == ["mesh"] and "pinion_bearing_force_y_n" in s["parts"]
    assert s["part_peak"].shape == (2, len(s["parts"]))
    for k, part in enumerate(s["parts"]):
        for name, array in ((part + "_peak", s["part_peak"]), (part + "_factor", s["part_factor"])):
            column = [float(r.split(",")[header.index(name)]) for r in rows[1:]]
            assert np.array_equal(array[:, k], column, equal_nan=True), name
    y = s["parts"].index("pinion_bearing_force_y_n")
    assert np.all(s["part_peak"][:, y] > 0) and np.all(s["part_factor"][:, y] > 1)
    assert np.all(np.isnan(s["part_factor"][:, s["parts"].index("pinion_bearing_force_x_n")]))
    ds = s.to_xarray()
    assert list(ds["part"].values) == s["parts"]
    assert np.array_equal(ds["part_peak"].sel(direction="up").values, s["part_peak"])
    df = s.to_pandas()
    assert list(df["pinion_bearing_force_y_n_peak"]) == list(s["part_peak"][:, y])
    assert "parts" not in geardyn.sweep(geardyn.Case(), "speed.shaft_frequency_hz", [2000.0],
                                        direction="up")


def _users_folder(path):
    path.mkdir(parents=True, exist_ok=True)
    (path / "thesis.tex").write_text("draft")
    (path / "src").mkdir(exist_ok=True)
    (path / "src" / "a.c").write_text("code")
    return path


def _expect_users_files(path):
    assert (path / "thesis.tex").read_text() == "draft"
    assert (path / "src" / "a.c").read_text() == "code"
    assert not [p for p in path.iterdir() if p.name.startswith(".geardyn-staging")]


def test_python_writers_keep_the_users_files(tmp_path, monkeypatch):
    r = geardyn.run(geardyn.Case.default().set("solver.duration_s", 0.002))
    folder = _users_folder(tmp_path / "work")
    assert r.write(str(folder)) == []
    assert r.write(str(folder)) == []
    _expect_users_files(folder)
    assert (folder / "summary.json").exists()
    here = _users_folder(tmp_path / "here")
    monkeypatch.chdir(here)
    r.write(".")
    _expect_users_files(here)
    assert (here / "timeseries.csv").exists()
    # A file geardyn wrote is replaced; one the user changed since, or wrote under one of our
    # names, stops the write with the folder as it was; any other name is the user's and stays.
    (here / "spare.csv").write_text("not ours")
    assert r.write(".") == []
    assert (here / "events.csv").read_text().startswith("t_s,kind")
    (here / "events.csv").write_text("mine now")
    before = {p.name: p.read_bytes() for p in here.iterdir() if p.is_file()}
    with pytest.raises(RuntimeError, match="events.csv: cannot write: the file exists and was "
                                           "not written by geardyn"):
        r.write(".")
    assert {p.name: p.read_bytes() for p in here.iterdir() if p.is_file()} == before
    assert (here / "spare.csv").read_text() == "not ours"


def test_save_replaces_the_file_whole_or_not_at_all(tmp_path):
    r = geardyn.run(geardyn.Case.default().set("solver.duration_s", 0.002))
    target = tmp_path / "r.nc"
    (tmp_path / "thesis.tex").write_text("draft")
    r.save(target)
    before = target.read_bytes()
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    ds = r.to_xarray()
    ds.attrs["not_storable"] = {"a dict": 1}  # NetCDF cannot store it: the write fails
    with pytest.raises(Exception):
        geardyn.save(ds, target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc", "thesis.tex"]


def test_ctrl_c_during_a_write_is_raised_once_the_file_is_whole(tmp_path):
    # Ctrl-C (SIGINT) in the middle of a write is held back: the file is finished and moved into
    # place, then KeyboardInterrupt is raised, and no temporary file stays beside the user's. A
    # write that fails under Ctrl-C leaves the earlier file. (A study interrupted while storing
    # a batch once left a stray temporary file in its store.)
    import signal

    from geardyn.data import write_atomically

    (tmp_path / "thesis.tex").write_text("draft")
    target = tmp_path / "out.txt"

    def interrupted_write(name):
        with open(name, "w") as f:
            f.write("first half, ")
            os.kill(os.getpid(), signal.SIGINT)
            f.write("second half")

    with pytest.raises(KeyboardInterrupt):
        write_atomically(target, interrupted_write, ".txt.tmp")
    assert target.read_text() == "first half, second half"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt", "thesis.tex"]

    def failing_write(name):
        with open(name, "w") as f:
            f.write("partial")
            os.kill(os.getpid(), signal.SIGINT)
            raise OSError("disk full")

    with pytest.raises(OSError):
        write_atomically(target, failing_write, ".txt.tmp")
    assert target.read_text() == "first half, second half"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt", "thesis.tex"]
    # Outside a write Ctrl-C is Python's again.
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_trains_orbit_from_python_is_the_command_lines():
    # The loose gear's rattle at 290 rad/s^2 (an orbit, unstable): the orbit's JSON from Python
    # is the command line's, and its unknowns, given back as `state`, start a Newton with
    # nothing left to do.
    path = SOURCE / "cases/loose_gear_rattle.toml"
    key = "train.speed[0].acceleration_harmonics"
    case = geardyn.Case.from_toml(path).with_({key: [[290, 2, 0]]})
    o = geardyn.orbit(case, segments=4, settle_periods=200)
    out = json.loads(cli("orbit", str(path), "--set", f"{key}=[[290, 2, 0]]", "--segments", "4",
                         "--settle-periods", "200", "--json").stdout)
    assert o["converged"] and out["converged"] and o["model"] == "train"
    assert o["coordinates"] == out["coordinates"] == ["loose_rad", "loose_rad_s"]
    assert o["unknowns"] == pytest.approx(np.array(out["unknowns"]), rel=1e-12, abs=1e-18)
    assert o["state"] == pytest.approx(np.array(out["state"]), rel=1e-12, abs=1e-18)
    assert [m["impacts_per_period"] for m in o["meshes"]] == \
        [m["impacts_per_period"] for m in out["meshes"]]
    again = geardyn.orbit(case, segments=4, settle_periods=0, state=o["unknowns"])
    assert again["converged"] and again["iterations"] <= 1
    # Newton starts again from later settled states (`starts`, the command line's --starts):
    # from one only, this rattle's first settled state leads nowhere.
    assert o["message"] == out["message"] and "(start " in o["message"]
    once = geardyn.orbit(case, segments=4, settle_periods=200, starts=1)
    assert not once["converged"] and "settled state" not in once["message"]
    with pytest.raises(geardyn.InputError, match=r"^starts = 0: must be an integer in \[1, 1000\]"):
        geardyn.orbit(case, starts=0)
    with pytest.raises(geardyn.InputError, match=r"state: 1 value given; this train takes 2"):
        geardyn.orbit(case, state=[0.0])


def test_a_rattling_trains_events_are_the_command_lines(tmp_path):
    # The loose gear's contact changes from Python are events.csv's, each impact's velocity
    # within the mesh's largest, and the summary's impacts those of its events.
    path = SOURCE / "cases/loose_gear_rattle.toml"
    case = geardyn.Case.from_toml(path).with_({"solver.duration_s": 0.06})
    r = geardyn.run(case)
    cli("run", str(path), "--set", "solver.duration_s=0.06", "--out", str(tmp_path))
    rows = [x.split(",") for x in (tmp_path / "events.csv").read_text().splitlines()]
    assert rows[0] == ["t_s", "part", "kind", "velocity_m_s"]
    e = r.events
    assert len(rows) - 1 == len(e["t_s"]) > 10
    assert [x[1] for x in rows[1:]] == e["part"] and [x[2] for x in rows[1:]] == e["kind"]
    assert [float(x[0]) for x in rows[1:]] == pytest.approx(list(e["t_s"]), rel=1e-14)
    assert [float(x[3]) for x in rows[1:]] == pytest.approx(list(e["velocity_m_s"]), rel=1e-9)
    mesh = r.summary["meshes"][0]
    impacts = [k != "separation" for k in e["kind"]]
    assert sum(impacts) == mesh["impacts"] and set(e["part"]) == {r.meshes[0]}
    assert np.abs(e["velocity_m_s"][impacts]).max() == mesh["max_impact_velocity_m_s"]


def test_a_trains_run_writes_saves_and_pickles_as_the_pairs_does(tmp_path):
    # write() puts the command line's files, byte for byte (the wall time aside), and refuses a
    # folder holding a file of those names that geardyn did not write; save() and to_xarray()
    # give the train's own Dataset; a pickled result keeps its arrays and says it cannot write.
    path = SOURCE / "cases/idler_train.toml"
    r = geardyn.run(geardyn.Case.from_toml(path).with_({"solver.duration_s": 0.01}))
    cli("run", str(path), "--set", "solver.duration_s=0.01", "--out", str(tmp_path / "cli"))
    assert r.write(tmp_path / "py") == []
    for name in ("timeseries.csv", "events.csv", "case.toml"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    written = [json.loads((tmp_path / d / "summary.json").read_text()) for d in ("py", "cli")]
    for s in written:
        s.pop("wall_time_s")
    assert written[0] == written[1]
    user = tmp_path / "user"
    user.mkdir()
    (user / "summary.json").write_text("mine")
    with pytest.raises(RuntimeError, match="summary.json"):
        r.write(user)
    assert [p.name for p in user.iterdir()] == ["summary.json"]
    assert (user / "summary.json").read_text() == "mine"

    r.save(tmp_path / "train.nc")
    assert geardyn.load(tmp_path / "train.nc").identical(r.to_xarray())
    assert geardyn.to_xarray(r).identical(r.to_xarray())
    # A dict that is no run, sweep, branch or chart is refused with its keys, nothing written.
    with pytest.raises(ValueError, match="this dict is none .its keys: a, b."):
        geardyn.save({"a": 1, "b": 2}, tmp_path / "other.nc")
    assert not (tmp_path / "other.nc").exists()

    back = pickle.loads(pickle.dumps(r))
    assert np.array_equal(back.force, r.force) and back.summary == r.summary
    with pytest.raises(RuntimeError, match="unpickled"):
        back.write(tmp_path / "back")
    assert not (tmp_path / "back").exists()


def test_a_gear_train_from_a_file_and_from_code_is_the_command_lines(tmp_path):
    # The idler train from its file, from the command line and from a dict built in code: the
    # same readings per mesh; its xarray has a mesh dimension.
    path = SOURCE / "cases/idler_train.toml"
    case = geardyn.Case.from_toml(path).with_({"solver.duration_s": 0.01})
    r = geardyn.run(case)
    assert isinstance(r, geardyn.TrainRunResult) and r.ok
    cli("run", str(path), "--set", "solver.duration_s=0.01", "--out", str(tmp_path))
    summary = json.loads((tmp_path / "summary.json").read_text())
    for s in (summary, r.summary):
        s.pop("wall_time_s")
    assert r.summary == summary
    assert r.meshes == ["in", "out"] and r.bodies == ["driver", "idler", "driven"]
    assert r.force.shape == (len(r.t), 2) and r.theta.shape == (len(r.t), 3)
    ds = r.to_xarray()
    assert ds["force"].dims == ("t", "mesh") and list(ds["mesh"].values) == ["in", "out"]
    assert float(ds["force"].sel(mesh="out").max()) <= summary["meshes"][1]["max_force_n"]
    assert float(ds["dynamic_factor"].sel(mesh="in")) == summary["meshes"][0]["dynamic_factor"]
    # Each mesh's k_m and backlash as the run took them (the file's).
    assert [m["mean_stiffness_n_per_m"] for m in summary["meshes"]] == [4e8, 4e8]
    assert list(ds["mean_stiffness_n_per_m"].values) == [4e8, 4e8]
    assert list(ds["backlash_m"].values) == pytest.approx([40e-6, 40e-6], rel=1e-12)
    # The steady part per mesh (where it starts in the summary), its forces within the whole's.
    assert summary["steady"]["basis"] in ("settled", "not_settled")
    assert float(ds["steady_max_force_n"].sel(mesh="in")) == \
        summary["meshes"][0]["steady"]["max_force_n"]
    assert (ds["steady_max_force_n"] <= ds["max_force_n"]).all()
    assert list(ds["steady_regime"].values) == [m["steady"]["regime"]
                                                for m in summary["meshes"]]
    # Each mesh's means and RMS over the samples are the samples' own.
    for m, x in enumerate(summary["meshes"]):
        f, d = r.force[:, m], r.deflection_bar[:, m]
        assert x["mean_force_n"] == pytest.approx(f.mean(), rel=1e-12)
        assert x["rms_force_n"] == pytest.approx(np.sqrt((f ** 2).mean()), rel=1e-12)
        assert x["mean_deflection_bar"] == pytest.approx(d.mean(), rel=1e-12)
        assert x["rms_deflection_bar"] == pytest.approx(np.sqrt((d ** 2).mean()), rel=1e-12)
    assert list(ds["rms_force_n"].values) == [x["rms_force_n"] for x in summary["meshes"]]
    # Each mesh's d' - e' at every sample, as the command line's timeseries.csv has it.
    rows = [x.split(",") for x in (tmp_path / "timeseries.csv").read_text().splitlines()]
    assert r.deflection_rate.shape == r.force.shape
    for m, name in enumerate(r.meshes):
        k = rows[0].index(name + "_deflection_rate_m_s")
        assert [float(x[k]) for x in rows[1:]] == pytest.approx(list(r.deflection_rate[:, m]),
                                                                rel=1e-9)
    assert np.abs(r.deflection_rate).max() > 0
    assert ds["deflection_rate"].dims == ("t", "mesh")
    assert ds["deflection_rate"].attrs["units"] == "m/s"
    phase = geardyn.plot.phase(r)  # a panel per mesh: (d - e) / b against d' - e'
    assert [a.get_title() for a in phase.axes] == ["mesh in", "mesh out"]
    part = r.t >= summary["steady"]["from_s"]
    for m, a in enumerate(phase.axes):
        steady = a.get_lines()[1]
        assert np.array_equal(steady.get_xdata(), r.deflection_bar[part, m])
        assert np.array_equal(steady.get_ydata(), r.deflection_rate[part, m])
    fig = geardyn.plot.run(r)  # a panel per mesh
    assert [a.get_title().split(" (")[0] for a in fig.axes if a.get_title()] == ["mesh in",
                                                                                 "mesh out"]

    gear = {"normal_module_mm": 2, "face_width_mm": 20}
    mesh = {"backlash_um": 40, "mean_stiffness_n_per_m": 4e8, "damping_ratio": 0.03}
    in_code = geardyn.Case(
        model={"form": "train"},
        train={"reference": "driver", "reference_speed_hz": 50,
               "body": [dict(gear, name="driver", teeth=30),
                        dict(gear, name="idler", teeth=47, bore_diameter_mm=25),
                        dict(gear, name="driven", teeth=60, bore_diameter_mm=30)],
               "mesh": [dict(mesh, name="in", driving="driver", driven="idler",
                             stiffness_harmonics=[[0.15, 0], [0.05, 0]]),
                        dict(mesh, name="out", driving="idler", driven="driven",
                             stiffness_harmonics=[[0.15, 90], [0.05, 180]])],
               "torque": [{"name": "drive", "body": "driver", "mean_nm": 20},
                          {"name": "load", "body": "driven", "mean_nm": -40}]},
        solver={"duration_s": 0.01, "initial": "static"})
    rc = geardyn.run(in_code)
    rc.summary.pop("wall_time_s")
    assert rc.summary["meshes"] == summary["meshes"]
    modes = geardyn.modes(in_code)
    assert modes["bodies"] == ["driver", "idler", "driven"] and modes["frequency_hz"][0] < 1e-6
    assert set(modes["mesh_energy"]) == {"in", "out"}
    # The idler planar on its bearing: its centre's two coordinates join the state and the
    # modes, a mode per new coordinate, every mode's strain energy shared by the meshes and the
    # bearing.
    planar = geardyn.Case(
        model={"form": "train"},
        train={"reference": "driver", "reference_speed_hz": 50,
               "body": [dict(gear, name="driver", teeth=30),
                        dict(gear, name="idler", teeth=47, bore_diameter_mm=25, dof="planar"),
                        dict(gear, name="driven", teeth=60, bore_diameter_mm=30)],
               "mesh": [dict(mesh, name="in", driving="driver", driven="idler",
                             position_angle_deg=0),
                        dict(mesh, name="out", driving="idler", driven="driven",
                             position_angle_deg=120)],
               "bearing": [{"body": "idler", "stiffness_n_per_m": 2e8}],
               "torque": [{"name": "drive", "body": "driver", "mean_nm": 20},
                          {"name": "load", "body": "driven", "mean_nm": -40}]},
        solver={"duration_s": 0.01, "initial": "static"})
    rp = geardyn.run(planar)
    assert rp.ok and rp.coordinates == ["driver_rad", "idler_rad", "driven_rad", "idler_x_m",
                                        "idler_y_m"]
    assert rp.q.shape == (len(rp.t), 5) and rp.theta.shape == (len(rp.t), 3)
    assert list(rp.to_xarray()["coordinate"].values) == rp.coordinates
    assert "layout_phase" not in rp.to_xarray()
    # Its bearing's force on the ground, x and y, from the static state it starts at.
    b = rp.summary["bearings"][0]
    assert rp.bearings == ["bearing1"] and rp.bearing_force.shape == (len(rp.t), 1, 2)
    assert abs(rp.bearing_force[0, 0, 1] - b["static_force_y_n"]) < 1e-6 * abs(b["static_force_y_n"])
    assert b["min_force_y_n"] <= rp.bearing_force[:, 0, 1].min() <= b["max_force_y_n"]
    # The phase from the layout: each mesh's along mesh, as summary.json gives it.
    phased = geardyn.run(planar.with_({"train.mesh_phase": "layout"}))
    assert [float(x) for x in phased.to_xarray()["layout_phase"].values] == \
        [m["layout_phase"] for m in phased.summary["meshes"]]
    pm = geardyn.modes(planar)
    assert pm["bodies"][3:] == ["idler_x", "idler_y"] and len(pm["frequency_hz"]) == 5
    for k in range(1, 5):
        total = sum(pm["mesh_energy"][m][k] for m in ("in", "out")) + \
            pm["bearing_energy"]["bearing1"][k]
        assert abs(total - 1) < 1e-12
    # Helical and spatial, the idler also slides along its axis and tilts: the two meshes'
    # thrusts on it cancel at rest (it is driven in one and drives in the other with the same
    # load), their moments do not; the bearing's axial force and moments read per sample, nan
    # for no bearing here but spatial ones.
    helical = {f"train.body[{i}].helix_angle_deg": 15 for i in range(3)}
    spatial = planar.with_(dict(helical, **{
        "train.body[1].dof": "spatial",
        "train.bearing": [{"body": "idler", "stiffness_n_per_m": 2e8,
                           "axial_stiffness_n_per_m": 1e8, "tilt_stiffness_n_m_per_rad": 5e5}]}))
    rs = geardyn.run(spatial)
    assert rs.ok and rs.coordinates[3:] == ["idler_x_m", "idler_y_m", "idler_z_m", "idler_tx_rad",
                                            "idler_ty_rad"]
    b = rs.summary["bearings"][0]
    assert rs.bearing_force.shape == (len(rs.t), 1, 2) and rs.bearing_axial.shape == (len(rs.t), 1, 3)
    thrust = rs.summary["meshes"][0]["static_force_n"] * math.sin(math.radians(14))
    assert abs(b["static_axial_force_n"]) < 1e-9 * thrust
    assert math.hypot(b["static_moment_x_nm"], b["static_moment_y_nm"]) > 1e-3 * thrust
    assert abs(rs.bearing_axial[0, 0, 1] - b["static_moment_x_nm"]) < 1e-6 * abs(b["static_moment_x_nm"])
    assert abs(rs.bearing_force[0, 0, 1] - b["static_force_y_n"]) < 1e-6 * abs(b["static_force_y_n"])
    assert b["min_moment_y_nm"] <= rs.bearing_axial[:, 0, 2].min() <= b["max_moment_y_nm"]
    assert np.isnan(rp.bearing_axial).all()  # the planar idler's bearing has none
    # The paper's pair as a train of elements: its run is the pair's.
    pair = geardyn.Case.default().with_({"solver.duration_s": 0.01})
    as_train = pair.train_form()
    assert as_train["model.form"] == "train"
    one, two = geardyn.run(pair), geardyn.run(as_train)
    assert np.max(np.abs(two.deflection_bar[:, 0] - one.delta_bar)) < 1e-8
    assert pair.with_({"mesh.tension": "clip"}).train_form()["train.mesh[0].tension"] == "clip"
    # The coupled pair with dof 6 as bodies held to the line of action that move along their
    # axes: each bearing reads its axial force, no moments.
    six = geardyn.Case.from_toml(SOURCE / "cases/park2010_coupled.toml").with_(
        {"model.dof": 6, "solver.duration_s": 0.005})
    r6 = geardyn.run(six.train_form())
    assert r6.coordinates == ["pinion_rad", "wheel_rad", "pinion_line_m", "pinion_z_m",
                              "wheel_line_m", "wheel_z_m"]
    assert np.isfinite(r6.bearing_axial[:, :, 0]).all() and np.isnan(r6.bearing_axial[:, :, 1:]).all()
    assert abs(r6.bearing_axial[:, 0, 0]).max() > 1.0  # the helix's thrust
    # The non-dimensional oscillator as a train in units where it is itself (seconds are tau).
    ks = geardyn.Case.from_toml(SOURCE / "cases/kahraman_singh.toml").with_(
        {"solver.duration_s": 60.0, "solver.initial": "center"})
    r_ks, r_tr = geardyn.run(ks), geardyn.run(ks.train_form())
    assert np.max(np.abs(r_tr.deflection_bar[:, 0] - r_ks.delta_bar)) < 1e-8
    sm = geardyn.modes(spatial)
    assert sm["bodies"][3:] == ["idler_x", "idler_y", "idler_z", "idler_tx", "idler_ty"]
    for k in range(1, 8):
        total = sum(sm["mesh_energy"][m][k] for m in ("in", "out")) + \
            sm["bearing_energy"]["bearing1"][k]
        assert abs(total - 1) < 1e-12
    assert set(pm["type"]) == {""} and list(pm["multiplicity"]) == [1] * 5
    # A planetary set: each mode's type and multiplicity, four planets by one key.
    lp = geardyn.Case.from_toml(SOURCE / "cases/lin_parker_1999.toml")
    lm = geardyn.modes(lp.with_({"train.planets": 4}))
    assert len(lm["frequency_hz"]) == 21 and lm["type"].count("planet") == 3
    assert all(m == 2 for m, t in zip(lm["multiplicity"], lm["type"]) if t == "translational")
    assert "pin4" in lm["bearing_energy"] and "sun_planet4" in lm["mesh_energy"]
    # In its turning carrier frame the set whirls: complex shapes, its pairs split.
    wm = geardyn.modes(lp.with_({"train.frame_terms": True, "train.reference_speed_hz": 100}))
    assert np.iscomplexobj(wm["shape"]) and wm["frequency_hz"][2] - wm["frequency_hz"][1] > 10
    # A loaded stage's run reads each sun's and ring's load sharing.
    ps = geardyn.Case.from_toml(SOURCE / "cases/planetary_set.toml").with_(
        {"solver.duration_s": 0.002, "train.planet_pin_errors_um": [[0, 20], [0, 0], [0, 0]]})
    pr = geardyn.run(ps)
    sharing = pr.summary["load_sharing"]
    assert [g["gear"] for g in sharing] == ["sun", "ring"]
    assert sharing[0]["static_factor"] > 1.05 and sharing[0]["lost_contact"] == []
    ds = pr.to_xarray()
    assert list(ds["group"].values) == ["sun", "ring"]
    assert float(ds["load_sharing_static_factor"].sel(group="sun")) == sharing[0]["static_factor"]
    assert float(ds["load_sharing_factor_with_startup"].sel(group="ring")) == \
        sharing[1]["factor_with_startup"]
    # Its figure: a panel per group, a line per planet's mesh, the factor at each sample.
    fig = geardyn.plot.load_sharing(pr)
    sun = fig.axes[0]
    assert [line.get_label() for line in sun.get_lines()] == \
        ["sun_planet1", "sun_planet2", "sun_planet3"]
    forces = np.column_stack([pr.force[:, pr.meshes.index(m)] for m in sharing[0]["meshes"]])
    factor = [a for a in fig.axes if a is not sun and a.bbox.bounds == sun.bbox.bounds][0]
    drawn = factor.get_lines()[0].get_ydata()
    assert np.allclose(drawn, 3 * forces.max(axis=1) / forces.sum(axis=1), rtol=1e-12)
    assert abs(max(drawn) - sharing[0]["factor_with_startup"]) < 1e-9
    with pytest.raises(ValueError, match="no load-sharing group"):
        geardyn.plot.load_sharing(geardyn.run(geardyn.Case.from_toml(
            SOURCE / "cases/two_stage_reducer.toml").with_({"solver.duration_s": 0.001})))
    # Each element's key is checked as in a file, named by its place in its array.
    with pytest.raises(geardyn.InputError, match=r"train\.mesh\[0\]\.backlash_um = -1"):
        geardyn.Case(model={"form": "train"},
                     train={"reference_speed_hz": 50, "body": [dict(gear, name="a", teeth=20)],
                            "mesh": [dict(mesh, driving="a", driven="a", backlash_um=-1)]})


def test_validate_passes_with_this_library_and_writes_its_reports_beside_the_users(tmp_path):
    (tmp_path / "mine.txt").write_text("mine")
    calls = []
    v = geardyn.validate(quick=True, out=tmp_path, progress=lambda d, t: calls.append((d, t)))
    assert v.passed and v.quick and not v.cancelled and v.failures == []
    assert len(v.rows) > 50
    assert {c["id"] for c in v.checks} == {r["check"] for r in v.rows}
    assert calls[0] == (0, len(v.checks)) and calls[-1] == (len(v.checks), len(v.checks))
    assert (tmp_path / "mine.txt").read_text() == "mine"
    assert json.loads((tmp_path / "validation.json").read_text())["rows"] == v.rows
    assert "<table" in v._repr_html_()
    assert f"{len(v.rows)} passed, 0 failed" in str(v)


def test_validate_stopped_by_its_progress_keeps_the_checks_done():
    v = geardyn.validate(quick=True, progress=lambda done, total: done < 2)
    assert v.cancelled and not v.passed
    assert [c for c in dict.fromkeys(r["check"] for r in v.rows)] == \
        [c["id"] for c in v.checks[:2]]
