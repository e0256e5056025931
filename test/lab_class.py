"""One class of the lab (6 groups, a fixed test secret), shared by test_lab and test_notebook.

``pendulum-accel lab make-class`` as a teacher runs it, made once per test run (conftest's ``lab_class``
fixture, shared by every xdist worker). Six groups: the filled student notebook is graded right on each of
them (test_notebook)."""

from __future__ import annotations

from pathlib import Path

from pendulum_accel.cli.main import main

GROUPS = 6
CLASS_NAME = "testclass"
SECRET = b"a fixed secret for the tests only, 47 bytes long"


def make_class(root: Path) -> None:
    """The class made in ``root``/class: group_01..group_06 (folders and zips) and teacher_key.md."""
    (root / "secret.txt").write_bytes(SECRET)
    argv = ["lab", "make-class", "--secret", str(root / "secret.txt"), "--groups", str(GROUPS)]
    assert main([*argv, "--out", str(root / "class"), "--class", CLASS_NAME]) == 0
