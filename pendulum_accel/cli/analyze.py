"""``pendulum-accel analyze BAG``: recorded estimate and offline re-run side by side, against the truth."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from pendulum_accel.bag.reader import read_bag, salvage_note
from pendulum_accel.errors import BagError
from pendulum_accel.overrides import OVERRIDE_BY_NAME
from pendulum_accel.recording.analyze import analysis_dict, analyze_bag, plot_analysis

ESTIMATOR_OVERRIDES = ("length", "noise_std")
"""Scene fields ``analyze`` lets the user replace in the estimator's settings (ranges: overrides.py)."""


def register(subparsers: Any) -> None:
    """Add the ``analyze`` subcommand."""
    parser = subparsers.add_parser(
        "analyze",
        help="compare a bag's recorded estimate and an offline re-run with its truth",
        description=(
            "Compare the estimate recorded in BAG (the live estimator's) and an offline re-run of an "
            "estimator on its recorded angles (no ROS needed) with the recorded truth, side by side: "
            "counts and holes, bias, RMS, max error, settling time, settled figures. The estimator "
            "settings come from the scene stored in the bag."
        ),
    )
    parser.add_argument("bag", help="bag directory (or .mcap file)")
    parser.add_argument(
        "--estimator",
        "-e",
        default=None,
        help="estimator to re-run (default: the one the bag was recorded with)",
    )
    parser.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="save angle / recorded and re-run acceleration / error plot",
    )
    parser.add_argument("--skip", type=float, default=0.0, metavar="S", help="ignore the first S seconds")
    parser.add_argument("--tolerance", type=float, default=None, metavar="A", help="settling band, m/s²")
    for name in ESTIMATOR_OVERRIDES:
        spec = OVERRIDE_BY_NAME[name]
        parser.add_argument(
            "--" + name.replace("_", "-"),
            type=float,
            default=None,
            help=f"{spec.description} ({spec.unit}), overrides the stored scene's",
        )
    parser.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the report (and plot); a damaged bag is analysed up to the damage, with a warning, exit 1."""
    bag = read_bag(args.bag)
    if args.skip > 0 and not args.skip < bag.duration_s:
        # Nothing would be left to average: the report would be NaN figures.
        raise BagError(f"--skip {args.skip:g} s leaves no samples: {bag.path} spans {bag.duration_s:.3f} s")
    config = {
        name: OVERRIDE_BY_NAME[name].check(getattr(args, name))
        for name in ESTIMATOR_OVERRIDES
        if getattr(args, name) is not None
    }
    result = analyze_bag(
        bag, estimator=args.estimator, config=config, skip=args.skip, tolerance=args.tolerance
    )
    if args.json:
        print(json.dumps(analysis_dict(result)))
    else:
        print("\n".join(result.lines()))
    if args.plot:
        path = plot_analysis(result, args.plot)
        if not args.json:
            print(f"plot:       {path}")
    note = salvage_note(bag)
    if note is not None:
        print(f"pendulum-accel analyze: warning: {note}", file=sys.stderr)
        return 1
    return 0
