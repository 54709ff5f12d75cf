#!/usr/bin/env python3
"""Checks the numbers the docs, the README and the shipped cases' comments quote from the
shipped cases against the tool: each claim below names the file, the words around the number
(a regular expression whose groups are the numbers), the geardyn command the numbers come from
and how to read them out of its output. A quoted number agrees when it is the tool's value
rounded to the digits it is written with; otherwise the claim fails, with both values.

    python3 scripts/check_docs.py [--geardyn build/release/geardyn] [--quick]

--quick leaves out the claims whose command takes more than a few seconds (the test suite's
`docs_numbers` runs the whole list). Exit 0 when every claim agrees, 1 otherwise, 2 when a
claim's words are no longer in its file (the claim must then be moved with the text)."""
import argparse
import json
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent


def mode_by_energy(modes, part, element):
    """The mode holding most of the strain energy in `element` (a shaft, a mesh)."""
    return max(modes["modes"], key=lambda m: m.get(part, {}).get(element, 0.0))


def first_mode(modes):
    """The lowest mode that is not a rigid-body rotation."""
    return min((m for m in modes["modes"] if m["frequency_hz"] > 0),
               key=lambda m: m["frequency_hz"])


def mesh(summary, name):
    return next(m for m in summary["meshes"] if m["name"] == name)


REDUCER = "cases/two_stage_reducer.toml"
TURBINE = "cases/wind_turbine_grc750.toml"

# (file, pattern with one group per number, command, the numbers from its output, slow)
# A command is "modes CASE", "describe CASE" or "validate" (their --json), or "run CASE" (its
# summary.json).
CLAIMS = [
    ("docs/sweeps.md", r"vehicle \(shuffle\) mode, ([\d.]+) Hz, damped ([\d.]+) %",
     ("modes", REDUCER),
     lambda j: [mode_by_energy(j, "shaft_energy", "half_shafts")["frequency_hz"],
                100 * mode_by_energy(j, "shaft_energy", "half_shafts")["damping_ratio"]], False),
    ("cases/two_stage_reducer.toml", r"the vehicle's shuffle mode \(([\d.]+) Hz\)",
     ("modes", REDUCER),
     lambda j: [mode_by_energy(j, "shaft_energy", "half_shafts")["frequency_hz"]], False),
    ("cases/two_stage_reducer.toml", r"common period \(61/23 motor turns, ([\d.]+) ms\)",
     ("run", REDUCER), lambda s: [1e3 * s["system_period_s"]], False),
    ("cases/two_stage_reducer.toml", r"motor\n# turns\) at about ([\d.]+) s",
     ("run", REDUCER), lambda s: [s["steady"]["from_s"]], False),
    ("docs/sweeps.md", r"first mode, ([\d.]+) % damped at ([\d.]+) Hz",
     ("modes", TURBINE),
     lambda j: [100 * first_mode(j)["damping_ratio"], first_mode(j)["frequency_hz"]], False),
    ("cases/wind_turbine_grc750.toml", r"first mode \(([\d.]+) Hz\)", ("modes", TURBINE),
     lambda j: [first_mode(j)["frequency_hz"]], False),
    ("cases/wind_turbine_grc750.toml",
     r"engage at 99 x [\d.]+ = ([\d.]+) Hz .*\n# intermediate stage at ([\d.]+) Hz, the "
     r"high-speed stage at ([\d.]+) Hz", ("describe", TURBINE),
     lambda d: [mesh(d, "ring_planet1")["mesh_frequency_hz"],
                mesh(d, "intermediate")["mesh_frequency_hz"],
                mesh(d, "high_speed")["mesh_frequency_hz"]], False),
    ("docs/numerics.md", r"wind-turbine gearbox's is ([\d.]+) s", ("run", TURBINE),
     lambda s: [s["system_period_s"]], True),
    ("cases/wind_turbine_grc750.toml", r"give them a common period of ([\d.]+) s",
     ("run", TURBINE), lambda s: [s["system_period_s"]], True),
    ("cases/wind_turbine_grc750.toml", r"agree from about ([\d.]+) s on", ("run", TURBINE),
     lambda s: [s["steady"]["from_s"]], True),
    ("README.md", r"14 s of it, steady from ([\d.]+) s", ("run", TURBINE),
     lambda s: [s["steady"]["from_s"]], True),
    ("README.md", r"`geardyn validate` re-runs (\d+) of\s+those comparisons", ("validate", None),
     lambda v: [len(v["rows"])], False),
]


def decimals(text):
    return len(text.split(".")[1]) if "." in text else 0


def agrees(quoted, value):
    """`quoted` (as written) is `value` rounded to its digits."""
    return abs(value - float(quoted)) <= 0.5 * 10 ** -decimals(quoted) * (1 + 1e-9)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--geardyn", default=str(ROOT / "build" / "release" / "geardyn"))
    p.add_argument("--quick", action="store_true", help="leave out the slow claims")
    a = p.parse_args()
    outputs = {}

    def output(command):
        if command not in outputs:
            kind, case = command
            if kind == "run":
                with tempfile.TemporaryDirectory() as d:
                    subprocess.run([a.geardyn, "run", case, "--out", d],
                                   cwd=ROOT, check=True, capture_output=True)
                    outputs[command] = json.loads((pathlib.Path(d) / "summary.json").read_text())
            else:
                r = subprocess.run([a.geardyn, kind] + ([case] if case else []) + ["--json"],
                                   cwd=ROOT, check=True, capture_output=True, text=True)
                outputs[command] = json.loads(r.stdout)
        return outputs[command]

    failed = missing = 0
    for file, pattern, command, read, slow in CLAIMS:
        if slow and a.quick:
            continue
        text = (ROOT / file).read_text()
        m = re.search(pattern, text)
        if not m:
            print(f"{file}: the words of a checked claim are gone: /{pattern}/ (move the claim "
                  "in scripts/check_docs.py with its text)")
            missing += 1
            continue
        line = text[:m.start()].count("\n") + 1
        values = read(output(command))
        for quoted, value in zip(m.groups(), values):
            ok = agrees(quoted, value)
            failed += not ok
            print(f"{'ok  ' if ok else 'FAIL'} {file}:{line}: {quoted} "
                  f"(geardyn {' '.join(c for c in command if c)}: {value:.6g})")
    if missing:
        sys.exit(2)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
