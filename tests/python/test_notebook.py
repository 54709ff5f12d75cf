"""The tutorial notebook runs from start to end (Debian's python3-nbclient and ipykernel) and
writes its figures."""
import os
import pathlib

import nbclient
import nbformat

SOURCE = pathlib.Path(os.environ["GEARDYN_SOURCE_DIR"])


def test_the_tutorial_executes_and_writes_its_figures(tmp_path, monkeypatch):
    nb = nbformat.read(SOURCE / "examples/tutorial.ipynb", as_version=4)
    monkeypatch.setenv("GEARDYN_TUTORIAL_OUT", str(tmp_path))
    nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    for name in ("run", "sweep", "map", "branch"):
        assert (tmp_path / f"tutorial_{name}.png").stat().st_size > 10000, name
    outputs = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                      for o in c.get("outputs", []))
    assert "fold" in outputs and "grazing" in outputs
