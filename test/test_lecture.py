"""The lecture's results: every command runs, its printed differences are within the printed tolerances,
its plot is a real PNG, and the lecture's formulas and numerical tools hold on cases known by hand."""

from __future__ import annotations

import importlib
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError
from pendulum_accel.lecture import RESULTS, Comparison, LectureReport, formulas, get_result, run_result
from pendulum_accel.lecture.gauge import car_frame_lagrangian, euler_lagrange_rhs, inertial_lagrangian
from pendulum_accel.lecture.measure import mean_period, zero_crossings
from pendulum_accel.lecture.plotting import write_plot
from pendulum_accel.physics.params import Pendulum

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# Results whose formulas involve the sign of θ print the mapping to the lecture's convention.
SIGNED_RESULTS = ("equilibrium", "frequency", "gauge", "accelerometer")
CHECK = re.compile(r"^  check: .* diff=(?P<diff>\S+) tol=(?P<tol>\S+) (?P<verdict>PASS|FAIL)$", re.M)


def assert_printed_checks_pass(text: str, expected: int) -> None:
    """Every printed check line parses, says PASS, and its printed |diff| ≤ its printed tol."""
    rows = list(CHECK.finditer(text))
    assert len(rows) == expected, text
    for row in rows:
        assert abs(float(row["diff"])) <= float(row["tol"]), row.group(0)
        assert row["verdict"] == "PASS", row.group(0)
    assert text.rstrip().endswith("result:   PASS"), text


