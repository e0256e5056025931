"""A disk that is full, or fills up during the write: one line, nothing partial left, and a damaged bag
given to repair left as it was. Each test mounts a tmpfs of a few KiB (test/tiny_filesystem.py; root only,
as CI runs)."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import pytest

from pendulum_accel.recording.generate import generate_bag
from test.conftest import cli
from test.refusal import one_line_error
from test.test_bag_io import _write_chain_bag
from test.tiny_filesystem import tiny_filesystem


def test_simulate_on_a_full_disk_leaves_no_partial_csv(tmp_path: Path) -> None:
    with tiny_filesystem(tmp_path / "fs", "64k") as fs:
        one_line_error(
            cli("simulate", "lecture_constant", "--out", str(fs / "run.csv")), "partial file was removed"
        )
        assert list(fs.iterdir()) == []


def test_generate_on_a_full_disk_leaves_no_partial_bag(tmp_path: Path) -> None:
    with tiny_filesystem(tmp_path / "fs", "512k") as fs:
        one_line_error(
            cli("generate", "lecture_constant", "--out", str(fs / "bag")), "partial bag was removed"
        )
        assert list(fs.iterdir()) == []


def test_repair_on_a_full_disk_leaves_the_damaged_bag_as_it_was(tmp_path: Path) -> None:
    with tiny_filesystem(tmp_path / "fs", "8m") as fs:
        _write_chain_bag(fs / "bag", n=3000)
        mcap = fs / "bag" / "bag.mcap"
        mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
        before = {p.name: p.read_bytes() for p in (fs / "bag").iterdir()}
        with contextlib.suppress(OSError), (fs / "filler").open("wb") as filler:
            while True:
                filler.write(b"\0" * 4096)
                filler.flush()
        one_line_error(cli("repair", str(fs / "bag")), "cannot write", "left as it was")
        assert {p.name: p.read_bytes() for p in (fs / "bag").iterdir()} == before
        assert sorted(p.name for p in fs.iterdir()) == ["bag", "filler"]


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A small generated chain bag (2 s of lecture_constant) for the commands that read one."""
    path = tmp_path_factory.mktemp("full_disk") / "bag"
    generate_bag("lecture_constant", path, duration=2.0)
    return str(path)


@pytest.mark.parametrize(
    ("line", "size"),
    [
        ("export {bag} --out {fs}/tables", "64k"),
        ("export {bag} --out {fs}/tables --format parquet", "16k"),
        ("animate {bag} --out {fs}/a.gif --duration 1 --fps 10", "16k"),
        ("animate {bag} --out {fs}/a.mp4 --duration 2 --fps 10", "16k"),  # ffmpeg's exit status
        ("analyze {bag} --plot {fs}/a.png", "16k"),
        ("sweep at_rest --length 0.5:2:100 --duration 0.2 --no-progress --out {fs}/s.csv", "16k"),
        ("simulate lecture_constant --plot {fs}/p.png", "16k"),
    ],
)
def test_a_disk_filling_up_during_the_write_is_one_line(
    bag: str, tmp_path: Path, line: str, size: str
) -> None:
    with tiny_filesystem(tmp_path / "fs", size) as fs:
        # Fill the file system but for a few KiB: the check passes (space is left), the write fails.
        with contextlib.suppress(OSError), (fs / "filler").open("wb") as filler:
            while os.statvfs(fs).f_bavail * os.statvfs(fs).f_frsize > 4096:
                filler.write(b"\0" * 4096)
                filler.flush()
        argv = [word.format(fs=fs, bag=bag) for word in line.split(" ")]
        one_line_error(cli(*argv), "cannot write", "No space left")
        assert sorted(p.name for p in fs.iterdir()) == ["filler"]  # the partial output is gone
