"""The lab's notebooks (docs/lab/): stored without outputs; the solution reproduces the teacher key, the
student notebook runs with its blanks and prints no answer."""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from pendulum_accel.lecture.lab_key import parse_key

LAB = Path(__file__).resolve().parent.parent / "docs" / "lab"
SOLUTION = LAB / "teacher" / "solution.ipynb"
STUDENT = LAB / "student.ipynb"
KEY = LAB / "teacher" / "teacher_key.md"
ANSWER_LINE = re.compile(r"^answer (\w+) = (\S+)", re.MULTILINE)


def _execute(path: Path, tmp_path: Path) -> str:
    """Run every cell in a fresh kernel (an error fails the test); the text of all outputs."""
    nb = nbformat.read(path, as_version=4)
    NotebookClient(
        nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    return "\n".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )


@pytest.mark.parametrize("path", [SOLUTION, STUDENT], ids=["solution", "student"])
def test_notebook_is_stored_without_outputs(path: Path) -> None:
    """No outputs or execution counts in git: they would go stale and bloat the diff."""
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]


def test_solution_notebook_prints_the_teacher_keys_answers(tmp_path: Path) -> None:
    """Every answer in the key is printed by the solution notebook, equal within the answer's tol.

    Both come from lab_answers; the key was computed on another run (possibly another machine), so the
    printed values may differ by rounding in the solver and the fits, which each tol bounds (lab_answers).
    The key's own printing rounds by at most tol/5, leaving 4/5 of tol for that drift.
    """
    text = _execute(SOLUTION, tmp_path)
    printed = {m.group(1): float(m.group(2)) for m in ANSWER_LINE.finditer(text)}
    key = parse_key(KEY.read_text(encoding="utf-8"))
    assert key and set(key) == set(printed), set(key) ^ set(printed)
    for name, (value, tol) in key.items():
        assert abs(printed[name] - float(value)) <= tol, (name, printed[name], value, tol)


def test_student_notebook_runs_with_its_blanks_and_shows_no_answers(tmp_path: Path) -> None:
    """The blanks print reminders, not numbers; no answer line or fitted value leaks into the outputs."""
    text = _execute(STUDENT, tmp_path)
    assert "(blank: fill in)" in text
    assert not ANSWER_LINE.search(text)
    for name in ("ω", "θ_eq", "a", "g", "ω(a)/ω(0)", "T", "bias over whole periods", "RMS error kalman"):
        assert f"{name}: (blank: fill in)" in text, name


BIAS_WHOLE = (
    "bias_whole = None  # ← np.trapezoid(raw[w], t[w]) / (t[w][-1] - t[w][0]) - RUN.accel, w: whole periods"
)
# What a group writes into the blanks: the worksheet's method, nothing from lab_answers.
FILLED = {
    "    return None  # ← the formula above": (
        "    return theta_eq + A * np.cos(omega * t) + B * np.sin(omega * t)"
    ),
    "p0 = None  # ← (omega, theta_eq, A, B): read rough values off the plot": (
        "p0 = (math.sqrt(math.hypot(G, RUN.accel) / L), math.atan2(RUN.accel, G), 0.05, 0.0)"
    ),
    "a_fit = a_sigma = g_fit = g_sigma = None  # ← formulas; propagate σ to first order": (
        "g_eff, s_geff = omega**2 * L, 2 * omega * L * omega_sigma\n"
        "a_fit, g_fit = g_eff * math.sin(theta_eq), g_eff * math.cos(theta_eq)\n"
        "a_sigma = math.hypot(math.sin(theta_eq) * s_geff, g_eff * math.cos(theta_eq) * theta_eq_sigma)\n"
        "g_sigma = math.hypot(math.cos(theta_eq) * s_geff, g_eff * math.sin(theta_eq) * theta_eq_sigma)"
    ),
    "ratio = ratio_sigma = None  # ← fit data0.t, data0.theta_measured as above": (
        "p00 = (math.sqrt(G / L), 0.0, 0.05, 0.0)\n"
        "popt0, pcov0 = curve_fit(model, data0.t, data0.theta_measured, p0=p00)\n"
        "ratio = omega / popt0[0]\n"
        "ratio_sigma = ratio * math.hypot(omega_sigma / omega, math.sqrt(pcov0[0, 0]) / popt0[0])"
    ),
    "T = None  # ← s": (
        "eq = math.atan2(RUN.accel, G)\n"
        "p02 = (math.sqrt(math.hypot(G, RUN.accel) / L), eq, -eq, 0.0)\n"
        "popt2, _ = curve_fit(model, data2.t, data2.theta_measured, p0=p02)\n"
        "T = 2 * math.pi / popt2[0]\n"
        "n = int((data2.t[-1] - data2.t[0]) // T) - 1\n"
        "whole = data2.t >= data2.t[-1] - n * T"
    ),
    BIAS_WHOLE: (
        "tw = data2.t[whole]\nbias_whole = np.trapezoid(raw[whole], tw) / (tw[-1] - tw[0]) - RUN.accel"
    ),
    "bias_all = None  # ← the same over all 20 s: why does it differ?": (
        "bias_all = np.trapezoid(raw, data2.t) / (data2.t[-1] - data2.t[0]) - RUN.accel"
    ),
    "rms = {name: None for name in estimates}  # ← np.sqrt(np.mean((est - data3.accel_true) ** 2))": (
        "rms = {n: float(np.sqrt(np.mean((e - data3.accel_true) ** 2))) for n, e in estimates.items()}"
    ),
}
PRINTED = re.compile(r"^(.+?): (-?[0-9.]+(?:e[-+]?\d+)?)(?: |$)", re.MULTILINE)


