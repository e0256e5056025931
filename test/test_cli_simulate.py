"""``pendulum-accel simulate`` and ``scenes``: CSV round trip in-process and as a subprocess."""

from __future__ import annotations

import csv
import io
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.scene import BUNDLED_SCENE_NAMES, SCENE_NAMES, load_scene
from pendulum_accel.scene_run import run_scene

REPO = Path(__file__).resolve().parent.parent
CLI = REPO / ".venv" / "bin" / "pendulum-accel"


def read_csv(text: str) -> tuple[list[str], np.ndarray]:
    """Header and float rows of a CSV text."""
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_scene_to_csv_file_matches_run_scene(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """simulate SCENE --out, every bundled scene: t, θ, θ', then what the model has; equal to run_scene.
    resonant_drive is chaotic at its target, so it runs only when told the inputs do not fix θ."""
    out = tmp_path / f"{name}.csv"
    accept = ["--accept-ill-conditioned"] if name == "resonant_drive" else []
    assert main(["simulate", name, "--out", str(out), *accept]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip().splitlines()[0].startswith("plan: ")
    header, data = read_csv(out.read_text(encoding="utf-8"))
    run = run_scene(load_scene(name))
    # The CSV has every column the model computes; the run keeps only what the scene publishes.
    assert header[:3] == ["t", "theta", "theta_dot"] and header[3:] in (["tension"], ["tension", "stretch"])
    extra = [column for column in ("tension", "stretch") if getattr(run, column) is not None]
    assert set(extra) <= set(header[3:])
    assert data.shape == (run.t.size, len(header))
    assert np.array_equal(data[:, 0], run.t)
    assert np.array_equal(data[:, 1], run.theta_true)  # 17 significant digits round-trip a double
    assert np.array_equal(data[:, 2], run.theta_dot)
    for column in extra:
        assert np.array_equal(data[:, header.index(column)], getattr(run, column)), column
    if name == "lecture_constant":
        assert captured.err.startswith("plan: exact model, closed-form")


def test_stdout_carries_only_the_csv(capsys: pytest.CaptureFixture[str]) -> None:
    """Without --out the CSV goes to stdout and the plan line to stderr; the elastic scene adds stretch."""
    assert main(["simulate", "elastic_string", "--duration", "0.5"]) == 0
    captured = capsys.readouterr()
    header, data = read_csv(captured.out)
    assert header == ["t", "theta", "theta_dot", "tension", "stretch"]
    assert data.shape[0] == 101 and np.all(np.isfinite(data))
    assert "plan: elastic model" in captured.err
    # Stretch ≈ m √(g² + a²)/k (quasi-static, the string's ~100 Hz ripple included) within 20%.
    scene = load_scene("elastic_string")
    assert scene.pendulum.stiffness is not None
    static = math.hypot(scene.pendulum.gravity, 2.0) / scene.pendulum.stiffness
    assert np.mean(data[:, 4]) == pytest.approx(static, rel=0.2)


def test_plain_flags_start_at_equilibrium_and_stay(capsys: pytest.CaptureFixture[str]) -> None:
    """No scene: --length 2 --accel 1 --theta0 atan(1/g): θ stays at θ_eq to 1e-12 rad (exact solution)."""
    theta_eq = math.atan2(1.0, 9.80665)
    args = [
        "simulate",
        "--length",
        "2",
        "--accel",
        "1",
        "--theta0",
        repr(theta_eq),
        "--duration",
        "3",
        "--rate",
        "20",
    ]
    assert main(args) == 0
    header, data = read_csv(capsys.readouterr().out)
    assert header == ["t", "theta", "theta_dot", "tension"]
    assert data.shape == (61, 4)
    assert np.max(np.abs(data[:, 1] - theta_eq)) < 1e-12
    assert np.allclose(data[:, 3], math.hypot(9.80665, 1.0), rtol=1e-12)  # T = m √(g² + a²), m = 1


def test_model_method_and_step_options(capsys: pytest.CaptureFixture[str]) -> None:
    """--model rigid --method rk4 --dt 0.001 is obeyed and agrees with the exact closed form to 1e-9 rad."""
    base = ["simulate", "large_swing", "--duration", "2"]
    assert main([*base, "--model", "rigid", "--method", "rk4", "--dt", "0.001"]) == 0
    rk4 = capsys.readouterr()
    assert "plan: rigid model, rk4 (dt = 0.001 s)" in rk4.err
    assert main([*base, "--model", "exact"]) == 0
    exact = capsys.readouterr()
    assert np.max(np.abs(read_csv(rk4.out)[1][:, 1] - read_csv(exact.out)[1][:, 1])) < 1e-9
    assert main([*base, "--rtol", "1e-10"]) == 0
    assert "DOP853 (rtol = 1.0e-10)" in capsys.readouterr().err


def test_set_goes_through_the_override_table(capsys: pytest.CaptureFixture[str]) -> None:
    """--set NAME=VALUE equals the matching flag; both are range-checked by the one override table."""
    assert main(["simulate", "braking", "--duration", "0.5", "--rate", "50"]) == 0
    flags = capsys.readouterr().out
    assert main(["simulate", "braking", "--set", "duration=0.5", "--set", "rate_hz=50"]) == 0
    assert capsys.readouterr().out == flags
    assert main(["simulate", "braking", "--set", "length=2000"]) == 2
    assert "length must be in [0.001, 1000] m" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["simulate", "nosuch"], "no bundled scene named 'nosuch'"),
        (["simulate", "--length", "-1"], "length"),
        (["simulate", "--set", "bogus=1"], "not an overridable scene field"),
        (["simulate", "--set", "length"], "NAME=NUMBER"),
        (["simulate", "lecture_constant", "--model", "exact", "--dt", "0.01"], "closed form"),
        (["simulate", "stop_and_go", "--model", "linear"], "undamped"),
        (["simulate", "lecture_constant", "--method", "RK45", "--dt", "0.01"], "--dt"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Errors: exit code 2, one stderr line naming the problem, nothing on stdout."""
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]


def test_scenes_lists_every_bundled_scene(capsys: pytest.CaptureFixture[str]) -> None:
    """`scenes`: one line per scene, name then description; `scenes NAME` prints YAML and the plan."""
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split()[0] for line in lines] == list(BUNDLED_SCENE_NAMES)
    for line, name in zip(lines, BUNDLED_SCENE_NAMES, strict=True):
        assert load_scene(name).description in line
    assert main(["scenes", "braking"]) == 0
    shown = capsys.readouterr()
    assert shown.out.startswith("name: braking") and "plan: exact model" in shown.err


def test_installed_console_script_round_trip(tmp_path: Path) -> None:
    """The real `pendulum-accel` executable: simulate at_rest to a file, header and row count as expected."""
    out = tmp_path / "rest.csv"
    executable = [str(CLI)] if CLI.exists() else [sys.executable, "-m", "pendulum_accel.cli.main"]
    result = subprocess.run(
        [*executable, "simulate", "at_rest", "--duration", "1", "--out", str(out)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""
    assert "plan: linear model" in result.stderr
    header, data = read_csv(out.read_text(encoding="utf-8"))
    assert header == ["t", "theta", "theta_dot", "tension"] and data.shape == (101, 4)
    assert np.all(data[:, 1] == 0.0)
