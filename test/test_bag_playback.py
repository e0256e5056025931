"""Playback pacing without ROS, on a fake wall clock: rate, pause/resume, step, seek both ways."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from pendulum_accel.bag.playback import Playback
from pendulum_accel.errors import ParameterError

NS = 1_000_000_000


class FakeWall:
    """A wall clock that moves only when told."""

    def __init__(self) -> None:
        """Start at 100 s."""
        self.now = 100.0

    def __call__(self) -> float:
        """The current fake time (s)."""
        return self.now


def _playback(paused: bool = False, rate: float = 1.0) -> tuple[Playback, FakeWall]:
    """Ten messages at 0, 1, ..., 9 s of bag time."""
    wall = FakeWall()
    return Playback(np.arange(10, dtype=np.int64) * NS, rate=rate, paused=paused, wall=wall), wall


def test_clock_follows_rate_and_freezes_while_paused() -> None:
    playback, wall = _playback(rate=2.0)
    wall.now += 1.0
    assert playback.bag_now_ns() == 2 * NS
    playback.set_rate(0.5)  # re-anchored: no jump
    assert playback.bag_now_ns() == 2 * NS
    wall.now += 2.0
    assert playback.bag_now_ns() == 3 * NS
    playback.pause()
    wall.now += 5.0
    assert playback.bag_now_ns() == 3 * NS and playback.paused
    assert playback.toggle() is False  # resumed where it stopped
    wall.now += 2.0
    assert playback.bag_now_ns() == 4 * NS
    with pytest.raises(ParameterError):
        playback.set_rate(0.0)


def test_position_is_the_next_message_when_the_schedule_runs_ahead() -> None:
    playback, wall = _playback()
    stop = threading.Event()
    playback.take_due(stop)  # message 0 out; the next is at 1 s
    wall.now += 0.5
    assert playback.position_ns() == playback.bag_now_ns() == NS // 2  # on schedule: the schedule
    wall.now += 1000.0  # nothing taken meanwhile: the schedule is at 1000.5 s, the player at 1 s
    assert playback.bag_now_ns() == 1000 * NS + NS // 2 and playback.position_ns() == NS
    while playback.take_due(stop) is not None:
        pass
    assert playback.position_ns() == 9 * NS  # at the end: the last message, not the schedule


def test_take_due_returns_messages_once_due_and_none_at_the_end() -> None:
    playback, wall = _playback()
    stop = threading.Event()
    taken = playback.take_due(stop)
    assert taken is not None and taken.index == 0 and taken.jumped
    wall.now += 9.0  # everything is due now
    indices = []
    while (t := playback.take_due(stop)) is not None:
        indices.append(t.index)
        assert not t.jumped
    assert indices == list(range(1, 10))


def test_step_only_while_paused_and_seek_both_ways() -> None:
    playback, _ = _playback(paused=True)
    first = playback.step()
    assert first is not None and first.index == 0
    second = playback.step()
    assert second is not None and second.index == 1 and playback.bag_now_ns() == 1 * NS
    assert playback.seek(round(6.5 * NS)) and playback.index == 7 and playback.bag_now_ns() == round(6.5 * NS)
    jumped = playback.step()
    assert jumped is not None and jumped.index == 7 and jumped.jumped
    assert playback.seek(2 * NS) and playback.index == 2  # backwards
    assert not playback.seek(-5 * NS) and playback.index == 2  # before the start: refused, unchanged
    assert not playback.seek(20 * NS) and playback.index == 2  # past the end: refused, unchanged
    playback.resume()
    assert playback.step() is None  # not paused
    with pytest.raises(ParameterError):
        Playback(np.zeros(0, dtype=np.int64))
