"""Are the planner's error predictions true? Measured error / predicted error over a battery of scenes.

Each case is planned (``planner.plan_scene``), simulated with its plan at the sensor's sample times, and
compared with a 37-digit Taylor reference (benchmarks/reference.py, which restarts at every change of
a(t)). Printed per run: target, predicted error (the run's own: the method's, with its round-off carried
through the problem's growth; past the linear regime twice the spread of five runs one ulp apart),
measured error, their ratio, and the plan's verdicts; then the ratio's distribution (runs whose response
to their inputs stays linear, announced ill-conditioned or not, and runs past it apart) and the three
counts the planner is held to: false alarms (TARGET NOT MET while within target), silent misses (over
target without a warning), and linear-regime ratios outside [0.1, 1].

    python -m benchmarks.error_bounds            # the full battery (≈ 100 runs, a few minutes)
    python -m benchmarks.error_bounds --quick    # the subset test/test_error_bounds.py runs
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.reference import reference_theta
from pendulum_accel import plan_scene
from pendulum_accel.physics.params import STANDARD_GRAVITY as G
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Constant, Ramp, Sinusoid, Step
from pendulum_accel.planner import Plan
from pendulum_accel.scene import Scene
from pendulum_accel.scene_run import simulate_plan
from pendulum_accel.sensor import SensorModel

TARGETS = (1e-6, 1e-9, 1e-12)
RATIO_RANGE = (0.1, 1.0)
OMEGA0 = math.sqrt(G)  # l = 1 m, a = 0
SEPARATRIX_RATE = 2.0 * OMEGA0


@dataclass(frozen=True)
class Case:
    """One battery entry: a scene without its target, run at each of ``targets``."""

    name: str
    scene: Scene
    targets: tuple[float, ...] = TARGETS


def _scene(
    name: str,
    *,
    length: float = 1.0,
    gravity: float = G,
    damping: float = 0.0,
    profile: AccelProfile | None = None,
    theta0: float = 0.0,
    theta_dot0: float = 0.0,
    duration: float = 20.0,
    rate: float = 100.0,
) -> Scene:
    """A battery scene: noiseless sensor at ``rate`` Hz, constant a = 0 unless a profile is given."""
    return Scene(
        name=name,
        description=f"error-bound battery: {name}",
        duration=duration,
        pendulum=Pendulum(length, gravity=gravity, damping=damping),
        profile=profile or Constant(0.0),
        sensor=SensorModel(rate),
        theta0=theta0,
        theta_dot0=theta_dot0,
    )


ILL_CONDITIONED = (
    # Three ill-conditioned starts: the inverted start with a = 2, a rotation start that grazes the
    # separatrix with a = -5 (1 ulp of θ'0 → 1e-3 rad at t = 18.3 s), and a resonantly driven, chaotic swing.
    Case("inverted a=2", _scene("inverted_a2", profile=Constant(2.0), theta0=3.3427769016943625), (1e-6,)),
    Case(
        "grazing a=-5",
        _scene(
            "grazing_am5", profile=Constant(-5.0), theta0=-0.47150295643494905, theta_dot0=6.635583474838093
        ),
        (1e-6,),
    ),
    Case(
        "resonant drive (chaos)",
        _scene("resonant", profile=Sinusoid(3.0, 0.5, offset=1.0), theta0=0.3, duration=100.0, rate=10.0),
        (1e-6,),
    ),
)


def battery(quick: bool = False) -> list[Case]:
    """The cases: every regime of the battery (quick: a shorter, coarser subset at targets 1e-6 and 1e-12)."""
    if quick:
        targets = (1e-6, 1e-12)
        cases = [
            Case("libration 1e-6 rad", _scene("lib_tiny", theta0=1e-6, duration=8.0, rate=20.0), targets),
            Case(
                "libration 1 rad a=2",
                _scene("lib1", profile=Constant(2.0), theta0=1.0, duration=8.0, rate=20.0),
                targets,
            ),
            Case("libration 3 rad", _scene("lib3", theta0=3.0, duration=8.0, rate=20.0), targets),
            Case(
                "below separatrix 1e-9",
                _scene("below9", theta_dot0=SEPARATRIX_RATE * (1 - 1e-9), duration=8.0, rate=20.0),
                targets,
            ),
            Case(
                "above separatrix 1e-12",
                _scene("above12", theta_dot0=SEPARATRIX_RATE * (1 + 1e-12), duration=8.0, rate=20.0),
                targets,
            ),
            Case(
                "rotation 50 rad/s a=2",
                _scene("rot50", profile=Constant(2.0), theta_dot0=50.0, duration=8.0, rate=20.0),
                targets,
            ),
            Case(
                "a = -10 g, l = 1 mm",
                _scene("fast", length=1e-3, profile=Constant(-10 * G), theta0=0.5, duration=1.0, rate=200.0),
                targets,
            ),
            Case(
                "steps 2 → -3",
                _scene("step", profile=Step(3.0, 2.0, -3.0), theta0=0.5, duration=8.0, rate=20.0),
                targets,
            ),
            Case(
                "ramp, damped",
                _scene(
                    "ramp", damping=0.2, profile=Ramp(1.0, 4.0, 0.0, 3.0), theta0=1.0, duration=8.0, rate=20.0
                ),
                (1e-6, 1e-9),
            ),
            Case(
                "sinusoid",
                _scene("sine", profile=Sinusoid(2.0, 0.3), theta0=0.5, duration=8.0, rate=20.0),
                (1e-6, 1e-9),
            ),
        ]
        inverted, grazing, _ = ILL_CONDITIONED
        return [*cases, inverted, grazing]
    cases = [
        Case(
            f"libration {amp:g} rad", _scene(f"lib_{amp:.0e}".replace(".", "_").replace("+", ""), theta0=amp)
        )
        for amp in (1e-6, 1e-3, 0.1, 1.0, 2.0, 3.0)
    ]
    cases.append(Case("libration 1 rad a=2", _scene("lib_a2", profile=Constant(2.0), theta0=1.0)))
    for gap in (1e-3, 1e-6, 1e-9, 1e-12):
        for side, sign in (("below", -1.0), ("above", 1.0)):
            rate = SEPARATRIX_RATE * (1.0 + sign * gap)
            cases.append(
                Case(
                    f"{side} separatrix {gap:g}",
                    _scene(f"{side}_{gap:.0e}".replace("+", ""), theta_dot0=rate),
                )
            )
    cases += [
        Case("inverted π - 1e-6", _scene("inv6", theta0=math.pi - 1e-6)),
        Case("rotation 50 rad/s", _scene("rot50", theta_dot0=50.0)),
        Case("rotation 50 rad/s a=2", _scene("rot50_a2", profile=Constant(2.0), theta_dot0=50.0)),
        Case("a = +10 g", _scene("plus10g", profile=Constant(10 * G), theta0=1.0)),
        Case("a = -10 g", _scene("minus10g", profile=Constant(-10 * G), theta0=-1.0, theta_dot0=3.0)),
        Case("l = 1 mm", _scene("l1mm", length=1e-3, theta0=1.0, duration=2.0, rate=1000.0)),
        Case("l = 100 m", _scene("l100m", length=100.0, theta0=1.0, duration=60.0)),
        Case("Moon", _scene("moon", gravity=1.62, theta0=2.0)),
        Case("Jupiter", _scene("jupiter", gravity=24.79, theta0=2.0)),
        Case("1e6 samples", _scene("million", theta0=1.0, duration=20.0, rate=49_999.95), (1e-9,)),
        Case("steps 2 → -3 → 0", _scene("steps", profile=Step(7.0, 2.0, -3.0), theta0=0.5)),
        Case("ramp", _scene("ramp", profile=Ramp(2.0, 12.0, 0.0, 4.0), theta0=1.0)),
        Case("sinusoid", _scene("sine", profile=Sinusoid(2.0, 0.3, offset=1.0), theta0=0.5)),
        Case("damped large swing", _scene("damped", damping=0.1, theta0=3.0)),
        Case(
            "damped rotation, sinusoid",
            _scene("damped_sine", damping=0.05, profile=Sinusoid(1.0, 0.2), theta_dot0=8.0),
        ),
    ]
    return [*cases, *ILL_CONDITIONED]


@dataclass(frozen=True)
class Row:
    """One run: the plan, what it predicted and what it measured against the reference."""

    case: str
    target: float
    plan: Plan
    measured: float
    plan_s: float

    @property
    def ratio(self) -> float:
        """measured / predicted."""
        return self.measured / self.plan.predicted_error

    @property
    def outside(self) -> bool:
        """measured/predicted outside RATIO_RANGE."""
        return not RATIO_RANGE[0] <= self.ratio <= RATIO_RANGE[1]

    @property
    def announced(self) -> bool:
        """The plan warned (TARGET NOT MET, which an ill-conditioned plan also says)."""
        return not self.plan.meets_target

    @property
    def false_alarm(self) -> bool:
        """Warned although the run measured within target and the inputs determine θ to the target."""
        return self.announced and self.measured <= self.target and not self.plan.ill_conditioned

    @property
    def silent_miss(self) -> bool:
        """Over target without a warning."""
        return self.measured > self.target and not self.announced


def run_case(case: Case, reference: dict[str, np.ndarray]) -> list[Row]:
    """Plan and simulate ``case`` at each target; the reference θ is computed once per case."""
    scene = case.scene
    t = scene.sensor.sample_times(scene.duration)
    if case.name not in reference:
        reference[case.name] = reference_theta(
            scene.pendulum, scene.profile, scene.theta0, scene.theta_dot0, t
        )
    rows = []
    for target in case.targets:
        targeted = replace(scene, accuracy=target)
        start = time.perf_counter()
        plan = plan_scene(targeted)
        elapsed = time.perf_counter() - start
        theta = simulate_plan(targeted, plan, t).theta
        measured = float(np.max(np.abs(theta - reference[case.name])))
        rows.append(Row(case.name, target, plan, measured, elapsed))
    return rows


def run_battery(cases: Sequence[Case]) -> list[Row]:
    """Every case at every target."""
    reference: dict[str, np.ndarray] = {}
    return [row for case in cases for row in run_case(case, reference)]


def run_report(rows: Sequence[Row]) -> str:
    """The per-run table and the summary (ratio distribution, false alarms, silent misses)."""
    lines = [
        f"{'case':<28} {'target':>7} {'model/method':<20} {'predicted':>9} {'measured':>9} "
        f"{'ratio':>6}  flags",
    ]
    for r in rows:
        flags = []
        if r.plan.ill_conditioned:
            flags.append("ILL-CONDITIONED")
        elif r.announced:
            flags.append("TARGET NOT MET")
        if r.false_alarm:
            flags.append("FALSE ALARM")
        if r.silent_miss:
            flags.append("SILENT MISS")
        if r.outside and _linear(r):
            flags.append("ratio outside [0.1, 1]")
        lines.append(
            f"{r.case:<28} {r.target:7.0e} {r.plan.model + '/' + r.plan.method:<20} "
            f"{r.plan.predicted_error:9.2e} {r.measured:9.2e} {r.ratio:6.3f}  {', '.join(flags)}"
        )
    linear = [r for r in rows if _linear(r)]
    past = [r for r in rows if not _linear(r)]
    ill = [r for r in rows if r.plan.ill_conditioned]
    lines += [
        "",
        f"runs: {len(rows)}; ill-conditioned (announced): {len(ill)}, "
        f"{sum(r.plan.ill_conditioned for r in linear)} of them in the linear regime",
        f"false alarms: {sum(r.false_alarm for r in rows)}; "
        f"silent misses: {sum(r.silent_miss for r in rows)}",
        f"measured/predicted in [0.1, 1]: {sum(not r.outside for r in linear)} of {len(linear)} "
        f"runs in the linear regime",
        _distribution("linear regime, well-conditioned", [r for r in linear if not r.plan.ill_conditioned]),
        _distribution("linear regime, ill-conditioned", [r for r in linear if r.plan.ill_conditioned]),
        _distribution("past the linear regime (no tight bound exists)", past),
        f"planning time: median {np.median([r.plan_s for r in rows]):.3f} s, "
        f"max {max(r.plan_s for r in rows):.3f} s",
    ]
    return "\n".join(lines)


def _linear(row: Row) -> bool:
    """The run's response to a one-ulp change of its inputs stayed linear (or was not measured)."""
    return row.plan.sensitivity is None or row.plan.sensitivity.linear


