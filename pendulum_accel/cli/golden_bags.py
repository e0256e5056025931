"""``pendulum-accel golden-bags DIR``: regenerate the golden bags (one per bundled scene) into DIR."""

from __future__ import annotations

import argparse

from pendulum_accel.recording.golden import GOLDEN_MAX_DURATION, write_golden_bags


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``golden-bags`` subcommand."""
    parser = subparsers.add_parser(
        "golden-bags",
        help="regenerate the small golden bags of the bundled scenes (make bags)",
        description="Write DIR/<scene>/ for every bundled scene (overwriting) and DIR/README.md.",
    )
    parser.add_argument("folder", help="output folder, e.g. bags")
    parser.add_argument(
        "--max-duration", type=float, default=GOLDEN_MAX_DURATION, metavar="S", help="cut scenes to S s"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Write the bags and print one line per bag."""
    bags = write_golden_bags(args.folder, max_duration=args.max_duration)
    for b in bags:
        s = b.analysis.stats
        print(
            f"{args.folder}/{b.scene}: {b.result.messages} messages, {b.size_bytes / 1e3:.0f} kB; "
            f"{b.analysis.estimator} RMS {s.rms:.4f} m/s², max {s.max_abs:.4f} m/s²"
        )
    print(f"total {sum(b.size_bytes for b in bags) / 1e6:.2f} MB")
    return 0
