"""The lab's class data (lab_teacher/, ``pendulum-accel lab make-class``) and the teacher key."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from lab_teacher import answers as la
from lab_teacher.classdata import (
    DRIVE_RUNS,
    MAX_GROUPS,
    MAX_SECRET_BYTES,
    draw,
    draw_from_digest,
    group_digest,
    group_names,
)
from lab_teacher.key import GROUP_TEMPLATE, PERIOD_ERROR, TEMPLATE, parse_key
from pendulum_accel.cli.main import main
from pendulum_accel.sensor import SensorModel
from test.lab_class import CLASS_NAME, GROUPS, SECRET

ROOT = Path(__file__).resolve().parent.parent
STUDENT_PAGES = [ROOT / "docs" / "lab" / "README.md", ROOT / "docs" / "lab" / "worksheet.md"]
PARAM_KEYS = {"class", "group", "length_m", "gravity_m_s2", "rate_hz", "exercise1", "exercise2", "exercise3"}
# A typed figure: a digit that does not continue a word (SHA256, x2) or a placeholder (${ex1_a}).
TYPED_FIGURE = re.compile(r"(?<![\w$])\d")
# A figure in words: a fraction or a span of time said instead of computed ("a sixteenth", "about a minute").
FIGURE_WORD = re.compile(
    r"\b(?:half|halves|thirds?|quarters?|fifths?|tenths?|sixteenths?|twice|dozens?|hundreds?|thousands?|"
    r"minutes?|hours?)\b",
    re.IGNORECASE,
)


def test_make_class_writes_a_folder_and_zip_per_group_and_the_key(lab_class: Path) -> None:
    """3 groups: each folder holds data/ (CSV and params.json), the worksheet and the notebook, and its zip
    the same files; the key has one table per group."""
    out = lab_class
    names = group_names(GROUPS)
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [*names, *(f"{n}.zip" for n in names), "teacher_key.md"]
    )
    key = parse_key((out / "teacher_key.md").read_text(encoding="utf-8"))
    assert sorted(key) == names
    for name in names:
        folder = out / name
        files = {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}
        assert {"worksheet.md", "student.ipynb", "data/params.json", "data/swing.csv"} <= files
        with zipfile.ZipFile(out / f"{name}.zip") as zf:
            assert {str(Path(n).relative_to(name)) for n in zf.namelist()} == files


def test_a_group_folder_holds_no_hidden_parameter(lab_class: Path) -> None:
    """params.json has only what the worksheet gives (no a of exercise 1, no release angle, no seeds or
    stretch starts), no file names the secret, and the key is not in any group's folder or zip."""
    out = lab_class
    for name in group_names(GROUPS):
        d = draw(SECRET, CLASS_NAME, name)
        params = json.loads((out / name / "data" / "params.json").read_text(encoding="utf-8"))
        assert set(params) == PARAM_KEYS
        text = json.dumps(params)
        for hidden in (d.accel, d.offset, d.release, *d.drive_starts, *d.seeds):
            assert repr(hidden) not in text and f"{hidden:.6g}" not in text, hidden
        assert params["exercise2"]["accel_m_s2"] == d.bias_accel  # given: the car's reference
        for path in (out / name).rglob("*"):
            if path.is_file():
                assert SECRET not in path.read_bytes() and b"Teacher key" not in path.read_bytes()
        with zipfile.ZipFile(out / f"{name}.zip") as zf:
            assert not any("teacher" in n or "solution" in n for n in zf.namelist())


def test_the_draw_needs_the_secret() -> None:
    """The same secret and group give the same draw; another secret, group or class, another one."""
    one = draw(SECRET, CLASS_NAME, "group_01")
    assert draw(SECRET, CLASS_NAME, "group_01") == one
    assert draw(SECRET + b"x", CLASS_NAME, "group_01").accel != one.accel
    assert draw(SECRET, CLASS_NAME, "group_02").accel != one.accel
    assert draw(SECRET, CLASS_NAME + "b", "group_01").accel != one.accel
    assert len(one.drive_starts) == DRIVE_RUNS


def _noise(seed: int) -> np.ndarray:
    """The first 8 readings of a still bob by a 1 mrad sensor with this seed: the noise a seed draws."""
    return SensorModel(rate_hz=100.0, noise_std=1e-3, seed=seed).measure(np.arange(8) / 100.0, np.zeros(8))


