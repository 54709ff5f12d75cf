"""Periodic orbits, continuation and stability from Python: the command line's results, the
progress callback, Ctrl-C with the points kept, errors."""
import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import geardyn

CLI = os.environ["GEARDYN_CLI"]
KS = [("model.form", "nondimensional"), ("model.force_alternating", 0.02)]
KS_CLI = ["--set", 'model.form="nondimensional"', "--set", "model.force_alternating=0.02"]


def ks(**keys):
    c = geardyn.Case.default()
    for k, v in KS:
        c.set(k, v)
    for k, v in keys.items():
        c.set("model." + k, v)
    return c


def test_orbit_matches_the_command_line():
    out = subprocess.run([CLI, "orbit", *KS_CLI, "--set", "model.omega=0.95", "--json"],
                         capture_output=True, text=True, check=True)
    j = json.loads(out.stdout)
    o = geardyn.orbit(ks(omega=0.95))
    assert o["converged"] and j["converged"]
    assert np.array_equal(o["state"], np.array(j["state"]))
    mu = np.array([complex(re, im) for re, im in j["floquet_multipliers"]])
    assert np.array_equal(o["floquet_multipliers"], mu)
    assert o["impacts_per_period"] == j["impacts_per_period"] == 1
    assert o["stable"]
    assert [e["event"] for e in o["sequence"]] == ["impact", "separation"]


def test_continuation_finds_the_folds_and_grazings_of_the_command_line(tmp_path):
    subprocess.run([CLI, "continue", *KS_CLI, "--param", "model.omega", "--from", "0.5",
                    "--to", "1.5", "--out", str(tmp_path), "--no-figures"],
                   capture_output=True, text=True, check=True)
    from_cli = json.loads((tmp_path / "bifurcations.json").read_text())
    b = geardyn.continuation(ks(), "model.omega", 0.5, 1.5)
    assert b["completed"], b["message"]
    assert [f["type"] for f in b["bifurcations"]] == [f["type"] for f in from_cli]
    for f, g in zip(b["bifurcations"], from_cli):
        assert f["param"] == g["param"]
    assert len(b["param"]) == len(b["x_a"]) == b["multipliers"].shape[0]
    assert (b["stable"] == 0).sum() > 0


TE_PAIR = [("model.form", "coupled"), ("model.dof", 3), ("mesh.stiffness_source", "harmonics"),
           ("mesh.damping_ratio", 0.05), ("mesh.transmission_error_um", [[2.0, 0.0]]),
           ("load.torque_nm", 150.0), ("load.fluctuation_ratio", 0.0),
           ("bearings.radial_stiffness_n_per_m", [2.34e8, 2.34e8]),
           ("solver.initial", "static")]


def test_a_coupled_continuation_matches_the_command_line(tmp_path):
    # The pair on bearings as stiff as the mesh, excited by a transmission error: the branch's
    # state columns are its train's unknowns (the wheel's angle and the centres along the line
    # of action, then their rates), as in the command line's branch.csv.
    case_file = tmp_path / "pair.toml"
    c = geardyn.Case.default()
    for k, v in TE_PAIR:
        c.set(k, v)
    case_file.write_text(c.to_toml())
    subprocess.run([CLI, "continue", str(case_file), "--param", "speed.shaft_frequency_hz",
                    "--from", "50", "--to", "60", "--out", str(tmp_path / "out"),
                    "--no-figures"], capture_output=True, text=True, check=True)
    rows = np.genfromtxt(tmp_path / "out" / "branch.csv", delimiter=",", names=True)
    b = geardyn.continuation(c, "speed.shaft_frequency_hz", 50, 60)
    assert b["completed"], b["message"]
    for name in ["param", "x_a", "wheel_rad", "pinion_line_m", "wheel_line_m", "wheel_rad_s",
                 "wheel_line_m_s"]:
        assert np.array_equal(b[name], rows[name]), name
    assert "delta_m" not in b
    assert [f["type"] for f in b["bifurcations"]] == ["grazing", "fold", "fold"]
    orbit = b["bifurcations"][1]["orbit"]
    assert orbit["model"] == "train" and orbit["unknowns"].shape == (6,)
    assert orbit["monodromy"].shape == (6, 6)


