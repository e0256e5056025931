"""A real sensor names its joint its own way: ``--joint NAME`` (the offline commands) and the estimator
node's ``joint`` parameter read the pendulum's angle by that name, the rule the chain applies to
``pendulum_joint``. Without it, such angles are refused in one line that says how to read them. A fleet
table applies --joint, --topic and --namespace to every bag (it ignored them before). The estimator's input
guard applies the same rule to each message: another joint or frame is dropped, counted and reported."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.writer import BagWriter
from pendulum_accel.estimators.guard import Decision, GuardState, InputGuard
from pendulum_accel.recording.generate import generate_bag
from test.bag_edits import rewritten
from test.conftest import cli, strict_json

JOINT = "encoder"


def _renamed(source: Path, out: Path, names: list[str], frame: str | None = None) -> Path:
    """``source`` rewritten with its angles naming ``names`` (the pendulum's value on the one named JOINT,
    0 on the others) and stamped in ``frame`` (None: as they were), every other message as it was."""

    def edit(msg: Any) -> None:
        """In place."""
        theta, rate = float(msg.position[0]), float(msg.velocity[0])
        msg.name = names
        msg.position = np.array([theta if n == JOINT else 0.0 for n in names])
        msg.velocity = np.array([rate if n == JOINT else 0.0 for n in names])
        if frame is not None:
            msg.header.frame_id = frame

    return rewritten(source, out, bm.TOPIC_JOINT_STATES, edit)


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the chain's step_start bag over 4 s, the same with its angles naming JOINT only)."""
    root = tmp_path_factory.mktemp("joint")
    generate_bag("step_start", root / "chain", duration=4.0)
    return root / "chain", _renamed(root / "chain", root / "fleet" / "sensor", [JOINT])


@pytest.mark.slow
def test_analyze_reads_a_named_joint_as_the_pendulum(bags: tuple[Path, Path]) -> None:
    chain, sensor = bags
    refused = cli("analyze", str(sensor))
    assert refused.returncode == 2 and refused.stdout == ""
    line = refused.stderr.strip()
    assert "\n" not in line and "Traceback" not in line
    assert f"names joint(s) '{JOINT}', not 'pendulum_joint'" in line and "--joint NAME" in line
    got = cli("analyze", str(sensor), "--joint", JOINT, "--json")
    assert got.returncode == 0, got.stderr
    want = cli("analyze", str(chain), "--json")
    figures, expected = strict_json(got.stdout), strict_json(want.stdout)
    figures.pop("bag"), expected.pop("bag")
    assert figures == expected  # the same angles, read by name: the same computation
    for command in (["export", "--out", str(sensor.parent.parent / "tables")], ["allan"]):
        assert cli(command[0], str(sensor), *command[1:]).returncode == 2
        done = cli(command[0], str(sensor), *command[1:], "--joint", JOINT)
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr


@pytest.mark.slow
def test_the_named_joint_is_read_at_its_place_among_a_robots_joints(
    bags: tuple[Path, Path], tmp_path: Path
) -> None:
    """A robot's aggregated JointState with the pendulum's joint second: the offline commands read it at
    its place (position[1]) and give the chain's own figures (they refused it: "not the first joint").
    Its place changing between messages is refused in one line, saying why."""
    chain, _ = bags
    mixed = _renamed(chain, tmp_path / "mixed", ["wheel", JOINT])
    got = cli("analyze", str(mixed), "--joint", JOINT, "--json")
    assert got.returncode == 0, got.stderr
    figures, expected = strict_json(got.stdout), strict_json(cli("analyze", str(chain), "--json").stdout)
    figures.pop("bag"), expected.pop("bag")
    assert figures == expected  # the same angles, read at their place: the same computation
    for command in (["allan"], ["export", "--out", str(tmp_path / "tables")]):
        done = cli(command[0], str(mixed), *command[1:], "--joint", JOINT)
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    swapped = _renamed(chain, tmp_path / "swapped", [JOINT, "wheel"])  # the same joints, other order
    refused = cli("analyze", str(_alternated(mixed, swapped, tmp_path / "alternated")), "--joint", JOINT)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert f"'{JOINT}' is at places [0, 1] among the joints of different messages" in refused.stderr


def _alternated(first: Path, second: Path, out: Path) -> Path:
    """``first`` with every other angle taken from ``second`` (the same stamps, another joint order)."""
    a, b = read_bag(first), read_bag(second)
    others = iter(b.raw_payloads(bm.TOPIC_JOINT_STATES))
    with BagWriter(out, custom_data=a.custom_data) as writer:
        for name, info in a.topics.items():
            writer.add_topic(name, info.msgtype)
        k = 0
        for topic, ns, data in a.iter_raw():
            if topic == bm.TOPIC_JOINT_STATES:
                other = next(others)
                data = other if k % 2 else data
                k += 1
            writer.write(topic, ns, data)
    return out