def test_every_byte_of_the_groups_hmac_reaches_its_parameters_and_its_noise() -> None:
    """Flipping any one of the digest's 32 bytes changes every hidden parameter and every sensor's noise,
    so the draw uses the whole 256-bit HMAC: neither can be found by searching a smaller seed.

    The changed values are compared exactly: a float drawn from another state equals the old one with
    probability ~2⁻⁵², and 8 Gaussian noise samples all equal theirs never.
    """
    digest = group_digest(SECRET, CLASS_NAME, "group_01")
    one = draw_from_digest(CLASS_NAME, "group_01", digest)
    assert one == draw(SECRET, CLASS_NAME, "group_01")
    assert all(s.bit_length() > 128 for s in one.seeds)  # 31-bit seeds could be searched in hours
    noise = [_noise(s) for s in one.seeds]
    for k in range(len(digest)):
        flipped = digest[:k] + bytes([digest[k] ^ 0x01]) + digest[k + 1 :]
        other = draw_from_digest(CLASS_NAME, "group_01", flipped)
        hidden = ("accel", "offset", "bias_accel", "release", "drive_starts")
        assert all(getattr(other, f) != getattr(one, f) for f in hidden), k
        for seed, before in zip(other.seeds, noise, strict=True):
            assert not np.any(_noise(seed) == before), k


