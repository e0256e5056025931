"""Progress bars for the lecture's sweeps: shown on a terminal once a result has run for a second."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")

DELAY_S = 1.0  # a result that finishes sooner never draws a bar


def progress(items: Iterable[T], desc: str) -> Iterator[T]:
    """``items`` one by one, with a tqdm bar on stderr after DELAY_S when stderr is a terminal."""
    yield from tqdm(items, desc=desc, delay=DELAY_S, file=sys.stderr, leave=False, disable=None)
