"""``pendulum-accel animate SCENE|BAG --out swing.gif|.mp4``: the car and the swinging bob from a run."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from pendulum_accel.cli.output import check_output_file, write_output
from pendulum_accel.cli.salvage import add_salvage_flag, read_intact, warn_salvaged
from pendulum_accel.cli.sensor_flags import add_sensor_flags, sensor_config
from pendulum_accel.cli.topics import add_topic_flags, choose_topics
from pendulum_accel.errors import ParameterError

DEFAULT_FPS = 20
DEFAULT_DURATION = 10.0  # s: a longer run is cut, so a GIF stays small; --duration changes it


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``animate`` subcommand."""
    parser = subparsers.add_parser(
        "animate",
        help="draw the car and the swinging bob from a scene or a bag, as a GIF or MP4",
        description=(
            "Animate SCENE (a bundled name or a YAML path, simulated) or BAG (a recorded bag directory or "
            ".mcap, with the estimator re-run offline): the car with the bob on its string, the true and "
            "estimated acceleration as arrows, and θ(t) below. GIF is written with Pillow, MP4 with ffmpeg."
        ),
    )
    parser.add_argument("source", metavar="SCENE|BAG", help="bundled scene name, scene YAML, or bag path")
    parser.add_argument("--out", type=Path, required=True, metavar="FILE.gif|FILE.mp4", help="output file")
    parser.add_argument(
        "--fps", type=int, default=DEFAULT_FPS, help=f"frames per second (default {DEFAULT_FPS})"
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=DEFAULT_DURATION,
        metavar="S",
        help=f"animate at most the first S seconds (default {DEFAULT_DURATION:g})",
    )
    parser.add_argument(
        "--estimator", "-e", default=None, help="estimator method (default: the package default)"
    )
    add_sensor_flags(parser)
    add_salvage_flag(parser)
    add_topic_flags(parser)
    parser.set_defaults(func=run)


def _is_bag(source: str) -> bool:
    """True when ``source`` is a bag directory (has metadata.yaml or an .mcap) or an .mcap file."""
    path = Path(source)
    if path.suffix == ".mcap":
        return True
    return path.is_dir() and ((path / "metadata.yaml").is_file() or any(path.glob("*.mcap")))


def run(args: argparse.Namespace) -> int:
    """Build the swing from the scene or bag, render every frame, write the file."""
    from pendulum_accel.animation import SwingAnimation, check_output_path, swing_from_bag, swing_from_scene
    from pendulum_accel.scene import load_scene

    # A bad path or a missing ffmpeg fails before the simulation, not after it.
    out_path = check_output_file(args.out, (".gif", ".mp4"))
    check_output_path(out_path)
    if args.fps < 1:
        raise ParameterError(f"--fps must be an integer >= 1, got {args.fps}")
    bag = choose_topics(read_intact(args.source, args.salvage), args) if _is_bag(args.source) else None
    if bag is not None:
        data = swing_from_bag(bag, args.estimator, sensor_config(args))
    elif sensor_config(args):
        raise ParameterError(
            "--length and --noise-std describe a bag's sensor; a scene's pendulum is its own (edit the scene)"
        )
    else:
        data = swing_from_scene(load_scene(args.source), args.estimator)
    anim = SwingAnimation(data, fps=args.fps, duration=args.duration)
    with tqdm(
        total=anim.times.size, desc="frames", file=sys.stderr, leave=False, delay=1.0, disable=None
    ) as bar:
        out = write_output(out_path, lambda path: anim.encode(path, on_frame=lambda: bar.update(1)))
    size = out.stat().st_size if out.is_file() else 0
    print(f"wrote {anim.times.size} frames at {args.fps:g} fps ({size / 1024:.0f} KiB) to {out}")
    return warn_salvaged("animate", bag) if bag is not None else 0
