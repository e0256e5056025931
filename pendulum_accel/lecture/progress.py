"""Progress bars for the lecture's sweeps: shown on a terminal once a result has run for a second."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")

DELAY_S = 1.0  # a result that finishes sooner never draws a bar


def progress(items: Iterable[T], desc: str) -> Iterator[T]:
    """``items`` one by one, with a tqdm bar on stderr after DELAY_S when stderr is a terminal."""
    yield from tqdm(items, desc=desc, delay=DELAY_S, file=sys.stderr, leave=False, disable=None)


@contextmanager
def working(desc: str, period: float = 0.2) -> Iterator[None]:
    """While the body runs: an elapsed-time tqdm line on stderr after DELAY_S, when stderr is a terminal.

    For results with no loop to count (one long simulation), so that every lecture command that takes
    more than a second shows it is at work.
    """
    bar = tqdm(desc=desc, total=None, delay=DELAY_S, file=sys.stderr, leave=False, disable=None, unit="s")
    done = threading.Event()

    def tick() -> None:
        """Refresh the line until the body ends (tqdm draws it once the delay has passed)."""
        while not done.wait(period):
            bar.refresh()

    thread = threading.Thread(target=tick, name="lecture-progress", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
        bar.close()
