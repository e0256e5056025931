"""The lab's notebooks: stored without outputs; the worked solution, run on each group's folder of a class,
prints the teacher key's answers within each answer's σ; the student notebook runs with its blanks and
prints no answer, and filled in as its own instructions say it is graded right on every answer the key
grades, for every group of the class."""

from __future__ import annotations

import copy
import re
import zipfile
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient
from nbformat import NotebookNode

from lab_teacher.classdata import group_names
from lab_teacher.key import GRADE_SIGMAS, SIGMA_FACTOR, parse_key, parse_readings
from test.figures import half_unit
from test.lab_class import GROUPS

ROOT = Path(__file__).resolve().parent.parent
SOLUTION = ROOT / "lab_teacher" / "solution.ipynb"
STUDENT = ROOT / "docs" / "lab" / "student.ipynb"
WORKSHEET = ROOT / "docs" / "lab" / "worksheet.md"
ANSWER_LINE = re.compile(r"^answer (\w+) = (\S+) ± (\S+)", re.MULTILINE)
READING_LINE = re.compile(r"^reading (\w+) = (\S+)", re.MULTILINE)
SOLUTION_GROUPS = 3  # the solution calls the key's own code: three groups show it calls it on each


def _execute(nb: NotebookNode, cwd: Path) -> NotebookNode:
    """Run every cell of ``nb`` in a fresh kernel started in ``cwd`` (an error fails the test)."""
    NotebookClient(
        nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(cwd)}}
    ).execute()
    return nb


def _text(cells: list[NotebookNode]) -> str:
    """All the output text of ``cells``' code cells."""
    return "\n".join(
        out.get("text", "") for cell in cells if cell.cell_type == "code" for out in cell.outputs
    )


@pytest.mark.parametrize("path", [SOLUTION, STUDENT], ids=["solution", "student"])
def test_notebook_is_stored_without_outputs(path: Path) -> None:
    """No outputs or execution counts in git: they would go stale and bloat the diff."""
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.source[:60]


@pytest.mark.parametrize("group", group_names(SOLUTION_GROUPS))
def test_solution_on_each_groups_folder_matches_the_key_within_its_sigma(
    group: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lab_class: Path
) -> None:
    """The solution reads the group's folder alone (LAB_GROUP) and prints every graded answer of the key's
    table, each within the key's σ of it (both are measured by lab_teacher.answers from the same files:
    they differ only by the key's rounding, ≤ σ/20, and floating-point rounding, ≪ σ), and every value the
    key lists ungraded, the same number as printed to READING_DIGITS (both printed values within half a
    unit of their last digit: test.figures.half_unit)."""
    out = lab_class
    monkeypatch.setenv("LAB_GROUP", str(out / group / "data"))
    monkeypatch.setenv("LAB_TEACHER_ROOT", str(ROOT))
    text = _text(_execute(nbformat.read(SOLUTION, as_version=4), tmp_path).cells)
    printed = {m.group(1): (float(m.group(2)), float(m.group(3))) for m in ANSWER_LINE.finditer(text)}
    key_text = (out / "teacher_key.md").read_text(encoding="utf-8")
    key = parse_key(key_text)[group]
    assert key and set(key) == set(printed), set(key) ^ set(printed)
    for name, (value, sigma) in key.items():
        assert abs(printed[name][0] - value) <= sigma, (name, printed[name], value, sigma)
    readings = {m.group(1): m.group(2) for m in READING_LINE.finditer(text)}
    listed = parse_readings(key_text)[group]
    assert listed and set(listed) == set(readings), set(listed) ^ set(readings)
    for name, value in listed.items():
        shown = readings[name]
        assert abs(float(shown) - value) <= half_unit(shown) + half_unit(f"{value:g}"), (name, shown, value)


def _handout(lab_class: Path, group: str, tmp_path: Path) -> Path:
    """The group's folder as a student unzips it from the group's zip."""
    with zipfile.ZipFile(lab_class / f"{group}.zip") as zf:
        zf.extractall(tmp_path)
    return tmp_path / group


def test_student_notebook_runs_with_its_blanks_and_shows_no_answers(tmp_path: Path, lab_class: Path) -> None:
    """From the group's handout alone: the blanks print reminders, not numbers, and nothing is an answer."""
    folder = _handout(lab_class, "group_01", tmp_path)
    text = _text(_execute(nbformat.read(folder / "student.ipynb", as_version=4), folder).cells)
    assert not ANSWER_LINE.search(text) and not PRINTED.search(text)
    for label in GRADED:
        assert f"{label}: (blank: fill in)" in text, label