def _distribution(label: str, rows: Sequence[Row]) -> str:
    """'ratio distribution (<label>): min …, 10% …, median …, 90% …, max …'."""
    ratios = [r.ratio for r in rows]
    quantiles = np.quantile(ratios, [0.0, 0.1, 0.5, 0.9, 1.0]) if ratios else [math.nan] * 5
    return "ratio distribution ({}): min {:.3g}, 10% {:.3g}, median {:.3g}, 90% {:.3g}, max {:.3g}".format(
        label, *quantiles
    )


def plot(rows: Sequence[Row], out: Path) -> Path:
    """error_bounds.png: each run's measured against its predicted error (log-log), runs in the linear
    regime and past it apart, beside the bound (measured = predicted) and RATIO_RANGE's floor."""
    fig, ax = report.new_axes(6.5, 5.5)
    tiny = 1e-300  # a run that matched its reference exactly: drawn at the floor of the axes, not lost
    for linear, marker, label in ((True, "o", "linear regime"), (False, "x", "past it")):
        mine = [r for r in rows if _linear(r) == linear]
        if mine:
            ax.loglog(
                [r.plan.predicted_error for r in mine],
                [max(r.measured, tiny) for r in mine],
                marker,
                ms=4,
                label=f"{label} ({len(mine)} runs)",
            )
    predicted = [r.plan.predicted_error for r in rows]
    span = np.geomspace(min(predicted), max(predicted), 50)
    ax.loglog(span, span, "--", color="tab:red", label="measured = predicted (the bound)")
    ax.loglog(
        span, RATIO_RANGE[0] * span, ":", color="tab:gray", label=f"measured = {RATIO_RANGE[0]:g} × predicted"
    )
    ax.set_xlabel("predicted max angle error (rad)")
    ax.set_ylabel("measured max angle error (rad)")
    ax.set_title("The planner's predicted error against the measured one", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return report.save_figure(fig, out)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the battery and print the report; exit 1 on a false alarm, a silent miss or a linear-regime run
    whose measured/predicted ratio leaves [0.1, 1]."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the test's shorter subset")
    parser.add_argument("--case", action="append", help="only cases whose name contains this text")
    parser.add_argument(
        "--out", type=Path, default=Path("out/bench"), help="where error_bounds.txt and .png go (out/bench)"
    )
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    cases = battery(args.quick)
    if args.case:
        cases = [c for c in cases if any(text in c.name for text in args.case)]
    rows = run_battery(cases)
    text = run_report(rows)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "error_bounds.txt").write_text(text + "\n", encoding="utf-8")
    png = plot(rows, args.out / "error_bounds.png")
    page = report.write_page(
        "error_bounds", "Error bounds: predicted against measured", [f"```text\n{text}\n```"],
        [(png, "Measured against predicted max angle error per run, beside the bound")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    bad = any(r.false_alarm or r.silent_miss or (r.outside and _linear(r)) for r in rows)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
