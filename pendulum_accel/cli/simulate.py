"""``pendulum-accel simulate [SCENE] [flags]``: plan and simulate a scene (or plain flags), write a CSV.

Columns: t, theta, theta_dot, then tension and stretch where the model has them. The plan's one-line
explanation goes to stderr, so the CSV on stdout stays clean.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import TextIO, TypedDict

import numpy as np

from pendulum_accel.cli.output import check_output_file, write_output, write_text_output
from pendulum_accel.errors import IllConditionedError, ParameterError, SceneError
from pendulum_accel.overrides import OVERRIDE_BY_NAME, SET_HELP, apply_overrides, parse_override
from pendulum_accel.physics.integrators import METHODS
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Constant
from pendulum_accel.physics.simulate import CLOSED_FORM_METHOD, MODELS
from pendulum_accel.physics.trajectory import Trajectory
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.sensor import SensorModel

CSV_COLUMNS: tuple[str, ...] = ("t", "theta", "theta_dot", "tension", "stretch")
PLAIN_DEFAULTS = {"length": 1.0, "duration": 10.0, "rate": 100.0, "target": 1e-6}
TABLE_FLAGS: dict[str, str] = {
    "length": "length",
    "gravity": "gravity",
    "theta0": "theta0",
    "duration": "duration",
    "rate": "rate_hz",
}
"""Flags that set an override-table field (flag → field): the same range check as --set and the nodes."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate",
        help="simulate a scene (or plain flags) with the planner's model and solver, write a CSV",
        description=(
            "Simulate SCENE (a bundled name, see `pendulum-accel scenes`, or a YAML path) or, without SCENE, "
            "a pendulum given by flags (defaults: l = 1 m, standard g, a = 0, θ0 = θ'0 = 0, 10 s at 100 Hz). "
            "Flags override the scene's values. The planner picks the cheapest model and solver meeting the "
            "accuracy target and its explanation is printed to stderr. CSV columns: t, theta, theta_dot, "
            "then tension and stretch where the model has them (SI units, rad)."
        ),
    )
    parser.add_argument("scene", nargs="?", metavar="SCENE", help="bundled scene name or scene YAML path")
    phys = parser.add_argument_group("physics (override the scene)")
    for flag, name in TABLE_FLAGS.items():
        spec = OVERRIDE_BY_NAME[name]
        phys.add_argument(
            f"--{flag}", type=float, metavar=spec.unit.upper(), help=f"{spec.description} ({spec.unit})"
        )
    phys.add_argument("--accel", type=float, metavar="M/S2", help="constant car acceleration a (m/s²)")
    phys.add_argument("--theta-dot0", type=float, metavar="RAD/S", help="initial rate θ'0 (rad/s)")
    phys.add_argument("--target", type=float, metavar="RAD", help="accuracy target: max angle error (rad)")
    phys.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE", help=SET_HELP
    )
    solver = parser.add_argument_group("solver (override the planner)")
    solver.add_argument("--model", choices=MODELS, help="force the model")
    solver.add_argument("--method", choices=(CLOSED_FORM_METHOD, *METHODS), help="force the integrator")
    step = solver.add_mutually_exclusive_group()
    step.add_argument("--dt", type=float, metavar="S", help="fixed step (fixed-step methods)")
    step.add_argument("--rtol", type=float, metavar="R", help="relative tolerance (adaptive methods)")
    parser.add_argument(
        "--out", type=Path, metavar="FILE.csv", help="write the CSV here (default, or '-': stdout)"
    )
    parser.add_argument(
        "--plot",
        type=Path,
        metavar="OUT.png",
        help="also plot θ(t) and the input sensitivity, marking where the inputs stop determining θ",
    )
    parser.add_argument(
        "--accept-ill-conditioned",
        action="store_true",
        help="simulate even when 1 ulp of the inputs moves θ by more than the target (else exit 2)",
    )
    parser.set_defaults(func=run)


class _SceneChanges(TypedDict, total=False):
    """The Scene fields simulate's own options replace (--accel, --theta-dot0, --target)."""

    profile: AccelProfile
    theta_dot0: float
    accuracy: float


def _plain_scene(args: argparse.Namespace) -> Scene:
    """A scene from flags alone, before the table's fields: no sensor noise, constant a, PLAIN_DEFAULTS."""
    return Scene(
        name="cli",
        description="pendulum given by command-line flags",
        duration=PLAIN_DEFAULTS["duration"],
        pendulum=Pendulum(PLAIN_DEFAULTS["length"], gravity=STANDARD_GRAVITY),
        profile=Constant(args.accel if args.accel is not None else 0.0),
        sensor=SensorModel(PLAIN_DEFAULTS["rate"]),
        theta_dot0=args.theta_dot0 if args.theta_dot0 is not None else 0.0,
        accuracy=args.target if args.target is not None else PLAIN_DEFAULTS["target"],
    )


