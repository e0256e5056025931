"""A profile mapping's fields (a scene's ``acceleration:``), each checked and converted, or one
ParameterError naming the field."""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence
from pathlib import Path

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.columns import is_number, parse_datetime, since
from pendulum_accel.physics.params import require_finite


def field_number(kind: str, name: str, value: object) -> float:
    """float(value) for profile field ``name``, else ParameterError naming it."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ParameterError(f"{kind} profile field '{name}' must be a number, got {value!r}", path=name)
    try:
        return require_finite(f"{kind} profile field '{name}'", value)
    except ParameterError as err:
        raise ParameterError(str(err), path=name) from None


def field_path(kind: str, raw: object, base_dir: Path | None) -> Path:
    """Profile field 'path' as a Path, ``~`` expanded (a scene is typed without a shell to expand it) and
    relative ones under ``base_dir``; else ParameterError naming it."""
    if not isinstance(raw, str | Path):
        raise ParameterError(f"{kind} profile field 'path' must be a file path, got {raw!r}", path="path")
    path = Path(raw).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


def field_scale(kind: str, d: Mapping[str, object]) -> float:
    """The optional 'scale' field (default 1): a non-zero number multiplying the values read."""
    scale = field_number(kind, "scale", d["scale"]) if "scale" in d else 1.0
    if scale == 0.0:
        raise ParameterError(f"{kind} profile field 'scale' must not be 0", path="scale")
    return scale


def field_column(kind: str, name: str, value: object) -> str | int:
    """Profile column field ``name``: a header name (text) or a column number counted from 1 (an int, for
    files with no header row), else ParameterError naming it."""
    if isinstance(value, str) and value:
        return value
    if isinstance(value, int) and not isinstance(value, bool) and value >= 1:
        return value
    raise ParameterError(
        f"{kind} profile field '{name}' must be a header name or a column number ≥ 1, got {value!r}",
        path=name,
    )


def field_time_columns(kind: str, value: object) -> str | int | tuple[str | int, str | int]:
    """Profile field 'time_column': one column (field_column), or a list of two, a ROS 2 stamp's sec and
    nanosec columns (``ros2 topic echo --csv`` writes ``header.stamp`` so), else ParameterError naming it."""
    if isinstance(value, list | tuple):
        if len(value) != 2:
            raise ParameterError(
                f"{kind} profile field 'time_column' must be one column or two (a stamp's sec and nanosec), "
                f"got {len(value)}: {value!r}",
                path="time_column",
            )
        sec, nanosec = (field_column(kind, "time_column", c) for c in value)
        return sec, nanosec
    return field_column(kind, "time_column", value)


def field_text(kind: str, name: str, value: object, choices: Sequence[str] = ()) -> str:
    """Profile field ``name`` as text (one of ``choices`` when given), else ParameterError naming it."""
    if not isinstance(value, str) or (choices and value not in choices):
        expected = f"one of {', '.join(choices)}" if choices else "text"
        raise ParameterError(f"{kind} profile field '{name}' must be {expected}, got {value!r}", path=name)
    return value


def field_numbers(kind: str, name: str, value: object) -> tuple[float, ...]:
    """Tuple of floats for list field ``name``, else ParameterError naming it."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence):
        raise ParameterError(
            f"{kind} profile field '{name}' must be a list of numbers, got {value!r}", path=name
        )
    try:
        return tuple(field_number(kind, f"{name}[{i}]", v) for i, v in enumerate(value))
    except ParameterError as err:
        raise ParameterError(str(err), path=name) from None


def window_fields(
    kind: str, d: Mapping[str, object], epoch: dt.datetime | None = None, time_format: str | None = None
) -> tuple[float | None, float | None]:
    """The optional 'start' and 'end' fields of a profile mapping, s after the trace's first sample (None
    when absent).

    Each is a number of seconds, or, when the trace's times are date-times from ``epoch`` on, a date-time:
    text in ``time_format`` or ISO 8601, or the datetime YAML reads from an unquoted one.
    """
    bounds: list[float | None] = []
    for name in ("start", "end"):
        value = d.get(name)
        if value is None:
            bounds.append(None)
        elif isinstance(value, dt.date) or (isinstance(value, str) and not is_number(value)):
            bounds.append(_moment_field(kind, name, value, epoch, time_format))
        else:
            bounds.append(field_number(kind, name, value))
    return bounds[0], bounds[1]


def _moment_field(
    kind: str, name: str, value: str | dt.date, epoch: dt.datetime | None, time_format: str | None
) -> float:
    """Date-time field ``name`` as s after ``epoch`` (value − epoch), else ParameterError naming it."""
    if epoch is None:
        raise ParameterError(
            f"{kind} profile field '{name}' is a date-time ({value!s}) but the trace's times are seconds: "
            "give it in s after the first sample",
            path=name,
        )
    if isinstance(value, dt.datetime):
        moment = value
    elif isinstance(value, dt.date):
        moment = dt.datetime.combine(value, dt.time())
    else:
        try:
            moment = parse_datetime(value, time_format)
        except ValueError:
            try:
                moment = parse_datetime(value, None)
            except ValueError:
                layout = f"time_format {time_format!r} or ISO 8601" if time_format else "ISO 8601"
                raise ParameterError(
                    f"{kind} profile field '{name}' must be a number of s or a date-time in {layout}, "
                    f"got {value!r}",
                    path=name,
                ) from None
    try:
        return since(moment, epoch)
    except ValueError as exc:
        raise ParameterError(f"{kind} profile field '{name}' {value!s}: {exc}", path=name) from None
