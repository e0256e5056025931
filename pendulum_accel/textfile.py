"""Read a small user-given text file (scene YAML, acceleration CSV) without trusting its size or bytes."""

from __future__ import annotations

from pathlib import Path

MAX_TEXT_BYTES = 64 * 1024**2
"""Scene and profile files are kilobytes; anything past this (``/dev/zero``, a disk image) is refused
before it is read into memory."""


def read_text_file(path: Path, limit: int = MAX_TEXT_BYTES) -> str:
    """UTF-8 text of ``path`` (≤ ``limit`` bytes); OSError when unreadable, else ValueError (one line)."""
    with path.open("rb") as handle:
        data = handle.read(limit + 1)
    if len(data) > limit:
        raise ValueError(f"more than {limit / 1024**2:g} MiB, not a text file of this kind")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start})") from None
