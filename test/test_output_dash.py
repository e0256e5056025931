"""``--out -``: standard output where a command writes one table (simulate, sweep, export --merged), one
line and exit 2 where it writes a file or a directory; never a file named '-'."""

from __future__ import annotations

import io
from pathlib import Path

import pandas as pd
import pytest

from pendulum_accel.cli.main import main

REPO = Path(__file__).resolve().parent.parent
GOLDEN = REPO / "bags" / "step_start"


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test runs in its own empty directory, where a file named '-' would show."""
    monkeypatch.chdir(tmp_path)


def _no_dash(tmp_path: Path) -> None:
    assert not (tmp_path / "-").exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "at_rest", "--duration", "0.2", "--out", "-"],
        ["sweep", "at_rest", "--length", "0.5,1", "--duration", "0.2", "--no-progress", "--out", "-"],
        ["export", str(GOLDEN), "--merged", "--no-smoothed", "--out", "-"],
    ],
    ids=["simulate", "sweep", "export"],
)
def test_a_single_table_goes_to_stdout(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The CSV is on stdout (a header and rows parse as a table), nothing lands in the directory."""
    assert main(argv) == 0
    out = capsys.readouterr().out
    table = pd.read_csv(io.StringIO(out))
    assert len(table) >= 2 and len(table.columns) >= 2 and table.iloc[:, 0].notna().all()
    _no_dash(tmp_path)


@pytest.mark.parametrize(
    "argv",
    [
        ["export", str(GOLDEN), "--out", "-"],
        ["export", str(GOLDEN), "--merged", "--format", "parquet", "--out", "-"],
        ["generate", "at_rest", "--duration", "0.2", "--out", "-"],
        ["animate", "at_rest", "--duration", "0.2", "--out", "-"],
        ["simulate", "at_rest", "--duration", "0.2", "--plot", "-"],
    ],
    ids=["export-tables", "export-parquet", "generate", "animate", "plot"],
)
def test_dash_is_refused_where_the_output_is_a_file_or_a_directory(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One line naming '-' and standard output, exit 2, nothing written."""
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "'-'" in captured.err and "standard output" in captured.err
    assert "Traceback" not in captured.err and captured.out == ""
    _no_dash(tmp_path)


def test_no_file_named_dash_is_tracked() -> None:
    """The repository holds no stray '-' (a CSV an old `--out -` once wrote into the working directory)."""
    assert not (REPO / "-").exists()
