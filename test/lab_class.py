"""One class of the lab made once per test process (6 groups, a fixed test secret), shared by test_lab
and test_notebook: ``pendulum-accel lab make-class`` as a teacher runs it. Six groups: the filled student
notebook is graded right on each of them (test_notebook)."""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

from pendulum_accel.cli.main import main

GROUPS = 6
CLASS_NAME = "testclass"
SECRET = b"a fixed secret for the tests only, 47 bytes long"


@functools.lru_cache(maxsize=1)
def made_class() -> Path:
    """The class's directory: group_01..group_06 (folders and zips) and teacher_key.md."""
    root = Path(tempfile.mkdtemp(prefix="lab_class_"))
    atexit.register(shutil.rmtree, root, True)
    (root / "secret.txt").write_bytes(SECRET)
    out = root / "class"
    argv = ["lab", "make-class", "--secret", str(root / "secret.txt"), "--groups", str(GROUPS)]
    assert main([*argv, "--out", str(out), "--class", CLASS_NAME]) == 0
    return out
