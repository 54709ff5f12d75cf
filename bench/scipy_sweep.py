#!/usr/bin/env python3
"""The same sweep points with SciPy's solve_ivp, as a user's script would do them.

Compares time and accuracy with `geardyn sweep` on the Table 1 case: the model (eqs. 6-11 with
the energy-method stiffness harmonics geardyn computes) is written out in Python, each point is
settled and measured over the same whole periods, and the rms of F/(b k_m) is compared with
geardyn's sweep.csv.

    python3 bench/scipy_sweep.py --geardyn build/release/geardyn --sweep-csv DIR/sweep.csv

Needs Debian's python3-scipy (run it with /usr/bin/python3).
"""
import argparse
import csv
import json
import math
import subprocess
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp


def model_parameters(geardyn):
    """m_eq, cos(beta_b), b, k(t), c and F(t) of the Table 1 case, from geardyn itself."""
    out = tempfile.mkdtemp()
    subprocess.run([geardyn, "run", "--set", "solver.duration_s=1e-4", "--out", out],
                   check=True, capture_output=True)
    summary = json.load(open(f"{out}/summary.json"))
    stiffness = json.loads(subprocess.run([geardyn, "stiffness", "--json"], check=True,
                                          capture_output=True, text=True).stdout)
    d = summary["derived"]
    return {
        "m": d["m_eq_kg"],
        "cb": math.cos(math.radians(d["base_helix_angle_deg"])),
        "b": 100e-6,
        "km": stiffness["case_mean_stiffness_n_per_m"],
        "harmonics": stiffness["energy"]["harmonics"],
        "c": d["damping_n_s_per_m"],
        "fm": d["mean_force_n"],
        "fa_ratio": 0.25,
        "z1": 56,
    }


def simulate_point(p, f1, rtol, settle_periods, measure_periods, samples_per_period=64):
    m, cb2, b, km, c = p["m"], p["cb"] ** 2, p["b"], p["km"], p["c"]
    w1 = 2 * math.pi * f1
    wz = p["z1"] * w1
    h = [(r * km, i + 1, math.radians(ph)) for i, (r, ph) in enumerate(p["harmonics"])]
    fm, fa = p["fm"], p["fa_ratio"] * p["fm"]

    def stiffness(t):
        return km + sum(a * math.cos(i * wz * t + ph) for a, i, ph in h)

    def mesh_force(t, x, v):
        if x >= b:
            return stiffness(t) * (x - b) + c * v
        if x <= -b:
            return stiffness(t) * (x + b) + c * v
        return 0.0

    def rhs(t, y):
        x, v = y
        return [v, (fm + fa * math.cos(w1 * t) - cb2 * mesh_force(t, x, v)) / m]

    period = 2 * math.pi / w1
    # Static contact as the starting state, as geardyn's solver.initial = "static".
    y0 = [b + fm / (cb2 * km), 0.0]
    # Cap the step at a tenth of the second mesh harmonic's period, so that RK45 cannot step over
    # the stiffness variation or a short contact.
    max_step = 2 * math.pi / (2 * wz) / 10
    sol = solve_ivp(rhs, (0, settle_periods * period), y0, method="RK45", rtol=rtol,
                    atol=rtol * b, max_step=max_step)
    t0 = sol.t[-1]
    n = measure_periods * samples_per_period
    t_eval = t0 + np.arange(n) * period / samples_per_period
    sol = solve_ivp(rhs, (t0, t0 + measure_periods * period), sol.y[:, -1], method="RK45",
                    rtol=rtol, atol=rtol * b, max_step=max_step, t_eval=t_eval)
    forces = [mesh_force(t, x, v) / (b * km) for t, x, v in zip(sol.t, sol.y[0], sol.y[1])]
    return math.sqrt(sum(f * f for f in forces) / len(forces))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--geardyn", default="build/release/geardyn")
    ap.add_argument("--sweep-csv", required=True, help="geardyn's sweep.csv of the same sweep")
    ap.add_argument("--points", type=int, default=6, help="points simulated with SciPy")
    ap.add_argument("--rtol", type=float, default=1e-7)
    ap.add_argument("--from-hz", type=float, default=2500.0)
    ap.add_argument("--to-hz", type=float, default=3500.0)
    # SciPy starts each point from static contact, so it settles longer than geardyn's sweep
    # (which continues from the previous point) to compare at 1e-3; its time is then scaled to
    # the periods geardyn runs per point: 20 settling + 2 x 10 measured.
    ap.add_argument("--settle-periods", type=int, default=100)
    ap.add_argument("--measure-periods", type=int, default=10)
    ap.add_argument("--geardyn-periods", type=int, default=40)
    args = ap.parse_args()

    p = model_parameters(args.geardyn)
    rows = [r for r in csv.DictReader(open(args.sweep_csv)) if r["direction"] == "up"]
    total_points = sum(1 for _ in csv.DictReader(open(args.sweep_csv)))
    chosen = [r for r in rows if args.from_hz <= float(r["value"]) <= args.to_hz]
    step = max(1, len(chosen) // args.points)
    chosen = chosen[::step][: args.points]

    worst, elapsed = 0.0, 0.0
    for r in chosen:
        f1 = float(r["value"])
        start = time.perf_counter()
        rms = simulate_point(p, f1, args.rtol, args.settle_periods, args.measure_periods)
        elapsed += time.perf_counter() - start
        ref = float(r["rms_force_bar"])
        worst = max(worst, abs(rms - ref) / ref)
        print(f"f1 = {f1:8.2f} Hz: SciPy rms F/(b k_m) = {rms:.6f}, geardyn {ref:.6f}, "
              f"difference {abs(rms - ref) / ref:.2e}")
    simulated = args.settle_periods + args.measure_periods
    per_point = elapsed / len(chosen) * args.geardyn_periods / simulated
    print(f"SciPy solve_ivp (RK45, rtol {args.rtol:g}): {per_point:.2f} s per point of "
          f"{args.geardyn_periods} periods; "
          f"{total_points} points would take {per_point * total_points:.0f} s on one core "
          f"({per_point * total_points / 2:.0f} s on two)")
    print(f"largest difference of rms F/(b k_m) from geardyn: {worst:.2e}")


if __name__ == "__main__":
    main()
