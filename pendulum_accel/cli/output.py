"""Write a command's output file so that a failure is one line and leaves no partial file behind."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import TextIO

from pendulum_accel.errors import OutputError


def write_text_output(path: Path, write: Callable[[TextIO], None]) -> None:
    """Call ``write`` on ``path`` opened for text; OutputError naming the cause on any OSError.

    A regular file this call created or truncated is removed on failure (no partial output); a device
    such as /dev/full is left alone. The message says that nothing was kept.
    """
    existed = path.exists()
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a directory; give a file name, nothing written")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", encoding="utf-8", newline="") as handle:
            write(handle)
    except OSError as err:
        removed = _remove_partial(path)
        kept = "the partial file was removed" if removed else "nothing was kept"
        if existed and not removed:
            kept = "nothing was written"
        raise OutputError(f"cannot write {path}: {err.strerror or err}; {kept}") from None


def _remove_partial(path: Path) -> bool:
    """Delete ``path`` if it is a regular file (never a device or directory); True when removed."""
    try:
        if not path.is_file() or not os.path.isfile(os.path.realpath(path)):
            return False
    except OSError:
        return False
    with contextlib.suppress(OSError):
        path.unlink()
        return True
    return False
