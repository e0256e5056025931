"""Every profile type a scene's ``acceleration:`` may name, its fields, and ``profile_from_dict``.

The made-up profiles (constant, step, ...) are built here from their fields; the real-motion ones are
read by their modules (speed_trace, accel_log, bag_topic). Each becomes a ``physics.profiles`` type.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.accel_log import accel_csv_profile, csv_table
from pendulum_accel.motion_input.bag_topic import bag_topic_profile
from pendulum_accel.motion_input.fields import field_number, field_numbers, field_path
from pendulum_accel.motion_input.speed_trace import speed_profile
from pendulum_accel.physics.profiles import AccelProfile, Braking, Constant, Ramp, Sinusoid, Step, Table

_FIELDS: dict[str, tuple[type[AccelProfile], tuple[str, ...], tuple[str, ...]]] = {
    # kind: (class, required fields, optional fields)
    "constant": (Constant, ("a",), ()),
    "step": (Step, ("t_step", "a_before", "a_after"), ()),
    "ramp": (Ramp, ("t_start", "t_end", "a_start", "a_end"), ()),
    "sinusoid": (Sinusoid, ("amplitude", "frequency_hz"), ("offset", "phase")),
    "table": (Table, ("times", "accels"), ()),
    "braking": (Braking, ("v0", "decel"), ("t_start",)),
    "csv": (Table, ("path",), ()),
    # Real motion (speed_trace, accel_log, bag_topic): each becomes a Table.
    "speed_table": (Table, ("times", "speeds", "units"), ("cutoff_hz", "start", "end", "signed")),
    "speed_csv": (
        Table,
        ("path", "units"),
        ("time_column", "speed_column", "cutoff_hz", "start", "end", "signed"),
    ),
    "bag_topic": (Table, ("path", "topic"), ("cutoff_hz", "start", "end")),
    # A phone's accelerometer log (phyphox's CSV export, or any t, a columns), used as recorded.
    "accel_csv": (Table, ("path",), ("time_column", "accel_column", "scale", "cutoff_hz", "start", "end")),
}
PROFILE_TYPES: tuple[str, ...] = tuple(_FIELDS)
PROFILE_FIELDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    kind: (required, optional) for kind, (_, required, optional) in _FIELDS.items()
}
"""Each profile type's (required fields, optional fields), as a scene's ``acceleration`` takes them."""
PROFILE_CLASSES: dict[str, type[AccelProfile]] = {kind: cls for kind, (cls, _, _) in _FIELDS.items()}
"""Each profile type's class (its docstring states a(t))."""


def profile_from_dict(d: Mapping[str, object], base_dir: Path | None = None) -> AccelProfile:
    """Profile from {'type': kind, field: value}, kind in PROFILE_TYPES; csv 'path' is under base_dir."""
    if not isinstance(d, Mapping):
        raise ParameterError(f"acceleration profile must be a mapping with a 'type', got {d!r}")
    kind = d.get("type")
    if kind not in _FIELDS:
        raise ParameterError(
            f"acceleration profile field 'type' must be one of {', '.join(_FIELDS)}, got {kind!r}",
            path="type",
        )
    assert isinstance(kind, str)
    cls, required, optional = _FIELDS[kind]
    for name in d:
        if name != "type" and name not in required and name not in optional:
            raise ParameterError(
                f"{kind} profile has unknown field '{name}' (allowed: {', '.join(required + optional)})",
                path=name,
            )
    for name in required:
        if name not in d:
            raise ParameterError(f"{kind} profile is missing field '{name}'", path=name)
    if kind in ("speed_table", "speed_csv"):
        return speed_profile(d, base_dir)
    if kind == "accel_csv":
        return accel_csv_profile(d, base_dir)
    if kind == "bag_topic":
        return bag_topic_profile(d, base_dir)
    if kind == "csv":
        return csv_table(field_path(kind, d["path"], base_dir))
    if kind == "table":
        return Table(field_numbers(kind, "times", d["times"]), field_numbers(kind, "accels", d["accels"]))
    kwargs = {name: field_number(kind, name, d[name]) for name in required + optional if name in d}
    return cls(**kwargs)
