"""Work-precision benchmark: max angle error against CPU time for every model and integrator.

``python -m benchmarks.work_precision [--out DIR] [--quick]`` (default out/bench) runs every
fixed-step method (euler, symplectic_euler, verlet, rk4) over four decades of step size hω, every
``solve_ivp`` method (RK45, DOP853, Radau, LSODA) over ten decades of rtol, and the closed forms
(exact, linear), on four scenes: the lecture's constant acceleration, a swing past 90°, a 0 → 3 m/s²
step and a stiff elastic string. Then it runs the planner at accuracy targets 1e-3 … 1e-12 rad and
checks its targets:

- at every target, the planner's choice costs ≤ 1/5 of the CPU of the cheapest ``solve_ivp`` run that
  reaches the same accuracy;
- for constant-acceleration scenes, the closed form is ≥ 100× faster than DOP853 at rtol 1e-12 and
  its error is ≤ 1e-12 rad.

Error = max |θ − θ_ref| over the samples. θ_ref: a 30-digit mpmath Taylor integration (``mpmath.odefun``)
for the rigid scenes, independent of every code path measured here; DOP853 at rtol 1e-13 for the
elastic string, cross-checked against Radau at rtol 1e-12 (the disagreement is printed as the floor).
CPU = ``time.process_time`` per call, best of several rounds. Writes work_precision.csv,
work_precision.md and work_precision.png.
"""

from __future__ import annotations

import argparse
import csv
import gc
import math
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from benchmarks import report
from benchmarks.work_precision_cases import (
    MPMATH_DIGITS,
    QUICK_MPMATH_DIGITS,
    Case,
    build_case,
    case_omega,
    case_specs,
    reference,
)
from pendulum_accel.errors import PendulumAccelError
from pendulum_accel.physics.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS
from pendulum_accel.physics.simulate import simulate

if TYPE_CHECKING:  # the planner is imported where a plan is made (the grid runs need none of it)
    from pendulum_accel.physics.trajectory import Trajectory
    from pendulum_accel.planner import Plan
    from pendulum_accel.scene import Scene

T = TypeVar("T")

TARGETS: tuple[float, ...] = tuple(10.0**-k for k in range(3, 13))
PLANNER_CPU_FRACTION = 0.2  # the planner's choice must cost ≤ 1/5 of the best solve_ivp run
CLOSED_FORM_SPEEDUP = 100.0
CLOSED_FORM_ERROR = 1e-12
ERROR_FLOOR = 1e-17  # where exact zeros are drawn on the log axis

# Step sizes as hω (ω: the fastest natural frequency; full grids are per scene), tolerances as rtol.
QUICK_H_OMEGA = tuple(10.0 ** (-0.5 - 0.5 * k) for k in range(5))  # 0.32 … 3.2e-3
FULL_RTOL = tuple(10.0 ** (-3.0 - 0.5 * k) for k in range(21))  # 1e-3 … 1e-13: ten decades
QUICK_RTOL = tuple(10.0**-k for k in (3, 6, 9))


@dataclass(frozen=True)
class Row:
    """One measured run: error = max |θ − θ_ref| (rad), cpu_s = best CPU seconds per call."""

    case: str
    model: str
    method: str
    setting: str  # 'dt', 'rtol', 'closed-form' or 'plan'
    value: float  # dt (s), rtol, or the planner's target
    h_omega: float  # dt·ω for fixed steps, else NaN
    error: float
    cpu_s: float
    nfev: int
    status: str  # 'ok', or why there is no measurement


@dataclass(frozen=True)
class PlannerCheck:
    """The planner's choice at one target against the cheapest solve_ivp run reaching that target."""

    case: str
    target: float
    plan: str
    error: float
    cpu_s: float
    best_ivp: str
    best_ivp_cpu_s: float
    accurate: bool
    cheap: bool
    plan_cpu_s: float = math.nan

    @property
    def ratio(self) -> float:
        """CPU(planner) / CPU(best solve_ivp at equal accuracy); NaN when solve_ivp never got there."""
        return self.cpu_s / self.best_ivp_cpu_s if self.best_ivp_cpu_s > 0 else math.nan

    @property
    def ratio_with_planning(self) -> float:
        """(CPU of planning + CPU of the planned run) / CPU(best solve_ivp); NaN as ``ratio``."""
        total = self.plan_cpu_s + self.cpu_s
        return total / self.best_ivp_cpu_s if self.best_ivp_cpu_s > 0 else math.nan


