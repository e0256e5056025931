"""``pendulum-accel export BAG``: a bag as CSV or Parquet tables (one per topic, or one merged)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pendulum_accel.bag.export import FORMATS, export_bag
from pendulum_accel.bag.reader import read_bag, salvage_note
from pendulum_accel.recording.analyze import smoothed_estimate

SMOOTHED = "/car/accel/smoothed"
"""Name of the derived smoother series (not a topic in the bag): columns a and variance."""


def register(subparsers: Any) -> None:
    """Add the ``export`` subcommand."""
    parser = subparsers.add_parser(
        "export",
        help="write a bag's topics as CSV or Parquet tables (pandas)",
        description=(
            "Write every topic of BAG (or --topics) as a table, one file per topic, or one table merged "
            "on the angle's stamps (--merged). Columns are named as PlotJuggler names them "
            "(/car/accel/estimate/accel/accel/linear/x). Needs the export extra (pandas, pyarrow)."
        ),
    )
    parser.add_argument("bag", help="bag directory (or .mcap file)")
    parser.add_argument("--out", required=True, metavar="DIR", help="directory for the tables")
    parser.add_argument("--format", choices=FORMATS, default="csv", help="file format (default csv)")
    parser.add_argument("--merged", action="store_true", help="one table on the angle's stamps")
    parser.add_argument("--topics", nargs="+", default=[], metavar="TOPIC", help="only these topics")
    parser.add_argument(
        "--no-smoothed",
        action="store_true",
        help=f"leave out {SMOOTHED}/a and /variance, the RTS smoother's acceleration over the whole bag "
        "(written by default when the bag stores its scene)",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Write the tables and list them; a damaged bag is exported up to the damage, with a warning, exit 1."""
    bag = read_bag(args.bag)
    smoothed = None if args.no_smoothed else smoothed_estimate(bag)
    derived = {} if smoothed is None else {SMOOTHED: smoothed}
    for path in export_bag(
        bag, args.out, fmt=args.format, merged=args.merged, topics=args.topics, derived=derived
    ):
        print(path)
    note = salvage_note(bag)
    if note is not None:
        print(f"pendulum-accel export: warning: {note}", file=sys.stderr)
        return 1
    return 0