# What a group writes into the blanks, following the notebook's own instructions with its own tools (and
# curve_fit), nothing from lab_teacher. Reading a period "off the plot" is the one step a test cannot do
# by eye: swings_timed stands in for it, timing the swings the plot shows between upward crossings of the
# curve's middle (smoothed over 0.25 s, as the eye smooths the noise), a reading good to about 0.01 s.
FILLED = {
    "    return None  # ← the formula above": (
        "    return theta_eq + A * np.cos(omega * t) + B * np.sin(omega * t)"
    ),
    "p0 = None  # ← (omega, theta_eq, A, B): read rough values off the plot": (
        "def swings_timed(t, y):\n"
        "    k = max(1, round(0.25 / (t[1] - t[0])))\n"
        "    ys = np.convolve(y - np.mean(y), np.ones(k) / k, mode='valid')\n"
        "    ts, h = t[k // 2 : k // 2 + len(ys)], np.ptp(ys) / 4\n"
        "    ups, below = [], False\n"
        "    for tk, yk in zip(ts, ys):\n"
        "        if yk < -h:\n"
        "            below = True\n"
        "        elif below and yk > h:\n"
        "            ups, below = ups + [tk], False\n"
        "    return (ups[-1] - ups[0]) / (len(ups) - 1)\n"
        "\n"
        "\n"
        "p0 = (2 * math.pi / swings_timed(t, theta), np.mean(theta), np.ptp(theta) / 2, 0.0)"
    ),
    "a_fit = a_sigma = g_fit = g_sigma = None  # ← formulas; propagate σ to first order": (
        "g_eff, s_geff = omega**2 * L, 2 * omega * L * omega_sigma\n"
        "a_fit, g_fit = g_eff * math.sin(theta_eq), g_eff * math.cos(theta_eq)\n"
        "a_sigma = math.hypot(math.sin(theta_eq) * s_geff, g_eff * math.cos(theta_eq) * theta_eq_sigma)\n"
        "g_sigma = math.hypot(math.cos(theta_eq) * s_geff, g_eff * math.sin(theta_eq) * theta_eq_sigma)"
    ),
    'ratio = ratio_sigma = None  # ← fit rest["t_s"], rest["theta_rad"] as above': (
        "tr, yr = rest['t_s'], rest['theta_rad']\n"
        "popt0, pcov0 = curve_fit(model, tr, yr, p0=(2 * math.pi / swings_timed(tr, yr), np.mean(yr), "
        "np.ptp(yr) / 2, 0.0))\n"
        "ratio = omega / popt0[0]\n"
        "ratio_sigma = ratio * math.hypot(omega_sigma / omega, math.sqrt(pcov0[0, 0]) / popt0[0])"
    ),
    "T_guess = None  # ← s: time ten swings on the plot": "T_guess = swings_timed(t2, theta2)",
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
    "bias_whole = None  # ← worksheet question 5: the plain mean of g tan θ over the whole record − a2": (
        "bias_whole = np.mean(raw) - a2"
    ),
    "rms_a = None  # ← (mean, standard error) in m/s²": (
        "dt = 1 / RATE\n"
        "lags = np.arange(0, round(3.0 / dt) + 1)\n"
        "ra, per = [], {name: ([], []) for name in ESTIMATORS}\n"
        "for d, est in zip(drives, estimates):\n"
        "    a = d['accel_m_s2']\n"
        "    idx = np.flatnonzero(d['t_s'] >= d['t_s'][0] + ex3['settle_s'])\n"
        "    ra.append(np.sqrt(np.mean(a[idx] ** 2)))\n"
        "    for name in ESTIMATORS:\n"
        "        err = [np.sqrt(np.mean((est[name][idx] - a[idx - m]) ** 2)) for m in lags]\n"
        "        per[name][0].append(err[0])\n"
        "        per[name][1].append(lags[int(np.argmin(err))] * dt)\n"
        "\n"
        "\n"
        "def mean_se(x):\n"
        "    return np.mean(x), np.std(x, ddof=1) / np.sqrt(len(x))\n"
        "\n"
        "\n"
        "rms_a = mean_se(ra)"
    ),
    "rms = {name: None for name in ESTIMATORS}  # ← (mean, standard error) in m/s²": (
        "rms = {name: mean_se(r) for name, (r, _) in per.items()}"
    ),
    "delay = {name: None for name in ESTIMATORS}  # ← (mean, standard error) in s": (
        "delay = {}\n"
        "for name, (_, dl) in per.items():\n"
        "    m, se = mean_se(dl)\n"
        "    delay[name] = (m, math.hypot(se, dt / math.sqrt(12)))"
    ),
}
PRINTED = re.compile(r"^(.+?): (-?[0-9.]+(?:e[-+]?\d+)?) ± ([0-9.]+(?:e[-+]?\d+)?)", re.MULTILINE)
GRADED = {  # what the notebook prints as value ± σ → the key's answer
    "ω": "ex1_omega",
    "θ_eq": "ex1_theta_eq",
    "a": "ex1_a",
    "g": "ex1_g",
    "ω(a)/ω(0)": "ex1_ratio",
    "bias over whole swings": "ex2_bias",
    "RMS of a(t) itself": "ex3_rms_a",
    **{f"RMS error {n}": f"ex3_rms_{n}" for n in ("instant", "period_mean", "kalman", "dynamic")},
    **{f"delay {n}": f"ex3_delay_{n}" for n in ("instant", "period_mean", "kalman", "dynamic")},
}


