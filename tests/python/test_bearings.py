"""geardyn.bearings against published worked examples, and the shipped case's bearing values."""

import json
import math
import os
import pathlib
import subprocess

import pytest

import geardyn
from geardyn.bearings import BallBearing

SOURCE = pathlib.Path(os.environ["GEARDYN_SOURCE_DIR"])

# The 6206 of eng-tools.dev's Hertz example ("A2 Hertz contact"): 9 balls of 9.525 mm on a
# 46.0 mm pitch circle, inner groove radius 4.89 mm; the outer groove (not given there, not used
# by its inner contact) at the usual conformity 0.52.
B6206 = BallBearing(balls=9, ball_diameter_mm=9.525, pitch_diameter_mm=46.0,
                    inner_groove_radius_mm=4.89, outer_groove_radius_mm=0.52 * 9.525)
# The deep-groove bearing of ISO/TS 16281's examples 1 and 2 (zero clearance, 1000 N).
ISO = BallBearing(balls=6, ball_diameter_mm=11.1, pitch_diameter_mm=43.5,
                  inner_groove_radius_mm=5.772, outer_groove_radius_mm=5.883)


def test_the_inner_contact_is_the_worked_examples():
    # Fr = 1000 N on the 6206: the most loaded ball's Q = 5 Fr / Z (Stribeck), and the example
    # prints E* 115.4 GPa, R 3.700 mm, k 12.19, a x b 1.368 x 0.112 mm, p0 1728 MPa.
    c = B6206.contact(5 * 1000 / 9, "inner")
    # Each to half a unit of the example's last printed digit.
    assert c["reduced_modulus_gpa"] == pytest.approx(115.4, abs=0.05)
    assert c["effective_radius_mm"] == pytest.approx(3.700, abs=5e-4)
    assert c["ellipticity"] == pytest.approx(12.19, abs=5e-3)
    assert c["semi_axes_mm"][0] == pytest.approx(1.368, abs=5e-4)
    assert c["semi_axes_mm"][1] == pytest.approx(0.112, abs=5e-4)
    assert c["peak_pressure_mpa"] == pytest.approx(1728, abs=0.5)


def test_the_deflections_are_iso_16281s_examples_within_two_percent():
    # Examples 1 (radial 1000 N: 16.9905 um) and 2 (axial 1000 N: 138.9128 um); the closed
    # forms of Hamrock and Brewe stay within 2 % of the standard's elliptic integrals.
    assert ISO.radial(1000.0)[0] * 1e6 == pytest.approx(16.9905, rel=0.01)
    assert ISO.axial(1000.0)[0] * 1e6 == pytest.approx(138.9128, rel=0.02)


@pytest.mark.parametrize("direction", ["radial", "axial"])
def test_the_stiffness_is_the_derivative_of_the_load_deflection_curve(direction):
    f = getattr(B6206, direction)
    for load in (50.0, 356.0, 2000.0):
        h = 1e-3 * load
        slope = 2 * h / (f(load + h)[0] - f(load - h)[0])
        assert f(load)[1] == pytest.approx(slope, rel=1e-6)
    # A Hertzian radial bearing: F ~ delta^1.5, so k = 1.5 F / delta.
    if direction == "radial":
        d, k = B6206.radial(356.0)
        assert k == pytest.approx(1.5 * 356.0 / d, rel=1e-12)


def test_bad_geometry_and_loads_are_named():
    with pytest.raises(ValueError, match="inner_groove_radius_mm = 4.0: must be > ball_"):
        BallBearing(9, 9.525, 46.0, 4.0, 5.0)
    with pytest.raises(ValueError, match="radial load_n = 0"):
        B6206.radial(0.0)


def test_the_shipped_coupled_case_has_the_6206_values_at_its_static_load(tmp_path):
    # Each gear on two 6206 bearings 80 mm apart, one locating: radial 2 k_r(F_line / 2), axial
    # k_a(F_axial), tilt k_r(F_line / 2) L^2 / 2, at the static mesh force of the case's torque
    # (the one-degree summary's static delta and base helix angle), two digits as shipped.
    path = SOURCE / "cases/park2010_coupled.toml"
    cli = os.environ.get("GEARDYN_CLI", "geardyn")
    subprocess.run([cli, "run", str(path), "--set", "solver.duration_s=0.001", "--out",
                    str(tmp_path)], check=True, capture_output=True)
    summary = json.loads((tmp_path / "summary.json").read_text())
    normal = summary["meshes"][0]["static_force_n"]
    case = geardyn.Case.from_toml(path)
    one = geardyn.run(case.with_({"model.form": "gear_pair", "solver.duration_s": 0.001}))
    helix = math.radians(one.summary["derived"]["base_helix_angle_deg"])
    line, axial = normal * math.cos(helix), normal * math.sin(helix)
    _, k_bearing = B6206.radial(line / 2)
    _, k_axial = B6206.axial(axial)
    span = 0.080
    for key, value in (("bearings.radial_stiffness_n_per_m", 2 * k_bearing),
                       ("bearings.axial_stiffness_n_per_m", k_axial),
                       ("bearings.tilt_stiffness_n_m_per_rad", k_bearing * span ** 2 / 2)):
        shipped = case[key]
        assert shipped[0] == shipped[1]
        assert shipped[0] == pytest.approx(value, rel=0.02), key
        assert shipped[0] == float(f"{value:.1e}"), key  # rounded to two digits
    # The defaults are the same bearings.
    default = geardyn.Case()
    for key in ("bearings.radial_stiffness_n_per_m", "bearings.axial_stiffness_n_per_m",
                "bearings.tilt_stiffness_n_m_per_rad"):
        assert list(default[key]) == list(case[key])
