"""Wall time of `geardyn run` as a user types it, files included (docs/performance.md, "A run's
files"): the paper's pair over 0.3 s (134 400 samples) as itself and as its train, and shipped
cases as they are, each into a fresh folder. Best of --repeat rounds in which every command runs
once in turn, so that the machine's drifting speed slows all columns alike; with --against, the
same commands of a second build beside the first, interleaved, and their ratio.

    python3 bench/run_command.py [--geardyn build/release/geardyn] [--against OTHER] [--repeat 21]
"""
import argparse
import pathlib
import shutil
import subprocess
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
LONG = ["--set", "solver.duration_s=0.3"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--geardyn", default=str(ROOT / "build/release/geardyn"))
    p.add_argument("--against", help="a second geardyn binary, timed beside the first")
    p.add_argument("--repeat", type=int, default=21)
    a = p.parse_args()
    binaries = {"geardyn": a.geardyn}
    if a.against:
        binaries["against"] = a.against
    with tempfile.TemporaryDirectory() as scratch:
        scratch = pathlib.Path(scratch)
        pair_train = scratch / "pair_train.toml"
        pair_train.write_text(subprocess.run(
            [a.geardyn, "train-form", str(ROOT / "cases/park2010.toml")], check=True,
            capture_output=True, text=True).stdout)
        commands = [
            ("the pair, 0.3 s", [str(ROOT / "cases/park2010.toml"), *LONG]),
            ("the pair as its train, 0.3 s", [str(pair_train), *LONG]),
            ("cases/park2010.toml", [str(ROOT / "cases/park2010.toml")]),
            ("cases/two_stage_reducer.toml", [str(ROOT / "cases/two_stage_reducer.toml")]),
            ("cases/loose_gear_rattle.toml", [str(ROOT / "cases/loose_gear_rattle.toml")]),
        ]
        best = {}
        out = scratch / "out"
        for _ in range(a.repeat):
            for name, args in commands:
                for which, binary in binaries.items():
                    shutil.rmtree(out, ignore_errors=True)
                    t = time.perf_counter()
                    subprocess.run([binary, "run", *args, "--out", str(out)], check=True,
                                   stdout=subprocess.DEVNULL)
                    dt = time.perf_counter() - t
                    best[name, which] = min(best.get((name, which), float("inf")), dt)
    head = "| command | geardyn (ms) |" + (" against (ms) | against / geardyn |" if a.against else "")
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for name, _ in commands:
        row = f"| {name} | {1e3 * best[name, 'geardyn']:.1f} |"
        if a.against:
            row += (f" {1e3 * best[name, 'against']:.1f} |"
                    f" {best[name, 'against'] / best[name, 'geardyn']:.2f} |")
        print(row)


if __name__ == "__main__":
    main()
