"""Every output path of every command, checked before the work starts and written so that a failure is one
line that leaves nothing behind.

The rules, the same for every command (docs/hostile_inputs.md lists the messages):

* a file output must end in one of the command's suffixes, and its directory must exist and be writable;
  a missing directory is refused, never created, so that nothing is written outside the path asked for;
* a directory output (``export``'s tables, ``generate``'s bag) is created by the command, but its parent
  must exist: again nothing is created above the path asked for;
* an existing device or FIFO (``/dev/null``, a pipe) is written as given when its name has the suffix,
  so the suffix always says the format (``/dev/full`` is refused by name; a full disk fails at the write);
* an empty path, a directory where a file goes, a file where a directory goes (or in the path above it),
  a read-only or full file system are refused before any work;
* a file is written under a hidden partial name and renamed when complete: a write that fails later
  (the disk fills up, an encoder exits non-zero) or an interrupt leaves nothing under the asked name,
  removes what this command wrote, and says so.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TextIO

from pendulum_accel.errors import OutputError
from pendulum_accel.textfile import not_a_file_or_directory, remove_partial, write_through_partial


def _check_directory(directory: Path, shown: str, option: str) -> None:
    """OutputError unless ``directory`` exists, is a directory, is writable and has free space."""
    for above in (directory, *directory.parents):
        if above.exists() and not above.is_dir():
            raise OutputError(f"{option} {shown}: {above} is not a directory; nothing written")
    if not directory.exists():
        raise OutputError(
            f"{option} {shown}: directory {directory} does not exist (it is not created: create it first); "
            "nothing written"
        )
    # os.access sees a read-only mount (EROFS) and an immutable directory (EPERM) even for root.
    if not os.access(directory, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {shown}: directory {directory} is not writable; nothing written")
    try:
        free = os.statvfs(directory).f_bavail
    except OSError:
        return
    if free == 0:
        raise OutputError(f"{option} {shown}: no space left on the device of {directory}; nothing written")


def _given(path: Path | str, option: str) -> Path:
    """``path`` as a Path; OutputError for an empty one (``--out ""`` would mean the current directory) and
    for '-', standard output, where the command writes a file or a directory."""
    if str(path).strip() == "":
        raise OutputError(f"{option} is empty: give a path; nothing written")
    if str(path) == "-":  # commands that can write to stdout take '-' before they call this
        raise OutputError(
            f"{option} '-' (standard output) is not possible here: give a path; nothing written"
        )
    return Path(path)


def check_output_file(path: Path | str, suffixes: Sequence[str], *, option: str = "--out") -> Path:
    """``path`` as a Path if a file with one of ``suffixes`` (e.g. ``(".png",)``) can be written there,
    else OutputError (one line naming ``option``). A device or FIFO with the suffix is accepted as it is."""
    out = _given(path, option)
    shown = repr(str(path))
    if out.is_dir() or str(path).endswith(("/", os.sep)):
        raise OutputError(f"{option} {shown} is a directory; give a file name; nothing written")
    if out.suffix.lower() not in suffixes:
        raise OutputError(f"{option} {shown} must end in {' or '.join(suffixes)}; nothing written")
    if not_a_file_or_directory(out) is not None:
        return out
    _check_directory(out.parent, shown, option)
    if out.exists() and not os.access(out, os.W_OK):
        raise OutputError(f"{option} {shown} exists and is not writable; nothing written")
    return out


def check_output_dir(path: Path | str, *, option: str = "--out") -> Path:
    """``path`` as a Path if the command can create (or fill) the directory there, else OutputError.

    The directory may exist (a writable directory) or not (its parent must exist and be writable)."""
    out = _given(path, option)
    shown = repr(str(path))
    if out.exists() and not out.is_dir():
        raise OutputError(f"{option} {shown} exists and is not a directory; nothing written")
    _check_directory(out if out.is_dir() else out.parent, shown, option)
    return out


def _failure(path: Path, err: OSError, removed: bool, existed: bool) -> OutputError:
    """The one line for a write that failed: the cause, then what was kept."""
    kept = "the partial file was removed" if removed else "nothing was kept"
    if existed:
        kept += f"; the existing {path.name} is as it was"
    return OutputError(f"cannot write {path}: {err.strerror or err}; {kept}")


def write_output(path: Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(target)`` (it creates the file), then rename ``target`` to ``path``; OutputError naming
    the cause on any OSError (the writes', the close's, an encoder's exit status).

    ``target`` is textfile.partial_path (textfile.write_through_partial): until the rename, ``path`` holds
    nothing new, so a full disk, an error or an interrupt never leaves a partial file under the asked name
    (nor spoils a file already there), and the partial file is removed. A device or FIFO (/dev/null, a
    pipe) is written directly. Returns ``path``.
    """
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a directory; give a file name, nothing written")
    existed = path.exists() and not_a_file_or_directory(path) is None  # a device is not "as it was"
    return write_through_partial(path, write, lambda err, removed: _failure(path, err, removed, existed))


def write_text_output(path: Path, write: Callable[[TextIO], None]) -> None:
    """``write`` on ``path`` opened for UTF-8 text, through write_output (one line, no partial file)."""

    def text(target: Path) -> None:
        """Open and fill ``target``."""
        with target.open("w", encoding="utf-8", newline="") as handle:
            write(handle)

    write_output(path, text)


@contextlib.contextmanager
def output_directory(path: Path) -> Iterator[Path]:
    """Create directory ``path`` (if new) for the body to fill. When the body fails (an OSError, any other
    error, an interrupt), what it added is removed (the directory too when this call created it); an
    OSError becomes one OutputError line, anything else is re-raised."""
    existed = path.is_dir()
    before = set(path.iterdir()) if existed else set()
    try:
        path.mkdir(exist_ok=True)
        yield path
    except BaseException as err:
        if existed:
            for added in set(path.iterdir()) - before:
                if added.is_dir() and not added.is_symlink():
                    shutil.rmtree(added, ignore_errors=True)
                else:
                    remove_partial(added)
            kept = "what it wrote was removed"
        else:
            shutil.rmtree(path, ignore_errors=True)
            kept = "the partial directory was removed"
        if isinstance(err, OSError):
            raise OutputError(f"cannot write {path}: {err.strerror or err}; {kept}") from None
        raise


def json_text(value: object) -> str:
    """``value`` as strict JSON (RFC 8259): every NaN or ±inf becomes null, since JSON has no such number and
    most parsers refuse Python's bare NaN and Infinity; numpy scalars become plain numbers."""

    def finite(item: object) -> object:
        """``item`` with its non-finite floats replaced by None, recursively."""
        if isinstance(item, dict):
            return {key: finite(v) for key, v in item.items()}
        if isinstance(item, list | tuple):
            return [finite(v) for v in item]
        if type(item).__module__ == "numpy" and hasattr(item, "item"):  # a numpy scalar (numpy not imported)
            item = item.item()
        if isinstance(item, float) and not math.isfinite(item):
            return None
        return item

    return json.dumps(finite(value), allow_nan=False)
