"""Hostile battery, ROS part: the recorder node on a disk that fills up while it records."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from test.chain_helpers import run_probe, start_node
from test.conftest import Spawn
from test.test_hostile_inputs import _tiny_filesystem

pytestmark = pytest.mark.ros


def test_recorder_on_a_full_disk_stops_with_one_line(spawn: Spawn, tmp_path: Path) -> None:
    """ENOSPC mid-recording: one error line naming repair, exit 1, no traceback."""
    with _tiny_filesystem(tmp_path / "fs", "48k") as fs:
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
