"""The streaming player's reader: bounded memory by construction, exact counts, seeks both ways.

A multi-chunk bag is read through ``StreamTimeline`` (what ``bag_player`` plays) while the chunk
decoder is watched: at any moment the messages decoded but not yet taken never exceed two chunks'
worth, whatever the bag's length. The messages and their order equal the in-memory reader's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmarks.player_memory import write_bag
from pendulum_accel.bag.errors import NotIndexedError
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.stream import StreamedBag

pytestmark = [pytest.mark.ros]  # player_node imports rclpy


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """About 6 MiB of 1 kHz JointState + AccelStamped: several 1 MiB chunks."""
    path = tmp_path_factory.mktemp("stream") / "bag"
    write_bag(path, 0.006)
    return path


def test_streaming_holds_at_most_two_chunks_of_decoded_messages(
    bag: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pendulum_accel.nodes.player_node import StreamTimeline

    decoded: list[int] = []  # messages of each chunk decoded so far
    original = StreamedBag.decode_chunk

    def counting(self: StreamedBag, *args: Any) -> list[tuple[int, str, bytes]]:
        """The chunk decoder, counting the messages of each chunk it decodes."""
        out = original(self, *args)
        decoded.append(len(out))
        return out

    monkeypatch.setattr(StreamedBag, "decode_chunk", counting)
    source = StreamedBag(bag)
    assert len(source.chunks) >= 4
    topics = list(source.topics)
    timeline = StreamTimeline(source, topics, source.start_ns, source.end_ns)
    decoded.clear()  # opening peeks at the first message; count from the cursor's first read on
    timeline.seek(timeline.first_ns)
    taken, held, times = 0, [], []
    while (ns := timeline.peek_ns()) is not None:
        timeline.take()
        times.append(ns)
        taken += 1
        # Decoded and not yet handed out (one message read ahead counts as taken's successor).
        held.append(sum(decoded) - taken)
    largest_chunk = max(decoded)
    assert len(decoded) == len(source.chunks)  # every chunk decoded exactly once, in one pass
    assert max(held) <= 2 * largest_chunk, (max(held), largest_chunk)
    whole = read_bag(bag)
    assert taken == timeline.size == whole.message_count
    assert np.array_equal(np.array(times), np.sort(np.concatenate([whole.raw(t)[0] for t in topics])))


def test_seek_positions_the_cursor_exactly_both_ways(bag: Path) -> None:
    from pendulum_accel.nodes.player_node import StreamTimeline

    source = StreamedBag(bag)
    topics = list(source.topics)
    timeline = StreamTimeline(source, topics, source.start_ns, source.end_ns)
    all_times = np.sort(np.concatenate([read_bag(bag).raw(t)[0] for t in topics]))
    for target in (all_times[-5] + 1, all_times[len(all_times) // 3], all_times[0], all_times[-1]):
        index = timeline.seek(int(target))
        expected = int(np.searchsorted(all_times, target, side="left"))
        assert index == expected and timeline.peek_ns() == all_times[expected]


def test_a_bag_without_chunk_index_is_not_streamed(bag: Path, tmp_path: Path) -> None:
    """A recording killed before its summary: refused by the stream, read whole by the player."""
    from pendulum_accel.nodes.player_node import open_source

    cut = tmp_path / "cut"
    cut.mkdir()
    data = (
        (bag / "bag.mcap").read_bytes()
        if (bag / "bag.mcap").exists()
        else next(bag.glob("*.mcap")).read_bytes()
    )
    (cut / "cut.mcap").write_bytes(data[: len(data) // 2])
    with pytest.raises(NotIndexedError):
        StreamedBag(cut / "cut.mcap")
    assert not isinstance(open_source(str(cut / "cut.mcap")), StreamedBag)
