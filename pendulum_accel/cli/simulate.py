"""``pendulum-accel simulate [SCENE] [flags]``: plan and simulate a scene (or plain flags), write a CSV.

Columns: t, theta, theta_dot, then tension and stretch where the model has them. The plan's one-line
explanation goes to stderr, so the CSV on stdout stays clean.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.physics.integrators import METHODS
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import CLOSED_FORM_METHOD, MODELS
from pendulum_accel.physics.trajectory import Trajectory
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.sensor import SensorModel

CSV_COLUMNS: tuple[str, ...] = ("t", "theta", "theta_dot", "tension", "stretch")
PLAIN_DEFAULTS = {"length": 1.0, "duration": 10.0, "rate": 100.0, "target": 1e-6}


def register(subparsers: Any) -> None:
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
    phys.add_argument("--length", type=float, metavar="M", help="pendulum length l (m)")
    phys.add_argument("--gravity", type=float, metavar="M/S2", help="gravity g (m/s²)")
    phys.add_argument("--accel", type=float, metavar="M/S2", help="constant car acceleration a (m/s²)")
    phys.add_argument("--theta0", type=float, metavar="RAD", help="initial angle θ0 (rad)")
    phys.add_argument("--theta-dot0", type=float, metavar="RAD/S", help="initial rate θ'0 (rad/s)")
    phys.add_argument("--duration", type=float, metavar="S", help="run length (s)")
    phys.add_argument("--rate", type=float, metavar="HZ", help="output sample rate (Hz)")
    phys.add_argument("--target", type=float, metavar="RAD", help="accuracy target: max angle error (rad)")
    solver = parser.add_argument_group("solver (override the planner)")
    solver.add_argument("--model", choices=MODELS, help="force the model")
    solver.add_argument("--method", choices=(CLOSED_FORM_METHOD, *METHODS), help="force the integrator")
    step = solver.add_mutually_exclusive_group()
    step.add_argument("--dt", type=float, metavar="S", help="fixed step (fixed-step methods)")
    step.add_argument("--rtol", type=float, metavar="R", help="relative tolerance (adaptive methods)")
    parser.add_argument("--out", type=Path, metavar="FILE.csv", help="write the CSV here (default: stdout)")
    parser.set_defaults(func=run)


def _plain_scene(args: argparse.Namespace) -> Scene:
    """A scene from flags alone: no sensor noise, constant a, defaults from PLAIN_DEFAULTS."""
    try:
        pendulum = Pendulum(
            args.length if args.length is not None else PLAIN_DEFAULTS["length"],
            gravity=args.gravity if args.gravity is not None else STANDARD_GRAVITY,
        )
        return Scene(
            name="cli",
            description="pendulum given by command-line flags",
            duration=args.duration if args.duration is not None else PLAIN_DEFAULTS["duration"],
            pendulum=pendulum,
            profile=Constant(args.accel if args.accel is not None else 0.0),
            sensor=SensorModel(args.rate if args.rate is not None else PLAIN_DEFAULTS["rate"]),
            theta0=args.theta0 if args.theta0 is not None else 0.0,
            theta_dot0=args.theta_dot0 if args.theta_dot0 is not None else 0.0,
            accuracy=args.target if args.target is not None else PLAIN_DEFAULTS["target"],
        )
    except ParameterError as err:
        raise SceneError(f"command-line scene: {err}") from None


def scene_from_args(args: argparse.Namespace) -> Scene:
    """The scene named by SCENE with every given flag applied, or the plain-flags scene."""
    if args.scene is None:
        return _plain_scene(args)
    scene = load_scene(args.scene)
    try:
        p = scene.pendulum
        if args.length is not None or args.gravity is not None:
            p = replace(
                p,
                length=args.length if args.length is not None else p.length,
                gravity=args.gravity if args.gravity is not None else p.gravity,
            )
        changes: dict[str, Any] = {"pendulum": p}
        if args.accel is not None:
            changes["profile"] = Constant(args.accel)
        if args.rate is not None:
            changes["sensor"] = replace(scene.sensor, rate_hz=args.rate)
        for flag, name in (("theta0", "theta0"), ("theta_dot0", "theta_dot0"), ("duration", "duration"),
                           ("target", "accuracy")):  # fmt: skip
            if getattr(args, flag) is not None:
                changes[name] = getattr(args, flag)
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

    scene = scene_from_args(args)
    plan = plan_with(scene, model=args.model, method=args.method, dt=args.dt, rtol=args.rtol)
    print(plan.explain(), file=sys.stderr)
    t = scene.sensor.sample_times(scene.duration)
    traj = simulate_plan(scene, plan, t)
    columns = trajectory_columns(traj)
    if not all(np.all(np.isfinite(v)) for v in columns.values()):
        raise SceneError(f"scene {scene.name}: the simulation produced NaN or inf; nothing written")
    if args.out is None:
        write_csv(sys.stdout, columns)
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", encoding="utf-8", newline="") as handle:
        write_csv(handle, columns)
    print(f"wrote {t.size} rows ({', '.join(columns)}) to {args.out}", file=sys.stderr)
    return 0
