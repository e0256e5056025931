"""A real-motion profile spec read as the Table it is: shared by the speed-trace, speed_csv, CSV-layout and
bag_topic tests."""

from __future__ import annotations

from pathlib import Path

from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.profiles import Table


def table_of(spec: dict[str, object], base_dir: Path | None = None) -> Table:
    """profile_from_dict(spec), which for every real-motion type is a Table."""
    profile = profile_from_dict(spec, base_dir=base_dir)
    assert isinstance(profile, Table)
    return profile