def cpu_time(fn: Callable[[], T], *, budget: float = 0.05, rounds: int = 3) -> tuple[float, T]:
    """(best CPU seconds per call, last result): ``rounds`` rounds of n calls, n such that a round ≥ budget.

    Uses time.process_time with the garbage collector off, like timeit. A first call longer than
    ``budget`` × ``rounds`` × 10 is taken as is (one sample), so long runs are not repeated.
    """
    gc_was_on = gc.isenabled()
    gc.disable()
    try:
        start = time.process_time()
        result = fn()
        first = time.process_time() - start
        if first > budget * rounds * 10:
            return first, result
        calls = max(1, math.ceil(budget / max(first, 1e-7)))
        best = first
        for _ in range(rounds):
            start = time.process_time()
            for _ in range(calls):
                result = fn()
            best = min(best, (time.process_time() - start) / calls)
        return best, result
    finally:
        if gc_was_on:
            gc.enable()


def measure(
    case: Case,
    theta_ref: np.ndarray,
    model: str,
    method: str,
    *,
    dt: float | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    budget: float = 0.05,
) -> tuple[float, float, int, str]:
    """(error, cpu_s, nfev, status) of one simulate() call; a refusal or failure becomes its status.

    Grid runs pass atol = rtol (per natural scale of each state component), looser and so cheaper than
    simulate()'s default atol = 1e-3 rtol; the planner's runs keep the default, as the package runs them.
    """

    def run() -> Trajectory:
        """One simulate() call with the run's settings."""
        return simulate(
            case.pendulum,
            case.profile,
            case.t,
            theta0=case.theta0,
            theta_dot0=case.theta_dot0,
            model=model,
            method=method,
            dt=dt,
            rtol=rtol,
            atol=atol,
        )

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy warns when rtol is below its floor; we report it
            cpu, traj = cpu_time(run, budget=budget)
    except PendulumAccelError as err:
        return math.nan, math.nan, 0, f"refused: {err}"
    error = float(np.max(np.abs(traj.theta - theta_ref)))
    if not math.isfinite(error):
        return math.nan, cpu, int(traj.nfev), "non-finite result"
    return error, cpu, int(traj.nfev), "ok"


def effective_step(t: np.ndarray, dt: float) -> float:
    """The step integrate() really takes: the sample interval Δ split in ⌈Δ/dt⌉ equal steps (uniform t)."""
    interval = float(t[1] - t[0])
    return interval / max(1, math.ceil(interval / dt * (1.0 - 1e-12)))


def run_case(case: Case, theta_ref: np.ndarray, *, quick: bool, log: Callable[[str], None]) -> list[Row]:
    """Every (model, method) of ``case`` over its step-size or tolerance grid."""
    rows: list[Row] = []
    budget = 0.01 if quick else 0.05
    h_grid = QUICK_H_OMEGA if quick else case.h_omega
    rtol_grid = QUICK_RTOL if quick else FULL_RTOL
    for model, method in case.runs:
        started = time.perf_counter()
        if model in ("exact", "linear"):
            error, cpu, nfev, status = measure(case, theta_ref, model, "auto", budget=budget)
            rows.append(
                Row(
                    case.name,
                    model,
                    "closed-form",
                    "closed-form",
                    math.nan,
                    math.nan,
                    error,
                    cpu,
                    nfev,
                    status,
                )
            )
        elif method in FIXED_STEP_METHODS:
            omega = case_omega(case, model)
            done: set[float] = set()
            for h_omega in h_grid:
                dt = effective_step(case.t, h_omega / omega)
                if dt in done:
                    continue  # capped by the sample interval: same run as the previous point
                done.add(dt)
                error, cpu, nfev, status = measure(case, theta_ref, model, method, dt=dt, budget=budget)
                rows.append(Row(case.name, model, method, "dt", dt, dt * omega, error, cpu, nfev, status))
        else:
            for rtol in rtol_grid:
                error, cpu, nfev, status = measure(
                    case, theta_ref, model, method, rtol=rtol, atol=rtol, budget=budget
                )
                rows.append(Row(case.name, model, method, "rtol", rtol, math.nan, error, cpu, nfev, status))
        log(f"  {case.name}: {model}/{method} done in {time.perf_counter() - started:.1f} s")
    return rows


