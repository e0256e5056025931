"""Read a small user-given text file (scene YAML, acceleration CSV): its size, type and bytes are checked.
And write an output through the one hidden partial name every writer uses, renamed only once complete."""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable
from pathlib import Path

MAX_TEXT_BYTES = 64 * 1024**2
"""Scene and profile files are kilobytes; anything past this (a disk image) is refused before it is read
into memory."""

_KINDS = {
    stat.S_IFDIR: "a directory",
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def not_a_file_or_directory(path: Path) -> str | None:
    """What ``path`` is when it exists but is neither a regular file nor a directory ("a FIFO (named
    pipe)", "a character device", ...), else None; a reader that opens it would block or never end."""
    try:
        kind = stat.S_IFMT(os.stat(path).st_mode)
    except OSError:
        return None
    if kind in (stat.S_IFREG, stat.S_IFDIR):
        return None
    return _KINDS.get(kind, "not a regular file")


def read_text_file(path: Path, limit: int = MAX_TEXT_BYTES) -> str:
    """UTF-8 text of regular file ``path`` (≤ ``limit`` bytes); OSError when unreadable, else ValueError.

    A leading byte-order mark (U+FEFF, which Excel and Windows tools write) is dropped: it is not part of
    the first value or header name.

    The file is opened without blocking and its type checked on the open descriptor before any read: a
    FIFO would block until a writer came, a device (/dev/zero) never ends.
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        kind = stat.S_IFMT(os.fstat(fd).st_mode)
        if kind != stat.S_IFREG:
            raise ValueError(f"{_KINDS.get(kind, 'not a regular file')}, not a text file")
        os.set_blocking(fd, True)
        with os.fdopen(fd, "rb", closefd=False) as handle:
            data = handle.read(limit + 1)
    finally:
        os.close(fd)
    if len(data) > limit:
        raise ValueError(f"more than {limit / 1024**2:g} MiB, not a text file of this kind")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(f"not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start})") from None


PARTIAL = ".partial"
"""What a partial name adds before the suffix (partial_path)."""


def partial_path(path: Path) -> Path:
    """Where ``path`` is written before it is complete: a hidden sibling with the same suffix (writers
    pick the format by it), ``.NAME.partial.SUFFIX``; the same directory, so the rename is atomic."""
    return path.with_name(f".{path.stem}{PARTIAL}{path.suffix}")


def remove_partial(path: Path) -> bool:
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


def write_through_partial(
    path: Path,
    write: Callable[[Path], object],
    failed: Callable[[OSError, bool], Exception] | None = None,
) -> Path:
    """``write(partial_path(path))`` (it creates the file), then os.replace it onto ``path``: until then
    ``path`` holds nothing new, so a failure or an interrupt never spoils a file already there. On any
    exception the partial file is removed (remove_partial) and the exception raised again, an OSError as
    ``failed(err, removed)`` when given. A device or FIFO (/dev/null, a pipe) is written directly."""
    if not_a_file_or_directory(path) is not None:
        try:
            write(path)
        except OSError as err:
            if failed is None:
                raise
            raise failed(err, False) from None
        return path
    partial = partial_path(path)
    try:
        write(partial)
        os.replace(partial, path)
    except OSError as err:
        removed = remove_partial(partial)
        if failed is None:
            raise
        raise failed(err, removed) from None
    except BaseException:
        remove_partial(partial)
        raise
    return path
