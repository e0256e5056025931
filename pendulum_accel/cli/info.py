"""``pendulum-accel info BAG``: topics, types, counts, rates, duration, scene and plan of a bag."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pendulum_accel.bag.reader import read_bag, salvage_note, scene_name
from pendulum_accel.bag.writer import CUSTOM_PLAN, CUSTOM_VERSION


def register(subparsers: Any) -> None:
    """Add the ``info`` subcommand."""
    parser = subparsers.add_parser(
        "info",
        help="summarise a bag: topics, counts, duration, scene and plan",
        description="Summarise a rosbag2 MCAP bag without ROS. A damaged bag is summarised up to the damage.",
    )
    parser.add_argument("bag", help="bag directory (or .mcap file)")
    parser.set_defaults(func=run)


def info_lines(path: str) -> tuple[list[str], str | None]:
    """(report lines, damage note or None) for the bag at ``path``."""
    bag = read_bag(path)
    size = bag.mcap_path.stat().st_size
    state = "complete" if bag.problem is None else "DAMAGED (see the warning)"
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
    return lines, salvage_note(bag)


def run(args: argparse.Namespace) -> int:
    """Print the summary; a damaged bag also prints one warning line on stderr and exits 1."""
    lines, note = info_lines(args.bag)
    print("\n".join(lines))
    if note is not None:
        print(f"pendulum-accel info: warning: {note}", file=sys.stderr)
        return 1
    return 0
