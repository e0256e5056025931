"""Speed traces v(t) → a(t): the ``speed_table`` and ``speed_csv`` profiles, in m/s, km/h or mph,
differentiated by the stated smoothing spline (``trace``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.columns import read_columns
from pendulum_accel.motion_input.fields import (
    field_number,
    field_numbers,
    field_path,
    field_text,
    window_fields,
)
from pendulum_accel.motion_input.trace import (
    check_trace,
    default_cutoff_hz,
    describe_differentiation,
    differentiate,
    median_step,
)
from pendulum_accel.physics.profiles import Table

SPEED_UNITS: dict[str, float] = {"m/s": 1.0, "km/h": 1.0 / 3.6, "mph": 0.44704}
"""Metres per second in one unit of each accepted speed unit (1 mph = 0.44704 m/s exactly)."""


def speed_profile(d: Mapping[str, object], base_dir: Path | None) -> Table:
    """Table of a(t) from a speed_table or speed_csv mapping (fields checked by registry.profile_from_dict).

    Its ``recipe`` is the speed_table mapping (the speeds inline, in the declared units), so a scene
    written back to YAML (the copy stored in a bag) stands alone and reads back into an equal profile.
    """
    kind = str(d["type"])
    units = field_text(kind, "units", d["units"], tuple(SPEED_UNITS))
    signed = d.get("signed", False)
    if not isinstance(signed, bool):
        raise ParameterError(
            f"{kind} profile field 'signed' must be true or false, got {signed!r}", path="signed"
        )
    if kind == "speed_csv":
        path = field_path(kind, d["path"], base_dir)
        time_column = field_text(kind, "time_column", d["time_column"]) if "time_column" in d else None
        speed_column = field_text(kind, "speed_column", d["speed_column"]) if "speed_column" in d else None
        times, values, lines = read_columns(path, time_column, speed_column)
        where: Callable[[int], str] = lambda i: f"{path}:{lines[i]}"  # noqa: E731
        label = f"speed_csv {path.name}"
    else:
        times = np.array(field_numbers(kind, "times", d["times"]))
        values = np.array(field_numbers(kind, "speeds", d["speeds"]))
        where = lambda i: f"speeds[{i}]"  # noqa: E731
        label = "speed_table"
    check_trace(times, values, where)
    if not signed:
        negative = np.flatnonzero(values < 0.0)
        if negative.size:
            i = int(negative[0])
            raise ParameterError(
                f"{where(i)}: speed {float(values[i])!r} {units} is negative (set signed: true for a trace "
                "that reverses)"
            )
    default = "cutoff_hz" not in d
    cutoff = default_cutoff_hz(times) if default else field_number(kind, "cutoff_hz", d["cutoff_hz"])
    start, end = window_fields(kind, d)
    recipe: dict[str, object] = {
        "type": "speed_table",
        "units": units,
        "times": times.tolist(),
        "speeds": values.tolist(),
        "cutoff_hz": cutoff,
    }
    recipe |= {k: v for k, v in (("start", start), ("end", end)) if v is not None}
    recipe |= {"signed": True} if signed else {}
    origin = f"{label} ({units}): " + describe_differentiation(cutoff, median_step(times), default)
    speeds = values * SPEED_UNITS[units]
    return differentiate(times, speeds, cutoff, start=start, end=end, origin=origin, recipe=recipe)
