"""A scene's motion that cannot be read, refused in one line by every command that loads a scene, before it
starts anything: speeds or time steps of 1e300, a cut-off of 1e-100 Hz, a bag topic with no messages, and a
FIFO where a bag, an .mcap file, a metadata.yaml or a CSV should be (never opened, so nothing hangs).

Each hostile profile replaces lecture_constant's acceleration. {ws} is the workspace of the fixture below.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from test.conftest import cli
from test.refusal import error_line

HOSTILE_PROFILES: dict[str, tuple[str, str]] = {
    "speeds_1e300": ("{type: speed_csv, path: huge.csv, units: m/s}", "varies too fast to tabulate"),
    "steps_1e300": ("{type: speed_csv, path: slow.csv, units: m/s}", "out of floating-point range"),
    "speed_cutoff_1e-100": (
        "{type: speed_csv, path: ramp.csv, units: m/s, cutoff_hz: 1.0e-100}",
        "cutoff_hz must be at least 0.0005 Hz",
    ),
    "speed_cutoff_0": (
        "{type: speed_csv, path: ramp.csv, units: m/s, cutoff_hz: 0}",
        "cutoff_hz must be > 0 Hz",
    ),
    "speed_cutoff_negative": (
        "{type: speed_csv, path: ramp.csv, units: m/s, cutoff_hz: -1}",
        "cutoff_hz must be > 0 Hz",
    ),
    "accel_cutoff_1e-100": (
        "{type: accel_csv, path: ramp.csv, cutoff_hz: 1.0e-100}",
        "cutoff_hz must be at least 0.0005 Hz",
    ),
    "empty_topic": ("{type: bag_topic, path: empty, topic: /odom}", "topic /odom has no messages"),
    "fifo_bag": ("{type: bag_topic, path: fifo.bag, topic: /odom}", "fifo.bag is a FIFO (named pipe)"),
    "fifo_mcap": ("{type: bag_topic, path: fifo.mcap, topic: /odom}", "fifo.mcap is a FIFO (named pipe)"),
    "fifo_in_bag_dir": ("{type: bag_topic, path: fifo_dir, topic: /odom}", "metadata.yaml is a FIFO"),
    "fifo_speed_csv": ("{type: speed_csv, path: fifo.csv, units: m/s}", "a FIFO (named pipe), not a text"),
    "fifo_accel_csv": ("{type: accel_csv, path: fifo.csv}", "a FIFO (named pipe), not a text file"),
}
PROFILE_COMMANDS = [
    "simulate {scene}",
    "generate {scene} --out {ws}/b",
    "scenes {scene}",
    "allan {scene}",
    "animate {scene} --out {ws}/a.gif",
    "sweep {scene} --length 1,2",
    "run {scene}",
]


@pytest.fixture(scope="module")
def hostile_profiles(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A scene file per HOSTILE_PROFILES entry, beside the data files, FIFOs and bags they name."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ws = tmp_path_factory.mktemp("hostile_profiles")
    steps = [float(k) for k in range(20)]
    rows = {
        "huge.csv": [(t, 1e300 * (k % 2)) for k, t in enumerate(steps)],  # speeds of 1e300, alternating
        "slow.csv": [(1e300 * t, 1.0 + t) for t in steps],  # one sample every 1e300 s
        "ramp.csv": [(t, 1.0 + t) for t in steps],
    }
    for name, pairs in rows.items():
        (ws / name).write_text("t,v\n" + "".join(f"{t!r},{v!r}\n" for t, v in pairs))
    for name in ("fifo.bag", "fifo.mcap", "fifo.csv"):
        os.mkfifo(ws / name)
    (ws / "fifo_dir").mkdir()
    os.mkfifo(ws / "fifo_dir" / "metadata.yaml")
    with Writer(ws / "empty", version=9) as writer:  # /odom declared, never written
        writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=get_typestore(Stores.ROS2_HUMBLE))
    text = cli("scenes", "lecture_constant").stdout
    start, end = text.index("acceleration:"), text.index("sensor:")
    scenes = {}
    for name, (profile, _) in HOSTILE_PROFILES.items():
        scenes[name] = ws / f"{name}.yaml"
        scenes[name].write_text(text[:start] + f"acceleration: {profile}\n" + text[end:])
    return scenes


@pytest.mark.parametrize("command", PROFILE_COMMANDS, ids=[c.split()[0] for c in PROFILE_COMMANDS])
@pytest.mark.parametrize("case", list(HOSTILE_PROFILES))
def test_a_hostile_profile_is_one_line_in_every_command(
    hostile_profiles: dict[str, Path],
    case: str,
    command: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
) -> None:
    """Speeds of 1e300, time steps of 1e300, a cut-off of 1e-100, 0 or -1 Hz, a topic with no messages, a
    FIFO for a bag or a CSV: one line, exit 2, no traceback and no hang, nothing written."""
    from pendulum_accel.cli.main import main

    scene = hostile_profiles[case]
    argv = [w.format(scene=scene, ws=tmp_path) for w in command.split(" ")]
    monkeypatch.chdir(tmp_path)
    returned = main(argv)
    error_line(returned, capsys.readouterr().err, HOSTILE_PROFILES[case][1])
    assert list(tmp_path.iterdir()) == []
