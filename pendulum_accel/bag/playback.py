"""Playback position and pacing of a bag player (no ROS): pause, resume, rate, step, seek.

The player's clock maps bag time to wall time: bag_now = anchor_ns + (wall − anchor_wall) · rate
while playing, frozen at anchor_ns while paused. Every control re-anchors the clock where it acts,
as rosbag2's ``TimeControllerClock`` does, so a rate change or a resume never makes the bag jump.
One publishing thread calls ``take_due``; controls (services, keys) may come from any other thread.

The messages come from a :class:`Timeline`: :class:`ArrayTimeline` over log times held in memory, or
the player's streaming one (``bag.stream``), which holds one chunk at a time. Only the cursor's next
message is ever looked at, so the pacing is the same for both.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.errors import ParameterError

_MAX_WAIT = 0.1  # s: longest sleep before the pacing loop looks at the controls again


@dataclass(frozen=True)
class Taken:
    """A message to publish now: its index, whether it follows a jump (start, seek, loop), and what the
    timeline holds for it (the message itself for a streaming timeline; the index for an array)."""

    index: int
    jumped: bool
    # Any: what the timeline's take gives (an ArrayTimeline's index, the player's (topic, ns, cdr)).
    item: Any = None


class Timeline(Protocol):
    """Messages in log-time order behind a cursor: ``size`` of them from ``first_ns`` to ``last_ns``."""

    size: int
    first_ns: int
    last_ns: int

    def seek(self, ns: int) -> int:
        """Put the cursor on the first message at or after ``ns``; its index (size when none)."""
        ...

    def peek_ns(self) -> int | None:
        """Log time of the message at the cursor, None past the last."""
        ...

    # Any: each Timeline's own item; Playback hands it on without looking at it.
    def take(self) -> Any:
        """The message at the cursor (the caller checked there is one); the cursor moves on."""
        ...


class ArrayTimeline:
    """A Timeline over sorted log times held in memory; ``take`` gives the message's index."""

    def __init__(self, times_ns: NDArray[np.int64]) -> None:
        """Cursor on the first of ``times_ns`` (sorted)."""
        self.times = np.asarray(times_ns, dtype=np.int64)
        self.size = int(self.times.size)
        self.first_ns = int(self.times[0]) if self.size else 0
        self.last_ns = int(self.times[-1]) if self.size else 0
        self._cursor = 0

    def seek(self, ns: int) -> int:
        """Cursor on the first message at or after ``ns`` (binary search); its index."""
        self._cursor = int(np.searchsorted(self.times, ns, side="left"))
        return self._cursor

    def peek_ns(self) -> int | None:
        """Log time at the cursor."""
        return int(self.times[self._cursor]) if self._cursor < self.size else None

    def take(self) -> int:
        """The cursor's index; the cursor moves on."""
        self._cursor += 1
        return self._cursor - 1


