"""The lab's notebooks: stored without outputs; the worked solution, run on each group's folder of a class,
prints the teacher key's answers within each answer's σ; the student notebook runs with its blanks and
prints no answer, and filled in as the worksheet asks it meets the key by the key's own grading rule."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from lab_teacher.classdata import group_names
from lab_teacher.key import GRADE_SIGMAS, SIGMA_FACTOR, parse_key
from test.lab_class import GROUPS, made_class

ROOT = Path(__file__).resolve().parent.parent
SOLUTION = ROOT / "lab_teacher" / "solution.ipynb"
STUDENT = ROOT / "docs" / "lab" / "student.ipynb"
ANSWER_LINE = re.compile(r"^answer (\w+) = (\S+) ± (\S+)", re.MULTILINE)


def _execute(path: Path, cwd: Path) -> str:
    """Run every cell in a fresh kernel started in ``cwd`` (an error fails the test); all output text."""
    nb = nbformat.read(path, as_version=4)
    NotebookClient(
        nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(cwd)}}
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


@pytest.mark.parametrize("group", group_names(GROUPS))
def test_solution_on_each_groups_folder_matches_the_key_within_its_sigma(
    group: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The solution reads the group's folder alone (LAB_GROUP) and prints every answer of the key's table,
    each within the key's σ of it (both are measured by lab_teacher.answers from the same files: they differ
    only by the key's rounding, ≤ σ/20, and floating-point rounding, ≪ σ)."""
    out = made_class()
    monkeypatch.setenv("LAB_GROUP", str(out / group / "data"))
    monkeypatch.setenv("LAB_TEACHER_ROOT", str(ROOT))
    text = _execute(SOLUTION, tmp_path)
    printed = {m.group(1): (float(m.group(2)), float(m.group(3))) for m in ANSWER_LINE.finditer(text)}
    key = parse_key((out / "teacher_key.md").read_text(encoding="utf-8"))[group]
    assert key and set(key) == set(printed), set(key) ^ set(printed)
    for name, (value, sigma) in key.items():
        assert abs(printed[name][0] - value) <= sigma, (name, printed[name], value, sigma)


def _handout(tmp_path: Path) -> Path:
    """A copy of group_01's handout (worksheet, notebook, data/), as a student unzips it."""
    folder = tmp_path / "group_01"
    shutil.copytree(made_class() / "group_01", folder)
    return folder


def test_student_notebook_runs_with_its_blanks_and_shows_no_answers(tmp_path: Path) -> None:
    """From the group's handout alone: the blanks print reminders, not numbers, and nothing is an answer."""
    folder = _handout(tmp_path)
    text = _execute(folder / "student.ipynb", folder)
    assert not ANSWER_LINE.search(text)
    for name in ("ω", "a", "g", "ω(a)/ω(0)", "bias over whole swings", "RMS error kalman", "delay kalman"):
        assert f"{name}: (blank: fill in)" in text, name


