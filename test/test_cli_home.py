"""A ``~`` after ``--option=`` is the home directory, as a shell makes it of ``--option ~/x``."""

from __future__ import annotations

from pathlib import Path

import pytest

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import expand_home_values, main


def test_values_after_an_equals_sign_expand_and_nothing_else_does(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """--opt=~ and --opt=~/x expand; a ~ inside a value, a positional or a short option is left as given."""
    monkeypatch.setenv("HOME", str(tmp_path))
    argv = ["run", "--record=~/bags/a", "--out=~", "--set=x~y", "~/scene.yaml", "-o=~/z", "--record", "~/q"]
    assert expand_home_values(argv) == [
        "run",
        f"--record={tmp_path}/bags/a",
        f"--out={tmp_path}",
        "--set=x~y",
        "~/scene.yaml",
        "-o=~/z",
        "--record",
        "~/q",
    ]


def test_generate_writes_its_bag_under_home(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """``generate step_start --out=~/b`` writes HOME/b and no directory named ``~``."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(tmp_path)
    assert main(["generate", "step_start", "--out=~/b"]) == 0
    assert not (tmp_path / "~").exists()
    assert read_bag(home / "b").message_count > 0  # a readable bag with messages, where the user asked
