"""``pendulum-accel design``: sensor designs × motion profiles × seeds, one row per design, and the
accuracy–latency front (recording.design_study), on Dask like ``analyze`` over many bags."""

from __future__ import annotations

import argparse
import math
import sys

from pendulum_accel.cli.output import check_output_file, write_output
from pendulum_accel.errors import ParameterError

TABLE_SUFFIXES = (".parquet", ".csv")


GRID_OPTIONS = ("lengths", "damping_ratios", "rates", "noises", "quantizations", "lags")
"""Options holding comma-separated numbers: parsed in run(), so a bad one is the package's one line."""


def _floats(option: str, text: str | list[float]) -> list[float]:
    """'0.05,0.2,1' → [0.05, 0.2, 1.0] (a default list as it is); ParameterError naming --option."""
    if isinstance(text, list):
        return text
    flag = "--" + option.replace("_", "-")
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ParameterError(f"{flag} takes comma-separated numbers, got {text!r}") from None
    if not values or not all(math.isfinite(v) for v in values):
        raise ParameterError(f"{flag} takes comma-separated finite numbers, got {text!r}")
    return values


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``design`` subcommand."""
    from pendulum_accel.recording.design_study import DEFAULT_DURATION, DEFAULT_LAGS, DEFAULT_PROFILES

    parser = subparsers.add_parser(
        "design",
        help="sweep sensor designs over motion profiles and seeds: a table and the accuracy-latency front",
        description=(
            "Simulate every sensor design (the grid of --lengths × --damping-ratios × --rates × --noises × "
            "--quantizations) on every motion profile with seeds 0..N-1, run the default estimator live "
            "and as a fixed-lag smoother at each --lags, and write one row per design: RMS per lag, "
            "delay, share of errors beyond 2σ steady and after a change (with its independent trials and "
            "95 % interval) and beyond 3σ, mean NEES. The plot draws each design's latency–RMS curve, "
            "named in its legend, and the front no design beats. One case (design × profile × seed) is "
            "one task on Dask (a local cluster, or --scheduler)."
        ),
    )
    parser.add_argument("--out", required=True, metavar="TABLE", help="the table (.parquet or .csv)")
    parser.add_argument("--plot", default=None, metavar="PNG", help="the accuracy–latency front")
    parser.add_argument(
        "--profiles",
        nargs="+",
        default=list(DEFAULT_PROFILES),
        metavar="SCENE",
        help=f"bundled scene names or scene YAML paths giving a(t) (default: {' '.join(DEFAULT_PROFILES)})",
    )
    parser.add_argument("--lengths", default=[0.05, 0.2, 1.0], metavar="L,...", help="m")
    parser.add_argument("--damping-ratios", default=[0.05, 0.7], metavar="Z,...", help="ζ (1: critical)")
    parser.add_argument("--rates", default=[50.0, 200.0], metavar="HZ,...", help="Hz")
    parser.add_argument("--noises", default=[1e-3, 5e-3], metavar="RAD,...", help="σ, rad")
    parser.add_argument("--quantizations", default=[0.0], metavar="RAD,...", help="step, rad")
    parser.add_argument("--lags", default=list(DEFAULT_LAGS), metavar="S,...", help="s")
    parser.add_argument("--seeds", type=int, default=2, metavar="N", help="sensor seeds per case")
    parser.add_argument(
        "--duration", type=float, default=DEFAULT_DURATION, metavar="S", help="seconds of each profile"
    )
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask scheduler to run on")
    parser.add_argument("--workers", type=int, default=None, metavar="N", help="local cluster's workers")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the study, write the table (and the plot)."""
    from pendulum_accel.recording import design_study as ds
    from pendulum_accel.recording.fleet import stderr_progress, write_rows
    from pendulum_accel.scene import load_scene

    for option in GRID_OPTIONS:
        setattr(args, option, _floats(option, getattr(args, option)))
    out = check_output_file(args.out, TABLE_SUFFIXES, option="--out")
    plot = check_output_file(args.plot, (".png",), option="--plot") if args.plot is not None else None
    if not 0.0 < args.duration <= 1e6:
        raise ParameterError(f"--duration must be in (0, 1e6] s, got {args.duration}")
    if args.workers is not None and not 1 <= args.workers <= 1024:
        raise ParameterError(f"--workers must be 1..1024, got {args.workers}")
    for profile in args.profiles:
        load_scene(profile)  # a typo or a bad scene is one line before any work
    designs = ds.design_grid(args.lengths, args.damping_ratios, args.rates, args.noises, args.quantizations)
    cases = len(designs) * len(args.profiles) * args.seeds
    if cases > 100_000:
        raise ParameterError(
            f"{cases} cases (designs × profiles × seeds) is more than 100000; narrow the grid"
        )
    tick, close = stderr_progress(cases, unit="case")
    try:
        rows = ds.study(
            designs,
            args.profiles,
            seeds=args.seeds,
            duration=args.duration,
            lags=args.lags,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=tick,
        )
    finally:
        close()
    write_output(out, lambda target: write_rows(rows, target))
    if plot is not None:
        write_output(plot, lambda target: ds.plot_front(rows, target))
    print(
        f"{len(designs)} designs × {len(args.profiles)} profiles × {args.seeds} seeds: table {out}",
        file=sys.stderr,
    )
    for latency, rms, name in ds.front(rows):
        print(f"front: latency {latency:.3g} s, RMS {rms:.3g} m/s², {name}")
    return 0
