"""``pendulum-accel info BAG``: topics, types, counts, rates, duration, scene and plan of a bag."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.integrity import damage_origin
from pendulum_accel.bag.metadata import listed_counts
from pendulum_accel.bag.reader import Bag, header_library, read_bag, salvage_note
from pendulum_accel.bag.repair import CUSTOM_REPAIRED
from pendulum_accel.bag.writer import CUSTOM_PLAN, CUSTOM_VERSION
from pendulum_accel.cli.topics import add_topic_flags, choose_topics
from pendulum_accel.errors import SeveralChainsError
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting, unexplained_missing
from pendulum_accel.recording.stored_scene import stored_scene_name


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``info`` subcommand."""
    parser = subparsers.add_parser(
        "info",
        help="summarise a bag: topics, counts, duration, scene and plan",
        description="Summarise a rosbag2 MCAP bag without ROS. A damaged bag is summarised up to the damage.",
    )
    parser.add_argument("bag", help="bag directory (or .mcap file)")
    add_topic_flags(parser)
    parser.set_defaults(func=run)


_STAMP_FIELDS = ("header.stamp.sec", "header.stamp.nanosec")
STAMP_BATCH = 1 << 17
"""Stamps held per topic at a time while holes are counted: memory does not grow with the bag."""


def bag_accounting(bag: Bag) -> Accounting | None:
    """The chain's counters stored in ``bag`` (custom_data), with the recording's topic map, or None."""
    text = bag.custom_data.get(CUSTOM_ACCOUNTING)
    return Accounting.from_json(text, bm.stored_roles(bag.custom_data)) if text else None


def missing_estimates(bag: Bag, accounting: Accounting | None) -> int:
    """Angles in ``bag`` without an estimate that neither warm-up nor a dropped input explains (the chain's
    ``accounting`` stored in it, if any)."""
    topics = bag.topics
    joint = bag.chain_topic(bm.TOPIC_JOINT_STATES)
    estimate = bag.chain_topic(bm.TOPIC_ACCEL_ESTIMATE)
    if joint not in topics or estimate not in topics:
        return 0
    angles, estimates = topics[joint].count, topics[estimate].count
    if accounting is not None and accounting.estimator:
        return unexplained_missing(angles, estimates, accounting, 0)  # the counters explain, not the stamps
    return unexplained_missing(angles, estimates, accounting, holes_after_first(bag, joint, estimate))


def _stamps_ns(bag: Bag, topic: str) -> Iterator[NDArray[np.int64]]:
    """Stamps of ``topic`` in integer ns (sec·10⁹ + nanosec), STAMP_BATCH at a time, in log-time order."""
    for batch in bag.decode_batches(topic, fields=_STAMP_FIELDS, rows=STAMP_BATCH):
        yield batch["header.stamp.sec"].astype(np.int64) * 1_000_000_000 + batch["header.stamp.nanosec"]


def _ascending(ns: NDArray[np.int64], after: int) -> bool:
    """ns non-decreasing and starting at or after ``after``."""
    return ns.size == 0 or (int(ns[0]) >= after and not bool(np.any(np.diff(ns) < 0)))


def holes_after_first(bag: Bag, joint: str, estimate: str) -> int:
    """Angles stamped at or after the first estimate that no estimate carries the stamp of (the estimator
    stamps each estimate with its angle's): all of them when there is no estimate.

    Both stamp streams are merged a batch of each at a time, as the chain writes them (in stamp order);
    a bag whose stamps go back is counted over whole arrays instead.
    """
    estimates = _stamps_ns(bag, estimate)
    window = np.zeros(0, dtype=np.int64)  # estimate stamps ≥ the current angle batch's first, sorted
    first: int | None = None
    exhausted = False
    last_angle = last_estimate = -(2**63)
    holes = 0
    for angles in _stamps_ns(bag, joint):
        if not _ascending(angles, last_angle):
            return _holes_whole(bag, joint, estimate)
        if angles.size == 0:
            continue
        last_angle = int(angles[-1])
        while not exhausted and last_estimate <= last_angle:
            more = next(estimates, None)
            if more is None:
                exhausted = True
            elif not _ascending(more, last_estimate):
                return _holes_whole(bag, joint, estimate)
            elif more.size:
                first = int(more[0]) if first is None else first
                last_estimate = int(more[-1])
                window = np.concatenate([window, more])
        window = window[np.searchsorted(window, angles[0]) :]  # later angles are never older than these
        if first is None:
            holes += int(angles.size)
            continue
        after = angles[angles >= first]
        at = np.minimum(np.searchsorted(window, after), max(window.size - 1, 0))
        found = window[at] == after if window.size else np.zeros(after.size, dtype=bool)
        holes += int(after.size - np.count_nonzero(found))
    return holes


