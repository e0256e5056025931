"""The lab's answers (pendulum_accel.lecture.lab_answers) and the teacher key rendered from them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pendulum_accel.lecture.lab_answers import Answer, answers, fit_swing, recover_a_g
from pendulum_accel.lecture.lab_data import LabRun
from pendulum_accel.lecture.lab_key import TABLE_ROW, parse_key, render_key
from test.figures import half_unit

KEY = Path(__file__).resolve().parent.parent / "docs" / "lab" / "teacher" / "teacher_key.md"


def _tol_cells(text: str) -> tuple[str, dict[str, str]]:
    """(the key with each answer-table tol replaced by '#', {name: tol as printed})."""
    tols = {m.group(1): m.group(3) for m in TABLE_ROW.finditer(text)}
    masked = TABLE_ROW.sub(lambda m: m.group(0)[: m.start(3) - m.start(0)] + "# |", text)
    return masked, tols


# A tol is k·q for an answer q (σ/100, noise/10, 0.05·nfev, d·1e-2 …) or a constant; q is itself accepted
# within its tol, so a fresh tol lies within k·tol_q of the stored one. The largest k·tol_q/tol in
# lab_answers is 0.1 (noise/10, noise accepted within noise/10); LSODA's 0.05·nfev moves by ≤ 5 %.
TOL_MOVE = 0.1


def test_teacher_key_is_its_template_filled_with_a_fresh_computation() -> None:
    """No hand edits and no drift: the stored key is the template filled with its own table, and that
    table equals a fresh computation within each answer's tol (the tol argument is in lab_answers).

    The key's text holds the stored printed values and the run's settings, compared exactly; only the
    table's tol column is computed afresh (e.g. ± 91 here, ± 92 on another CPU for LSODA's f-calls), so it
    is parsed and compared within half a unit of each printed last digit plus TOL_MOVE of the tol.
    """
    stored = KEY.read_text(encoding="utf-8")
    table = parse_key(stored)
    fresh = answers()
    assert set(table) == set(fresh)
    rendered = render_key(fresh, {name: value for name, (value, _) in table.items()})
    stored_text, stored_tols = _tol_cells(stored)
    rendered_text, rendered_tols = _tol_cells(rendered)
    assert stored_text == rendered_text
    for name, printed in stored_tols.items():
        again = rendered_tols[name]
        allowed = half_unit(printed) + half_unit(again) + TOL_MOVE * float(printed)
        assert abs(float(again) - float(printed)) <= allowed, (name, printed, again, allowed)
    for name, (value, tol) in table.items():
        assert abs(float(value) - fresh[name].value) <= tol, (name, value, fresh[name].value)


def test_fit_recovers_a_known_swing_within_its_stated_sigma() -> None:
    """A synthetic θ_eq + A cos ωt + B sin ωt + white noise: the fit lands within 4σ of each parameter.

    4σ: a false failure has probability 6e-5 per parameter for a Gaussian estimate.
    """
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 20.0, 0.01)
    omega, theta_eq = 3.2, 0.3
    theta = theta_eq + 0.03 * np.cos(omega * t) + 0.04 * np.sin(omega * t) + rng.normal(0.0, 0.02, t.size)
    fit = fit_swing(t, theta)
    assert abs(fit.omega - omega) <= 4 * fit.omega_sigma
    assert abs(fit.theta_eq - theta_eq) <= 4 * fit.theta_eq_sigma
    assert math.isclose(fit.amplitude, 0.05, rel_tol=0.1)  # 0.05 = hypot(0.03, 0.04); σ_A/A ≈ 2 %
    a, s_a, g, s_g = recover_a_g(fit, 1.0)
    # The formula's identity: a² + g² = (ω² l)² exactly, whatever the fit's errors.
    assert math.isclose(math.hypot(a, g), fit.omega**2, rel_tol=1e-12)
    assert s_a > 0 and s_g > 0


def test_answers_depend_on_the_groups_run() -> None:
    """Two seeds give two different fitted ω, each within 4σ of the other's (the same physics)."""
    one = answers(LabRun(seed=1), extensions=False)
    two = answers(LabRun(seed=2), extensions=False)
    w1, w2 = one["ex1_omega"], two["ex1_omega"]
    assert w1.value != w2.value
    sigma = math.hypot(one["ex1_omega_sigma"].value, two["ex1_omega_sigma"].value)
    assert abs(w1.value - w2.value) <= 4 * sigma


def test_exercise2_averages_whole_periods_to_the_lectures_bias() -> None:
    """The whole-period bias at a = 3 m/s² is `lecture accelerometer`'s printed +0.152 m/s².

    That run has l = 0.5 m and another seed; the bias depends only on a/g and the amplitude θ_eq, so the two
    differ by the sensor noise (4σ) plus 0.0015 m/s²: the printed value's rounding (0.0005) and ≤ 0.5 % of
    the bias for where each run's whole periods begin (the swing is not exactly harmonic at 0.3 rad).
    """
    found = answers(LabRun(seed=5), extensions=False)
    assert abs(found["ex2_bias_whole"].value - 0.152) <= 4 * found["ex2_bias_noise"].value + 0.0015
    assert found["ex2_bias_whole"].value > found["ex2_bias_predicted"].value  # the 4th-order term adds


def test_answer_text_rounds_within_a_fifth_of_tol() -> None:
    """Printed values round by at most tol/5: fixed and scientific notation and whole counts."""
    for value, tol in ((3.2055321, 2e-5), (4.4876e-4, 4.5e-6), (1817.0, 90.0), (9.0, 0.5), (4.85e-12, 5e-14)):
        text = Answer("x", "x", value, "", tol).text
        assert abs(float(text) - value) <= tol / 5, (value, text)


def test_a_groups_bad_choice_is_one_line_and_the_window_fits_the_cycle() -> None:
    """LabRun refuses a seed < 0, a ≤ 0 and a window past the cycle's end; its UDDS length is the scene's."""
    import pytest

    from pendulum_accel.errors import ParameterError
    from pendulum_accel.lecture import lab_data
    from pendulum_accel.lecture.lab_answers import main
    from pendulum_accel.scene import load_scene

    assert load_scene(lab_data.DRIVE_SCENE).duration == lab_data.UDDS_LENGTH
    for bad in ({"seed": -1}, {"accel": 0.0}, {"drive_start": lab_data.LAST_DRIVE_START + 1.0}):
        with pytest.raises(ParameterError, match=r"^[^\n]*$"):
            LabRun(**bad)
    assert main(["--drive-start", "1300"]) == 2
