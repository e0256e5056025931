"""Rebuild a damaged bag (killed recorder, cut-off copy) from what its MCAP file still holds.

Every message that reads before the damage is rewritten, with its channel's type, QoS and the
bag's custom_data, into a fresh file through :class:`BagWriter`, which writes the MCAP summary,
index and metadata.yaml anew. The damaged file is kept next to it as ``<name>.mcap.damaged``.
Only files inside the bag directory are ever touched (the reader refuses a metadata.yaml that names
one outside), and a write failure leaves the damaged bag as it was.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from pendulum_accel.bag.messages import TYPESTORE
from pendulum_accel.bag.metadata import parse_qos
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.writer import BagWriter, Stream
from pendulum_accel.errors import BagError


@dataclass(frozen=True)
class RepairResult:
    """Outcome of repair_bag: whether it rewrote the bag, the per-topic counts kept, the damage seen."""

    path: Path
    rewritten: bool
    counts: dict[str, int]
    problem: str | None
    backup: Path | None


def metadata_matches(bag: Bag) -> bool:
    """True when metadata.yaml exists and its per-topic message counts equal what the file holds."""
    if bag.metadata is None:
        return False
    info = bag.metadata.get("rosbag2_bagfile_information")
    if not isinstance(info, dict):
        return False
    try:
        listed = {
            str(t["topic_metadata"]["name"]): int(t["message_count"])
            for t in info.get("topics_with_message_count") or []
        }
    except (KeyError, TypeError, ValueError):
        return False
    actual = {name: topic.count for name, topic in bag.topics.items()}
    return listed == actual and int(info.get("message_count", -1)) == bag.message_count


def repair_bag(path: Path | str, *, keep_backup: bool = True) -> RepairResult:
    """Rewrite bag directory ``path`` from its readable messages unless it is intact already.

    Intact = the MCAP file reads to its footer and metadata.yaml lists the same counts.
    """
    root = Path(path)
    if not root.is_dir():
        raise BagError(f"repair needs a bag directory, {root} is not one")
    bag = read_bag(root)
    if bag.problem is None and metadata_matches(bag):
        return RepairResult(root, False, {n: t.count for n, t in bag.topics.items()}, None, None)
    for name, topic in bag.topics.items():
        if topic.msgtype not in TYPESTORE.types:
            raise BagError(
                f"cannot repair {root}: topic {name} has type {topic.msgtype!r} unknown to rosbags"
            )
        if topic.serialization_format != "cdr":
            raise BagError(f"cannot repair {root}: topic {name} is {topic.serialization_format!r}-encoded")
    staging = root.parent / f".{root.name}.repair"
    try:
        return _rewrite(root, bag, staging, keep_backup)
    except OSError as err:
        # Disk full, read-only or unwritable directory: nothing of the original bag has been moved yet
        # when the new one fails to write, and the staging copy is gone (finally below).
        raise BagError(
            f"cannot write the repaired bag next to {root} ({err.strerror or err}); "
            f"the damaged bag is left as it was"
        ) from None


def _rewrite(root: Path, bag: Bag, staging: Path, keep_backup: bool) -> RepairResult:
    """Write the readable messages to ``staging``, then swap them into ``root`` (see repair_bag)."""
    if staging.exists():
        shutil.rmtree(staging)
    new_dir = staging / root.name
    try:
        with BagWriter(new_dir, custom_data=bag.custom_data, flush_interval=None) as writer:
            for name, topic in bag.topics.items():
                writer.add_topic(name, topic.msgtype, parse_qos(topic.offered_qos_profiles or []))
            streams = []
            for name in bag.topics:
                times, payloads = bag.raw(name)
                streams.append(Stream(name, times, payloads))
            writer.write_sorted(streams)
            counts = writer.counts
        new_mcap = new_dir / f"{root.name}.mcap"
        backup: Path | None = None
        if bag.mcap_path.exists():
            if keep_backup:
                backup = bag.mcap_path.with_name(bag.mcap_path.name + ".damaged")
                bag.mcap_path.replace(backup)
            else:
                bag.mcap_path.unlink()
        new_mcap.replace(root / new_mcap.name)
        (new_dir / "metadata.yaml").replace(root / "metadata.yaml")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    problem = bag.problem or "metadata.yaml was missing or listed other message counts"
    return RepairResult(root, True, counts, problem, backup)
