"""Playback position and pacing of a bag player (no ROS): pause, resume, rate, step, seek.

The player's clock maps bag time to wall time: bag_now = anchor_ns + (wall − anchor_wall) · rate
while playing, frozen at anchor_ns while paused. Every control re-anchors the clock where it acts,
as rosbag2's ``TimeControllerClock`` does, so a rate change or a resume never makes the bag jump.
One publishing thread calls ``take_due``; controls (services, keys) may come from any other thread.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.errors import ParameterError

_MAX_WAIT = 0.1  # s: longest sleep before the pacing loop looks at the controls again


@dataclass(frozen=True)
class Taken:
    """A message to publish now: its index, and whether it follows a jump (start, seek, loop)."""

    index: int
    jumped: bool


class Playback:
    """Which message of ``times_ns`` (sorted log times) comes next, and when it is due."""

    def __init__(
        self,
        times_ns: NDArray[np.int64],
        *,
        rate: float = 1.0,
        paused: bool = False,
        wall: Callable[[], float] = time.perf_counter,
    ) -> None:
        """Positioned on the first message, clock anchored there; ParameterError for no messages."""
        if times_ns.size == 0:
            raise ParameterError("nothing to play: no message in the chosen range")
        self.times = np.asarray(times_ns, dtype=np.int64)
        self._wall = wall
        self._cond = threading.Condition()
        self.index = 0
        self.rate = check_rate(rate)
        self.paused = paused
        self._anchor_ns = int(self.times[0])
        self._anchor_wall = wall()
        self._jumped = True

    @property
    def size(self) -> int:
        """Number of messages."""
        return int(self.times.size)

    def bag_now_ns(self) -> int:
        """Bag time now: anchor_ns + (wall − anchor_wall) · rate · 1e9, frozen while paused."""
        with self._cond:
            return self._now_ns()

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
        """Go to the first message at or after bag time ``ns`` (clamped to the first message), clock there.

        False, and nothing changes, when ``ns`` is after the last message (rosbag2: the time must lie
        within the bag).
        """
        with self._cond:
            if ns > int(self.times[-1]):
                return False
            ns = max(int(ns), int(self.times[0]))
            self.index = int(np.searchsorted(self.times, ns, side="left"))
            self._anchor(ns)
            self._jumped = True
            self._cond.notify_all()
            return True

    def restart(self) -> None:
        """Back to the first message (a loop's next pass), keeping the paused state."""
        self.seek(int(self.times[0]))

    def reanchor(self) -> None:
        """Bag time is now that of the next message (or the last one at the end): pacing starts here."""
        with self._cond:
            self._anchor(int(self.times[min(self.index, self.size - 1)]))
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
        self.index += 1
        if self.paused:
            self._anchor(int(self.times[i]))
        jumped, self._jumped = self._jumped, False
        return Taken(i, jumped)

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
                wait = (int(self.times[self.index]) - self._now_ns()) * 1e-9 / self.rate
                if wait > 0.0:
                    self._cond.wait(min(wait, _MAX_WAIT))
                    continue
                return self._take()
        return None

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
