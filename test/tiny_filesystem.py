"""A small tmpfs mounted for one test: a disk that fills up, or a read-only directory root cannot write."""

from __future__ import annotations

import contextlib
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest


@contextlib.contextmanager
def tiny_filesystem(where: Path, size: str, options: str = "") -> Iterator[Path]:
    """A tmpfs of ``size`` mounted at ``where`` (root only: CI runs as root) and unmounted afterwards."""
    if os.geteuid() != 0:
        pytest.fail(
            "this test mounts a small tmpfs to fill the disk: run it as root (CI does)", pytrace=False
        )
    where.mkdir()
    opts = f"size={size}" + (f",{options}" if options else "")
    subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(where)], check=True)
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)