# What a group writes into the blanks: the worksheet's method and the notebook's own tools, nothing from
# lab_teacher. T_guess is the small-angle prediction, not measured (the window does not need it exactly).
FILLED = {
    "    return None  # ← the formula above": (
        "    return theta_eq + A * np.cos(omega * t) + B * np.sin(omega * t)"
    ),
    "p0 = None  # ← (omega, theta_eq, A, B): read rough values off the plot": (
        "p0 = (2 * math.pi / 1.95, np.mean(theta), np.ptp(theta) / 2, 0.0)"
    ),
    "a_fit = a_sigma = g_fit = g_sigma = None  # ← formulas; propagate σ to first order": (
        "g_eff, s_geff = omega**2 * L, 2 * omega * L * omega_sigma\n"
        "a_fit, g_fit = g_eff * math.sin(theta_eq), g_eff * math.cos(theta_eq)\n"
        "a_sigma = math.hypot(math.sin(theta_eq) * s_geff, g_eff * math.cos(theta_eq) * theta_eq_sigma)\n"
        "g_sigma = math.hypot(math.cos(theta_eq) * s_geff, g_eff * math.sin(theta_eq) * theta_eq_sigma)"
    ),
    'ratio = ratio_sigma = None  # ← fit rest["t_s"], rest["theta_rad"] as above': (
        "p00 = (2 * math.pi / 2.0, np.mean(rest['theta_rad']), np.ptp(rest['theta_rad']) / 2, 0.0)\n"
        "popt0, pcov0 = curve_fit(model, rest['t_s'], rest['theta_rad'], p0=p00)\n"
        "ratio = omega / popt0[0]\n"
        "ratio_sigma = ratio * math.hypot(omega_sigma / omega, math.sqrt(pcov0[0, 0]) / popt0[0])"
    ),
    "T_guess = None  # ← s: time ten swings on the plot": (
        "T_guess = 2 * math.pi * math.sqrt(L / math.hypot(G, a2))"
    ),
    "bias = None  # ← window_mean(t2, raw, first maximum, last maximum) − a2": (
        "tm, sm = find_maxima(t2, theta2, T_guess)\n"
        "mean = window_mean(t2, raw, tm[0], tm[-1])\n"
        "bias = mean - a2\n"
        "w = (t2 >= tm[0]) & (t2 <= tm[-1])"
    ),
    "sigma_noise = None  # ← √⟨(g sec²θ)²⟩ σ_θ / √N over the window's N samples": (
        "sigma_noise = np.sqrt(np.mean((G / np.cos(theta2[w]) ** 2) ** 2)) * sigma2 / np.sqrt(w.sum())"
    ),
    "sigma_window = None  # ← moving an end by δt moves the mean by (g tan θ_end − mean) δt / span": (
        "ends = np.interp([tm[0], tm[-1]], t2, raw) - mean\n"
        "sigma_window = math.hypot(ends[0] * sm[0], ends[1] * sm[-1]) / (tm[-1] - tm[0])"
    ),
    "bias_sigma = None  # ← both together": "bias_sigma = math.hypot(sigma_noise, sigma_window)",
    "rms = {name: None for name in ESTIMATORS}  # ← (mean, standard error) in m/s²": (
        "dt = 1 / RATE\n"
        "lags = np.arange(round(-0.5 / dt), round(3.0 / dt) + 1)\n"
        "rms, delay = {}, {}\n"
        "for name in ESTIMATORS:\n"
        "    r, dl = [], []\n"
        "    for d, est in zip(drives, estimates):\n"
        "        a, e = d['accel_m_s2'], est[name]\n"
        "        i0 = max(round(ex3['settle_s'] / dt), lags[-1])\n"
        "        idx = np.arange(i0, len(a) + lags[0])\n"
        "        err = [np.sqrt(np.mean((e[idx] - a[idx - m]) ** 2)) for m in lags]\n"
        "        dl.append(lags[int(np.argmin(err))] * dt)\n"
        "        keep = d['t_s'] >= d['t_s'][0] + ex3['settle_s']\n"
        "        r.append(np.sqrt(np.mean((e[keep] - a[keep]) ** 2)))\n"
        "    rms[name] = (np.mean(r), np.std(r, ddof=1) / np.sqrt(len(r)))\n"
        "    # one rounding to whole samples shared by every stretch: Δt/√12 beside the spread\n"
        "    s_dl = np.std(dl, ddof=1) / np.sqrt(len(dl))\n"
        "    delay[name] = (np.mean(dl), math.hypot(s_dl, dt / math.sqrt(12)))"
    ),
    "delay = {name: None for name in ESTIMATORS}  # ← (mean, standard error) in s": "",
}
PRINTED = re.compile(r"^(.+?): (-?[0-9.]+(?:e[-+]?\d+)?) ± ([0-9.]+(?:e[-+]?\d+)?)", re.MULTILINE)
GRADED = {  # the notebook's label → the key's answer
    "a": "ex1_a",
    "g": "ex1_g",
    "ω(a)/ω(0)": "ex1_ratio",
    "bias over whole swings": "ex2_bias",
    **{f"RMS error {n}": f"ex3_rms_{n}" for n in ("instant", "period_mean", "kalman", "dynamic")},
    **{f"delay {n}": f"ex3_delay_{n}" for n in ("instant", "period_mean", "kalman", "dynamic")},
}


def test_filled_student_notebook_passes_the_keys_grading(tmp_path: Path) -> None:
    """With the blanks filled as the worksheet asks, from the handout alone, each graded value passes the
    key's rule: within GRADE_SIGMAS of its own printed σ of the key, its σ within SIGMA_FACTOR of the key's.

    The student prints 5 significant digits and σ to 2 (rounding ≤ 5 % of σ), inside the rule's margins.
    """
    folder = _handout(tmp_path)
    nb = nbformat.read(folder / "student.ipynb", as_version=4)
    for blank, code in FILLED.items():
        cells = [c for c in nb.cells if c.cell_type == "code" and blank in c.source]
        assert len(cells) == 1, blank
        cells[0].source = cells[0].source.replace(blank, code)
    nbformat.write(nb, folder / "filled.ipynb")
    text = _execute(folder / "filled.ipynb", folder)
    assert "(blank: fill in)" not in text
    printed = {m.group(1): (float(m.group(2)), float(m.group(3))) for m in PRINTED.finditer(text)}
    key = parse_key((made_class() / "teacher_key.md").read_text(encoding="utf-8"))["group_01"]
    for label, name in GRADED.items():
        (x, s_x), (value, sigma) = printed[label], key[name]
        assert abs(x - value) <= GRADE_SIGMAS * s_x, (label, x, s_x, value, sigma)
        assert sigma / SIGMA_FACTOR <= s_x <= sigma * SIGMA_FACTOR, (label, s_x, sigma)
