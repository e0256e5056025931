"""The lab's notebooks (docs/lab/): stored without outputs; the solution reproduces the teacher key, the
student notebook runs with its blanks and prints no answer."""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from pendulum_accel.lecture.lab_key import parse_key

LAB = Path(__file__).resolve().parent.parent / "docs" / "lab"
SOLUTION = LAB / "teacher" / "solution.ipynb"
STUDENT = LAB / "student.ipynb"
KEY = LAB / "teacher" / "teacher_key.md"
ANSWER_LINE = re.compile(r"^answer (\w+) = (\S+)", re.MULTILINE)


def _execute(path: Path, tmp_path: Path) -> str:
    """Run every cell in a fresh kernel (an error fails the test); the text of all outputs."""
    nb = nbformat.read(path, as_version=4)
    NotebookClient(
        nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    return "\n".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )


@pytest.mark.parametrize("path", [SOLUTION, STUDENT], ids=["solution", "student"])
def test_notebook_is_stored_without_outputs(path: Path) -> None:
    """No outputs or execution counts in git: they would go stale and bloat the diff."""
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]


def test_solution_notebook_prints_the_teacher_keys_answers(tmp_path: Path) -> None:
    """Every answer in the key is printed by the solution notebook, equal within the answer's tol.

    Both come from lab_answers; the key was computed on another run (possibly another machine), so the
    printed values may differ by rounding in the solver and the fits, which each tol bounds (lab_answers).
    The key's own printing rounds by at most tol/5, leaving 4/5 of tol for that drift.
    """
    text = _execute(SOLUTION, tmp_path)
    printed = {m.group(1): float(m.group(2)) for m in ANSWER_LINE.finditer(text)}
    key = parse_key(KEY.read_text(encoding="utf-8"))
    assert key and set(key) == set(printed), set(key) ^ set(printed)
    for name, (value, tol) in key.items():
        assert abs(printed[name] - float(value)) <= tol, (name, printed[name], value, tol)


def test_student_notebook_runs_with_its_blanks_and_shows_no_answers(tmp_path: Path) -> None:
    """The blanks print reminders, not numbers; no answer line or fitted value leaks into the outputs."""
    text = _execute(STUDENT, tmp_path)
    assert "(blank: fill in)" in text
    assert not ANSWER_LINE.search(text)
    for name in ("ω", "θ_eq", "a", "g", "ω(a)/ω(0)", "T", "bias over whole periods", "RMS error kalman"):
        assert f"{name}: (blank: fill in)" in text, name
