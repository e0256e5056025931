"""Every refusal writes nothing: the red-team table of output paths, hostile scene inputs and foreign data.

Each row: a command line (placeholders below), a fragment of its one error line, its exit code. Rows run
in-process (main(argv)) from a scratch directory: an exception other than the package's own propagates
and fails the row, as a traceback would. The scratch directory and the workspace must be as they were
afterwards: nothing is written outside the path asked for, not even on refusal.
  {ws}  a workspace: {ws}/afile (a file), {ws}/adir (a directory), {ws}/ro (a read-only tmpfs),
        {ws}/fifo.yaml (a FIFO), {ws}/dir.yaml (a directory), {ws}/missing (absent)
  {bag} a small generated bag; {elbow}, {moving}, {odom}, {est_odom}: copies carrying foreign data
  {huge_FIELD}: lecture_constant with sensor FIELD at 1e300 (bias_random_walk 1e307)
docs/hostile_inputs.md lists the messages.
"""

from __future__ import annotations

import copy
import itertools
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pendulum_accel.bag import messages as bm
from pendulum_accel.recording.generate import generate_bag
from test.bag_edits import rewritten
from test.conftest import cli
from test.refusal import error_line
from test.tiny_filesystem import tiny_filesystem

HUGE_SENSOR = {
    "noise_density": 1e300,
    "bias_stddev": 1e300,
    "dynamic_bias_stddev": 1e300,
    "bias_mean": 1e300,
    "bias_random_walk": 1e307,
}

RED_TEAM: list[tuple[str, str, int]] = [
    # output paths, file outputs
    ("simulate --out {ws}/ro/x.csv", "is not writable", 2),
    ("simulate --out {ws}/adir", "is a directory; give a file name; nothing written", 2),
    ("simulate --out {ws}/afile/x.csv", "is not a directory", 2),
    ("simulate --out {ws}/x.txt", "must end in .csv", 2),
    ("simulate --out {ws}/missing/x.csv", "does not exist (it is not created", 2),
    # The suffix says the format, devices included: /dev/full is refused by its name, before the run.
    ("simulate --out /dev/full", "must end in .csv; nothing written", 2),
    ("simulate --plot {ws}/ro/x.png", "is not writable", 2),
    ("simulate --plot {ws}/x.jpg", "must end in .png", 2),
    ("sweep at_rest --length 1,2 --out {ws}/ro/s.csv", "is not writable", 2),
    ("sweep at_rest --length 1,2 --out {ws}/adir", "is a directory", 2),
    ("sweep at_rest --length 1,2 --plot {ws}/s.svg", "must end in .png", 2),
    ("sweep at_rest --length 1,2 --plot {ws}/missing/s.png", "does not exist", 2),
    ("lecture equilibrium --plot {ws}/ro/x.png", "is not writable", 2),
    ("lecture equilibrium --plot {ws}/afile/x.png", "is not a directory", 2),
    ("lecture equilibrium --plot {ws}/x.pdf", "must end in .png", 2),
    ("lecture equilibrium --plot-dir {ws}/missing", "does not exist", 2),
    ("analyze {bag} --plot {ws}/ro/a.png", "is not writable", 2),
    ("analyze {bag} --plot {ws}/adir", "is a directory", 2),
    ("analyze {bag} --plot {ws}/afile/a.png", "is not a directory", 2),
    ("analyze {bag} --plot {ws}/a.jpg", "must end in .png", 2),
    ("allan {bag} --plot {ws}/ro/a.png", "is not writable", 2),
    ("animate {bag} --out {ws}/ro/a.gif", "is not writable", 2),
    ("animate {bag} --out {ws}/a.png", "must end in .gif or .mp4", 2),
    ("animate {bag} --out {ws}/adir", "is a directory", 2),
    ("animate {bag} --out {ws}/missing/a.gif", "does not exist", 2),
    ("animate {bag} --out /dev/full", "must end in .gif or .mp4", 2),
    # output paths, directory outputs
    ("export {bag} --out ", "--out is empty", 2),
    ("export {bag} --out {ws}/afile", "is not a directory", 2),
    ("export {bag} --out {ws}/afile/sub", "is not a directory", 2),
    ("export {bag} --out {ws}/ro/t", "is not writable", 2),
    ("export {bag} --out {ws}/missing/t", "does not exist", 2),
    ("export {bag} --out /dev/full", "is not a directory", 2),
    ("generate lecture_constant --out {ws}/ro/b", "is not writable", 2),
    ("generate lecture_constant --out {ws}/afile", "is not a directory", 2),
    ("generate lecture_constant --out {ws}/missing/b", "does not exist", 2),
    ("generate lecture_constant --out /dev/full", "is not a directory", 2),
    ("generate lecture_constant --out {ws}/b --duration 1000", "lecture_constant lasts 20 s", 2),
    # analysis options out of range: refused before the estimator allocates anything
    ("analyze {bag} --lag 1e300", "longer than the recording", 2),
    ("analyze {bag} --lag inf", "lag must be a finite number", 2),
    # hostile scene inputs
    *[(f"simulate {{huge_{name}}}", f"sensor.{name} must be in [", 2) for name in HUGE_SENSOR],
    *[(f"generate {{huge_{name}}} --out {{ws}}/b", f"sensor.{name} must be in [", 2) for name in HUGE_SENSOR],
    ("simulate {ws}/fifo.yaml", "a FIFO (named pipe), not a text file", 2),
    ("simulate {ws}/dir.yaml", "a directory, not a text file", 2),
    ("simulate /proc/self/mem", "cannot read scene file", 2),  # unreadable even for root (EIO)
    ("repair {ws}/adir", ".mcap", 2),
    # foreign data, refused offline as the estimator node refuses it online
    *[
        (f"{command} {{{bag}}}{tail}", fragment, 2)
        for bag, fragment in (
            ("elbow", "names joint(s) 'elbow_joint', not 'pendulum_joint'"),
            ("moving", "'pendulum_joint' is at places [0, 1] among the joints of different messages"),
            ("odom", "/pendulum/joint_states messages are not the pendulum chain's (frame_id 'odom'"),
            ("est_odom", "/car/accel/estimate messages are not the pendulum chain's (frame_id 'odom'"),
        )
        for command, tail in (
            ("analyze", ""),
            ("allan", ""),
            ("export", " --out {ws}/t"),
            ("animate", " --out {ws}/a.gif"),
        )
    ],
]