class Playback:
    """Which message of a timeline (or of ``times_ns``, sorted log times) comes next, and when it is due."""

    def __init__(
        self,
        times_ns: NDArray[np.int64] | Timeline,
        *,
        rate: float = 1.0,
        paused: bool = False,
        wall: Callable[[], float] = time.perf_counter,
    ) -> None:
        """Positioned on the first message, clock anchored there; ParameterError for no messages."""
        timeline = ArrayTimeline(times_ns) if isinstance(times_ns, np.ndarray) else times_ns
        if timeline.size == 0:
            raise ParameterError("nothing to play: no message in the chosen range")
        self.timeline = timeline
        self._wall = wall
        self._cond = threading.Condition()
        self.index = 0
        self.rate = check_rate(rate)
        self.paused = paused
        self._anchor_ns = timeline.first_ns
        timeline.seek(timeline.first_ns)
        self._anchor_wall = wall()
        self._jumped = True

    @property
    def size(self) -> int:
        """Number of messages."""
        return int(self.timeline.size)

    @property
    def first_ns(self) -> int:
        """Log time of the first message."""
        return int(self.timeline.first_ns)

    @property
    def last_ns(self) -> int:
        """Log time of the last message."""
        return int(self.timeline.last_ns)

    def bag_now_ns(self) -> int:
        """Bag time now: anchor_ns + (wall − anchor_wall) · rate · 1e9, frozen while paused."""
        with self._cond:
            return self._now_ns()

    def position_ns(self) -> int:
        """Where the playback is: the schedule (bag_now_ns), but never past the next message still to go
        out (or the last one): a player that falls behind shows its position, not its schedule."""
        with self._cond:
            upcoming = self.timeline.peek_ns()
            return min(self._now_ns(), self.last_ns if upcoming is None else upcoming)

    def _now_ns(self) -> int:
        """bag_now_ns without taking the lock (callers hold it)."""
        if self.paused:
            return self._anchor_ns
        return self._anchor_ns + round((self._wall() - self._anchor_wall) * self.rate * 1e9)

    def _anchor(self, ns: int) -> None:
        """Re-anchor the clock: bag time ``ns`` is now."""
        self._anchor_ns = int(ns)
        self._anchor_wall = self._wall()

    def set_rate(self, rate: float) -> None:
        """Play ``rate`` times as fast from now on (> 0; ParameterError otherwise)."""
        rate = check_rate(rate)
        with self._cond:
            self._anchor(self._now_ns())
            self.rate = rate
            self._cond.notify_all()

    def pause(self) -> None:
        """Stop the clock where it is (idempotent)."""
        with self._cond:
            if not self.paused:
                self._anchor(self._now_ns())
                self.paused = True
            self._cond.notify_all()

    def resume(self) -> None:
        """Restart the clock from where it stopped (idempotent)."""
        with self._cond:
            if self.paused:
                self._anchor_wall = self._wall()
                self.paused = False
            self._cond.notify_all()

    def toggle(self) -> bool:
        """Pause if playing, resume if paused; True when now paused."""
        with self._cond:
            if self.paused:
                self.resume()
            else:
                self.pause()
            return self.paused

    def seek(self, ns: int) -> bool:
        """Go to the first message at or after bag time ``ns``, clock there.

        False, and nothing changes, when ``ns`` lies outside the played span [first, last] (rosbag2:
        the time must lie within the bag).
        """
        with self._cond:
            if not self.first_ns <= ns <= self.last_ns:
                return False
            self.index = self.timeline.seek(int(ns))
            self._anchor(ns)
            self._jumped = True
            self._cond.notify_all()
            return True

    def restart(self) -> None:
        """Back to the first message (a loop's next pass), keeping the paused state."""
        self.seek(self.first_ns)

    def reanchor(self) -> None:
        """Bag time is now that of the next message (or the last one at the end): pacing starts here."""
        with self._cond:
            upcoming = self.timeline.peek_ns()
            self._anchor(self.last_ns if upcoming is None else upcoming)
            self._cond.notify_all()

    def step(self) -> Taken | None:
        """While paused: take the next message now, the clock jumps to it; None when playing or at the end."""
        with self._cond:
            if not self.paused or self.index >= self.size:
                return None
            return self._take()

    def _take(self) -> Taken:
        """Take the message at the cursor (callers hold the lock and checked there is one)."""
        i = self.index
        ns = self.timeline.peek_ns()
        item = self.timeline.take()
        self.index += 1
        if self.paused and ns is not None:
            self._anchor(ns)
        jumped, self._jumped = self._jumped, False
        return Taken(i, jumped, item)

    def take_due(self, stop: threading.Event) -> Taken | None:
        """Wait until the next message is due (playing, its time reached), take it; None at the end of
        the messages (while playing) or once ``stop`` is set."""
        with self._cond:
            while not stop.is_set():
                if self.paused:
                    self._cond.wait(_MAX_WAIT)
                    continue
                if self.index >= self.size:
                    return None
                upcoming = self.timeline.peek_ns()
                if upcoming is None:
                    return None
                wait = (upcoming - self._now_ns()) * 1e-9 / self.rate
                if wait > 0.0:
                    self._cond.wait(min(wait, _MAX_WAIT))
                    continue
                return self._take()
        return None

    def at_end(self) -> bool:
        """True when the cursor is past the last message."""
        with self._cond:
            return self.timeline.peek_ns() is None

    def wake(self) -> None:
        """Wake a waiting ``take_due`` (after ``stop`` was set)."""
        with self._cond:
            self._cond.notify_all()


def check_rate(rate: float) -> float:
    """``rate`` as a float when it is finite and > 0; ParameterError otherwise."""
    value = float(rate)
    if not (np.isfinite(value) and value > 0.0):
        raise ParameterError(f"rate must be a finite number > 0, got {rate!r}")
    return value
