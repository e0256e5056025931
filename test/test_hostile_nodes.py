"""Hostile battery, ROS part: the recorder node on a disk that fills up while it records."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from test.chain_helpers import run_probe, start_node
from test.conftest import PYTHON, Spawn
from test.tiny_filesystem import tiny_filesystem

pytestmark = pytest.mark.ros


def test_recorder_on_a_full_disk_stops_with_one_line(spawn: Spawn, tmp_path: Path) -> None:
    """ENOSPC mid-recording: one error line naming repair, exit 1, no traceback."""
    with tiny_filesystem(tmp_path / "fs", "48k") as fs:
        recorder = start_node(spawn, "recorder_node", {"path": str(fs / "bag"), "scene": "lecture_constant"})
        recorder.wait_for(r"recording \d+ topics", timeout=60)
        run_probe(spawn, {"wait_subscribers": 1, "feed": [[0.001 * i, 0.1] for i in range(1, 1500)]}, 120)
        try:
            code = recorder.finish(timeout=20)
        except Exception:  # still running: the disk did not fill; stop it and report below
            recorder.proc.send_signal(signal.SIGINT)
            code = recorder.finish(timeout=30)
        assert "Traceback" not in recorder.text, recorder.text
        errors = [line for line in recorder.text.splitlines() if "cannot write the bag" in line]
        assert len(errors) == 1 and "pendulum-accel repair" in errors[0], recorder.text
        assert code == 1


_NODES = ("simulator_node", "estimator_node", "recorder_node", "player_node")


@pytest.mark.parametrize("module", _NODES)
@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--params-file", "/nonexistent/params.yaml"], "cannot read the parameters file"),
        (["--params-file", "{BAD_YAML}"], "is not valid YAML"),
        (["--params-file", "{LIST_YAML}"], "must map node names"),
        (["-p", "scene:=[1,"], "the value is not valid YAML"),
        (["-p", "scene"], "must read name:=value"),
    ],
    ids=["missing-file", "malformed-file", "not-a-mapping", "bad-value", "no-assignment"],
)
def test_bad_ros_arguments_are_one_line_and_exit_2(
    spawn: Spawn, tmp_path: Path, module: str, args: list[str], expected: str
) -> None:
    """A missing or malformed --params-file, or a bad -p rule: one error line, exit 2, no traceback
    (rcl would otherwise raise RCLError from rclpy.init after logging its own line)."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("pendulum_sim: {ros__parameters: [scene\n")
    listed = tmp_path / "list.yaml"
    listed.write_text("- scene\n")
    argv = [a.replace("{BAD_YAML}", str(bad)).replace("{LIST_YAML}", str(listed)) for a in args]
    proc = spawn([PYTHON, "-m", f"pendulum_accel.nodes.{module}", "--ros-args", *argv])
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, (out, err)
    lines = [line for line in (out + err).splitlines() if line.strip()]
    assert len(lines) == 1 and "error:" in lines[0] and expected in lines[0], lines