def _holes_whole(bag: Bag, joint: str, estimate: str) -> int:
    """holes_after_first over whole arrays (stamps out of order)."""
    angles = np.concatenate([np.zeros(0, dtype=np.int64), *_stamps_ns(bag, joint)])
    estimates = np.concatenate([np.zeros(0, dtype=np.int64), *_stamps_ns(bag, estimate)])
    after_first = angles[angles >= estimates.min()] if estimates.size else angles
    return int(np.count_nonzero(~np.isin(after_first, estimates)))


def damage_state(bag: Bag) -> str:
    """'DAMAGED: chunk 4, 3.012–3.998 s; chunk 6, …': one entry per damaged chunk (times from the chunk's
    message start/end, relative to the bag's start), then a cut-off end or broken framing (of each file it
    befell, in a split recording; a file metadata.yaml lists that is missing comes first)."""
    origin = damage_origin(bag.start_ns, bag.damage)
    parts = [f"{name} missing" for name in bag.missing_files]
    parts += [d.span(origin) for d in bag.damage]
    parts += bag.endings()
    if bag.abandoned is not None:
        parts.append(f"its writer {bag.abandoned.describe()} ended without closing it")
    return "DAMAGED: " + "; ".join(parts or ["see the warning"])


def fewer_than_listed(bag: Bag) -> list[str]:
    """'metadata.yaml lists 999 /clock messages, the bag holds 401', one per topic of which the files
    hold fewer messages than metadata.yaml lists: messages written and since lost (a file replaced or cut
    short while its framing still holds). More than listed is no loss (a recorder killed before it
    rewrote its metadata); no counts listed, nothing to check."""
    listed = listed_counts(bag.metadata)
    if listed is None:
        return []
    topics = bag.topics
    held = {name: topics[name].count if name in topics else 0 for name in listed[0]}
    return [
        f"metadata.yaml lists {n} {name} messages, the bag holds {held[name]}"
        for name, n in listed[0].items()
        if held[name] < n
    ]


def bag_state(bag: Bag) -> tuple[str, list[str]]:
    """('complete' | 'RECORDING: …' | 'DAMAGED …' | 'INCOMPLETE: …' | 'recorded intact; …', the losses found).

    'RECORDING' is a bag whose writer holds its lock (bag/lock.py): summarised as far as it is written,
    neither damaged nor complete. 'INCOMPLETE' names the first loss: fewer messages than metadata.yaml
    lists or than the recorder wrote (the file moved or replaced under it), a chain that ended early, a
    publisher's count above the recorder's (each topic found through the recording's topic map), or
    angles without an estimate.

    'complete' only where something could be checked: a bag written offline (no recorder counters), or a
    live recording whose publishers' counters agree with it. A live recording whose publishers left no
    counters (nodes started on their own, not by ``run``) is intact as far as the recorder saw, which
    says nothing of messages it never received.
    """
    if bag.recording is not None:
        # Not damage: the recorder's lock is held, the end of the file is being written (bag/lock.py).
        return f"RECORDING: being written by {bag.recording.describe()}; summarised as far as written", []
    if bag.problem is not None:
        return damage_state(bag), []
    short = fewer_than_listed(bag)
    if short:
        return f"INCOMPLETE: {short[0]}", short
    if CUSTOM_REPAIRED in bag.custom_data:
        # Intact as a file now, but these records came back without a checksum to vouch for them.
        return f"repaired: {bag.custom_data[CUSTOM_REPAIRED]}", []
    accounting = bag_accounting(bag)
    held = accounting.held_short({name: t.count for name, t in bag.topics.items()}) if accounting else []
    if held:
        # Written, then lost: the file was replaced or moved while the recorder wrote it.
        return f"INCOMPLETE: {held[0]}", held
    ending = accounting.ending() if accounting else None
    if ending is not None:
        # A chain cut short by a dead node or an interrupt: the bag holds less than the scene.
        return f"INCOMPLETE: {ending}", [ending]
    losses = accounting.unrecorded() if accounting else []
    missing = missing_estimates(bag, accounting)
    if missing:
        losses.append(
            f"{missing} angles have no estimate, and the estimator's counters explain none of them "
            "(the estimator started late or estimates were lost)"
        )
        return f"INCOMPLETE: {missing} angles without an estimate", losses
    if losses:
        return f"INCOMPLETE: {losses[0]}", losses
    if accounting is not None and accounting.recorder and not accounting.publishers_counted:
        return "recorded intact; the publishers left no counts to check it against", []
    return "complete", []


