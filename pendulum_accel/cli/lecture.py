"""``pendulum-accel lecture [NAME|all]``: list the lecture's results or reproduce one (or all) with a plot."""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from pendulum_accel.cli.output import check_output_file, write_output
from pendulum_accel.errors import ParameterError
from pendulum_accel.lecture import RESULTS, get_result

ALL = "all"


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``lecture`` subcommand."""
    parser = subparsers.add_parser(
        "lecture",
        help="reproduce a result of the lecture notes: formula vs simulation, with a plot",
        description=(
            "Without NAME: list the results. With NAME: print the lecture's formula, the simulated value, "
            "their difference against a stated tolerance (PASS/FAIL; exit code 1 on FAIL) and write a PNG "
            f"plot. NAME '{ALL}' runs every result."
        ),
    )
    parser.add_argument("name", nargs="?", metavar="NAME", help=f"one of: {', '.join(RESULTS)}, {ALL}")
    out = parser.add_mutually_exclusive_group()
    out.add_argument(
        "--plot", type=Path, metavar="OUT.png", help="where to write the plot (default: ./lecture_NAME.png)"
    )
    out.add_argument(
        "--plot-dir", type=Path, metavar="DIR", help="write the plot as DIR/lecture_NAME.png (for NAME 'all')"
    )
    out.add_argument("--no-plot", action="store_true", help="print the comparison only")
    parser.add_argument("--quick", action="store_true", help="coarse sweeps: faster, same checks")
    parser.set_defaults(func=run)


def plot_path(args: argparse.Namespace, name: str) -> Path | None:
    """--plot, else DIR/lecture_NAME.png for --plot-dir, else ./lecture_NAME.png; None with --no-plot."""
    if args.no_plot:
        return None
    if args.plot is not None:
        return Path(args.plot)
    return (args.plot_dir or Path.cwd()) / f"lecture_{name}.png"


def run(args: argparse.Namespace) -> int:
    """List results, or run the named one(s): print the report, write the plot; 1 if any check fails."""
    if args.name is None:
        width = max(len(n) for n in RESULTS)
        print("results of the lecture (run one with: pendulum-accel lecture NAME [--plot out.png]):")
        for result in RESULTS.values():
            if not result.extension:
                print(f"  {result.name:<{width}}  {result.summary}")
        print("extensions (beyond the lecture notes: road grade, chaos):")
        for result in RESULTS.values():
            if result.extension:
                print(f"  {result.name:<{width}}  {result.summary}")
        return 0
    names = list(RESULTS) if args.name == ALL else [get_result(args.name).name]
    if len(names) > 1 and args.plot is not None:
        raise ParameterError(f"--plot names one file; use --plot-dir DIR with '{ALL}'")
    # Imported here so listing the results stays quick (no matplotlib import).
    from pendulum_accel.lecture.plotting import write_plot
    from pendulum_accel.lecture.progress import working

    # A typo in the path fails before minutes of simulation, not after.
    option = "--plot-dir" if args.plot_dir is not None else "--plot"
    paths = {name: plot_path(args, name) for name in names}
    paths = {
        name: None if path is None else check_output_file(path, (".png",), option=option)
        for name, path in paths.items()
    }
    failed = 0
    for i, name in enumerate(names):
        with working(f"lecture {name}"):
            report = RESULTS[name].run(args.quick)
        if i:
            print()
        print(report.text())
        path = paths[name]
        if path is not None:
            print(f"  plot:     {write_output(path, functools.partial(write_plot, report))}")
        failed += not report.passed
    return 1 if failed else 0