def test_a_trains_continuation_is_the_command_lines_and_grazes_at_the_rattle_onset(tmp_path):
    # The loose gear along its input's acceleration amplitude: the branch and its bifurcations
    # as `geardyn continue` writes them, the state columns its free body's, the first grazing
    # at the closed-form onset J (R_in / R_loose) a = T_drag, about 240.5 rad/s^2.
    path = os.path.join(os.environ["GEARDYN_SOURCE_DIR"], "cases", "loose_gear_rattle.toml")
    key = "train.speed[0].acceleration_harmonics[0][0]"
    out = subprocess.run([CLI, "continue", path, "--param", key, "--from", "230", "--to", "245",
                          "--mesh", "rattle", "--out", str(tmp_path), "--no-figures"],
                         capture_output=True, text=True, check=True).stdout
    assert "the branch reads mesh rattle" in out
    rows = np.genfromtxt(tmp_path / "branch.csv", delimiter=",", names=True)
    from_cli = json.loads((tmp_path / "bifurcations.json").read_text())
    b = geardyn.continuation(geardyn.Case.from_toml(path), key, 230, 245)
    assert b["completed"], b["message"]
    assert b["mesh"] == "rattle" and all(f["mesh"] == "rattle" for f in from_cli)
    with pytest.raises(geardyn.InputError, match=r'^mesh = "gear": the train has no mesh'):
        geardyn.continuation(geardyn.Case.from_toml(path), key, 230, 245, mesh="gear")
    for name in ["param", "x_a", "loose_rad", "loose_rad_s", "max_multiplier"]:
        assert np.array_equal(b[name], rows[name]), name
    assert [f["param"] for f in b["bifurcations"]] == [f["param"] for f in from_cli]
    first = b["bifurcations"][0]
    assert first["type"] == "grazing" and first["detail"].startswith("mesh rattle impacts 0 -> ")
    assert abs(first["param"] / 240.5 - 1) < 1e-3
    assert first["orbit"]["model"] == "train" and first["orbit"]["coordinates"] == [
        "loose_rad", "loose_rad_s"]
    # As a Dataset along point, saved and read back identical: the multipliers' re and im,
    # the bifurcations as JSON (a complex multiplier as [re, im]), the key given recorded.
    ds = geardyn.to_xarray(b, param=key)
    assert ds.attrs["param_key"] == key and ds.attrs["completed"] == 1
    assert np.array_equal(ds["loose_rad"].values, b["loose_rad"])
    assert np.array_equal(ds["multipliers_re"] + 1j * ds["multipliers_im"], b["multipliers"])
    graze = json.loads(ds.attrs["bifurcations"])[0]
    assert graze["param"] == first["param"]
    assert graze["orbit"]["floquet_multipliers"] == [
        [z.real, z.imag] for z in first["orbit"]["floquet_multipliers"]]
    geardyn.save(b, tmp_path / "branch.nc")
    assert geardyn.load(tmp_path / "branch.nc").identical(geardyn.to_xarray(b))


def test_progress_stops_and_ctrl_c_raises_with_the_points_kept():
    seen = []
    b = geardyn.continuation(ks(), "model.omega", 0.5, 1.5,
                             progress=lambda p, n: seen.append(p) or n < 5)
    assert b["cancelled"] and not b["completed"] and len(b["param"]) == 5
    assert seen == list(b["param"][1:])

    sent = []

    def interrupt(p, n):
        if n == 7:
            sent.append(time.monotonic())
            os.kill(os.getpid(), signal.SIGINT)
            # The watching thread sees the signal within 0.05 s (it takes the lock this
            # callback leaves while it sleeps), before the branch can end.
            time.sleep(0.2)
        return True

    with pytest.raises(KeyboardInterrupt) as e:
        geardyn.continuation(ks(), "model.omega", 0.5, 1.5, progress=interrupt)
    assert time.monotonic() - sent[0] < 0.5  # Ctrl-C is looked for every 0.05 s
    full = len(geardyn.continuation(ks(), "model.omega", 0.5, 1.5)["param"])
    assert 7 <= len(e.value.result["param"]) < full


def test_a_failing_callback_raises_its_error():
    def bad(p, n):
        raise RuntimeError("from the callback")

    with pytest.raises(RuntimeError, match="from the callback"):
        geardyn.continuation(ks(), "model.omega", 0.5, 1.5, progress=bad)


def test_stability_boundaries_of_the_mathieu_tongue():
    c = ks(zeta=0.0, stiffness_harmonics=[[0.2, 0]])
    s = geardyn.stability(c, "model.omega", np.linspace(1.5, 2.5, 41))
    types = [b["type"] for b in s["boundaries"]]
    assert types == ["period_doubling", "period_doubling"]
    left, right = (b["param"] for b in s["boundaries"])
    inside = (s["param"] > left) & (s["param"] < right)
    assert (s["stable"][inside] == 0).all() and (s["stable"][~inside] == 1).all()


def test_a_trains_stability_is_the_command_lines(tmp_path):
    # The loose gear (its input's speed prescribed) over its mesh's damping: the multipliers
    # `geardyn stability` writes, each stable, the largest falling as the damping rises.
    path = os.path.join(os.environ["GEARDYN_SOURCE_DIR"], "cases", "loose_gear_rattle.toml")
    subprocess.run([CLI, "stability", path, "--param", "train.mesh[0].damping_ratio",
                    "--from", "0.01", "--to", "0.1", "--points", "3", "--out", str(tmp_path)],
                   capture_output=True, text=True, check=True)
    rows = np.genfromtxt(tmp_path / "stability.csv", delimiter=",", names=True)
    case = geardyn.Case.from_toml(path)
    s = geardyn.stability(case, "train.mesh[0].damping_ratio", list(rows["param"]))
    assert np.array_equal(s["max_multiplier"], rows["max_multiplier"])
    assert (s["stable"] == 1).all() and (np.diff(s["max_multiplier"]) < 0).all()
    geardyn.save(s, tmp_path / "chart.nc")
    chart = geardyn.load(tmp_path / "chart.nc")
    assert chart.identical(geardyn.to_xarray(s)) and chart.attrs["boundaries"] == "[]"
    assert np.array_equal(chart["max_multiplier"], s["max_multiplier"])
    with pytest.raises(geardyn.InputError, match=r"train.mesh\[0\].name: not a real number"):
        geardyn.stability(case, "train.mesh[0].name", [0.01, 0.1])


def test_bad_input_is_an_input_error():
    with pytest.raises(geardyn.InputError, match="^periods = 0"):
        geardyn.orbit(ks(omega=0.95), periods=0)
    with pytest.raises(geardyn.InputError, match="^param solver.method: not a real number the model reads"):
        geardyn.continuation(ks(), "solver.method", 0, 1)


def test_a_branch_figure_shows_what_happened():
    import matplotlib
    matplotlib.use("Agg")
    b = geardyn.continuation(ks(), "model.omega", 0.5, 1.5)
    fig = geardyn.plot.branch(b, "Omega")
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert labels == ["stable", "unstable", "fold", "grazing"]
