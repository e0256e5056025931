"""``pendulum-accel info BAG``: topics, types, counts, rates, duration, scene and plan of a bag."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.integrity import damage_origin
from pendulum_accel.bag.reader import Bag, read_bag, salvage_note, scene_name
from pendulum_accel.bag.repair import CUSTOM_REPAIRED
from pendulum_accel.bag.writer import CUSTOM_PLAN, CUSTOM_VERSION
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting, unexplained_missing


def register(subparsers: Any) -> None:
    """Add the ``info`` subcommand."""
    parser = subparsers.add_parser(
        "info",
        help="summarise a bag: topics, counts, duration, scene and plan",
        description="Summarise a rosbag2 MCAP bag without ROS. A damaged bag is summarised up to the damage.",
    )
    parser.add_argument("bag", help="bag directory (or .mcap file)")
    parser.set_defaults(func=run)


_STAMP_FIELDS = ("header.stamp.sec", "header.stamp.nanosec")


def bag_accounting(bag: Bag) -> Accounting | None:
    """The chain's counters stored in ``bag`` (custom_data), or None."""
    text = bag.custom_data.get(CUSTOM_ACCOUNTING)
    return Accounting.from_json(text) if text else None


def missing_estimates(bag: Bag, accounting: Accounting | None) -> int:
    """Angles in ``bag`` without an estimate that neither warm-up nor a dropped input explains (the chain's
    ``accounting`` stored in it, if any)."""
    topics = bag.topics
    joint = bm.chain_topic(topics, bm.TOPIC_JOINT_STATES)
    estimate = bm.chain_topic(topics, bm.TOPIC_ACCEL_ESTIMATE)
    if joint not in topics or estimate not in topics:
        return 0
    both = bag.decode_topics({joint: (None, _STAMP_FIELDS), estimate: (None, _STAMP_FIELDS)})
    angles, estimates = both[joint].stamp, both[estimate].stamp
    after_first = angles[angles >= estimates.min()] if estimates.size else angles
    holes = int(np.count_nonzero(~np.isin(after_first, estimates)))
    return unexplained_missing(angles.size, estimates.size, accounting, holes)


def damage_state(bag: Bag) -> str:
    """'DAMAGED: chunk 4, 3.012–3.998 s; chunk 6, …': one entry per damaged chunk (times from the chunk's
    message start/end, relative to the bag's start), then a cut-off end or broken framing."""
    origin = damage_origin(bag.start_ns, bag.damage)
    parts = [d.span(origin) for d in bag.damage]
    problem = bag.problem or ""
    if not bag.complete:
        cut = "truncated" in problem or "without its MCAP footer" in problem
        parts.append("cut off before its footer" if cut else "record framing broken")
    return "DAMAGED: " + "; ".join(parts or ["see the warning"])


def bag_state(bag: Bag) -> tuple[str, list[str]]:
    """('complete' | 'DAMAGED …' | 'INCOMPLETE: …' | 'recorded intact; …', the losses found).

    'complete' only where something could be checked: a bag written offline (no recorder counters), or a
    live recording whose publishers' counters agree with it. A live recording whose publishers left no
    counters (nodes started on their own, not by ``run``) is intact as far as the recorder saw, which
    says nothing of messages it never received.
    """
    if bag.problem is not None:
        return damage_state(bag), []
    if CUSTOM_REPAIRED in bag.custom_data:
        # Intact as a file now, but these records came back without a checksum to vouch for them.
        return f"repaired: {bag.custom_data[CUSTOM_REPAIRED]}", []
    accounting = bag_accounting(bag)
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


def info_lines(path: str) -> tuple[list[str], str | None]:
    """(report lines, damage note or None) for the bag at ``path``."""
    bag = read_bag(path)
    size = bag.mcap_path.stat().st_size
    state, losses = bag_state(bag)
    lines = [
        f"bag:       {bag.path}  [{state}]",
        f"file:      {bag.mcap_path.name}  {size / 1e6:.2f} MB",
        f"duration:  {bag.duration_s:.3f} s  (log time {bag.start_ns * 1e-9:.3f}-{bag.end_ns * 1e-9:.3f} s)",
        f"messages:  {bag.message_count}",
        f"scene:     {scene_name(bag) or '(not stored)'}",
        f"plan:      {bag.custom_data.get(CUSTOM_PLAN, '(not stored)').removeprefix('plan: ')}",
        f"written by pendulum_accel {bag.custom_data.get(CUSTOM_VERSION, '?')}",
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
    lines, note = info_lines(args.bag)
    print("\n".join(lines))
    if note is not None:
        print(f"pendulum-accel info: warning: {note}", file=sys.stderr)
        return 1
    return 0
