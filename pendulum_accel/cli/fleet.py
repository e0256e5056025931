"""``pendulum-accel analyze`` over many bags: one table, one row per bag × estimator (recording.fleet)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pendulum_accel.cli.output import check_output_file, write_output
from pendulum_accel.cli.sensor_flags import sensor_config
from pendulum_accel.cli.topics import topic_rules
from pendulum_accel.errors import BagError, ParameterError
from pendulum_accel.recording.fleet import (
    COLUMNS,
    Job,
    analyze_many,
    find_bags,
    is_bag_dir,
    stderr_progress,
    write_csv,
    write_rows,
)

TABLE_SUFFIXES = (".parquet", ".csv")

SINGLE_BAG_ONLY = ("plot", "seeds", "json", "salvage", "tolerance")
"""analyze options that describe one bag's report; a fleet table refuses them in one line."""


def fleet_wanted(args: argparse.Namespace) -> bool:
    """True for a fleet run: several inputs, --out, --scheduler, or one input that is not itself a bag."""
    if len(args.bags) > 1 or args.out is not None or args.scheduler is not None:
        return True
    if args.estimator is not None and len(args.estimator) > 1:
        return True
    path = Path(args.bags[0])
    if not path.exists():
        return any(c in args.bags[0] for c in "*?[")
    return path.is_dir() and not is_bag_dir(path)


def _refuse_single_bag_options(args: argparse.Namespace) -> None:
    """ParameterError naming the first single-bag option given to a fleet run."""
    for name in SINGLE_BAG_ONLY:
        value = getattr(args, name, None)
        if value not in (None, False, 0):
            flag = "--" + name.replace("_", "-")
            raise ParameterError(
                f"{flag} describes one bag's report; a fleet table (several bags) takes no {flag}"
            )


def run_fleet(args: argparse.Namespace) -> int:
    """Analyse every bag named by args.bags into one table (--out, default CSV on standard output).
    Exit 0 when every bag gave figures, 1 when some gave an error row (the table says which)."""
    _refuse_single_bag_options(args)
    if args.workers is not None and not 1 <= args.workers <= 1024:
        raise ParameterError(f"--workers must be 1..1024, got {args.workers}")
    out = None if args.out in (None, "-") else check_output_file(args.out, TABLE_SUFFIXES, option="--out")
    paths = find_bags(args.bags)
    if not paths:
        raise BagError(f"no bags found in {' '.join(args.bags)}")
    job = Job(
        estimators=tuple(args.estimator) if args.estimator else (None,),
        skip=args.skip,
        lag=args.lag,
        config=sensor_config(args),  # --length, --noise-std: one sensor's recordings without a scene
        topics=topic_rules(args),
    )
    tick, close = stderr_progress(len(paths))
    try:
        rows = analyze_many(paths, job, scheduler=args.scheduler, workers=args.workers, progress=tick)
    finally:
        close()
    if out is None:
        write_csv(rows, sys.stdout)
    else:
        write_output(out, lambda target: write_rows(rows, target, COLUMNS))
    failed = sorted({r["bag"] for r in rows if r["error"]})
    where = "standard output" if out is None else str(out)
    print(
        f"analyzed {len(paths)} bag(s) into {len(rows)} row(s) on {where}"
        + (f"; {len(failed)} bag(s) gave an error row" if failed else ""),
        file=sys.stderr,
    )
    return 1 if failed else 0
