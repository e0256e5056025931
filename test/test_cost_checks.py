"""Work that would take hours, or arrays larger than memory, is refused with its cost before it starts: a
plan's step count (planner.py), a sweep's trajectory-steps and bytes (sweep.py), a run's sample count
(sensor.py). Each refusal is one line (exit 2, no traceback) naming what it would have cost."""

from __future__ import annotations

from pathlib import Path

import pytest

from test.conftest import cli
from test.refusal import one_line_error


def _scene_with(tmp_path: Path, old: str, new: str, scene: str = "lecture_constant") -> Path:
    """A copy of a bundled scene with one text replacement, in tmp_path."""
    text = cli("scenes", scene).stdout
    assert old in text
    path = tmp_path / "scene.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_forced_euler_at_a_tight_target_is_refused_with_its_cost(tmp_path: Path) -> None:
    text = cli("scenes", "step_start").stdout.replace("max_angle_error: 1.0e-06", "max_angle_error: 1.0e-12")
    scene = tmp_path / "euler.yaml"
    scene.write_text(text + "force:\n  model: rigid\n  method: euler\n")
    one_line_error(cli("simulate", str(scene), timeout=60), "needs", "steps", "euler")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("simulate", "--dt", "1e-12"), ("needs", "steps")),
        (("sweep", "lecture_constant", "--length", "1,2", "--dt", "1e-9"), ("trajectory-steps",)),
        (("sweep", "lecture_constant", "--length", "0.5:1:1000000"), ("GiB",)),
    ],
)
def test_huge_work_is_refused_before_it_starts(args: tuple[str, ...], words: tuple[str, ...]) -> None:
    one_line_error(cli(*args, timeout=60), *words)


def test_a_huge_duration_is_one_line(tmp_path: Path) -> None:
    scene = _scene_with(tmp_path, "duration: 20.0", "duration: 1.0e+308")
    one_line_error(cli("simulate", str(scene)), "samples")
    one_line_error(cli("sweep", "at_rest", "--length", "1", "--duration", "1e308"), "samples")