def test_filled_student_notebook_reaches_the_answers_for_its_own_run(tmp_path: Path) -> None:
    """With the blanks filled as the worksheet asks, a group's notebook prints lab_answers for its run.

    Tolerances: the fits find the same least-squares optimum as lab_answers (another start), so they agree
    to far below σ; the notebook prints 5 significant digits (rounding ≤ 5e-5 of the value), so each
    fitted value is allowed σ/10 plus that rounding. T is fitted here (a sinusoid's ω over a 0.2 rad
    swing: its fundamental) but timed exactly in lab_answers: 1e-3 s covers the harmonics' leakage. The
    whole-period bias uses that T: the window's start moves by n·δT (here 9 × 8e-6 s), which changes the
    window only if a sample lies that close to its edge, and then by one sample of 0.01 s out of
    nT ≈ 18 s, at most (0.01/18)·max|raw − a| ≈ 2.5e-3 m/s².
    """
    from pendulum_accel.lecture.lab_answers import answers
    from pendulum_accel.lecture.lab_data import LabRun

    nb = nbformat.read(STUDENT, as_version=4)
    for blank, code in FILLED.items():
        cells = [c for c in nb.cells if c.cell_type == "code" and blank in c.source]
        assert len(cells) == 1, blank
        cells[0].source = cells[0].source.replace(blank, code)
    filled = tmp_path / "filled.ipynb"
    nbformat.write(nb, filled)
    text = _execute(filled, tmp_path)
    assert "(blank: fill in)" not in text
    printed = {m.group(1): float(m.group(2)) for m in PRINTED.finditer(text)}
    key = answers(LabRun(seed=1, accel=2.0, drive_start=300.0), extensions=False)

    def close(label: str, name: str, tol: float) -> None:
        value = key[name].value
        assert abs(printed[label] - value) <= tol + 5e-5 * abs(value), (label, printed[label], value, tol)

    close("ω", "ex1_omega", key["ex1_omega_sigma"].value / 10)
    close("θ_eq", "ex1_theta_eq", key["ex1_theta_eq_sigma"].value / 10)
    close("a", "ex1_a", key["ex1_a_sigma"].value / 10)
    close("g", "ex1_g", key["ex1_g_sigma"].value / 10)
    close("ω(a)/ω(0)", "ex1_ratio", key["ex1_ratio_sigma"].value / 10)
    close("T", "ex2_period", 1e-3)
    close("bias over whole periods", "ex2_bias_whole", 2.5e-3)
    close("bias over all 20 s", "ex2_bias_window", 0.0)  # the same samples, the same formula
    for name in ("instant", "period_mean", "kalman", "dynamic"):
        close(f"RMS error {name}", f"ex3_rms_{name}", 1e-4)
