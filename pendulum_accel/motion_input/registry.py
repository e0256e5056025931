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
        ("time_column", "speed_column", "time_format", "time_units", "cutoff_hz", "start", "end", "signed"),
    ),
    "bag_topic": (Table, ("path", "topic"), ("field", "scale", "cutoff_hz", "start", "end")),
    # A phone's accelerometer log (phyphox's CSV export, or any t, a columns), used as recorded.
    "accel_csv": (
        Table,
        ("path",),
        ("time_column", "accel_column", "time_format", "time_units", "scale", "cutoff_hz", "start", "end"),
    ),
}
PROFILE_TYPES: tuple[str, ...] = tuple(_FIELDS)
PROFILE_FIELDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    kind: (required, optional) for kind, (_, required, optional) in _FIELDS.items()
}
"""Each profile type's (required fields, optional fields), as a scene's ``acceleration`` takes them."""
PROFILE_CLASSES: dict[str, type[AccelProfile]] = {kind: cls for kind, (cls, _, _) in _FIELDS.items()}
"""Each profile type's class (its docstring states a(t))."""

PROFILE_SUMMARIES: dict[str, str] = {
    "csv": "a table read from a (t, a) CSV file",
    "speed_table": "a(t) = s'(t), s the smoothing spline of the speeds given inline",
    "speed_csv": "a(t) = s'(t), s the smoothing spline of a speed column of a CSV file",
    "bag_topic": "a(t) from a bag topic: odometry or twist speeds differentiated, Imu or accel as recorded",
    "accel_csv": "a(t) = scale × an acceleration column of a CSV file (a vehicle's or phone's log)",
}
"""What a(t) is for the types read from data (the others' class docstring says it)."""

_WINDOW = (
    "s after the first sample, or, when the time column holds date-times, a date-time (in `time_format` or "
    "ISO 8601); the window is cut before the gap check, so gaps outside it are allowed"
)
PROFILE_FIELD_DOCS: dict[str, str] = {
    "a": "m/s²",
    "t_step": "s, the time a jumps",
    "a_before": "m/s², before t_step",
    "a_after": "m/s², from t_step on",
    "t_start": "s: the ramp's or the braking's start",
    "t_end": "s: the ramp's end, > t_start",
    "a_start": "m/s², up to t_start",
    "a_end": "m/s², from t_end on",
    "amplitude": "m/s²",
    "frequency_hz": "Hz, ≥ 0",
    "offset": "m/s², added (default 0)",
    "phase": "rad (default 0)",
    "times": "s, increasing (strictly for `table`; `speed_table` averages rows at a repeated time)",
    "accels": "m/s², one per time",
    "v0": "m/s, > 0: the speed braking starts from",
    "decel": "m/s², > 0",
    "path": "a CSV file (csv, speed_csv, accel_csv) or a bag (bag_topic: ROS 1 .bag or a rosbag2 directory), "
    "relative to the scene file",
    "units": "the speeds' unit: m/s, km/h or mph",
    "speeds": "in `units`, one per time",
    "topic": "the bag topic: nav_msgs/Odometry, geometry_msgs/TwistStamped or TwistWithCovarianceStamped "
    "(speeds), sensor_msgs/Imu, geometry_msgs/AccelStamped, AccelWithCovarianceStamped or Vector3Stamped "
    "(accelerations)",
    "time_column": "header name or number (from 1) of the time column (default: 1); it holds seconds or "
    "date-times such as `2007-03-28 07:33:05`. Or a list of two, a ROS 2 stamp's sec and nanosec columns "
    "(`[1, 2]` for `ros2 topic echo --csv`)",
    "speed_column": "header name or number (from 1: a file with no header) of the speed column (default: 2)",
    "accel_column": "header name or number (from 1: a file with no header) of the acceleration column, m/s² "
    "(default: 2)",
    "time_format": "the time column's date-time layout in strptime codes, e.g. `%d/%m/%Y %H:%M:%S` "
    "(default: ISO 8601 detected)",
    "time_units": "the unit of a numeric time column: s (default), ms, us or ns (a logger's epoch "
    "nanoseconds, as `rostopic echo -p` writes them); integers are counted exactly from the first row",
    "cutoff_hz": "-3 dB cut-off of the smoothing spline, Hz (speeds: default min(1/(4 h), 1 Hz) for samples "
    "h apart; accelerations: none, used as recorded)",
    "start": "window start (default: the first sample): " + _WINDOW,
    "end": "window end (default: the last sample): " + _WINDOW,
    "signed": "true lets the speed go negative (reversing); default false",
    "scale": "multiplies the column or the bag field (default 1; -1 when the logger's axis points backward), "
    "≠ 0",
    "field": "the message field read, dotted (default by type: twist.twist.linear.x, linear_acceleration.x, "
    "accel.linear.x; e.g. linear_acceleration.z for an IMU mounted z forward); a speed type's is a speed",
}
"""Each profile field's meaning and unit, for the scene reference page."""


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
