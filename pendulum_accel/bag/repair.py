"""Rebuild a damaged bag (killed recorder, cut-off copy, flipped bytes) from what its MCAP file still holds.

Every message the reader keeps is rewritten, with its channel's type, QoS and the bag's custom_data,
into a fresh file through :class:`BagWriter`, which writes the MCAP summary, index, CRCs and
metadata.yaml anew. The reader keeps every chunk whose CRC matches and, of a damaged or cut-off chunk,
every intact message record (``bag.integrity``: it frames, names a known channel, lies in the chunk's
time range and decodes as CDR of the channel's type). ``DROPS`` says what is not kept. The repaired
bag's custom_data ``pendulum_accel.repaired`` says what was recovered without a checksum, for ``info``.
Each file it replaces is kept next to the new one: a damaged file as ``<name>.mcap.damaged``, an intact
one (another file of a split recording, or a file whose metadata.yaml was missing or wrong) as
``<name>.mcap.orig``, so the names say which held the damage. A recording split into several files is
rewritten as one file; a file its metadata.yaml lists and that is missing is named in
``pendulum_accel.repaired``, so ``info`` never calls the result complete.
Only files inside the bag directory are ever touched (the reader refuses a metadata.yaml that names
one outside), and a write failure leaves the damaged bag as it was. A bag being recorded is left alone:
one whose lock a live writer holds (bag/lock.py), or whose files another process has open (a recorder of
another make). Repair holds the bag's lock while it rewrites, and removes a lock a dead writer left.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from pendulum_accel.bag.errors import RepairError
from pendulum_accel.bag.integrity import ChunkDamage, damage_origin
from pendulum_accel.bag.lock import LOCK_NAME, BagLock, open_by_others
from pendulum_accel.bag.messages import TYPESTORE
from pendulum_accel.bag.metadata import listed_counts, parse_qos
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.writer import BagWriter, Stream

CUSTOM_REPAIRED = "pendulum_accel.repaired"
"""custom_data key of a repaired bag: what repair recovered by parsing, without a checksum (one line)."""

BACKUP_SUFFIXES = {True: ".damaged", False: ".orig"}
"""What a replaced file's kept copy is named by, keyed by whether its own read found damage."""

DROPS = (
    "repair drops only what is not intact: in a damaged or cut-off chunk, the records that do not frame, "
    "name an unknown channel, lie outside the chunk's time range or do not decode as CDR of their "
    "channel's type, and the record the end of the file cuts off; a chunk whose own header fields are "
    "damaged, whole; in a file without its summary, everything after broken record framing. It does not "
    "carry over sequence numbers and publish times (rewritten as 0 and the log time), MCAP attachments, "
    "or metadata records other than rosbag2's"
)


@dataclass(frozen=True)
class RepairResult:
    """Outcome of repair_bag: whether it rewrote the bag, the per-topic counts kept, the damage seen
    (``damage``, with chunk times relative to ``origin_ns``)."""

    path: Path
    rewritten: bool
    counts: dict[str, int]
    problem: str | None
    backups: tuple[Path, ...]
    """The replaced files, kept beside the rewritten one: ``.damaged`` or ``.orig`` (BACKUP_SUFFIXES; none
    with keep_backup False)."""
    damage: tuple[ChunkDamage, ...] = ()
    origin_ns: int = 0

    @property
    def recovered(self) -> int:
        """Message records recovered by parsing damaged chunks (no checksum vouches for them)."""
        return sum(d.recovered for d in self.damage)

    @property
    def dropped(self) -> int:
        """Message records found in damaged chunks that were not intact."""
        return sum(d.dropped for d in self.damage)


def metadata_matches(bag: Bag) -> bool:
    """True when metadata.yaml exists and its per-topic message counts equal what the file holds."""
    listed = listed_counts(bag.metadata)
    if listed is None:
        return False
    actual = {name: topic.count for name, topic in bag.topics.items()}
    return listed == (actual, bag.message_count)