def plan_at(case: Case, target: float) -> Plan:
    """The planner's Plan for ``case.scene`` with its accuracy target set to ``target`` rad."""
    from pendulum_accel.planner import plan_scene

    return plan_scene(with_target(case.scene, target))


def with_target(scene: Scene, target: float) -> Scene:
    """A copy of ``scene`` whose max angle error target is ``target`` rad."""
    return replace(scene, accuracy=target)


def run_planner(
    case: Case, theta_ref: np.ndarray, rows: Sequence[Row], targets: Iterable[float], *, quick: bool
) -> tuple[list[Row], list[PlannerCheck]]:
    """For each target: the planner's choice, its measured error and CPU, and the cheapest solve_ivp run."""
    plan_rows: list[Row] = []
    checks: list[PlannerCheck] = []
    budget = 0.01 if quick else 0.05
    for target in targets:
        plan_cpu, plan = cpu_time(lambda: plan_at(case, target), budget=budget)  # noqa: B023 (called here)
        method = "auto" if plan.model in ("exact", "linear") else plan.method
        error, cpu, nfev, status = measure(
            case, theta_ref, plan.model, method, dt=plan.dt, rtol=plan.rtol, budget=budget
        )
        label = f"{plan.model}/{plan.method}" + (
            f" dt={plan.dt:.3g}" if plan.dt else f" rtol={plan.rtol:.0e}" if plan.rtol else ""
        )
        plan_rows.append(
            Row(case.name, plan.model, plan.method, "plan", target, math.nan, error, cpu, nfev, status)
        )
        # A scene that asks for the stretch can only be answered by the elastic model: the rigid runs
        # (plotted for reference) are not a competitor there, however close their angle.
        best = best_ivp(rows, case.name, target, ("elastic",) if case.scene.wants_stretch else ())
        best_label = (
            "none reaches it" if best is None else f"{best.model}/{best.method} rtol={best.value:.0e}"
        )
        best_cpu = math.nan if best is None else best.cpu_s
        checks.append(
            PlannerCheck(
                case=case.name,
                target=target,
                plan=label,
                error=error,
                cpu_s=cpu,
                best_ivp=best_label,
                best_ivp_cpu_s=best_cpu,
                accurate=status == "ok" and error <= target,
                cheap=status == "ok" and (best is None or cpu <= PLANNER_CPU_FRACTION * best_cpu),
                plan_cpu_s=plan_cpu,
            )
        )
    return plan_rows, checks


def best_ivp(rows: Sequence[Row], case: str, target: float, models: Sequence[str] = ()) -> Row | None:
    """The cheapest solve_ivp run of ``case`` whose error is ≤ target, of one of ``models`` if given."""
    candidates = [
        r
        for r in rows
        if r.case == case
        and r.method in ADAPTIVE_METHODS
        and r.status == "ok"
        and r.error <= target
        and (not models or r.model in models)
    ]
    return min(candidates, key=lambda r: r.cpu_s, default=None)


@dataclass(frozen=True)
class ClosedFormCheck:
    """Closed form against DOP853 at rtol 1e-12 (rigid model) on a constant-acceleration scene."""

    case: str
    exact_error: float
    exact_cpu_s: float
    dop853_error: float
    dop853_cpu_s: float

    @property
    def speedup(self) -> float:
        """CPU(DOP853, rtol 1e-12) / CPU(closed form)."""
        return self.dop853_cpu_s / self.exact_cpu_s

    @property
    def passed(self) -> bool:
        """speedup ≥ 100 and exact error ≤ 1e-12 rad."""
        return self.speedup >= CLOSED_FORM_SPEEDUP and self.exact_error <= CLOSED_FORM_ERROR


