"""Damaged bags in the commands that compute from one: refused, unless ``--salvage`` asks for what is intact.

``analyze``, ``export``, ``allan`` and ``animate`` read their bag through ``read_intact``: a bag whose
reader found damage (a chunk CRC mismatch, a cut-off file, broken framing: ``Bag.problem``) is one
BagError line, exit 2, naming the damage and the two ways on. With ``--salvage`` the intact chunks and
the intact records of damaged chunks are used, and ``warn_salvaged`` prints what was dropped.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pendulum_accel.bag.reader import Bag, read_bag, salvage_note


def add_salvage_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--salvage`` to a bag-reading command."""
    parser.add_argument(
        "--salvage",
        action="store_true",
        help="use the intact chunks and records of a damaged bag instead of refusing it "
        "(what is dropped is named on stderr, exit 1)",
    )


def read_intact(path: str | Path, salvage: bool) -> Bag:
    """The bag at ``path``; BagError when it is damaged, unless ``salvage``."""
    return read_bag(path, salvage=salvage)


def warn_salvaged(command: str, bag: Bag) -> int:
    """Print the salvage note of a damaged bag on stderr; the exit code: 1 for damaged, 0 for intact."""
    note = salvage_note(bag)
    if note is None:
        return 0
    print(f"pendulum-accel {command}: warning: {note}", file=sys.stderr)
    return 1
