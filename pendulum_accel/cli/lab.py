"""``pendulum-accel lab check``: a student proves the install works before class, and compiles into numba's
cache the estimators the notebook runs, on data read from a CSV file as the notebook reads its group's.
``pendulum-accel lab make-class``: a teacher writes a class's lab data (one folder and zip per group) and
its key from a secret. The code that measures the answers lives in the repository's ``lab_teacher/``
(the teacher's edition), which the installed package does not hold: make-class runs from a clone (or
with ``--teacher DIR``)."""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from types import ModuleType

from pendulum_accel.errors import ParameterError

TEACHER_PACKAGE = "lab_teacher"


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``lab`` subcommand and its ``make-class`` action."""
    parser = subparsers.add_parser(
        "lab",
        help="the lab: check a student's install; make a class's data and key from a secret (teachers)",
        description=(
            "The lab (docs/lab/). 'lab check': students, before class, prove the install works and compile "
            "the estimators the notebook runs, once. 'lab make-class --secret FILE --class NAME --groups N "
            "--out DIR': teachers write a folder and zip per group and the key (from a clone of the "
            "repository, the teacher's edition, which holds lab_teacher/)."
        ),
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    check = actions.add_parser(
        "check",
        help="students, before class: check the install and compile the notebook's estimators (once)",
        description=(
            "Simulate a short swing, write it to a CSV file and read it back as the notebook reads its "
            "group's data, run the lab's four estimators on it, draw a plot and look for Jupyter. The first "
            "run compiles the estimators into numba's on-disk cache, so that the notebook's cells do not "
            "compile in class; later runs take seconds. Ends with 'install OK', or names what is missing "
            "(exit 2)."
        ),
    )
    check.set_defaults(func=run_check)
    make = actions.add_parser(
        "make-class",
        help="write one data folder and zip per group, and the teacher key, from a secret",
        description=(
            "Write DIR/group_NN/ (data/ with the group's recordings and params.json, the worksheet and the "
            "student notebook), DIR/group_NN.zip to hand out, and DIR/teacher_key.md. Each group's hidden "
            "parameters are drawn from HMAC-SHA256(secret, CLASS/group_NN): without the secret nobody can "
            "regenerate them."
        ),
    )
    make.add_argument("--secret", type=Path, required=True, metavar="FILE", help="at least 16 random bytes")
    make.add_argument(
        "--class",
        dest="class_name",
        required=True,
        metavar="NAME",
        help="the class's name: with the secret, it draws the data (another class, other data)",
    )
    make.add_argument("--groups", type=int, required=True, metavar="N", help="number of groups, 1 to 99")
    make.add_argument(
        "--out", type=Path, required=True, metavar="DIR", help="a new directory (its parent must exist)"
    )
    make.add_argument(
        "--teacher",
        type=Path,
        metavar="DIR",
        help="the clone holding lab_teacher/ (default: the clone this package runs from, or the current one)",
    )
    make.set_defaults(func=run)


def _teacher_module(where: Path | None) -> ModuleType:
    """lab_teacher.key, imported from ``where``, the clone this package sits in, or the working directory."""
    candidates = [where] if where else [Path(__file__).resolve().parents[2], Path.cwd()]
    for root in candidates:
        if (root / TEACHER_PACKAGE / "key.py").is_file():
            if str(root) not in sys.path:
                sys.path.insert(0, str(root))
            return importlib.import_module(f"{TEACHER_PACKAGE}.key")
    raise ParameterError(
        "make-class needs the teacher material (lab_teacher/ in a clone of the repository); "
        "run it from the clone or give --teacher DIR"
    )


LAB_ESTIMATORS = ("instant", "period_mean", "kalman", "dynamic")  # the estimators the lab's notebook runs
LAB_MODULES = ("jupyterlab", "ipykernel")  # the lab extra: the notebook needs them, the package does not


def run_check(args: argparse.Namespace) -> int:
    """Run what the lab's notebook runs, once, and report each step's time; 'install OK' at the end.

    The estimators run on a CSV file read back with np.genfromtxt(names=True), as the notebook's ``load``
    reads a group's data: the columns of that table are what the notebook's cells hand the estimators.
    """
    import dataclasses
    import importlib.util
    import io
    import tempfile
    import time

    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pendulum_accel.estimators import estimate_batch
    from pendulum_accel.scene import load_scene
    from pendulum_accel.scene_run import run_scene

    missing = [name for name in LAB_MODULES if importlib.util.find_spec(name) is None]
    if missing:
        raise ParameterError(f'missing {", ".join(missing)}: install the lab extra (pip install ".[lab]")')
    start = time.perf_counter()
    run = run_scene(dataclasses.replace(load_scene("lecture_constant"), duration=5.0))
    print(f"simulator: {run.t.size} samples ({time.perf_counter() - start:.1f} s)")
    p, s = run.scene.pendulum, run.scene.sensor
    cfg = {"length": p.length, "gravity": p.gravity, "noise_std": s.noise_std, "rate_hz": s.rate_hz}
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "check.csv"
        columns = np.column_stack((run.t, run.theta_measured, run.accel_true))
        np.savetxt(path, columns, delimiter=",", header="t_s,theta_rad,accel_m_s2", comments="")
        table = np.genfromtxt(path, delimiter=",", names=True)  # the notebook's load()
    start = time.perf_counter()
    for name in LAB_ESTIMATORS:
        estimate_batch(name, table["t_s"], table["theta_rad"], **cfg)
    took = time.perf_counter() - start
    print(
        f"estimators: {', '.join(LAB_ESTIMATORS)} on a CSV read as the notebook reads it ({took:.1f} s; "
        "the first run compiles them, once)"
    )
    fig, ax = plt.subplots()
    ax.plot(run.t, run.theta_measured)
    fig.savefig(io.BytesIO(), format="png")
    plt.close(fig)
    print("plot: matplotlib draws; Jupyter: " + ", ".join(LAB_MODULES) + " found")
    print("install OK")
    return 0


def run(args: argparse.Namespace) -> int:
    """Make the class and print where its key and zips are."""
    key = _teacher_module(args.teacher).make_class(args.secret, args.groups, args.out, args.class_name)
    zips = sorted(args.out.glob("*.zip"))
    print(f"wrote {len(zips)} group folders and zips in {args.out} (hand out the zips)")
    print(f"teacher key: {key} (keep it, and the secret, to yourself)")
    return 0
