"""A bag copied with one topic's messages edited, every other message as it was: foreign or hostile data
built from a bag the chain wrote."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.writer import BagWriter


def rewritten(source: Path, target: Path, topic: str, edit: Callable[[Any], None]) -> Path:
    """A copy of bag ``source`` whose ``topic`` messages went through ``edit`` (in place)."""
    bag = read_bag(source)
    with BagWriter(target, custom_data=bag.custom_data) as writer:
        for name, info in bag.topics.items():
            writer.add_topic(name, info.msgtype)
        for name, ns, data in bag.iter_raw():
            if name == topic:
                msg = bm.deserialize(data, bag.topics[name].msgtype)
                edit(msg)
                data = bm.serialize(msg, bag.topics[name].msgtype)
            writer.write(name, ns, data)
    return target