@pytest.mark.slow
def test_a_sensor_stamping_its_own_frame_is_read_with_joint_frame(
    bags: tuple[Path, Path], tmp_path: Path
) -> None:
    """A real sensor's driver stamps its JointState in its own frame (here pan_link): refused in one line
    that names --joint-frame, and read with it as the chain's own angles (the same figures); the chain's
    base_link and an empty frame stay accepted without it."""
    chain, _ = bags
    own = _renamed(chain, tmp_path / "own", [JOINT], frame="pan_link")
    refused = cli("analyze", str(own), "--joint", JOINT)
    line = refused.stderr.strip()
    assert refused.returncode == 2 and "\n" not in line and "Traceback" not in line
    assert "(frame_id 'pan_link', not 'base_link')" in line and "--joint-frame FRAME" in line
    assert "--joint NAME" not in line  # the joint was found: only the frame is at fault
    got = cli("analyze", str(own), "--joint", JOINT, "--joint-frame", "pan_link", "--json")
    assert got.returncode == 0, got.stderr
    figures, expected = strict_json(got.stdout), strict_json(cli("analyze", str(chain), "--json").stdout)
    figures.pop("bag"), expected.pop("bag")
    assert figures == expected
    bare = _renamed(chain, tmp_path / "bare", [JOINT], frame="")
    assert cli("analyze", str(bare), "--joint", JOINT, "--joint-frame", "pan_link").returncode == 0
    assert cli("analyze", str(chain), "--joint-frame", "pan_link").returncode == 2  # base_link is not it


def test_an_empty_joint_name_is_refused(bags: tuple[Path, Path]) -> None:
    chain, _ = bags
    refused = cli("analyze", str(chain), "--joint", "")
    assert refused.returncode == 2 and "--joint must name the pendulum's joint" in refused.stderr


@pytest.mark.slow
def test_a_fleet_table_applies_joint_topic_and_namespace_to_every_bag(bags: tuple[Path, Path]) -> None:
    chain, sensor = bags
    fleet = sensor.parent
    _renamed(chain, fleet / "sensor2", [JOINT])
    out = fleet.parent / "table.csv"

    refused = cli("analyze", str(fleet), "--out", str(out))
    assert refused.returncode == 1
    rows = pd.read_csv(out, keep_default_na=False)
    assert len(rows) == 2 and all("--joint NAME" in e for e in rows["error"])
    done = cli("analyze", str(fleet), "--out", str(out), "--joint", JOINT)
    assert done.returncode == 0, done.stderr
    rows = pd.read_csv(out, keep_default_na=False)
    assert len(rows) == 2 and set(rows["error"]) == {""}
    single = strict_json(cli("analyze", str(sensor), "--joint", JOINT, "--json").stdout)
    assert rows["rms"].tolist() == [single["rms"]] * 2  # CSV keeps the float's shortest repr
    asked = cli("analyze", str(fleet), "--out", str(out), "--joint", JOINT, "--namespace", "car7")
    assert asked.returncode == 1
    rows = pd.read_csv(out, keep_default_na=False)
    assert all("--namespace car7: the bag has no topic under /car7/" in e for e in rows["error"])


def test_a_foreign_joint_is_dropped_counted_and_reported() -> None:
    guard = InputGuard(rate_hz=100.0)
    assert guard.check(0.0, 0.1, names=["elbow_joint"]) is Decision.DROP
    assert guard.check(0.01, 0.1, names=[bm.PENDULUM_JOINT]) is Decision.ACCEPT
    # Extra joints: a robot's aggregated JointState; θ is the pendulum's by name, the others are counted.
    assert guard.check(0.02, 0.1, names=["wheel", bm.PENDULUM_JOINT, "arm"]) is Decision.ACCEPT
    assert guard.ignored_joints == 2
    assert guard.check(0.03, 0.1, names=[bm.PENDULUM_JOINT], frame_id="odom") is Decision.DROP
    assert guard.check(0.04, 0.1, names=[bm.PENDULUM_JOINT], frame_id=bm.FRAME_ID) is Decision.ACCEPT
    assert guard.check(0.05, 0.1, names=[bm.PENDULUM_JOINT], frame_id="") is Decision.ACCEPT
    assert guard.check(0.06, 0.1) is Decision.ACCEPT  # a bare angle, no names
    report = guard.report()
    assert report.state is GuardState.ERROR and "odom" in report.message
    assert dict(report.values)["dropped_wrong_joint"] == "2"
    assert dict(report.values)["ignored_joints"] == "2"
    assert guard.accepted == 5


def test_a_sensor_frame_is_accepted_only_where_it_is_named() -> None:
    """joint_frame (the node's joint_frame_id): a real sensor's own frame is accepted in place of base_link,
    and an empty frame still is; base_link then is another frame."""
    guard = InputGuard(rate_hz=100.0, joint_frame="pan_link")
    assert guard.check(0.0, 0.1, names=[bm.PENDULUM_JOINT], frame_id="pan_link") is Decision.ACCEPT
    assert guard.check(0.01, 0.1, names=[bm.PENDULUM_JOINT], frame_id="") is Decision.ACCEPT
    assert guard.check(0.02, 0.1, names=[bm.PENDULUM_JOINT], frame_id=bm.FRAME_ID) is Decision.DROP
    report = guard.report()
    assert report.state is GuardState.ERROR
    assert "frame_id 'base_link', not 'pan_link'" in report.message


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(max_size=30).filter(lambda s: s != bm.PENDULUM_JOINT), min_size=1, max_size=5))
def test_any_name_list_without_the_pendulum_joint_is_dropped(names: list[str]) -> None:
    guard = InputGuard(rate_hz=100.0)
    assert guard.check(0.0, 0.1, names=names) is Decision.DROP
    assert guard.dropped_wrong_joint == 1 and guard.accepted == 0
