"""``pendulum-accel generate SCENE --out BAG``: a bag straight from a scene, no DDS."""

from __future__ import annotations

import argparse
import shutil

from pendulum_accel.cli.output import check_output_dir
from pendulum_accel.errors import OutputError
from pendulum_accel.overrides import SET_HELP, apply_overrides, parse_override
from pendulum_accel.recording.generate import generate_bag
from pendulum_accel.scene import load_scene


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``generate`` subcommand."""
    parser = subparsers.add_parser(
        "generate",
        help="write a bag straight from a scene (every topic a live recording holds), no DDS",
        description=(
            "Simulate SCENE (a bundled name or a YAML path), run the default estimator, and write "
            "everything a live recording would hold to the bag directory --out."
        ),
    )
    parser.add_argument("scene", help="bundled scene name or scene YAML path")
    parser.add_argument("--out", "-o", required=True, help="bag directory to create")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bag at --out")
    parser.add_argument(
        "--duration", type=float, default=None, metavar="S", help="shorten the scene to S s (at most its own)"
    )
    parser.add_argument("--estimator", "-e", default=None, help="estimator for /car/accel/estimate")
    parser.add_argument("--compress", action="store_true", help="zstd-compress the MCAP chunks")
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE", help=SET_HELP
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Generate and print counts and speed; a write failure is one line and leaves no partial bag."""
    out = check_output_dir(args.out)
    overrides = dict(parse_override(text) for text in args.overrides)
    scene = apply_overrides(load_scene(args.scene), overrides) if overrides else args.scene
    existed = out.exists()
    try:
        result = generate_bag(
            scene,
            out,
            overwrite=args.overwrite,
            estimator=args.estimator,
            duration=args.duration,
            compression="zstd" if args.compress else None,
        )
    except OSError as err:
        # A generated bag is cheap to make again: a partial one is removed rather than kept for repair.
        removed = out.is_dir() and not out.is_symlink() and (args.overwrite or not existed)
        if removed:
            shutil.rmtree(out, ignore_errors=True)
        kept = "the partial bag was removed" if removed else "nothing was written"
        raise OutputError(f"cannot write bag {out}: {err.strerror or err}; {kept}") from None
    speed = result.sim_duration / result.wall_s if result.wall_s > 0 else float("inf")
    print(
        f"{result.path}: {result.messages} messages, {result.sim_duration:.3f} s of sim time "
        f"in {result.wall_s:.3f} s ({speed:.0f}x real time)"
    )
    for topic, count in result.counts.items():
        print(f"  {topic}: {count}")
    return 0