def scene_from_args(args: argparse.Namespace) -> Scene:
    """The scene named by SCENE (or the plain-flags scene) with every given flag and --set applied."""
    values = {
        name: getattr(args, flag) for flag, name in TABLE_FLAGS.items() if getattr(args, flag) is not None
    }
    values.update(parse_override(text) for text in args.overrides)
    if args.scene is None:
        try:
            return apply_overrides(_plain_scene(args), values)
        except ParameterError as err:
            raise SceneError(f"command-line scene: {err}") from None
    scene = load_scene(args.scene)
    try:
        scene = apply_overrides(scene, values)
        changes: _SceneChanges = {}
        if args.accel is not None:
            changes["profile"] = Constant(args.accel)
        if args.theta_dot0 is not None:
            changes["theta_dot0"] = args.theta_dot0
        if args.target is not None:
            changes["accuracy"] = args.target
        return replace(scene, **changes)
    except ParameterError as err:
        raise SceneError(f"{scene.source or scene.name}: {err}") from None


def trajectory_columns(traj: Trajectory) -> dict[str, np.ndarray]:
    """{'t', 'theta', 'theta_dot'} plus 'tension' and 'stretch' where the model has them."""
    columns = traj.columns()
    return {name: columns[name] for name in CSV_COLUMNS if name in columns}


def write_csv(handle: TextIO, columns: dict[str, np.ndarray]) -> None:
    """CSV with a header row; every value with 17 significant digits (round-trips a double)."""
    data = np.column_stack([np.asarray(v, dtype=np.float64) for v in columns.values()])
    np.savetxt(handle, data, fmt="%.17g", delimiter=",", header=",".join(columns), comments="")


def run(args: argparse.Namespace) -> int:
    """Plan, simulate at the output rate, write the CSV; the plan's explanation goes to stderr."""
    from pendulum_accel.planner import plan_with
    from pendulum_accel.scene_run import simulate_plan

    to_stdout = args.out is None or str(args.out) == "-"  # '-' is stdout, as for most Unix tools
    out = None if to_stdout else check_output_file(args.out, (".csv",))
    plot = check_output_file(args.plot, (".png",), option="--plot") if args.plot is not None else None
    scene = scene_from_args(args)
    interval = scene.sensor.period
    if args.dt is not None and args.dt > interval:
        # The integrator would silently shorten it to fill each sample interval with whole steps.
        raise ParameterError(
            f"--dt {args.dt:g} s is longer than the sample interval {interval:g} s "
            f"({scene.sensor.rate_hz:g} Hz); give at most {interval:g} s"
        )
    plan = plan_with(scene, model=args.model, method=args.method, dt=args.dt, rtol=args.rtol)
    origin = getattr(scene.profile, "origin", "")
    if origin:
        print(f"acceleration: {origin}", file=sys.stderr)
    print(plan.explain(), file=sys.stderr)
    if plan.ill_conditioned and not args.accept_ill_conditioned:
        raise IllConditionedError(
            f"scene {scene.name}: the inputs determine θ only to "
            f"{plan.sensitivity.floor if plan.sensitivity else math.nan:.1e} rad, over the target "
            f"{scene.accuracy:.1e} rad; nothing simulated (--accept-ill-conditioned to run anyway)"
        )
    if not plan.meets_target and not plan.ill_conditioned:
        # A run that cannot meet its target is refused, not written with a warning: its figures would be
        # used as if they met it. The user may loosen the target to what the plan can promise.
        raise SceneError(
            f"scene {scene.name}: the plan cannot meet the target {scene.accuracy:.1e} rad (predicted "
            f"{plan.predicted_error:.1e} rad); nothing simulated (give --target "
            f"{_rounded_up(plan.predicted_error)} or more to run it anyway)"
        )
    t = scene.sensor.sample_times(scene.duration)
    traj = simulate_plan(scene, plan, t)
    columns = trajectory_columns(traj)
    if not all(np.all(np.isfinite(v)) for v in columns.values()):
        raise SceneError(f"scene {scene.name}: the simulation produced NaN or inf; nothing written")
    if plot is not None:
        from pendulum_accel.cli.simulate_plot import plot_simulation

        written = write_output(plot, lambda target: plot_simulation(traj, plan, target))
        print(f"plot: {written}", file=sys.stderr)
    if out is None:
        write_csv(sys.stdout, columns)
        return 0
    write_text_output(out, lambda handle: write_csv(handle, columns))
    print(f"wrote {t.size} rows ({', '.join(columns)}) to {args.out}", file=sys.stderr)
    return 0


def _rounded_up(value: float) -> str:
    """``value`` rounded up to 2 significant digits: 10^(e−1) ⌈value / 10^(e−1)⌉, e = ⌊log10 value⌋."""
    unit = 10.0 ** (math.floor(math.log10(value)) - 1)
    return f"{math.ceil(value / unit) * unit:.2g}"