def _joints(names: list[str]) -> Callable[[Any], None]:
    """Edit: the JointState names ``names``, its positions and velocities repeated to their number."""

    def edit(msg: Any) -> None:
        """In place."""
        msg.name = names
        msg.position = np.resize(msg.position, len(names))
        msg.velocity = np.resize(msg.velocity, len(names))

    return edit


def _moving_joint() -> Callable[[Any], None]:
    """Edit: the pendulum's joint first in one message and second, after elbow_joint, in the next (a robot
    whose joint order changes: the offline commands read one place, so they refuse it)."""
    count = itertools.count()

    def edit(msg: Any) -> None:
        """In place."""
        names = [bm.PENDULUM_JOINT, "elbow_joint"]
        _joints(names[::-1] if next(count) % 2 else names)(msg)

    return edit


def _frame(frame_id: str) -> Callable[[Any], None]:
    """Edit: header.frame_id = ``frame_id``."""

    def edit(msg: Any) -> None:
        """In place."""
        msg.header.frame_id = frame_id

    return edit


@pytest.fixture(scope="module")
def red_team(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, str]]:
    """The placeholders of RED_TEAM, made real (the read-only tmpfs is unmounted at the end)."""
    base = tmp_path_factory.mktemp("red_team")
    ws = base / "ws"
    ws.mkdir()
    (ws / "afile").write_text("a file\n")
    (ws / "adir").mkdir()
    (ws / "dir.yaml").mkdir()
    os.mkfifo(ws / "fifo.yaml")
    bags = base / "bags"
    bags.mkdir()
    generate_bag("lecture_constant", bags / "bag", duration=2.0)
    places = {"ws": str(ws), "bag": str(bags / "bag")}
    for name, topic, edit in (
        ("elbow", bm.TOPIC_JOINT_STATES, _joints(["elbow_joint"])),
        ("moving", bm.TOPIC_JOINT_STATES, _moving_joint()),
        ("odom", bm.TOPIC_JOINT_STATES, _frame("odom")),
        ("est_odom", bm.TOPIC_ACCEL_ESTIMATE, _frame("odom")),
    ):
        places[name] = str(rewritten(bags / "bag", bags / name, topic, edit))
    scene = yaml.safe_load(cli("scenes", "lecture_constant").stdout)
    for name, value in HUGE_SENSOR.items():
        doc = copy.deepcopy(scene)
        doc["sensor"][name] = value
        if name == "noise_density":
            doc["sensor"].pop("noise_std", None)  # one or the other
        if name == "dynamic_bias_stddev":
            doc["sensor"]["dynamic_bias_correlation_time"] = 1.0  # needed with it
        path = bags / f"huge_{name}.yaml"
        path.write_text(yaml.safe_dump(doc))
        places[f"huge_{name}"] = str(path)
    with tiny_filesystem(ws / "ro", "64k", "ro"):
        yield places


def _tree(root: Path) -> set[str]:
    """Every path under ``root`` (the read-only mount's inside included), relative."""
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.parametrize(("line", "fragment", "code"), RED_TEAM, ids=[row[0] for row in RED_TEAM])
def test_red_team_case_is_one_line(
    red_team: dict[str, str],
    line: str,
    fragment: str,
    code: int,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from pendulum_accel.cli.main import main

    words = line.split(" ")
    argv = [word.format(**red_team) for word in words]
    ws = Path(red_team["ws"])
    before = _tree(ws)
    monkeypatch.chdir(tmp_path)
    try:
        returned = main(argv)
    except SystemExit as exit_:  # argparse
        returned = int(exit_.code or 0)
    err = capsys.readouterr().err
    assert returned == code, err
    error_line(returned, err, fragment)
    assert _tree(ws) == before  # nothing written in the workspace, even inside the path asked for
    assert list(tmp_path.iterdir()) == []  # nor in the working directory (``export --out ""``)
