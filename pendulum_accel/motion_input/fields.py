"""A profile mapping's fields (a scene's ``acceleration:``), each checked and converted, or one
ParameterError naming the field."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import require_finite


def field_number(kind: str, name: str, value: object) -> float:
    """float(value) for profile field ``name``, else ParameterError naming it."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ParameterError(f"{kind} profile field '{name}' must be a number, got {value!r}", path=name)
    try:
        return require_finite(f"{kind} profile field '{name}'", value)  # type: ignore[arg-type]
    except ParameterError as err:
        raise ParameterError(str(err), path=name) from None


def field_path(kind: str, raw: object, base_dir: Path | None) -> Path:
    """Profile field 'path' as a Path, relative ones under ``base_dir``; else ParameterError naming it."""
    if not isinstance(raw, str | Path):
        raise ParameterError(f"{kind} profile field 'path' must be a file path, got {raw!r}", path="path")
    path = Path(raw)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


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


def window_fields(kind: str, d: Mapping[str, object]) -> tuple[float | None, float | None]:
    """The optional 'start' and 'end' fields of a profile mapping, s (None when absent)."""
    start = field_number(kind, "start", d["start"]) if "start" in d else None
    end = field_number(kind, "end", d["end"]) if "end" in d else None
    return start, end
