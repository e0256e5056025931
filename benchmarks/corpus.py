"""The real-motion corpus: every profile the benchmarks fit on (train) or report on (validate), by kind.

Each entry is a bundled scene's a(t), optionally cut to a window, with the recording it comes from, so a
split can hold out whole recordings. Sources, licences and conversions: scenes/real_motion/README.md.

- car (a speed trace): train udds_p1, bus_1; validate hwfet, udds_p2, comma2k19_speed, bus_2.
- robot (wheel odometry): train husky_1, f1tenth_ds1, f1tenth_ds3, jackal (simulated); validate husky_2,
  f1tenth_ds2, f1tenth_ds4, f1tenth_ds5.
- accel_table (a logged IMU, accel_csv): train husky_imu_1, f1tenth_ds1_imu, phone_trip1; validate
  husky_imu_2, f1tenth_ds5_imu, comma2k19_imu, phone_trip2.
- lab (made up): train stop_and_go, step; validate braking.

Held out whole: the F1TENTH runs DS2, DS4, DS5 (their odometry and IMU), the comma2k19 minute (its CAN
speed and IMU), the dashboard phone's return trip and HWFET; no part of them is in training. The Husky's
one drive, the UDDS and the bus ride are split in time (train on the first part, validate on the rest),
as the benchmark did for the first two before the corpus grew. The Jackal is a Gazebo simulation (its
bag's stamps are simulation time), so it trains and is never reported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from pendulum_accel import load_scene
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.profiles import AccelProfile, Braking, Step

SCENES_DIR = Path(__file__).resolve().parents[1] / "pendulum_accel" / "scenes"
KINDS = ("car", "robot", "accel_table", "lab")
SPLITS = ("train", "validate")


@dataclass(frozen=True)
class Entry:
    """One corpus profile: its a(t) (built on demand), kind, split, recording, and duration (s)."""

    name: str
    kind: str  # one of KINDS
    split: str  # "train" or "validate"
    recording: str  # entries of one recording share it; a held-out recording has no train entry
    duration: float
    build: Callable[[], AccelProfile] = field(compare=False, repr=False)
    scene: str | None = None  # the bundled scene whose a(t) this is, None for a made-up profile
    start: float | None = None
    end: float | None = None


def window(scene: str, start: float | None = None, end: float | None = None) -> Callable[[], AccelProfile]:
    """A builder of bundled scene ``scene``'s profile cut to [start, end] s (the window is cut from the
    spline of its gap-free stretch, up to spline_margin beyond it, so it adds no end effects of its own),
    as the scene's YAML states it."""

    def build() -> AccelProfile:
        spec = dict(
            yaml.safe_load((SCENES_DIR / f"{scene}.yaml").read_text(encoding="utf-8"))["acceleration"]
        )
        if start is not None:
            spec["start"] = start
        if end is not None:
            spec["end"] = end
        return profile_from_dict(spec, SCENES_DIR)

    return build


def whole(scene: str) -> Callable[[], AccelProfile]:
    """A builder of bundled scene ``scene``'s acceleration profile."""
    return lambda: load_scene(scene).profile


def _scene_entry(
    name: str, kind: str, split: str, recording: str, scene: str, duration: float,
    start: float | None = None, end: float | None = None,
) -> Entry:  # fmt: skip
    """An entry of bundled scene ``scene``, whole or cut to [start, end]."""
    build = whole(scene) if start is None and end is None else window(scene, start, end)
    return Entry(name, kind, split, recording, duration, build, scene, start, end)


CORPUS: tuple[Entry, ...] = (
    # train
    _scene_entry("udds_p1", "car", "train", "udds", "udds", 505.0, 0.0, 505.0),
    _scene_entry("bus_1", "car", "train", "bus", "bus_gps_speed", 300.0, 0.0, 300.0),
    _scene_entry("husky_1", "robot", "train", "husky", "husky_odom", 195.0, 0.0, 195.0),
    _scene_entry("f1tenth_ds1", "robot", "train", "f1tenth_ds1", "f1tenth_ds1_odom", 43.0),
    _scene_entry("f1tenth_ds3", "robot", "train", "f1tenth_ds3", "f1tenth_ds3_odom", 126.0),
    _scene_entry("jackal", "robot", "train", "jackal_sim", "jackal_odom", 61.0),
    _scene_entry("husky_imu_1", "accel_table", "train", "husky", "husky_imu", 195.0, 0.0, 195.0),
    _scene_entry("f1tenth_ds1_imu", "accel_table", "train", "f1tenth_ds1", "f1tenth_ds1_imu", 43.0),
    _scene_entry("phone_trip1", "accel_table", "train", "phone_trip1", "phone_corolla_trip1", 355.0),
    _scene_entry("stop_and_go", "lab", "train", "stop_and_go", "stop_and_go", 30.0),
    Entry("step", "lab", "train", "step", 20.0, lambda: Step(8.0, 0.0, 3.0)),
    # validate
    _scene_entry("hwfet", "car", "validate", "hwfet", "hwfet", 765.0),
    _scene_entry("udds_p2", "car", "validate", "udds", "udds", 864.0, 505.0, 1369.0),
    _scene_entry("comma2k19_speed", "car", "validate", "comma2k19", "comma2k19_speed", 59.0),
    _scene_entry("bus_2", "car", "validate", "bus", "bus_gps_speed", 298.0, 300.0, 598.0),
    _scene_entry("husky_2", "robot", "validate", "husky", "husky_odom", 195.0, 200.0, 395.0),
    _scene_entry("f1tenth_ds2", "robot", "validate", "f1tenth_ds2", "f1tenth_ds2_odom", 115.0),
    _scene_entry("f1tenth_ds4", "robot", "validate", "f1tenth_ds4", "f1tenth_ds4_odom", 112.0),
    _scene_entry("f1tenth_ds5", "robot", "validate", "f1tenth_ds5", "f1tenth_ds5_odom", 56.0),
    _scene_entry("husky_imu_2", "accel_table", "validate", "husky", "husky_imu", 195.0, 200.0, 395.0),
    _scene_entry("f1tenth_ds5_imu", "accel_table", "validate", "f1tenth_ds5", "f1tenth_ds5_imu", 56.0),
    _scene_entry("comma2k19_imu", "accel_table", "validate", "comma2k19", "comma2k19_imu", 59.0),
    _scene_entry("phone_trip2", "accel_table", "validate", "phone_trip2", "phone_corolla_trip2", 357.0),
    Entry("braking", "lab", "validate", "braking", 20.0, lambda: Braking(14.0, 4.0, 6.0)),
)
"""Every corpus profile, train first. Real recordings in validation: robots husky_2 and F1TENTH DS2, DS4,
DS5; acceleration tables husky_imu_2, f1tenth_ds5_imu, comma2k19_imu, phone_trip2; cars hwfet, udds_p2,
comma2k19_speed, bus_2 (a GPS speed)."""

SPLIT_IN_TIME = ("udds", "husky", "bus")
"""Recordings split in time rather than held out whole (their train and validate windows do not overlap)."""


def entries(split: str | None = None, kind: str | None = None) -> tuple[Entry, ...]:
    """The CORPUS entries of ``split`` and ``kind`` (None: any)."""
    return tuple(
        e for e in CORPUS if (split is None or e.split == split) and (kind is None or e.kind == kind)
    )