def closed_form_check(
    case: Case, theta_ref: np.ndarray, rows: Sequence[Row], *, quick: bool
) -> ClosedFormCheck:
    """Measure exact vs rigid DOP853 at rtol 1e-12 (reusing the grid's runs when it has them)."""
    budget = 0.01 if quick else 0.05
    exact = next((r for r in rows if r.case == case.name and r.model == "exact"), None)
    if exact is None or exact.status != "ok":
        e_err, e_cpu, _, _ = measure(case, theta_ref, "exact", "auto", budget=budget)
    else:
        e_err, e_cpu = exact.error, exact.cpu_s
    d_err, d_cpu, _, _ = measure(case, theta_ref, "rigid", "DOP853", rtol=1e-12, atol=1e-12, budget=budget)
    return ClosedFormCheck(case.name, e_err, e_cpu, d_err, d_cpu)


def write_csv(rows: Sequence[Row], path: Path) -> None:
    """All rows as CSV, one per run (NaN written as an empty cell)."""
    names = list(Row.__dataclass_fields__)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(names)
        for row in rows:
            cells = []
            for name in names:
                value = getattr(row, name)
                if isinstance(value, float):
                    cells.append(f"{value:.6g}" if math.isfinite(value) else "")
                else:
                    cells.append(str(value))
            writer.writerow(cells)


def _ms(seconds: float) -> str:
    """CPU seconds as milliseconds with 3 significant digits."""
    return f"{seconds * 1e3:.3g} ms"


def cost_table(rows: Sequence[Row], case: str, targets: Sequence[float]) -> list[str]:
    """Markdown: for each (model, method), the cheapest run reaching each target (CPU and setting)."""
    header = "| model / method | " + " | ".join(f"≤ {t:.0e} rad" for t in targets) + " |"
    lines = [header, "|---|" + "---|" * len(targets)]
    keys = sorted(
        {(r.model, r.method) for r in rows if r.case == case and r.setting != "plan"},
        key=lambda k: (k[0] != "exact", k[0] != "linear", k[0], k[1]),
    )
    for model, method in keys:
        cells = []
        for target in targets:
            ok = [
                r
                for r in rows
                if r.case == case
                and (r.model, r.method) == (model, method)
                and r.setting != "plan"
                and r.status == "ok"
                and r.error <= target
            ]
            best = min(ok, key=lambda r: r.cpu_s, default=None)
            if best is None:
                cells.append("—")
            elif best.setting == "dt":
                cells.append(f"{_ms(best.cpu_s)} (hω={best.h_omega:.2g})")
            elif best.setting == "rtol":
                cells.append(f"{_ms(best.cpu_s)} (rtol={best.value:.0e})")
            else:
                cells.append(_ms(best.cpu_s))
        lines.append(f"| {model} / {method} | " + " | ".join(cells) + " |")
    return lines


