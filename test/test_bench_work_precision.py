"""The work-precision harness (quick mode) measures real errors: finite, shrinking as h⁴ for RK4.

Benchmarks are not timed here; only the correctness of what the harness writes is checked.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import work_precision as wp
from benchmarks import work_precision_cases as wpc
from pendulum_accel.physics.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step

# RK4 is fourth order: the log-log slope of error vs step is 4; the fit over the quick grid's points
# above the rounding floor lands within ±0.5 of it.
ORDER_TOL = 0.5
ROUNDING_FLOOR = 1e-12


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One quick run on the lecture scene; returns its output directory."""
    out = tmp_path_factory.mktemp("wp")
    assert wp.main(["--quick", "--case", "lecture", "--out", str(out), "--docs", str(out / "docs")]) == 0
    return out


def _rows(out: Path) -> list[dict[str, str]]:
    """The CSV rows."""
    with (out / "work_precision.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_outputs_written(quick_run: Path) -> None:
    """CSV, markdown and a non-empty PNG are written."""
    assert (quick_run / "work_precision.md").read_text(encoding="utf-8").startswith("# Work-precision")
    png = (quick_run / "work_precision.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    page = (quick_run / "docs" / "benchmarks" / "work_precision.md").read_text(encoding="utf-8")
    assert page.startswith("# Work-precision") and "Machine: " in page and "--quick" in page
    assert (quick_run / "docs" / "img" / "bench_work_precision.png").read_bytes() == png


def test_every_method_measured_with_finite_errors(quick_run: Path) -> None:
    """Every integrator and closed form appears; every 'ok' row has a finite error and CPU > 0."""
    rows = _rows(quick_run)
    methods = {r["method"] for r in rows if r["setting"] != "plan"}
    assert set(FIXED_STEP_METHODS + ADAPTIVE_METHODS) | {"closed-form"} <= methods
    ok = [r for r in rows if r["status"] == "ok"]
    assert len(ok) >= 30
    for r in ok:
        assert math.isfinite(float(r["error"])) and float(r["cpu_s"]) > 0.0
    refused = [r for r in rows if r["status"] != "ok"]
    assert all(r["status"].startswith("refused") for r in refused)


def test_rk4_error_shrinks_as_h_to_the_fourth(quick_run: Path) -> None:
    """rk4 errors decrease with the step and the fitted order is 4 ± 0.5."""
    rk4 = sorted(
        ((float(r["value"]), float(r["error"])) for r in _rows(quick_run) if r["method"] == "rk4"),
        reverse=True,
    )
    steps = np.array([h for h, _ in rk4])
    errors = np.array([e for _, e in rk4])
    usable = errors > ROUNDING_FLOOR
    assert usable.sum() >= 3
    assert np.all(np.diff(errors[usable]) < 0)
    slope = np.polyfit(np.log(steps[usable]), np.log(errors[usable]), 1)[0]
    assert abs(slope - 4.0) < ORDER_TOL


def test_closed_form_is_exact_against_mpmath(quick_run: Path) -> None:
    """The exact closed form agrees with the 20-digit mpmath reference to 1e-12 rad."""
    exact = [r for r in _rows(quick_run) if r["model"] == "exact" and r["setting"] == "closed-form"]
    assert len(exact) == 1 and float(exact[0]["error"]) < 1e-12


def test_mpmath_reference_restarts_at_a_step() -> None:
    """The mpmath reference over a step profile matches the chained closed form to 1e-13 rad."""
    from pendulum_accel.physics.simulate import simulate

    t = np.linspace(0.0, 1.0, 11)
    profile = Step(0.35, 0.0, 3.0)
    ref = wpc.mpmath_reference(Pendulum(0.7), profile, t, 0.1, -0.2, digits=20)
    exact = simulate(Pendulum(0.7), profile, t, theta0=0.1, theta_dot0=-0.2, model="exact")
    assert np.max(np.abs(ref - exact.theta)) < 1e-13


def test_cpu_time_returns_the_result() -> None:
    """cpu_time gives a positive per-call time and the callable's result."""
    seconds, value = wp.cpu_time(lambda: sum(range(1000)), budget=0.001, rounds=2)
    assert seconds > 0.0 and value == 499500
