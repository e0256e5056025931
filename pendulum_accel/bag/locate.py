"""Finding a bag: its MCAP files in recording order, its metadata.yaml, and the paths it may name.

A bag is a directory (rosbag2's layout) or a bare ``.mcap`` file. A directory's files are those its
metadata.yaml lists (``relative_file_paths``, several for a split recording), in that order; without
them (a renamed copy, no metadata) its ``*.mcap`` files in recording order by name. Input that is not
an MCAP bag (a ROS 1 bag, rosbag2's SQLite storage, a file or bag compressed whole or message by
message, a FIFO or device) is refused with one line that says how to convert it. A metadata.yaml
naming a file outside the bag directory (absolute, ``..``, a symlink leading out) is refused: nothing
outside the bag is ever read, renamed or deleted through it.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from pendulum_accel.bag.errors import ReaderError
from pendulum_accel.bag.mcap_file import MAGIC
from pendulum_accel.bag.metadata import load_metadata
from pendulum_accel.textfile import not_a_file_or_directory


@dataclass(frozen=True)
class Located:
    """A bag's directory (or bare .mcap file), its MCAP files in recording order, its parsed
    metadata.yaml (None: none), and a sentence naming files the metadata lists that are missing."""

    root: Path
    files: list[Path]
    doc: object
    """The parsed metadata.yaml as read (any YAML value; None without one): see metadata.listed_counts."""
    gone: tuple[str, ...] = ()
    """Files metadata.yaml lists that are not there."""

    @property
    def missing(self) -> str | None:
        """One sentence naming the files that are not there; None when none is missing."""
        if not self.gone:
            return None
        listed = len(self.files) + len(self.gone)
        verb = "is" if len(self.gone) == 1 else "are"
        return (
            f"bag {self.root}: metadata.yaml lists {listed} files and {', '.join(self.gone)} {verb} missing; "
            f"read the {len(self.files)} there"
        )


def _recording_order(name: str) -> list[str | int]:
    """Sort key of a file name with its digit runs as numbers: rosbag2 names a split recording's files
    ``<bag>_0.mcap``, ``<bag>_1.mcap``, …, ``<bag>_10.mcap``, and 10 comes after 9."""
    return [int(part) if i % 2 else part for i, part in enumerate(re.split(r"(\d+)", name))]


def locate(path: Path) -> Located:
    """The MCAP files of a bag directory or a bare .mcap file; the metadata is parsed here once, for the
    file names and for read_bag.

    A directory's files are those its metadata.yaml lists (``relative_file_paths``; several for a split
    recording), in that order. When none of them is there (a renamed copy) or there is no metadata, its
    ``*.mcap`` files are the bag, in recording order by name.
    """
    odd = not_a_file_or_directory(path)
    if odd is not None:
        # Opening a FIFO for reading would wait for a writer forever; a device is no bag either.
        raise ReaderError(f"bag {path} is {odd}, not a bag directory or an .mcap file")
    if path.is_file():
        _check_magic(path)
        return Located(path, [path], None)
    if not path.is_dir():
        raise ReaderError(f"bag {path} does not exist")
    meta = path / "metadata.yaml"
    doc = None
    if meta.is_file():
        doc = load_metadata(meta)
        info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
        info = info if isinstance(info, dict) else {}
        files = info.get("relative_file_paths")
        if str(info.get("compression_mode") or "").upper() == "MESSAGE":
            # Each payload is a zstd frame, not CDR: read as CDR, every message would look damaged.
            raise ReaderError(
                f"bag {path}: its messages are compressed one by one (rosbag2's --compression-mode "
                f"message, {info.get('compression_format') or 'unnamed'}); {convert_hint(path)}"
            )
        # A metadata.yaml of another shape names nothing usable: look for the MCAP files instead.
        names = [str(f) for f in files] if isinstance(files, list) else []
        listed = [inside_bag(path, name) for name in names]
        present = [p for p in listed if p.is_file()]
        for name, target in zip(names, listed, strict=True):
            if target.is_file() and name.endswith(".mcap.zstd"):
                # rosbag2's --compression-mode file: the whole MCAP file is one zstd frame.
                raise ReaderError(
                    f"bag {path}: {name} is an MCAP file compressed whole (rosbag2's --compression-mode "
                    f"file); {convert_hint(path)}"
                )
            if target.is_file() and not name.endswith(".mcap"):
                raise ReaderError(f"bag {path} uses storage {name!r}, not MCAP; {convert_hint(path)}")
        if present:
            return Located(path, present, doc, tuple(p.name for p in listed if not p.is_file()))
    named = sorted(
        (f for f in path.glob("*.mcap") if not f.is_symlink() or _within(path, f)),
        key=lambda f: _recording_order(f.name),
    )
    found = [f for f in named if f.is_file()]
    if not found and named:
        what = not_a_file_or_directory(named[0]) or "a directory"
        raise ReaderError(f"bag {path}: {named[0].name} is {what}, not an MCAP file")
    if not found:
        raise ReaderError(f"bag {path} holds no .mcap file: not a bag directory")
    return Located(path, found, doc)


def convert_hint(source: Path) -> str:
    """'convert it: rosbags-convert --src SRC --dst SRC-mcap --dst-storage mcap': rosbags (a dependency,
    so the command is installed beside ours) rewrites a ROS 1 bag, a rosbag2 SQLite bag or a compressed
    one as an uncompressed MCAP bag, which every command reads."""
    name = source.name.removesuffix(".bag") if source.is_file() else source.name
    dst = source.parent / f"{name}-mcap"
    return f"convert it: rosbags-convert --src {source} --dst {dst} --dst-storage mcap"


_ROS1_MAGIC = b"#ROSBAG V2.0"
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"


def _check_magic(path: Path) -> None:
    """BagError unless the regular file ``path`` starts with the MCAP magic bytes (or cannot be read)."""
    try:
        with path.open("rb") as handle:
            head = handle.read(len(_ROS1_MAGIC))
    except OSError as err:
        raise ReaderError(f"cannot read {path}: {err.strerror or err}") from None
    if head.startswith(_ROS1_MAGIC):
        raise ReaderError(f"{path} is a ROS 1 bag, not MCAP; {convert_hint(path)}")
    if head.startswith(_ZSTD_MAGIC):
        # rosbags converts a bag directory; a file compressed on its own is decompressed on its own.
        parent = path.parent
        hint = (
            convert_hint(parent) if (parent / "metadata.yaml").is_file() else f"decompress it: zstd -d {path}"
        )
        raise ReaderError(f"{path} is compressed whole (zstd), not MCAP; {hint}")
    if not head.startswith(MAGIC):
        raise ReaderError(f"{path} is not an MCAP file (bad magic bytes)")


def inside_bag(root: Path, name: str) -> Path:
    """root / name for a file name from a bag's metadata; BagError when it would lead out of ``root``.

    Refused: an absolute path, a ``..`` component, and a name (or symlink) resolving outside ``root``.
    """
    parts = Path(name).parts
    if not name or Path(name).is_absolute() or ".." in parts or "\0" in name:
        raise ReaderError(f"bag {root}: metadata.yaml names {name!r}, outside the bag directory; refused")
    target = root / name
    if not _within(root, target):
        raise ReaderError(f"bag {root}: metadata.yaml names {name!r}, which leads outside the bag; refused")
    return target


def _within(root: Path, target: Path) -> bool:
    """True when ``target`` (symlinks resolved) lies inside ``root`` (symlinks resolved)."""
    base = os.path.realpath(root)
    return os.path.commonpath([base, os.path.realpath(target)]) == base