def _filled() -> NotebookNode:
    """The student notebook with every blank filled as FILLED says (each blank found exactly once)."""
    nb = nbformat.read(STUDENT, as_version=4)
    for blank, code in FILLED.items():
        cells = [c for c in nb.cells if c.cell_type == "code" and blank in c.source]
        assert len(cells) == 1, blank
        cells[0].source = cells[0].source.replace(blank, code)
    return nb


def test_the_key_grades_exactly_the_worksheets_and_notebooks_blanks(lab_class: Path) -> None:
    """Every group's key grades the answers the notebook prints as value ± σ, no other; as many as the
    worksheet has value ± σ blanks ('____ ± ____'); and lists the same ungraded values for every group."""
    text = (lab_class / "teacher_key.md").read_text(encoding="utf-8")
    key, readings = parse_key(text), parse_readings(text)
    blanks = re.findall(r"_{4,} ± _{4,}", WORKSHEET.read_text(encoding="utf-8"))
    assert len(key) == GROUPS
    for group, answers in key.items():
        assert set(answers) == set(GRADED.values()), (group, set(answers) ^ set(GRADED.values()))
        assert set(readings[group]) == set(readings["group_01"]) and "ex2_bias_whole" in readings[group]
    assert len(blanks) == len(GRADED)


def test_filled_student_notebook_is_graded_right_for_every_group(tmp_path: Path, lab_class: Path) -> None:
    """The notebook filled in as its instructions say, run from each group's unzipped handout (one kernel,
    the filled cells once per group after a chdir into its folder): every graded answer passes the key's
    rule, within GRADE_SIGMAS of its own printed σ of the key, its σ within SIGMA_FACTOR of the key's.

    The student prints 5 significant digits and σ to 2 (rounding ≤ 5 % of σ), inside the rule's margins.
    """
    filled = [c for c in _filled().cells if c.cell_type == "code"]
    nb = nbformat.v4.new_notebook(metadata=copy.deepcopy(nbformat.read(STUDENT, as_version=4).metadata))
    spans = {}
    for group in group_names(GROUPS):
        folder = _handout(lab_class, group, tmp_path)
        nb.cells.append(nbformat.v4.new_code_cell(f"import os\n\nos.chdir({str(folder)!r})"))
        spans[group] = (len(nb.cells), len(nb.cells) + len(filled))
        nb.cells.extend(copy.deepcopy(filled))
    _execute(nb, tmp_path)
    key = parse_key((lab_class / "teacher_key.md").read_text(encoding="utf-8"))
    for group, (first, last) in spans.items():
        text = _text(nb.cells[first:last])
        assert "(blank: fill in)" not in text and f"{group}:" in text, group
        printed = {m.group(1): (float(m.group(2)), float(m.group(3))) for m in PRINTED.finditer(text)}
        assert set(printed) == set(GRADED), (group, set(printed) ^ set(GRADED))
        for label, name in GRADED.items():
            (x, s_x), (value, sigma) = printed[label], key[group][name]
            assert abs(x - value) <= GRADE_SIGMAS * s_x, (group, label, x, s_x, value, sigma)
            assert sigma / SIGMA_FACTOR <= s_x <= sigma * SIGMA_FACTOR, (group, label, s_x, sigma)
