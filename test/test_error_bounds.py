"""The planner's predicted error against a 37-digit reference (benchmarks/reference.py) on a battery.

The quick battery of benchmarks/error_bounds.py: libration (1e-6 … 3 rad), both sides of the separatrix,
rotation at 50 rad/s, a = -10 g with l = 1 mm, steps, a damped ramp, a sinusoid, targets 1e-6 … 1e-12,
two ill-conditioned starts, and the resonantly driven chaotic swing over 70 s. Held: no
false alarm, no silent miss, and measured/predicted in [0.1, 1] wherever the inputs determine θ to the
target; ill-conditioned starts and chaos announced in one line with the time they take over.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks import error_bounds as eb
from benchmarks.reference import reference_theta
from pendulum_accel import planner
from pendulum_accel.conditioning import input_sensitivity
from pendulum_accel.physics.exact import exact_solution
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant, Sinusoid
from pendulum_accel.scene_run import simulate_plan


@functools.cache
def rows() -> tuple[eb.Row, ...]:
    """The quick battery, run once."""
    return tuple(eb.run_battery(eb.battery(quick=True)))


def test_reference_matches_the_closed_form() -> None:
    """The Taylor reference agrees with the Jacobi closed form to 1e-13 rad on a 20 s libration."""
    t = np.linspace(0.0, 20.0, 41)
    reference = reference_theta(Pendulum(1.0), Constant(2.0), 1.0, 0.5, t)
    closed, _ = exact_solution(Pendulum(1.0), 2.0, 1.0, 0.5, t)
    assert np.max(np.abs(reference - closed)) <= 1e-13


def test_no_false_alarm_and_no_silent_miss() -> None:
    """TARGET NOT MET only where the run misses or the inputs cannot determine θ; every miss announced."""
    for row in rows():
        assert not row.false_alarm, (row.case, row.target, row.plan.explain(), row.measured)
        assert not row.silent_miss, (row.case, row.target, row.plan.explain(), row.measured)


def test_prediction_is_an_upper_bound_and_tight() -> None:
    """0.1 ≤ measured/predicted ≤ 1 on every run whose response to its inputs stays linear, announced
    ill-conditioned or not: the prediction is the run's own error (method and round-off through the same
    growth), not the floor. Past the linear regime (a one-ulp change moves θ by > 0.01 rad) the error is
    decided by how rounding falls and no tight bound exists."""
    linear = [row for row in rows() if row.plan.sensitivity is None or row.plan.sensitivity.linear]
    assert len(linear) >= 15 and any(row.plan.ill_conditioned for row in linear)
    for row in linear:
        assert 0.1 <= row.ratio <= 1.0, (row.case, row.target, row.plan.explain(), row.measured)


def test_prediction_bounds_announced_ill_conditioned_runs_too() -> None:
    """Where the inputs cannot determine θ the predicted figure is still ≥ the measured error (the run's
    own error, or past the linear regime twice the spread of five runs one ulp apart)."""
    ill = [row for row in rows() if row.plan.ill_conditioned]
    assert ill
    for row in ill:
        assert row.measured <= row.plan.predicted_error, (row.case, row.target, row.plan.explain())


def test_chaotic_drive_past_its_horizon_predicts_an_upper_bound() -> None:
    """The resonant drive over 100 s (θ decided by how rounding falls from ≈ 70 s on): past the linear
    regime the prediction is SPREAD_SAFETY × the spread of the one-ulp runs, ≥ the measured error, and the
    plan line says what that figure is."""
    (row,) = eb.run_case(eb.ILL_CONDITIONED[2], {})
    sensitivity = row.plan.sensitivity
    assert sensitivity is not None and not sensitivity.linear and row.plan.ill_conditioned
    assert row.plan.predicted_error >= planner.SPREAD_SAFETY * sensitivity.spread >= sensitivity.floor
    assert row.measured <= row.plan.predicted_error
    assert "spread" in row.plan.explain() and "not an accuracy of the method" in row.plan.explain()


def test_method_error_and_floor_are_separate() -> None:
    """Near the separatrix the run's own error (start rounding through S(t)) is what it predicts, even where
    the input-sensitivity floor is far larger and the inputs are announced ill-conditioned."""
    row = next(r for r in rows() if r.case == "below separatrix 1e-9" and r.target == 1e-12)
    sensitivity = row.plan.sensitivity
    assert sensitivity is not None and row.plan.ill_conditioned
    assert row.plan.method_error < sensitivity.floor
    assert 0.1 <= row.measured / row.plan.method_error <= 1.0
    assert row.plan.predicted_error == row.plan.method_error  # the floor is announced, not predicted
    assert "ILL-CONDITIONED" in row.plan.explain()


def test_ill_conditioned_starts_are_announced_with_their_time() -> None:
    """The inverted (a = 2) and grazing (a = -5) starts: ill-conditioned at 1e-6, said in one line."""
    flagged = {row.case: row for row in rows() if row.case in ("inverted a=2", "grazing a=-5")}
    assert set(flagged) == {"inverted a=2", "grazing a=-5"}
    for row in flagged.values():
        text = row.plan.explain()
        assert row.plan.ill_conditioned and not row.plan.meets_target and "\n" not in text
        assert "the inputs do not determine θ to within the target" in text and "input sensitivity" in text
        assert row.measured > row.target  # the miss really happens
    grazing = flagged["grazing a=-5"].plan.sensitivity
    assert grazing is not None and grazing.input == "θ'0" and 5e-4 <= grazing.floor <= 2e-3


def test_chaotic_resonant_drive_is_announced_and_exact_before_its_time() -> None:
    """a = 1 + 3 sin πt (the resonant_drive scene's drive) over 70 s: the plan states λ > 0 and the time
    from which the inputs no longer determine θ to 1e-6; before it the run meets 1e-6 against the
    reference, and at that time the announced sensitivity has reached the target."""
    case = eb.Case(
        "resonant",
        eb._scene("resonant", profile=Sinusoid(3.0, 0.5, offset=1.0), theta0=0.3, duration=70.0, rate=10.0),
        (1e-6,),
    )
    (row,) = eb.run_case(case, {})
    plan, sensitivity = row.plan, row.plan.sensitivity
    assert sensitivity is not None and plan.driven and plan.ill_conditioned
    assert sensitivity.lyapunov > 0.1 and sensitivity.lost_at is not None
    text = plan.explain()
    assert "Lyapunov" in text and f"from t = {sensitivity.lost_at:.3g} s on" in text
    scene = case.scene
    t = scene.sensor.sample_times(scene.duration)
    theta = simulate_plan(replace(scene, accuracy=1e-6), plan, t).theta
    error = np.abs(theta - reference_theta(scene.pendulum, scene.profile, scene.theta0, 0.0, t))
    assert np.max(error[t < 0.5 * sensitivity.lost_at]) <= 1e-6


def test_sensitivity_of_a_linear_response_is_per_ulp() -> None:
    """A runner θ(t) = θ0 + t θ'0: S = max over t of one ulp of θ'0 × t, found at the last time."""
    t = np.linspace(0.0, 10.0, 11)
    sensitivity = input_sensitivity(lambda a, b: a + t * b, 0.5, 2.0, 1.0, t, 1e-12)
    assert sensitivity.input == "θ'0" and sensitivity.at == 10.0 and sensitivity.linear
    assert sensitivity.floor == pytest.approx(10.0 * math.ulp(2.0), rel=0.05)
    assert sensitivity.lost_at is None and sensitivity.lyapunov == pytest.approx(0.0, abs=0.2)


def test_exponential_growth_gives_the_lyapunov_exponent_and_the_lost_time() -> None:
    """θ(t) = θ0 e^{0.5 t}: λ ≈ 0.5 1/s, and θ leaves the target at ulp(θ0) e^{t/2} = target."""
    t = np.linspace(0.0, 60.0, 601)
    sensitivity = input_sensitivity(lambda a, b: a * np.exp(0.5 * t) + b, 1.0, 0.0, 1.0, t, 1e-6)
    assert sensitivity.lyapunov == pytest.approx(0.5, rel=0.05)
    expected = 2.0 * math.log(1e-6 / math.ulp(1.0))
    assert sensitivity.lost_at == pytest.approx(expected, abs=0.2)
    assert "Lyapunov" in sensitivity.chaos() and sensitivity.verdict().startswith("ILL-CONDITIONED")


def test_the_plot_draws_every_run_beside_the_bound(tmp_path: Path) -> None:
    """error_bounds.png: the quick battery's runs, measured against predicted, with the bound's line."""
    assert eb.plot(rows(), tmp_path / "error_bounds.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
