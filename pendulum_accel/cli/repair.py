"""``pendulum-accel repair BAG``: rebuild metadata.yaml and the MCAP index/summary from the data on disk."""

from __future__ import annotations

import argparse

from pendulum_accel.bag.repair import BACKUP_SUFFIXES, DROPS, repair_bag


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``repair`` subcommand."""
    parser = subparsers.add_parser(
        "repair",
        help="rebuild a damaged bag (killed recorder) from what its MCAP file holds",
        description=(
            "Rewrite BAG from every intact chunk and every intact message record of its damaged or "
            "cut-off chunks, with a new MCAP summary/index/CRCs and metadata.yaml. Each file replaced is "
            "kept unless --no-backup: a damaged one as <name>.mcap.damaged, an intact one (of a split "
            "recording, or with a wrong metadata.yaml) as <name>.mcap.orig. " + DROPS + "."
        ),
    )
    parser.add_argument("bag", help="bag directory")
    parser.add_argument(
        "--no-backup", action="store_true", help="delete the replaced files instead of keeping them"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Repair and report what was kept."""
    result = repair_bag(args.bag, keep_backup=not args.no_backup)
    if not result.rewritten:
        total = sum(result.counts.values())
        print(f"{result.path}: intact ({total} messages), nothing to repair")
        return 0
    print(f"{result.path}: {result.problem}")
    print(f"rebuilt with {sum(result.counts.values())} messages:")
    for name, count in result.counts.items():
        print(f"  {name}: {count}")
    for damage in result.damage:
        print(f"  damaged {damage.sentence(result.origin_ns)}")
    if result.recovered:
        print(
            f"{result.recovered} messages were recovered by parsing damaged chunks: each frames and decodes "
            "as CDR of its channel's type, but no checksum vouches for its values (a flipped bit inside a "
            "number decodes too); info shows them as repaired"
        )
    print(f"dropped: {result.dropped} message records found not intact. {DROPS}.")
    for backup in result.backups:
        what = "damaged" if backup.name.endswith(BACKUP_SUFFIXES[True]) else "intact"
        print(f"{what} file kept as {backup}")
    return 0
