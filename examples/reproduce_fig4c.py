#!/usr/bin/env python3
"""The paper's Fig. 4(c) from Python: the Table 1 gear at f1 = 1 kHz, b = 100 um, xi = 0.02,
F_a/F_m = 0.25, over the reproduction's 20 ms window; the teeth rattle over the whole window.

    PYTHONPATH=build/release/python python3 examples/reproduce_fig4c.py --out fig4c.png
"""
import argparse

import matplotlib

matplotlib.use("Agg")

import geardyn  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="fig4c.png")
    args = ap.parse_args()

    case = geardyn.Case.default()  # Table 1 at the conditions of Fig. 4(c)
    case.set("solver.duration_s", 0.02)
    r = geardyn.run(case)
    s = r.summary
    print(f"Fig. 4(c): regime {s['regime']}, {s['impacts']} impacts, last separation at "
          f"{s['last_separation_s'] * 1e3:.2f} ms, separated {100 * s['separated_fraction']:.1f} %")
    fig = geardyn.plot.run(r, title="Fig. 4(c): f1 = 1 kHz, b = 100 um, xi = 0.02, Fa/Fm = 0.25")
    fig.savefig(args.out, dpi=120)
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
