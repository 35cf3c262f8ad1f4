"""The example notebook and its script hold the same cells, and the notebook runs end to end.

`python python/tests/test_example.py` writes examples/compare.ipynb anew from
examples/compare.py (its `# %%` cells).
"""

import json
import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "compare.py"
NOTEBOOK = ROOT / "examples" / "compare.ipynb"


def cells_of_script(text: str) -> list:
    """The notebook cells of a script of `# %%` cells (`# %% [markdown]`: a comment block)."""
    cells = []
    for block in re.split(r"^# %%", text, flags=re.M)[1:]:
        header, _, body = block.partition("\n")
        body = body.strip("\n")
        if header.strip() == "[markdown]":
            lines = [line[2:] if line.startswith("# ") else line.lstrip("#") for line in body.splitlines()]
            cells.append({"cell_type": "markdown", "metadata": {}, "source": "\n".join(lines)})
        else:
            cells.append({"cell_type": "code", "execution_count": None, "metadata": {},
                          "outputs": [], "source": body})
    return cells


def notebook_of_script(text: str) -> dict:
    cells = cells_of_script(text)
    for cell in cells:
        cell["source"] = cell["source"].splitlines(keepends=True)
    return {
        "cells": cells,
        "metadata": {
            "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
            "language_info": {"name": "python"},
        },
        "nbformat": 4,
        "nbformat_minor": 5,
    }


def test_the_notebook_holds_the_scripts_cells():
    expected = notebook_of_script(SCRIPT.read_text())
    assert json.loads(NOTEBOOK.read_text()) == expected, (
        "examples/compare.ipynb differs from compare.py: run python python/tests/test_example.py"
    )


def test_the_notebook_runs_end_to_end(tmp_path, monkeypatch):
    notebook = json.loads(NOTEBOOK.read_text())
    monkeypatch.chdir(ROOT / "examples")
    monkeypatch.setenv("RAYLAB_EXAMPLE_OUT", str(tmp_path / "out"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    namespace = {"__name__": "__main__"}
    for k, cell in enumerate(notebook["cells"]):
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), f"compare.ipynb cell {k}", "exec"), namespace)
    written = {p.name for p in (tmp_path / "out").iterdir()}
    assert {"equal_time.png", "convergence.png", "redder.png", "compare", "sweep"} <= written
    assert (tmp_path / "out" / "compare" / "index.html").exists()


if __name__ == "__main__":
    NOTEBOOK.write_text(json.dumps(notebook_of_script(SCRIPT.read_text()), indent=1) + "\n")
    print("wrote", NOTEBOOK)
