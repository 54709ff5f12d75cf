#!/usr/bin/env python3
"""The library's layers and where its declarations live, checked from the sources.

Layers, lowest first; a file may include its own layer's headers and those below, never one
above:

  support   what knows nothing of dynamics: errors, threads, CSV, folders, spelling
  engine    the piecewise-linear systems and their integrators: nothing of gears
  elements  the train's elements and their assembly into such a system
  model     case files, gear data, stiffness, presets, the static state
  studies   runs, sweeps, orbits, continuation, stability, samples, reproduction, validation
  output    summaries, files and figures of the studies' results
  reference the reference implementations the tests and `geardyn validate` hold the library to
            (reference/: the one-degree and coupled models' own runs and orbits, the
            validation): nothing of
            the library includes them

The command line (apps/) and the Python package (python/src/) sit above them all. Every file of
src/, include/geardyn/, reference/ and reference/include/geardyn/ must be in LAYERS, so that a new file is placed on purpose,
and a source of src/ lies in its layer's folder, src/<layer>/ (the public headers stay together
in include/geardyn/, as users include them).

Every function declared at namespace scope in a header NAME.hpp and defined in a source is
defined in NAME.cpp: a declaration sits beside its definition.

    python3 tests/lint/layers.py [SOURCE_DIR]

Exit 0 when all holds, 1 with each breach on its own line otherwise. Before reading the tree it
checks itself on a planted upward include (an engine file including a study's header), which
it must report.
"""
import pathlib
import re
import sys

ORDER = ["support", "engine", "elements", "model", "studies", "output", "reference"]

LAYERS = {
    "support": ["input_error", "parallel", "csv", "suggest", "output_folder", "harmonic_series"],
    "engine": ["integrator", "linear_system", "engine", "adaptive", "newmark_flow",
               "rigid_split", "steady", "spectrum", "guard_crossing"],
    "elements": ["kinematics", "joint", "train"],
    "model": ["case", "case_keys", "toml_source", "geometry", "stiffness", "transmission_error",
              "train_case", "element_keys", "damper", "drag", "train_presets", "planetary_preset", "train_statics", "plausibility",
              "describe", "model", "case_model", "coupled_model"],
    "studies": ["analysis", "contact_tracker", "run", "train_run", "train_steadiness", "orbit",
                "train_orbit", "shooting", "continuation", "stability", "sweep",
                "study_sample", "reproduce"],
    "output": ["output", "figures", "train_figures", "mesh_stiffness_report", "sweep_output",
               "continuation_output", "stability_output", "reproduce_output"],
    "reference": ["one_degree_reader", "one_degree_run", "one_degree_shooting", "one_degree_orbit",
                  "coupled_run", "coupled_orbit", "validation", "validation_output"],
}

INCLUDE = re.compile(r'^#include "(?:geardyn/|[a-z]+/)?([a-z_]+)\.hpp"', re.M)


def layer_of():
    table = {}
    for layer, stems in LAYERS.items():
        for stem in stems:
            table[stem] = ORDER.index(layer)
    return table


def sources(root):
    """Every source and header of the library and of its references."""
    out = sorted((root / "src").rglob("*.[ch]pp")) + sorted((root / "reference").glob("*.[ch]pp"))
    for folder in ("include", "reference/include"):
        out += sorted((root / folder / "geardyn").glob("*.hpp"))
    return out


def includes(root):
    """{(file name, header name)} of every quoted include of sources(root)."""
    found = set()
    for path in sources(root):
        for stem in INCLUDE.findall(path.read_text()):
            found.add((path.name, stem + ".hpp"))
    return found


def folder_breaches(root, layers):
    """A source of src/ outside the folder of its layer (src/<layer>/)."""
    out = []
    for path in sorted((root / "src").rglob("*.[ch]pp")):
        layer = layers.get(path.stem)
        if layer is not None and path.parent != root / "src" / ORDER[layer]:
            out.append(f"{path.relative_to(root)}: its layer is {ORDER[layer]}, its folder "
                       f"src/{ORDER[layer]}/")
    return out


def layer_breaches(found, layers):
    out = []
    for name, header in sorted(found):
        here, there = pathlib.Path(name).stem, pathlib.Path(header).stem
        for stem in (here, there):
            if stem not in layers:
                out.append(f"{stem}: in no layer (add it to LAYERS in tests/lint/layers.py)")
        if here not in layers or there not in layers or layers[there] <= layers[here]:
            continue
        out.append(f"{name} ({ORDER[layers[here]]}) includes {header} ({ORDER[layers[there]]}):"
                   " an include that points up a layer")
    return sorted(set(out))


DECLARATION = re.compile(
    r"^(?!namespace|struct|class|using|enum|template|constexpr|inline|extern|static|friend|"
    r"return|typedef)[A-Za-z][\w:<>,*& ]*?[\s*&]([a-z_]\w*)\(([^;{}]*?)\)\s*(?:const)?\s*;",
    re.M)
DEFINITION = re.compile(
    r"^(?!namespace|struct|class|using|static|constexpr)[A-Za-z][\w:<>,*& ]*?[\s*&]"
    r"(?:[\w:<>]+::)?([a-z_]\w*)\(([^;{}]*?)\)\s*(?:const)?\s*(?:->[^{;]*)?\{",
    re.M)


def declaration_breaches(root):
    defined = {}
    for path in sources(root):
        if path.suffix == ".cpp":
            for name, _ in DEFINITION.findall(path.read_text()):
                defined.setdefault(name, set()).add(path.stem)
    out = []
    for header in sources(root):
        if header.suffix != ".hpp" or header.parent.name != "geardyn":
            continue
        for name, _ in DECLARATION.findall(header.read_text()):
            where = defined.get(name, set())
            if where and header.stem not in where:
                out.append(f"{name}: declared in {header.relative_to(root)}, defined in "
                           + ", ".join(f"{s}.cpp" for s in sorted(where)))
    return out


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                        pathlib.Path(__file__).resolve().parents[2])
    layers = layer_of()
    planted = layer_breaches({("engine.cpp", "train_run.hpp")}, layers)
    if not any("points up" in b for b in planted):
        print("layers.py: the planted include engine.cpp -> train_run.hpp was not reported")
        return 1
    breaches = (layer_breaches(includes(root), layers) + declaration_breaches(root) +
                folder_breaches(root, layers))
    for b in breaches:
        print(b)
    if not breaches:
        print(f"{len(LAYERS)} layers, {sum(map(len, LAYERS.values()))} files: no include points "
              "up a layer, every source in its layer's folder, every declaration beside its "
              "definition")
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main())
