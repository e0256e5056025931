"""``pendulum-accel analyze BAG``: recorded estimate and offline re-run side by side, against the truth."""

from __future__ import annotations

import argparse

from pendulum_accel.cli.fleet import fleet_wanted, run_fleet
from pendulum_accel.cli.output import check_output_file, json_text, write_output
from pendulum_accel.cli.salvage import add_salvage_flag, read_intact, warn_salvaged
from pendulum_accel.cli.sensor_flags import add_sensor_flags, sensor_config
from pendulum_accel.cli.topics import add_topic_flags, choose_topics
from pendulum_accel.errors import ParameterError
from pendulum_accel.recording.analysis_plot import plot_analysis
from pendulum_accel.recording.analyze import analysis_dict, analyze_bag
from pendulum_accel.recording.coverage import nees_fields
from pendulum_accel.recording.seed_spread import SeedSpread, seed_spread
from pendulum_accel.recording.stored_scene import stored_scene


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
    parser.add_argument(
        "bags",
        nargs="+",
        metavar="BAG",
        help="bag directory or .mcap file; several, a directory tree (every bag below it) or a glob "
        "analyse a fleet into one table (--out)",
    )
    parser.add_argument(
        "--estimator",
        "-e",
        action="append",
        default=None,
        help="estimator to re-run (default: the one the bag was recorded with); repeat it for a fleet "
        "table's rows per estimator",
    )
    parser.add_argument(
        "--out",
        default=None,
        metavar="TABLE",
        help="write one row per bag × estimator to TABLE (.parquet or .csv; - for CSV on standard output); "
        "implied for several bags",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run a fleet on this Dask scheduler (e.g. tcp://10.0.0.5:8786; default $DASK_SCHEDULER_ADDRESS, "
        "else a local cluster sized to the machine)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the local cluster (default: one per CPU)",
    )
    parser.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="save angle / recorded and re-run acceleration / error plot",
    )
    parser.add_argument("--skip", type=float, default=0.0, metavar="S", help="ignore the first S seconds")
    parser.add_argument(
        "--lag",
        type=float,
        default=0.0,
        metavar="S",
        help="re-run as a fixed-lag smoother: each estimate uses S s of later data (kalman; 0: the filter; "
        "--estimator smoother: the whole bag)",
    )
    parser.add_argument("--tolerance", type=float, default=None, metavar="A", help="settling band, m/s²")
    add_sensor_flags(parser)
    parser.add_argument(
        "--seeds",
        type=int,
        default=0,
        metavar="N",
        help="also re-simulate the bag's scene with sensor seeds 0..N-1 and print the calibration pooled "
        "over them (their independent trials summed, the pooled share's 95 %% interval at that sum), with "
        "the spread of one seed's share beyond 2σ (one bag is one draw of its noise)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the figures as one JSON object (strict JSON: a figure that does not exist is null)",
    )
    add_salvage_flag(parser)
    add_topic_flags(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the report (and plot); a damaged bag is refused, or with --salvage analysed from its intact
    records, with a warning, exit 1. Several bags (or --out): the fleet table (cli.fleet)."""
    if fleet_wanted(args):
        return run_fleet(args)
    args.estimator = args.estimator[0] if args.estimator else None
    plot = check_output_file(args.plot, (".png",), option="--plot") if args.plot is not None else None
    bag = choose_topics(read_intact(args.bags[0], args.salvage), args)
    if args.skip > 0 and not args.skip < bag.duration_s:
        # Nothing would be left to average: the report would be NaN figures.
        raise ParameterError(
            f"--skip {args.skip:g} s leaves no samples: {bag.path} spans {bag.duration_s:.3f} s"
        )
    config = sensor_config(args)
    if args.seeds < 0:
        raise ParameterError(f"--seeds must be >= 0, got {args.seeds}")
    scene = stored_scene(bag) if args.seeds else None
    if args.seeds and scene is None:
        raise ParameterError(f"--seeds re-simulates the bag's scene, and {bag.path} stores none")
    result = analyze_bag(
        bag, estimator=args.estimator, config=config, skip=args.skip, tolerance=args.tolerance, lag=args.lag
    )
    spread = (
        None if scene is None else seed_spread(scene, result.estimator, result.options, args.seeds, args.skip)
    )
    if args.json:
        print(json_text({**analysis_dict(result), "seed_spread": _spread_dict(spread)}))
    else:
        print("\n".join(result.lines()))
        if spread is not None:
            print(spread.line())
    if plot is not None:
        path = write_output(plot, lambda target: plot_analysis(result, target))
        if not args.json:
            print(f"plot:       {path}")
    return warn_salvaged("analyze", bag)


def _spread_dict(spread: SeedSpread | None) -> dict[str, float | None] | None:
    """{seeds, nees_<window>_…}: the pooled figures under a single bag's keys (recording.coverage.nees_fields:
    mean, median, share_2sigma, trials, share_2sigma_low/_high, share_3sigma), and
    nees_<window>_share_p10/_p90 of one seed's share; a window without samples null throughout. None
    without --seeds."""
    if spread is None:
        return None
    out: dict[str, float | None] = {"seeds": spread.seeds}
    for window in ("steady", "after_change"):
        w = getattr(spread, window)
        key = f"nees_{window}"
        out.update(nees_fields(key, None if w is None else w.pooled))
        out[f"{key}_share_p10"] = None if w is None else w.share_low
        out[f"{key}_share_p90"] = None if w is None else w.share_high
    return out