def repair_bag(path: Path | str, *, keep_backup: bool = True) -> RepairResult:
    """Rewrite bag directory ``path`` from its readable messages unless it is intact already.

    Intact = the MCAP file reads to its footer and metadata.yaml lists the same counts.
    """
    root = Path(path)
    if not root.is_dir():
        raise RepairError(f"repair needs a bag directory, {root} is not one")
    if not any(root.glob("*.mcap")) and not (root / "metadata.yaml").is_file():
        raise RepairError(
            f"{root} is not a bag directory (no metadata.yaml, no .mcap file); nothing repaired"
        )
    bag = read_bag(root)
    if bag.recording is not None:
        raise RepairError(
            f"{bag.problem}: not damaged, its end is still being written; repair leaves a recording in "
            "progress alone (run it after the recording ends, if the bag is damaged then); nothing changed"
        )
    if bag.problem is None and metadata_matches(bag):
        return RepairResult(root, False, {n: t.count for n, t in bag.topics.items()}, None, ())
    if bag.abandoned is not None and not bag.abandoned.verified:
        raise RepairError(
            f"bag {root} has the lock of {bag.abandoned.describe()}, which cannot be checked from this host "
            f"(a recording there may be in progress); if it has ended, remove {root / LOCK_NAME} and repair "
            "again; nothing changed"
        )
    busy = open_by_others(bag.mcap_paths)
    if busy:
        held, pid, command = busy[0]
        raise RepairError(
            f"{held} is open in process {pid} ({command}): a recording in progress? repair never moves a "
            "file another process has open; nothing changed"
        )
    for name, topic in bag.topics.items():
        if topic.msgtype not in TYPESTORE.types:
            raise RepairError(
                f"cannot repair {root}: topic {name} has type {topic.msgtype!r} unknown to rosbags"
            )
        if topic.serialization_format != "cdr":
            raise RepairError(f"cannot repair {root}: topic {name} is {topic.serialization_format!r}-encoded")
    staging = root.parent / f".{root.name}.repair"
    lock: BagLock | None = None
    try:
        # Held while the files are swapped: a second repair, or a writer told to --overwrite, waits its turn.
        lock = BagLock(root, "pendulum-accel repair")
        return _rewrite(root, bag, staging, keep_backup)
    except OSError as err:
        # Disk full, read-only or unwritable directory: nothing of the original bag has been moved yet
        # when the new one fails to write, and the staging copy is gone (finally below).
        raise RepairError(
            f"cannot write the repaired bag next to {root} ({err.strerror or err}); "
            f"the damaged bag is left as it was"
        ) from None
    finally:
        if lock is not None:
            lock.release()  # the lock file goes too, and with it one a dead writer left


def _rewrite(root: Path, bag: Bag, staging: Path, keep_backup: bool) -> RepairResult:
    """Write the readable messages to ``staging``, then swap them into ``root`` (see repair_bag)."""
    if staging.exists():
        shutil.rmtree(staging)
    new_dir = staging / root.name
    origin = damage_origin(bag.start_ns, bag.damage)
    custom = dict(bag.custom_data)
    notes = [f"{name}, listed in metadata.yaml, was missing" for name in bag.missing_files]
    notes += [
        f"{d.recovered} messages recovered by parsing from damaged {d.span(origin)} ({d.reason})"
        for d in bag.damage
        if d.recovered
    ]
    if notes:
        custom[CUSTOM_REPAIRED] = "; ".join(notes)
    try:
        with BagWriter(new_dir, custom_data=custom, flush_interval=None) as writer:
            for name, topic in bag.topics.items():
                writer.add_topic(name, topic.msgtype, parse_qos(topic.offered_qos_profiles or []))
            streams = []
            for name in bag.topics:
                times, payloads = bag.raw(name)
                streams.append(Stream(name, times, payloads))
            writer.write_sorted(streams)
            counts = writer.counts
        new_mcap = new_dir / f"{root.name}.mcap"
        backups: list[Path] = []
        for old in bag.mcap_paths:
            if not old.exists():
                continue
            if keep_backup:
                backups.append(old.with_name(old.name + BACKUP_SUFFIXES[old in bag.damaged_files]))
                old.replace(backups[-1])
            else:
                old.unlink()
        new_mcap.replace(root / new_mcap.name)
        (new_dir / "metadata.yaml").replace(root / "metadata.yaml")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    problem = bag.problem or "metadata.yaml was missing or listed other message counts"
    return RepairResult(root, True, counts, problem, tuple(backups), tuple(bag.damage), origin)
