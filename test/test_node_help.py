"""``--help`` on every node, from its parameter table, where rclpy cannot even be imported."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from pendulum_accel.nodes.node_help import NODE_MODULES, help_text
from pendulum_accel.nodes.parameters import NODE_PARAMETERS
from test.conftest import PYTHON, REPO


def _broken_ros(tmp_path: Path) -> dict[str, str]:
    """An environment whose first PYTHONPATH entry holds an rclpy that raises on import."""
    fake = tmp_path / "rclpy"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('rclpy must not be imported for --help')\n")
    import os

    return {**os.environ, "PYTHONPATH": f"{tmp_path}:{REPO}"}


@pytest.mark.parametrize("node", list(NODE_MODULES))
def test_help_prints_the_table_without_rclpy(node: str, tmp_path: Path) -> None:
    env = _broken_ros(tmp_path)
    script = f"from pendulum_accel.nodes.node_help import {node}; raise SystemExit({node}())"
    for cmd in (
        [PYTHON, "-m", f"pendulum_accel.nodes.{NODE_MODULES[node]}", "--help"],
        [PYTHON, "-c", f"import sys; sys.argv = ['{node}', '-h']; {script}"],
    ):
        result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120, cwd=REPO)
        assert result.returncode == 0, result.stderr
        assert result.stdout.strip() == help_text(node)
    text = help_text(node)
    for spec in NODE_PARAMETERS[node]:
        assert spec.help_line() in text  # name, type, range, default and description, from the table


def test_help_line_of_a_ranged_parameter() -> None:
    line = next(line for line in help_text("accel_estimator").splitlines() if "warn_angle_deg" in line)
    assert line.strip().startswith("warn_angle_deg (double, 1..89.9, read-only; default 80.0):")


def test_an_integer_range_is_printed_whole() -> None:
    """seed's range is 0..2147483647 as a user types it, not %g's 0..2.14748e+09; its bounds parse back to
    the table's exactly."""
    line = next(line for line in help_text("pendulum_sim").splitlines() if line.strip().startswith("seed "))
    spec = next(s for s in NODE_PARAMETERS["pendulum_sim"] if s.name == "seed")
    low, high = line.split("(integer, ")[1].split(";")[0].split("..")
    assert (int(low), int(high)) == (spec.low, spec.high) and "e+" not in line


def test_run_without_rclpy_is_one_line_and_exit_2(tmp_path: Path) -> None:
    env = _broken_ros(tmp_path)
    cmd = [PYTHON, "-m", "pendulum_accel.cli.main", "run", "--record", str(tmp_path / "bag")]
    result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "rclpy is not installed" in lines[0] and "requirements-ros.txt" in lines[0]
    assert not (tmp_path / "bag").exists()