def write_markdown(
    cases: Sequence[Case],
    rows: Sequence[Row],
    checks: Sequence[PlannerCheck],
    closed: Sequence[ClosedFormCheck],
    floors: dict[str, float],
    path: Path,
    command: str,
) -> None:
    """work_precision.md: cost-to-accuracy tables, the planner check and the closed-form check."""
    lines = [f"# Work-precision (`{command}`)", ""]
    lines += [
        "CPU = `time.process_time` per simulate() call, best of several rounds; error = max |θ − θ_ref|.",
        "",
    ]
    for case in cases:
        floor = floors.get(case.name, 0.0)
        check = "Radau rtol 1e-12" if case.pendulum.stiffness is not None else "RK4 at hω = 5e-4"
        ref = (
            "mpmath 30 digits (Taylor series, independent of every method measured)"
            if case.reference == "mpmath"
            else f"DOP853 rtol 1e-13 (agrees with {check} to {floor:.1e} rad)"
        )
        lines += [f"## {case.title}", "", f"Reference: {ref}. Cheapest run reaching each accuracy:", ""]
        lines += cost_table(rows, case.name, (1e-3, 1e-6, 1e-9, 1e-12))
        lines.append("")
    lines += ["## Planner vs the best solve_ivp method at equal accuracy", ""]
    lines += [
        "Best solve_ivp = the cheapest solve_ivp run whose error is within the target, among the models that "
        "deliver the scene's outputs: the stiff-string scene asks for the stretch, so only elastic runs "
        "compete there (its rigid/DOP853 row above is for reference). CPU is simulate() alone; the last "
        "column adds planning (pilots and the input-sensitivity runs) to it: what a user who asks for a "
        "target pays, against solve_ivp whose rtol was picked knowing the answer.",
        "",
    ]
    lines += [
        "| scene | target | planner's choice | error | CPU | best solve_ivp | its CPU | ratio | "
        "error ≤ target | ≤ 1/5 CPU | planning CPU | ratio with planning |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in checks:
        best_cpu = _ms(c.best_ivp_cpu_s) if math.isfinite(c.best_ivp_cpu_s) else "—"
        ratio = f"{c.ratio:.3f}" if math.isfinite(c.ratio) else "—"
        with_plan = f"{c.ratio_with_planning:.3f}" if math.isfinite(c.ratio_with_planning) else "—"
        lines.append(
            f"| {c.case} | {c.target:.0e} | {c.plan} | {c.error:.1e} | {_ms(c.cpu_s)} | {c.best_ivp} | "
            f"{best_cpu} | {ratio} | {'yes' if c.accurate else '**no**'} | "
            f"{'yes' if c.cheap else '**no**'} | {_ms(c.plan_cpu_s)} | {with_plan} |"
        )
    lines += ["", "## Closed form vs DOP853 at rtol 1e-12 (constant acceleration)", ""]
    lines += [
        "| scene | closed-form error | closed-form CPU | DOP853 error | DOP853 CPU | speed-up | target met |",
        "|---|---|---|---|---|---|---|",
    ]
    for cf in closed:
        lines.append(
            f"| {cf.case} | {cf.exact_error:.1e} | {_ms(cf.exact_cpu_s)} | {cf.dop853_error:.1e} | "
            f"{_ms(cf.dop853_cpu_s)} | {cf.speedup:.0f}× | {'yes' if cf.passed else '**no**'} |"
        )
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


_MARKERS = {
    "euler": "v",
    "symplectic_euler": "^",
    "verlet": "s",
    "rk4": "D",
    "RK45": "o",
    "DOP853": "P",
    "Radau": "X",
    "LSODA": "h",
}


def plot(cases: Sequence[Case], rows: Sequence[Row], plan_rows: Sequence[Row], path: Path) -> None:
    """Log-log error vs CPU, one panel per scene; the planner's choices as numbered black stars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ncols = 2
    nrows = math.ceil(len(cases) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(13, 5.2 * nrows), squeeze=False)
    for ax, case in zip(axes.flat, cases, strict=False):
        mine = [r for r in rows if r.case == case.name and r.status == "ok"]
        for model, method in dict.fromkeys((r.model, r.method) for r in mine):
            run = sorted((r for r in mine if (r.model, r.method) == (model, method)), key=lambda r: -r.value)
            cpu = np.array([r.cpu_s for r in run])
            err = np.maximum([r.error for r in run], ERROR_FLOOR)
            if method == "closed-form":
                ax.plot(cpu, err, "o", ms=11, mfc="none", mew=2, label=f"{model} (closed form)")
            else:
                style = "--" if method in FIXED_STEP_METHODS else "-"
                ax.plot(
                    cpu,
                    err,
                    style,
                    marker=_MARKERS.get(method, "."),
                    ms=4,
                    lw=1,
                    label=method if model == "rigid" and case.reference == "mpmath" else f"{model}/{method}",
                )
        plans = [r for r in plan_rows if r.case == case.name and r.status == "ok"]
        if plans:
            ax.plot(
                [r.cpu_s for r in plans],
                np.maximum([r.error for r in plans], ERROR_FLOOR),
                "*",
                color="black",
                ms=15,
                label="planner (target 1e-k)",
                zorder=5,
            )
            for r in plans:
                ax.annotate(
                    f"{-math.log10(r.value):.0f}",
                    (r.cpu_s, max(r.error, ERROR_FLOOR)),
                    textcoords="offset points",
                    xytext=(6, 4),
                    fontsize=8,
                )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time per run (s)")
        ax.set_ylabel("max |θ − θ_ref| (rad)")
        ax.set_title(case.title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    for ax in list(axes.flat)[len(cases) :]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def summary_lines(checks: Sequence[PlannerCheck], closed: Sequence[ClosedFormCheck]) -> list[str]:
    """The targets, one line per scene, with MET / MISSED and the numbers behind it."""
    lines = ["TARGETS"]
    for case in dict.fromkeys(c.case for c in checks):
        mine = [c for c in checks if c.case == case]
        bad = [c for c in mine if not (c.accurate and c.cheap)]
        verdict = "MET" if not bad else "MISSED"
        worst = max((c.ratio for c in mine if math.isfinite(c.ratio)), default=math.nan)
        planned = [c.ratio_with_planning for c in mine if math.isfinite(c.ratio_with_planning)]
        lines.append(
            f"  planner ≤ 1/5 CPU of best solve_ivp, {case}: {verdict} at {len(mine) - len(bad)}/{len(mine)} "
            f"levels (worst CPU ratio {worst:.3f}; with planning {max(planned, default=math.nan):.3f}, "
            f"≤ 1/5 at {sum(r <= PLANNER_CPU_FRACTION for r in planned)}/{len(planned)})"
        )
        for c in bad:
            why = []
            if not c.accurate:
                why.append(f"error {c.error:.2e} > target")
            if not c.cheap:
                why.append(f"CPU ratio {c.ratio:.3f} > {PLANNER_CPU_FRACTION}")
            lines.append(f"      {c.target:.0e}: {c.plan}: {', '.join(why)} (best solve_ivp {c.best_ivp})")
    for cf in closed:
        lines.append(
            f"  closed form vs DOP853 rtol 1e-12, {cf.case}: {'MET' if cf.passed else 'MISSED'} "
            f"(speed-up {cf.speedup:.0f}×, needs ≥ {CLOSED_FORM_SPEEDUP:.0f}×; error {cf.exact_error:.1e}, "
            f"needs ≤ {CLOSED_FORM_ERROR:.0e})"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, write CSV/markdown/PNG under --out and print the target check."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.work_precision",
        description="Work-precision benchmark: max angle error vs CPU time for every model and integrator.",
    )
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory (out/bench)")
    parser.add_argument(
        "--quick", action="store_true", help="a small grid on short runs (seconds, for tests)"
    )
    names = ", ".join(s.name for s in case_specs())
    parser.add_argument("--case", action="append", help=f"run only this scene (repeatable): {names}")
    parser.add_argument("--no-planner", action="store_true", help="skip the planner points and targets")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    specs = [s for s in case_specs() if not args.case or s.name in args.case]
    if not specs:
        print(f"work_precision: error: no scene named {args.case}; choose from {names}", file=sys.stderr)
        return 2
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)

    def log(message: str) -> None:
        """Progress to stderr."""
        print(message, file=sys.stderr, flush=True)

    cases = [build_case(s, quick=args.quick) for s in specs]
    targets = (1e-3, 1e-6, 1e-9) if args.quick else TARGETS
    rows: list[Row] = []
    plan_rows: list[Row] = []
    checks: list[PlannerCheck] = []
    closed: list[ClosedFormCheck] = []
    floors: dict[str, float] = {}
    for case in cases:
        started = time.perf_counter()
        digits = QUICK_MPMATH_DIGITS if args.quick else MPMATH_DIGITS
        theta_ref, floors[case.name] = reference(case, out / "cache", digits)
        log(f"{case.name}: reference ({case.reference}) in {time.perf_counter() - started:.1f} s")
        case_rows = run_case(case, theta_ref, quick=args.quick, log=log)
        rows += case_rows
        if case.constant_accel and case.reference == "mpmath":
            closed.append(closed_form_check(case, theta_ref, case_rows, quick=args.quick))
        if not args.no_planner:
            p_rows, p_checks = run_planner(case, theta_ref, case_rows, targets, quick=args.quick)
            plan_rows += p_rows
            checks += p_checks
    command = "python -m benchmarks.work_precision" + (" --quick" if args.quick else "")
    write_csv(rows + plan_rows, out / "work_precision.csv")
    write_markdown(cases, rows, checks, closed, floors, out / "work_precision.md", command)
    plot(cases, rows, plan_rows, out / "work_precision.png")
    print("\n".join(summary_lines(checks, closed)))
    # The markdown's own first line is its title; the page has its own.
    tables = (out / "work_precision.md").read_text(encoding="utf-8").split("\n", 2)[2]
    page = report.write_page(
        "work_precision", "Work-precision: error against CPU for every model and integrator",
        [tables, "\n".join(summary_lines(checks, closed))],
        [(out / "work_precision.png", "max angle error against CPU time")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    print(f"wrote {out / 'work_precision.csv'}, {out / 'work_precision.md'}, {out / 'work_precision.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