def assert_png(path: Path) -> None:
    """A PNG file (signature), non-trivial size, decodes to an RGB(A) image of the figure's size."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert len(data) > 20_000
    image = imread(path)
    assert image.shape[0] >= 500 and image.shape[1] >= 800 and image.shape[2] in (3, 4)
    assert float(np.std(image[..., :3])) > 0.05  # not a blank canvas


def test_registry_matches_modules() -> None:
    assert list(RESULTS) == [
        "equilibrium",
        "frequency",
        "multiplier",
        "elastic",
        "gauge",
        "accelerometer",
        "equivalence",
        "butterfly",
    ]
    for name, result in RESULTS.items():
        module = importlib.import_module(result.module)
        assert name == module.NAME
        assert result.summary == module.SUMMARY


@pytest.mark.parametrize("name", list(RESULTS))
def test_result_within_tolerance_and_plots(name: str, tmp_path: Path) -> None:
    report = run_result(name, quick=True)
    assert report.name == name
    assert report.comparisons and report.passed
    assert report.formulas and report.setup
    assert_printed_checks_pass(report.text(), len(report.comparisons))
    if name in SIGNED_RESULTS:
        assert "θ_ours = −θ_lecture" in report.text()
    out = write_plot(report, tmp_path / f"lecture_{name}.png")
    assert_png(out)


def test_cli_lists_results_as_console_script() -> None:
    script = Path(sys.executable).with_name("pendulum-accel")
    done = subprocess.run([str(script), "lecture"], capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    # Indented lines name a result; the heading "extensions (...)" separates those beyond the notes.
    lines = done.stdout.splitlines()[1:]
    listed = [line.split()[0] for line in lines if line.startswith("  ")]
    assert listed == [n for n, r in RESULTS.items() if not r.extension] + [
        n for n, r in RESULTS.items() if r.extension
    ]
    heading = next(i for i, line in enumerate(lines) if line.startswith("extensions"))
    assert all(RESULTS[line.split()[0]].extension for line in lines[heading + 1 :])
    for result in RESULTS.values():
        assert result.summary in done.stdout


def test_cli_runs_one_result_with_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mu.png"
    assert main(["lecture", "multiplier", "--quick", "--plot", str(out)]) == 0
    text = capsys.readouterr().out
    assert "μ = −T/l" in text
    assert_printed_checks_pass(text.split("  plot:")[0], 2)
    assert f"plot:     {out}" in text
    assert_png(out)


def test_cli_rejects_unknown_name_and_bad_plot_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["lecture", "pendulum"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "'pendulum'" in err and "equilibrium" in err
    assert main(["lecture", "multiplier", "--quick", "--plot", str(tmp_path / "x.jpg")]) == 2
    assert "must end in .png" in capsys.readouterr().err
    with pytest.raises(ParameterError, match="choose from"):
        get_result("tension")


def test_failing_comparison_is_reported_as_fail() -> None:
    good = Comparison("x", "m", 1.0, 1.0 + 1e-9, 1e-6)
    bad = Comparison("y", "m", 1.0, 1.1, 1e-3)
    nan = Comparison("z", "m", 1.0, math.nan, 1.0)
    assert good.passed and not bad.passed and not nan.passed
    assert bad.line().endswith("diff=+1.000e-01 tol=1.0e-03 FAIL")
    report = LectureReport("demo", "demo", ("f",), "s", (good, bad, nan))
    assert not report.passed
    assert report.text().endswith("result:   FAIL (2 of 3 outside tolerance)")
    with pytest.raises(ParameterError, match="no plot"):
        write_plot(report, "demo.png")


def test_lecture_formulas_on_known_cases() -> None:
    p = Pendulum(length=2.0, mass=3.0)
    g = p.gravity
    # one libm atan/hypot/sqrt (≤ 1 ulp each) and ≤ 3 roundings against a constant: within 5 ε of the value
    assert formulas.equilibrium_angle(p, g) == pytest.approx(math.pi / 4, abs=1e-15)
    assert formulas.equilibrium_angle(p, -g) == pytest.approx(-math.pi / 4, abs=1e-15)  # bob forward
    assert formulas.rest_tension(p, 0.0) == pytest.approx(3.0 * g, rel=1e-15)
    assert formulas.rest_tension(p, g) == pytest.approx(3.0 * g * math.sqrt(2.0), rel=1e-15)
    assert formulas.omega_squared(p, 0.0) == pytest.approx(g / 2.0, rel=1e-15)
    assert formulas.multiplier_from_tension(p, 6.0) == pytest.approx(-3.0)
    # 4 K(m)/ω → 2π/ω as A → 0; at A = π/2, K(1/2) = 1.854074677301372 (Abramowitz & Stegun 17.3).
    assert formulas.exact_period(p, 3.0, 1e-8) == pytest.approx(
        formulas.small_angle_period(p, 3.0), rel=1e-14
    )
    omega = math.sqrt(formulas.omega_squared(p, 0.0))
    assert formulas.exact_period(p, 0.0, math.pi / 2) == pytest.approx(
        4 * 1.854074677301372 / omega, rel=1e-13
    )


def test_zero_crossing_timer_on_a_known_wave() -> None:
    period = 1.7
    t = np.linspace(0.0, 10.0, 1201)
    w = 2 * math.pi / period
    y = np.cos(w * t) + 0.3 * np.cos(3 * w * t)  # anharmonic, zero crossings still one period apart
    dy = -w * np.sin(w * t) - 0.9 * w * np.sin(3 * w * t)
    assert mean_period(t, y, dy) == pytest.approx(period, abs=1e-8)
    assert zero_crossings(t[:50], y[:50], dy[:50]).size == 0
    with pytest.raises(ParameterError, match="at least 3 zero crossings"):
        mean_period(t[:100], y[:100], dy[:100])


def test_finite_difference_euler_lagrange_recovers_the_equation_of_motion() -> None:
    p = Pendulum(length=0.8)
    a = 2.5
    rng = np.random.default_rng(8)
    for rhs in (
        euler_lagrange_rhs(inertial_lagrangian(p, a)),
        euler_lagrange_rhs(car_frame_lagrangian(p, a)),
    ):
        for theta, theta_dot, t in rng.uniform((-1.2, -3.0, 0.0), (1.2, 3.0, 10.0), size=(20, 3)):
            expected = -(p.gravity / p.length) * math.sin(theta) + (a / p.length) * math.cos(theta)
            got = rhs(float(t), np.array([theta, theta_dot]))
            assert got[0] == theta_dot
            assert got[1] == pytest.approx(expected, abs=1e-7)


@pytest.mark.slow
def test_a_result_that_takes_over_a_second_shows_progress_on_a_terminal_only() -> None:
    """lecture butterfly (a few seconds, no loop to count) draws an elapsed-time line on a terminal's
    stderr, and nothing on a pipe."""
    import fcntl
    import os
    import struct
    import subprocess
    import termios

    command = [sys.executable, "-m", "pendulum_accel.cli.main", "lecture", "butterfly", "--no-plot"]
    master, slave = os.openpty()
    # A fresh pty is 0 columns wide, where tqdm draws nothing; a terminal window is 80 wide.
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    chunks = []
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    assert proc.wait(timeout=120) in (0, 1)
    assert "lecture butterfly" in b"".join(chunks).decode(errors="replace")
    piped = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert "lecture butterfly" not in piped.stderr
