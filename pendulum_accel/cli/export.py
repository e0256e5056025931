"""``pendulum-accel export BAG``: a bag as CSV or Parquet tables (one per topic, or one merged)."""

from __future__ import annotations

import argparse
import functools
import sys

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.export import FORMATS, VISUAL_ROLES, export_bag, export_tables, write_csv_table
from pendulum_accel.cli.output import check_output_dir, output_directory
from pendulum_accel.cli.salvage import add_salvage_flag, read_intact, warn_salvaged
from pendulum_accel.cli.sensor_flags import add_sensor_flags, sensor_config
from pendulum_accel.cli.topics import add_topic_flags, choose_topics, namespace_topics
from pendulum_accel.errors import OutputError

SMOOTHED = "/car/accel/smoothed"
"""Name of the derived smoother series (not a topic in the bag): columns a and variance."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="directory for the tables, or '-': the one --merged CSV table to standard output",
    )
    parser.add_argument("--format", choices=FORMATS, default="csv", help="file format (default csv)")
    parser.add_argument("--merged", action="store_true", help="one table on the angle's stamps")
    parser.add_argument("--topics", nargs="+", default=[], metavar="TOPIC", help="only these topics")
    add_salvage_flag(parser)
    add_topic_flags(parser)
    parser.add_argument(
        "--no-smoothed",
        action="store_true",
        help=f"leave out {SMOOTHED}/a and /variance, the RTS smoother's acceleration over the whole bag "
        "(written by default when the bag stores its scene, or --length gives its sensor)",
    )
    add_sensor_flags(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Write the tables and list them; a damaged bag is refused, or with --salvage exported from its intact
    records, with a warning, exit 1.

    The output directory is checked first; a bag of foreign data (another joint, another frame) is refused.
    """
    from pendulum_accel.recording.contract import check_chain_contract  # estimators: loaded when used

    to_stdout = args.out == "-"
    if to_stdout and not (args.merged and args.format == "csv"):
        raise OutputError(
            "--out '-' (standard output) takes one CSV table: add --merged (and --format csv), or give a "
            "directory; nothing written"
        )
    out = None if to_stdout else check_output_dir(args.out)
    bag = choose_topics(read_intact(args.bag, args.salvage), args)
    check_chain_contract(bag)
    from pendulum_accel.recording.smoothed import smoothable, smoothed_estimate  # estimators: when used

    # Computed when its table is written (after the topics'; first for --merged): the smoother's memory
    # and the topics' batches are not held at once.
    config = sensor_config(args)
    smooth = not args.no_smoothed and smoothable(bag, config)
    derived = {SMOOTHED: functools.partial(smoothed_estimate, bag, config)} if smooth else {}
    # With --namespace, by default that chain's topics (but the visual ones, as export_bag leaves them).
    in_ns = [t for t in namespace_topics(bag) if bm.role_of(t) not in VISUAL_ROLES]
    topics = args.topics or (in_ns if bag.choice.namespace else [])
    if out is None:
        (frames,) = export_tables(bag, merged=True, topics=topics, derived=derived).values()
        write_csv_table(frames, sys.stdout)
        return warn_salvaged("export", bag)
    with output_directory(out):
        paths = export_bag(bag, out, fmt=args.format, merged=args.merged, topics=topics, derived=derived)
    for path in paths:
        print(path)
    return warn_salvaged("export", bag)