def info_lines(path: str, args: argparse.Namespace | None = None) -> tuple[list[str], str | None]:
    """(report lines, damage note or None) for the bag at ``path``, its chain chosen by ``args``'s
    --topic and --namespace (cli.topics); a bag of several chains without a choice is listed unchecked."""
    bag = read_bag(path)
    if args is not None:
        choose_topics(bag, args)
    size = sum(p.stat().st_size for p in bag.mcap_paths)
    files = bag.mcap_path.name
    if len(bag.mcap_paths) > 1:
        files = f"{len(bag.mcap_paths)} files, {bag.mcap_path.name} to {bag.mcap_paths[-1].name}"
    try:
        state, losses = bag_state(bag)
    except SeveralChainsError as err:
        state, losses = f"several chains ({', '.join(err.namespaces)}): --namespace NS checks one", []
    lines = [
        f"bag:       {bag.path}  [{state}]",
        f"file:      {files}  {size / 1e6:.2f} MB",
        f"duration:  {bag.duration_s:.3f} s  (log time {bag.start_ns * 1e-9:.3f}-{bag.end_ns * 1e-9:.3f} s)",
        f"messages:  {bag.message_count}",
        f"scene:     {stored_scene_name(bag) or '(not stored)'}",
        f"plan:      {bag.custom_data.get(CUSTOM_PLAN, '(not stored)').removeprefix('plan: ')}",
        f"written by {_writer(bag)}",
        "topics:",
    ]
    topics = bag.topics
    width = max((len(name) for name in topics), default=5)
    type_width = max((len(t.msgtype) for t in topics.values()), default=4)
    for name, topic in topics.items():
        rate = (topic.count - 1) / bag.duration_s if topic.count > 1 and bag.duration_s > 0 else 0.0
        lines.append(
            f"  {name:<{width}}  {topic.msgtype:<{type_width}}  {topic.count:>8} msgs  {rate:9.1f} Hz"
        )
    note = salvage_note(bag)
    if losses and note is None:
        note = "; ".join(losses)
    return lines, note


def run(args: argparse.Namespace) -> int:
    """Print the summary; a damaged bag also prints one warning line on stderr and exits 1."""
    lines, note = info_lines(args.bag, args)
    print("\n".join(lines))
    if note is not None:
        print(f"pendulum-accel info: warning: {note}", file=sys.stderr)
        return 1
    return 0


def _writer(bag: Bag) -> str:
    """Who wrote the bag: its MCAP Header's library (pendulum_accel-0.1.0, rosbags-0.11.9, …), else the
    pendulum_accel version its custom data stores, else '(not stated)'."""
    library = header_library(bag.mcap_path)
    if library:
        return library
    version = bag.custom_data.get(CUSTOM_VERSION)
    return f"pendulum_accel-{version}" if version else "(not stated)"
