"""Speed traces v(t) → a(t): the ``speed_table`` and ``speed_csv`` profiles, in m/s, km/h or mph,
differentiated by the stated smoothing spline (``trace``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.fields import field_numbers, field_text, window_fields
from pendulum_accel.motion_input.trace import (
    Stretch,
    check_trace,
    csv_trace,
    describe_differentiation,
    differentiate,
    fitted_stretch,
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
        stretch, columns, path = csv_trace(kind, d, base_dir, "speed_column", name="speed")
        where: Callable[[int], str] = lambda i: columns.where(i, path)  # noqa: E731
        label = f"speed_csv {path.name}"
    else:
        times = np.array(field_numbers(kind, "times", d["times"]))
        values = np.array(field_numbers(kind, "speeds", d["speeds"]))
        where = lambda i: f"speeds[{i}]"  # noqa: E731
        label = "speed_table"
        start, end = window_fields(kind, d)
        stretch = check_trace(times, values, where, start=start, end=end)
    stretch, cutoff, default = fitted_stretch(kind, d, stretch)  # only what the window's a(t) depends on
    if not signed:
        negative = np.flatnonzero(stretch.values < 0.0)
        if negative.size:
            i = int(negative[0])
            raise ParameterError(
                f"{where(int(stretch.rows[i]))}: speed {float(stretch.values[i])!r} {units} is negative (set "
                "signed: true for a trace that reverses)"
            )
    times, values = stretch.times, stretch.values
    recipe = speed_recipe(units, stretch, cutoff, d, signed=signed)
    origin = f"{label} ({units}{stretch.note()}): " + describe_differentiation(
        cutoff, median_step(times), default
    )
    speeds = values * SPEED_UNITS[units]
    return differentiate(
        times, speeds, cutoff, start=stretch.lo, end=stretch.hi, origin=origin, recipe=recipe
    )


def speed_recipe(
    units: str, stretch: Stretch, cutoff: float, d: Mapping[str, object], *, signed: bool
) -> dict[str, object]:
    """The speed_table mapping that rebuilds a speed profile: the stretch's speeds inline, its window
    (when one was stated or the stretch is not the whole trace), the cut-off."""
    recipe: dict[str, object] = {
        "type": "speed_table",
        "units": units,
        "times": stretch.times.tolist(),
        "speeds": stretch.values.tolist(),
        "cutoff_hz": cutoff,
    }
    if "start" in d or not stretch.whole:
        recipe["start"] = stretch.lo
    if "end" in d or not stretch.whole:
        recipe["end"] = stretch.hi
    return recipe | ({"signed": True} if signed else {})
