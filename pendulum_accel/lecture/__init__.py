"""The lecture's results, each reproducible by one call (or ``pendulum-accel lecture NAME``).

Every result module defines ``NAME``, ``SUMMARY`` and ``run(quick=False) -> LectureReport``:
the lecture's formula, the simulated value from :mod:`pendulum_accel.physics`, their difference
against a stated tolerance, and a plot callback (see :func:`plotting.write_plot`).
``quick=True`` uses coarse sweeps (tests); the default is what the README plots show.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

from pendulum_accel.errors import ParameterError
from pendulum_accel.lecture.report import Comparison, LectureReport

__all__ = ["RESULTS", "Comparison", "LectureReport", "LectureResult", "get_result", "run_result"]


@dataclass(frozen=True)
class LectureResult:
    """One registered result: its name, one-line summary and module (imported on first use)."""

    name: str
    summary: str
    module: str
    extension: bool = False  # True: goes beyond the lecture notes (listed as an extension, not a result)

    def run(self, quick: bool = False) -> LectureReport:
        """Import the result's module and run it."""
        runner: Callable[[bool], LectureReport] = importlib.import_module(self.module).run
        return runner(quick)


# Kept as literal text rather than imported so `pendulum-accel lecture` lists results without
# importing scipy/matplotlib; test_lecture checks they equal each module's SUMMARY.
RESULTS: dict[str, LectureResult] = {
    r.name: r
    for r in (
        LectureResult(
            "equilibrium",
            "equilibrium angle tan θ = a/g and tension T = m √(g² + a²) against a sweep of constant a",
            "pendulum_accel.lecture.equilibrium",
        ),
        LectureResult(
            "frequency",
            "small-oscillation ω² = √(g² + a²)/l over a sweep of a (extension: the exact, elliptic period)",
            "pendulum_accel.lecture.frequency",
        ),
        LectureResult(
            "multiplier",
            "Lagrange multiplier μ of the Cartesian model against −T/l from Newton's tension, along a swing",
            "pendulum_accel.lecture.multiplier",
        ),
        LectureResult(
            "elastic",
            "elastic string V(r) = ½ k (r − l)²: stretch ≈ T/k; converges to the rigid pendulum as k → ∞",
            "pendulum_accel.lecture.elastic",
        ),
        LectureResult(
            "gauge",
            "the ½ m a² t² term (a total time derivative) leaves the motion unchanged, shown numerically",
            "pendulum_accel.lecture.gauge",
        ),
        LectureResult(
            "accelerometer",
            "a = g tan θ off a swinging bob: the raw reading's bias, and how each estimator removes it",
            "pendulum_accel.lecture.accelerometer",
        ),
        LectureResult(
            "equivalence",
            "grade β and acceleration g tan β give one angle; the period and the tension tell them apart",
            "pendulum_accel.lecture.equivalence",
            extension=True,
        ),
        LectureResult(
            "butterfly",
            "two runs one ulp apart diverge in the driven pendulum: when the inputs stop counting",
            "pendulum_accel.lecture.butterfly",
            extension=True,
        ),
    )
}


def get_result(name: str) -> LectureResult:
    """The registered result called ``name``; ParameterError listing the names otherwise."""
    try:
        return RESULTS[name]
    except KeyError:
        raise ParameterError(f"unknown lecture result {name!r}; choose from {', '.join(RESULTS)}") from None


def run_result(name: str, quick: bool = False) -> LectureReport:
    """Run the result called ``name`` (coarse sweeps when ``quick``)."""
    return get_result(name).run(quick)
