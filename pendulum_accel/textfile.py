"""Read a user-given text file, its size, type and bytes checked: a scene's YAML whole (read_text_file), a
logger's CSV line by line in the encoding it was written in (text_lines). And write an output through the
one hidden partial name every writer uses, renamed only once complete."""

from __future__ import annotations

import codecs
import contextlib
import io
import os
import stat
from collections.abc import Callable, Iterator
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


@contextlib.contextmanager
def _regular_file(path: Path) -> Iterator[tuple[io.BufferedReader, int]]:
    """(binary handle, size in bytes) of regular file ``path``; OSError when it cannot be opened, ValueError
    when it is not a regular file. Opened without blocking and its type checked on the open descriptor
    before any read: a FIFO would block until a writer came, a device (/dev/zero) never ends."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        status = os.fstat(fd)
        kind = stat.S_IFMT(status.st_mode)
        if kind != stat.S_IFREG:
            raise ValueError(f"{_KINDS.get(kind, 'not a regular file')}, not a text file")
        os.set_blocking(fd, True)
        with os.fdopen(fd, "rb", closefd=False) as handle:
            yield handle, status.st_size
    finally:
        os.close(fd)


def read_head(path: Path, count: int) -> bytes:
    """The first ``count`` bytes of regular file ``path`` (all of it when shorter), opened as _regular_file
    opens it: OSError when it cannot be opened, ValueError for a FIFO or a device, before any read."""
    with _regular_file(path) as (handle, _):
        return handle.read(count)


def read_text_file(path: Path, limit: int = MAX_TEXT_BYTES) -> str:
    """UTF-8 text of regular file ``path`` (≤ ``limit`` bytes); OSError when unreadable, else ValueError.

    A leading byte-order mark (U+FEFF, which Excel and Windows tools write) is dropped: it is not part of
    the first value or header name.

    The file is opened as _regular_file opens it: a FIFO or a device is refused before any read.
    """
    data = read_head(path, limit + 1)
    if len(data) > limit:
        raise ValueError(f"more than {limit / 1024**2:g} MiB, not a text file of this kind")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(f"not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start})") from None


MAX_DATA_BYTES = 1024**3
"""A data file (a logger's CSV) is read line by line, so it may be large: an hour of a phone's 400 Hz
accelerometer in phyphox's layout is 85 MiB, and this bound (about half a day of it) only refuses what no
log is, before anything is read."""
HEAD_BYTES = 1024**2
"""The start of a data file that ``text_encoding`` decides its encoding on."""
LEGACY_ENCODING = "cp1252"
"""Windows-1252: what Excel writes a "CSV" in, in western locales, where "m/s²" is the byte 0xB2."""
_BOMS = ((codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


def text_encoding(head: bytes) -> str:
    """The encoding of a text file that starts with ``head``: the one its byte-order mark names (UTF-8, or
    UTF-16 as Excel's "Unicode Text" writes), else UTF-8 when ``head`` decodes as UTF-8 (a character cut
    at its end allowed), else Windows-1252 (LEGACY_ENCODING); ValueError for a NUL byte (binary data, or
    UTF-16 without its mark) or bytes that are neither.

    Pure ASCII reads the same in all of them, so the choice matters only for the text a file holds beyond
    ASCII, as in its header names."""
    for bom, encoding in _BOMS:
        if head.startswith(bom):
            return encoding
    nul = head.find(b"\x00")
    if nul >= 0:
        raise ValueError(f"not text: a NUL byte at offset {nul} (binary data, or UTF-16 without its mark?)")
    try:
        codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError as err:
        try:
            head.decode(LEGACY_ENCODING)
        except UnicodeDecodeError:
            raise ValueError(
                f"not UTF-8 text (byte 0x{head[err.start]:02x} at offset {err.start}), nor Windows-1252"
            ) from None
        return LEGACY_ENCODING
    return "utf-8"


def _decoded_lines(text: Iterator[str], encoding: str, ascii_head: bool) -> Iterator[str]:
    """The lines of ``text`` (decoded with surrogateescape), each checked: a byte the encoding could not
    decode is a ValueError naming its line, not a chunk's worth of lines later.

    ``ascii_head``: the file's head was ASCII, which reads the same in every encoding here, so UTF-8 was
    only a default: the first line with other bytes decides, as text_encoding decides on a head (UTF-8 when
    they decode as UTF-8, else Windows-1252). A long ASCII log whose first "°" or "ü" is a Windows-1252
    byte, past the head, reads as Windows-1252 from that line on."""
    legacy = 0  # the line that chose Windows-1252, once one has
    for number, line in enumerate(text, start=1):
        if line.isascii():
            yield line
            continue
        if legacy:
            yield _legacy_line(line, number, legacy)
            continue
        try:
            line.encode("utf-8")  # a surrogate escape (an undecodable byte) does not encode
        except UnicodeEncodeError as err:
            if ascii_head:
                legacy = number
                yield _legacy_line(line, number, legacy)
                continue
            byte = ord(line[err.start]) - 0xDC00
            raise ValueError(
                f"line {number} is not {encoding} text (byte 0x{byte:02x}), the encoding of the file's byte-"
                "order mark or its earlier text: save the file as UTF-8"
            ) from None
        ascii_head = False  # the first non-ASCII bytes are UTF-8: so is the file
        yield line


def _legacy_line(line: str, number: int, chosen: int) -> str:
    """``line`` (decoded as UTF-8 with surrogateescape, so its bytes come back whole) read as Windows-1252,
    the encoding line ``chosen`` decided; ValueError naming the line for a byte Windows-1252 leaves
    undefined."""
    raw = line.encode("utf-8", "surrogateescape")
    try:
        return raw.decode(LEGACY_ENCODING)
    except UnicodeDecodeError as err:
        byte = f"byte 0x{raw[err.start]:02x}"
        if number == chosen:
            raise ValueError(f"line {number} is neither UTF-8 nor Windows-1252 text ({byte})") from None
        raise ValueError(
            f"line {number} is not Windows-1252 text ({byte}), the encoding line {chosen} chose: save the "
            "file as UTF-8"
        ) from None


@contextlib.contextmanager
def text_lines(path: Path, limit: int = MAX_DATA_BYTES) -> Iterator[Iterator[str]]:
    """The lines of regular file ``path`` (≤ ``limit`` bytes), decoded in its encoding (text_encoding on its
    first HEAD_BYTES, or on its first non-ASCII line when those are ASCII: _decoded_lines) with universal
    newlines (``\\n``, ``\\r\\n``, and the ``\\r`` old Mac spreadsheets end rows with), read as they are
    iterated; OSError when unreadable, ValueError when not a regular file, too large or not text, or, from
    the iteration, at a line the encoding cannot decode. A byte-order mark is dropped.

    Opened by _regular_file, as read_text_file's is."""
    with _regular_file(path) as (raw, size):
        if size > limit:
            raise ValueError(
                f"{size / 1024**2:.0f} MiB, more than the {limit / 1024**2:g} MiB a data file may hold"
            )
        head = raw.read(HEAD_BYTES)
        encoding = text_encoding(head)
        raw.seek(0)
        with io.TextIOWrapper(raw, encoding=encoding, errors="surrogateescape", newline=None) as text:
            yield _decoded_lines(iter(text), encoding, encoding == "utf-8" and head.isascii())


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
