"""docs/lab.ipynb: stored without outputs, and every cell runs against the current package (nbclient)."""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "lab.ipynb"


def test_notebook_is_stored_without_outputs() -> None:
    """No outputs or execution counts in git: they would go stale and bloat the diff."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]


def test_notebook_runs_and_reaches_the_expected_answers(tmp_path: Path) -> None:
    """Execute every cell in a fresh kernel (an error fails the test) and check the key printed answers."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    text = "\n".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )
    assert "ratio 0.8409 (2^-1/4 = 0.8409)" in text  # exercise 1: the period shrinks by 2^-1/4
    assert "g tan β = 0.9807" in text and "estimated (kalman) 0.98" in text  # exercise 4: the hill's reading