@pytest.mark.timeout(120)  # a FIFO or /dev/zero read as the secret hung: fail, do not wait 600 s
def test_make_class_refuses_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A missing, short or oversized secret, a FIFO or /dev/zero as the secret, no groups or more than
    MAX_GROUPS, an existing --out or one whose parent is missing, no --class, no teacher material: exit 2,
    one line, nothing written, and at once (no group is simulated: each would take seconds)."""
    short = tmp_path / "short.txt"
    short.write_bytes(b"too short")
    huge = tmp_path / "huge.txt"
    huge.write_bytes(b"x" * (MAX_SECRET_BYTES + 1))
    good = tmp_path / "secret.txt"
    good.write_bytes(SECRET)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    (tmp_path / "exists").mkdir()
    cases = [
        (tmp_path / "missing.txt", "1", tmp_path / "a", "cannot read the secret"),
        (short, "1", tmp_path / "b", "use at least"),
        (huge, "1", tmp_path / "b", f"more than {MAX_SECRET_BYTES} bytes"),
        (fifo, "1", tmp_path / "b", "FIFO"),
        (Path("/dev/zero"), "1", tmp_path / "b", "character device"),
        (good, "0", tmp_path / "c", f"1 to {MAX_GROUPS}"),
        (good, "1000000", tmp_path / "c", f"1 to {MAX_GROUPS}"),
        (good, str(MAX_GROUPS + 1), tmp_path / "c", f"1 to {MAX_GROUPS}"),
        (good, "1", tmp_path / "exists", "exists already"),
        (good, "1", tmp_path / "no" / "such" / "parent", "does not exist (it is not created"),
    ]
    for secret, groups, out, says in cases:
        argv = ["lab", "make-class", "--secret", str(secret), "--groups", groups, "--out", str(out)]
        code = main([*argv, "--class", CLASS_NAME])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err and says in err, (says, err)
    # No --class: argparse's one line (exit 2), so that one secret never gives two classes the same data.
    with pytest.raises(SystemExit) as stop:
        main(["lab", "make-class", "--secret", str(good), "--groups", "1", "--out", str(tmp_path / "e")])
    assert stop.value.code == 2 and "--class" in capsys.readouterr().err
    # A student's install has no lab_teacher/: the command says so instead of making anything.
    argv = ["lab", "make-class", "--secret", str(good), "--groups", "1", "--out", str(tmp_path / "d")]
    assert main([*argv, "--class", CLASS_NAME, "--teacher", str(tmp_path)]) == 2
    assert "lab_teacher" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "exists",
        "fifo",
        "huge.txt",
        "secret.txt",
        "short.txt",
    ]


def test_every_key_answer_carries_an_uncertainty_and_meets_the_hidden_truth(lab_class: Path) -> None:
    """Each answer is value ± σ with σ > 0; where the key has a hidden truth it lies within 4σ of it
    (4σ: a Gaussian measurement misses with probability 6e-5; 36 such comparisons here)."""
    text = (lab_class / "teacher_key.md").read_text(encoding="utf-8")
    key = parse_key(text)
    rows = re.findall(
        r"^\| `(\w+)` \| [^|]* \| (\S+) ± (\S+) \| [^|]* \| (\S+) \| (\S+) \|$", text, re.MULTILINE
    )
    assert len(rows) == sum(len(k) for k in key.values()) > 0
    truths = 0
    for _name, _value, sigma, truth, off in rows:
        assert float(sigma) > 0
        if truth != "—":
            truths += 1
            assert abs(float(off.rstrip("σ"))) <= 4.0, (_name, off)
    assert truths == 6 * GROUPS  # ex1: ω, θ_eq, a, g, ratio; ex2: the bias


def test_exercise2_moves_less_than_its_sigma_when_the_period_is_off(lab_class: Path) -> None:
    """Each group's bias, measured with the period read 0.01 s short and long: the window's ends are
    turning points found in the data, so it moves by less than its own stated σ."""
    for name in group_names(GROUPS):
        folder = lab_class / name / "data"
        rel = la.load_csv(folder / "released.csv")
        guess = la.period_guess_of(rel["t_s"], rel["theta_rad"])
        base = {a.name: a for a in la.exercise2(folder, guess)}["ex2_bias"]
        for error in (-PERIOD_ERROR, PERIOD_ERROR):
            moved = {a.name: a for a in la.exercise2(folder, guess + error)}["ex2_bias"]
            assert abs(moved.value - base.value) < base.sigma, (name, error, moved, base)


def test_the_keys_template_holds_no_typed_figure() -> None:
    """Every number in the key is computed: no digit outside placeholders and names like SHA256, and no
    figure in words ("a sixteenth of A²", "about a minute") where a computed number goes."""
    for template in (TEMPLATE, GROUP_TEMPLATE):
        figures = [m.start() for m in TYPED_FIGURE.finditer(template.template)]
        assert not figures, [template.template[max(0, i - 30) : i + 10] for i in figures]
        words = [m.group(0) for m in FIGURE_WORD.finditer(template.template)]
        assert not words, words


def test_the_package_students_install_holds_no_answer(tmp_path: Path) -> None:
    """What setup.py builds into the wheel (build_py: every module and package data file) is
    pendulum_accel alone: no lab_teacher, no test, no solution or key, and no module that names the code
    measuring the answers (lab_teacher.answers, measure_group) beyond cli/lab.py, which looks for the
    teacher's clone to run make-class. The wheel's other files are setup.py's data_files: launch files,
    config, URDF, viewer layouts and scenes."""
    build = tmp_path / "build"
    subprocess.run(
        [sys.executable, "setup.py", "-q", "build_py", "--build-lib", str(build)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    files = [p.relative_to(build) for p in build.rglob("*") if p.is_file()]
    assert files and {f.parts[0] for f in files} == {"pendulum_accel"}
    for f in files:
        assert not re.search(r"answer|solution|teacher|key\.md|test_", str(f)), f
        if f.suffix == ".py":
            text = (build / f).read_text(encoding="utf-8")
            assert "measure_group" not in text and "lab_teacher.answers" not in text, f
            if f.as_posix() != "pendulum_accel/cli/lab.py":
                assert "lab_teacher" not in text, f


def test_teacher_material_is_not_on_the_docs_site_and_no_student_page_sends_to_the_repository() -> None:
    """The docs site has no solution or key. The students' pages (the lab's README and the worksheet, which
    each zip holds) install the wheel, never a clone: no clone, make, source install or path into
    lab_teacher/ or test/; they say the repository is the teacher's edition; and name no command that
    prints a result (lecture equivalence, lecture accelerometer)."""
    assert not list((ROOT / "docs").rglob("*key*.md")) and not list((ROOT / "docs").rglob("solution*"))
    for page in (ROOT / "docs").rglob("*.md"):
        assert "lab_answers" not in page.read_text(encoding="utf-8"), page
    for page in [*STUDENT_PAGES, ROOT / "docs" / "teaching.md"]:
        text = page.read_text(encoding="utf-8")
        assert "simulator_node" not in text and "estimator_node" not in text, page.name
    for page in STUDENT_PAGES:
        text = page.read_text(encoding="utf-8")
        assert ".whl[lab]" in text, page.name
        for route in ("git clone", "make lab", 'install ".[lab]"', "install .", "lab_teacher/", "test/"):
            assert route not in text, (page.name, route)
        assert "lecture equivalence" not in text and "lecture accelerometer" not in text, page.name
    assert "teacher's edition" in STUDENT_PAGES[0].read_text(encoding="utf-8")


def test_fit_recovers_a_known_swing_within_its_stated_sigma() -> None:
    """A synthetic θ_eq + A cos ωt + B sin ωt + white noise: the fit lands within 4σ of each parameter.

    4σ: a false failure has probability 6e-5 per parameter for a Gaussian estimate.
    """
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 20.0, 0.01)
    omega, theta_eq = 3.2, 0.3
    theta = theta_eq + 0.03 * np.cos(omega * t) + 0.04 * np.sin(omega * t) + rng.normal(0.0, 0.02, t.size)
    fit = la.fit_swing(t, theta)
    assert abs(fit.omega - omega) <= 4 * fit.omega_sigma
    assert abs(fit.theta_eq - theta_eq) <= 4 * fit.theta_eq_sigma
    a, s_a, g, s_g = la.recover_a_g(fit, 1.0)
    # The formula's identity: a² + g² = (ω² l)² to rounding (a few ulp of ω⁴ ≈ 100).
    assert math.isclose(math.hypot(a, g), fit.omega**2, rel_tol=1e-12)
    assert s_a > 0 and s_g > 0


def test_lab_check_proves_the_install_or_names_what_is_missing(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`pendulum-accel lab check` runs the simulator, the four estimators and a plot, and ends with
    'install OK'; a missing Jupyter module is one line on stderr and exit 2."""
    from pendulum_accel.cli import lab

    monkeypatch.setattr(lab, "LAB_MODULES", ("ipykernel",))
    assert main(["lab", "check"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("install OK")
    monkeypatch.setattr(lab, "LAB_MODULES", ("ipykernel", "no_such_module_for_the_lab"))
    assert main(["lab", "check"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no_such_module_for_the_lab" in err


# Run in a fresh process from a group's folder: `lab check`, then the student notebook's own cells up to
# its drive cell; print the numba specializations the notebook's cells added to those the check made.
_COMPILE_PROBE = """
import sys
import numba
from pendulum_accel.cli import lab
lab.LAB_MODULES = ()  # Jupyter is not what this probes
lab.run_check(None)

def specializations():
    found = set()
    for name, module in list(sys.modules.items()):
        if name.startswith("pendulum_accel"):
            for attr, value in vars(module).items():
                if isinstance(value, numba.core.registry.CPUDispatcher):
                    found |= {f"{name}.{attr}{sig}" for sig in value.signatures}
    return found

before = specializations()
for source in CELLS:
    exec(source)
print("NEW", sorted(specializations() - before))
"""


def test_lab_check_compiles_every_kernel_the_notebooks_drive_cell_runs(
    tmp_path: Path, lab_class: Path
) -> None:
    """After `lab check`, the student notebook's cells through its drive cell, run on a group's data, add
    no numba specialization: a new one would be compiled in class. (The kalman's run_imm was, once more,
    for the strided columns np.genfromtxt gives: the check now reads a CSV as the notebook does, and the
    estimators take their input contiguous.)"""
    with zipfile.ZipFile(lab_class / "group_01.zip") as zf:
        zf.extractall(tmp_path)
    nb = json.loads((ROOT / "docs" / "lab" / "student.ipynb").read_text(encoding="utf-8"))
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    drive = next(i for i, source in enumerate(code) if "estimate_batch(name" in source)
    cells = [
        "\n".join(line for line in s.splitlines() if not line.startswith("%")) for s in code[: drive + 1]
    ]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, "-c", f"CELLS = {cells!r}\n{_COMPILE_PROBE}"],
        cwd=tmp_path / "group_01",
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    new = [line for line in done.stdout.splitlines() if line.startswith("NEW")]
    assert new == ["NEW []"], done.stdout[-2000:]
