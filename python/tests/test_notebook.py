"""examples/ptsa-from-python.ipynb runs, cell by cell, from the repository's root."""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "examples" / "ptsa-from-python.ipynb"


def test_every_cell_of_the_notebook_runs(monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(ROOT)
    cells = json.loads(NOTEBOOK.read_text())["cells"]
    code = [c for c in cells if c["cell_type"] == "code"]
    assert len(code) >= 5
    scope: dict = {}
    for k, c in enumerate(code):
        exec(compile("".join(c["source"]), f"{NOTEBOOK.name} cell {k + 1}", "exec"), scope)
        # A notebook shows a cell's last expression; it must at least evaluate.
    import matplotlib.pyplot as plt

    assert len(plt.get_fignums()) == 3, "each task draws its figure"
    plt.close("all")
