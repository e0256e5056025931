"""Car acceleration profiles a(t) in m/s², forward (+x, REP-103) positive, all vectorised over t.

Every profile is a frozen dataclass with:

- ``profile(t)``: a(t) for a scalar or array ``t`` (returns an array of ``t``'s shape);
- ``breakpoints()``: the times where a or a' jumps, so integrators can stop there and keep their order;
- ``constant_pieces(t0, t1)``: ``[(start, end, a), ...]`` covering [t0, t1] when a is piecewise
  constant there (closed-form models chain over these), else ``None``;
- ``max_abs(t0, t1)``: max |a| on [t0, t1] (for step-size stability limits);
- ``to_dict()``: a plain mapping that ``motion_input.profile_from_dict`` turns back into an equal profile.

Outside its defined span each profile holds its end value (a Table or Ramp stays flat, Braking is 0).
Reading profiles from scene mappings, files and bags is ``pendulum_accel.motion_input``'s job: physics
holds only the types it integrates.
"""

from __future__ import annotations

import bisect
import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import require_finite, require_positive

Piece = tuple[float, float, float]


def _as_times(t: ArrayLike) -> np.ndarray:
    """Return ``t`` as a float array (0-d for a scalar)."""
    return np.asarray(t, dtype=float)


def _check_interval(t0: float, t1: float) -> tuple[float, float]:
    """Return (t0, t1) as floats when finite and t0 <= t1, else raise ParameterError."""
    start = require_finite("t0", t0)
    end = require_finite("t1", t1)
    if end < start:
        raise ParameterError(f"time interval must have t1 >= t0, got t0={start!r}, t1={end!r}")
    return start, end


def _split_constant(
    t0: float, t1: float, cuts: Sequence[float], value: Callable[[float], float]
) -> list[Piece]:
    """Pieces of [t0, t1] between the ``cuts`` inside it; each piece's a is ``value(midpoint)``."""
    edges = [t0, *sorted(c for c in cuts if t0 < c < t1), t1]
    if t0 == t1:
        return [(t0, t1, value(t0))]
    return [(lo, hi, value(0.5 * (lo + hi))) for lo, hi in itertools.pairwise(edges)]


class AccelProfile(ABC):
    """a(t): car acceleration along +x (forward), m/s²."""

    kind: ClassVar[str] = ""

    @abstractmethod
    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t), element-wise over ``t``."""

    def scalar(self, t: float) -> float:
        """a(t) for one float t; the same value as ``__call__``, without numpy's per-call overhead."""
        return float(self(t))

    def breakpoints(self) -> tuple[float, ...]:
        """Times where a(t) or a'(t) is discontinuous, ascending (none by default)."""
        return ()

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """[(start, end, a)] covering [t0, t1] when a is piecewise constant there, else None."""
        return None

    def max_abs(self, t0: float, t1: float) -> float:
        """max |a(t)| on [t0, t1], from the values at the ends and at the breakpoints inside."""
        start, end = _check_interval(t0, t1)
        times = np.array([start, end, *(b for b in self.breakpoints() if start < b < end)])
        return float(np.max(np.abs(self(times))))

    @abstractmethod
    def to_dict(self) -> dict[str, object]:
        """{'type': kind, field: value, ...}, the inverse of ``motion_input.profile_from_dict``."""


@dataclass(frozen=True)
class Constant(AccelProfile):
    """a(t) = a."""

    a: float
    kind: ClassVar[str] = "constant"

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", require_finite("a", self.a))

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = a."""
        return np.full_like(_as_times(t), self.a)

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """[(t0, t1, a)]."""
        start, end = _check_interval(t0, t1)
        return [(start, end, self.a)]

    def max_abs(self, t0: float, t1: float) -> float:
        """|a|."""
        _check_interval(t0, t1)
        return abs(self.a)

    def to_dict(self) -> dict[str, object]:
        """{'type': 'constant', 'a': a}."""
        return {"type": self.kind, "a": self.a}


@dataclass(frozen=True)
class Step(AccelProfile):
    """a(t) = a_before for t < t_step, a_after for t >= t_step."""

    t_step: float
    a_before: float
    a_after: float
    kind: ClassVar[str] = "step"

    def __post_init__(self) -> None:
        for name in ("t_step", "a_before", "a_after"):
            object.__setattr__(self, name, require_finite(name, getattr(self, name)))

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = a_before if t < t_step else a_after."""
        times = _as_times(t)
        return np.where(times < self.t_step, self.a_before, self.a_after).astype(float)

    def breakpoints(self) -> tuple[float, ...]:
        """(t_step,)."""
        return (self.t_step,)

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """[(t0, t_step, a_before), (t_step, t1, a_after)] clipped to [t0, t1]."""
        start, end = _check_interval(t0, t1)
        return _split_constant(start, end, self.breakpoints(), lambda s: float(self(s)))

    def to_dict(self) -> dict[str, object]:
        """{'type': 'step', 't_step', 'a_before', 'a_after'}."""
        return {"type": self.kind, "t_step": self.t_step, "a_before": self.a_before, "a_after": self.a_after}


@dataclass(frozen=True)
class Ramp(AccelProfile):
    """a = a_start for t <= t_start, linear to a_end at t_end, a_end after."""

    t_start: float
    t_end: float
    a_start: float
    a_end: float
    kind: ClassVar[str] = "ramp"

    def __post_init__(self) -> None:
        for name in ("t_start", "t_end", "a_start", "a_end"):
            object.__setattr__(self, name, require_finite(name, getattr(self, name)))
        if self.t_end <= self.t_start:
            raise ParameterError(
                f"ramp t_end must be > t_start, got t_start={self.t_start}, t_end={self.t_end}"
            )

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = interp(t, [t_start, t_end], [a_start, a_end]), flat outside."""
        times = _as_times(t)
        return np.asarray(
            np.interp(times, [self.t_start, self.t_end], [self.a_start, self.a_end]), dtype=float
        )

    def scalar(self, t: float) -> float:
        """a(t) = interp(t, [t_start, t_end], [a_start, a_end]), flat outside, for one float t."""
        return _interp((self.t_start, self.t_end), (self.a_start, self.a_end), t)

    def breakpoints(self) -> tuple[float, ...]:
        """(t_start, t_end): a' jumps at both."""
        return (self.t_start, self.t_end)

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """Pieces when [t0, t1] avoids the sloped part (or a_start == a_end), else None."""
        start, end = _check_interval(t0, t1)
        if self.a_start != self.a_end and start < self.t_end and end > self.t_start:
            return None
        return _split_constant(start, end, (), lambda s: float(self(s)))

    def to_dict(self) -> dict[str, object]:
        """{'type': 'ramp', 't_start', 't_end', 'a_start', 'a_end'}."""
        return {
            "type": self.kind,
            "t_start": self.t_start,
            "t_end": self.t_end,
            "a_start": self.a_start,
            "a_end": self.a_end,
        }


@dataclass(frozen=True)
class Sinusoid(AccelProfile):
    """a(t) = offset + amplitude · sin(2π · frequency_hz · t + phase)."""

    amplitude: float
    frequency_hz: float
    offset: float = 0.0
    phase: float = 0.0
    kind: ClassVar[str] = "sinusoid"

    def __post_init__(self) -> None:
        for name in ("amplitude", "frequency_hz", "offset", "phase"):
            object.__setattr__(self, name, require_finite(name, getattr(self, name)))
        if self.frequency_hz < 0.0:
            raise ParameterError(f"sinusoid frequency_hz must be >= 0, got {self.frequency_hz!r}")

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = offset + A sin(2π f t + φ)."""
        times = _as_times(t)
        return self.offset + self.amplitude * np.sin(2.0 * math.pi * self.frequency_hz * times + self.phase)

    def scalar(self, t: float) -> float:
        """a(t) = offset + A sin(2π f t + φ) for one float t."""
        return self.offset + self.amplitude * math.sin(2.0 * math.pi * self.frequency_hz * t + self.phase)

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """[(t0, t1, a)] when A = 0 or f = 0, else None."""
        start, end = _check_interval(t0, t1)
        if self.amplitude == 0.0 or self.frequency_hz == 0.0:
            return [(start, end, float(self(start)))]
        return None

    def max_abs(self, t0: float, t1: float) -> float:
        """max |a| on [t0, t1]: ends plus every crest 2πft + φ = π/2 + kπ inside."""
        start, end = _check_interval(t0, t1)
        omega = 2.0 * math.pi * self.frequency_hz
        candidates = [start, end]
        if omega > 0.0:
            k_lo = math.ceil((omega * start + self.phase - math.pi / 2) / math.pi)
            k_hi = math.floor((omega * end + self.phase - math.pi / 2) / math.pi)
            if k_hi - k_lo >= 2:
                return abs(self.offset) + abs(self.amplitude)
            candidates += [(math.pi / 2 + k * math.pi - self.phase) / omega for k in range(k_lo, k_hi + 1)]
        return float(np.max(np.abs(self(np.array(candidates)))))

    def to_dict(self) -> dict[str, object]:
        """{'type': 'sinusoid', 'amplitude', 'frequency_hz', 'offset', 'phase'}."""
        return {
            "type": self.kind,
            "amplitude": self.amplitude,
            "frequency_hz": self.frequency_hz,
            "offset": self.offset,
            "phase": self.phase,
        }


def _finite_floats(name: str, values: Sequence[float]) -> tuple[float, ...]:
    """tuple(require_finite(f"{name}[i]", v) for each v): the floats, or the ParameterError naming the
    first bad entry. The per-entry names are made only on a failure: a recorded log's table has millions
    of entries, and naming each took seconds."""
    try:
        floats = tuple(map(float, values))
    except (TypeError, ValueError):
        floats = None
    if floats is None or not all(map(math.isfinite, floats)):
        return tuple(require_finite(f"{name}[{i}]", v) for i, v in enumerate(values))  # raises, naming it
    return floats


@dataclass(frozen=True)
class Table(AccelProfile):
    """a(t) piecewise linear through (times[i], accels[i]), flat beyond the first and last point.

    A table derived from real motion (motion_input) carries ``origin``, one line saying where it
    came from and how it was differentiated (for plan lines and listings), and ``recipe``, the
    ``speed_table`` mapping it was built from, which ``to_dict`` returns instead of every sample. Neither
    takes part in equality.
    """

    times: tuple[float, ...]
    accels: tuple[float, ...]
    origin: str = field(default="", compare=False)
    recipe: Mapping[str, object] | None = field(default=None, compare=False, repr=False)
    kind: ClassVar[str] = "table"
    _t: np.ndarray = field(init=False, repr=False, compare=False)
    _a: np.ndarray = field(init=False, repr=False, compare=False)
    _breaks: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        times = _finite_floats("times", self.times)
        accels = _finite_floats("accels", self.accels)
        if not times:
            raise ParameterError("table needs at least one (t, a) point, got none")
        if len(times) != len(accels):
            raise ParameterError(f"table times and accels differ in length: {len(times)} vs {len(accels)}")
        t = np.array(times)
        back = np.flatnonzero(t[1:] <= t[:-1])
        if back.size:
            i = int(back[0]) + 1
            raise ParameterError(
                f"table times must be strictly increasing: times[{i}]={times[i]} <= {times[i - 1]}"
            )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "accels", accels)
        object.__setattr__(self, "_t", t)
        object.__setattr__(self, "_a", np.array(accels))
        # Flat extrapolation means slope 0 before the first point and after the last.
        slopes = np.concatenate(([0.0], np.diff(self._a) / np.diff(self._t), [0.0]))
        breaks = tuple(t[np.flatnonzero(slopes[:-1] != slopes[1:])].tolist())
        object.__setattr__(self, "_breaks", breaks)

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = linear interpolation of the table, flat beyond its ends."""
        times = _as_times(t)
        return np.asarray(np.interp(times, self._t, self._a), dtype=float)

    def scalar(self, t: float) -> float:
        """a(t) = linear interpolation of the table, flat beyond its ends, for one float t."""
        return _interp(self.times, self.accels, t)

    def breakpoints(self) -> tuple[float, ...]:
        """Every table time where the slope changes (computed once, at construction)."""
        return self._breaks

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """Pieces when every segment meeting [t0, t1] is flat, else None."""
        start, end = _check_interval(t0, t1)
        for i in range(len(self.times) - 1):
            lo, hi = self.times[i], self.times[i + 1]
            if self.accels[i] != self.accels[i + 1] and start < hi and end > lo:
                return None
        return _split_constant(start, end, self.times, lambda s: float(self(s)))

    def to_dict(self) -> dict[str, object]:
        """{'type': 'table', 'times': [...], 'accels': [...]}, or the recipe of a derived table."""
        if self.recipe is not None:
            return dict(self.recipe)
        return {"type": self.kind, "times": list(self.times), "accels": list(self.accels)}


@dataclass(frozen=True)
class Braking(AccelProfile):
    """a = -decel for t_start <= t < t_start + v0/decel (the car stops), 0 otherwise."""

    v0: float
    decel: float
    t_start: float = 0.0
    kind: ClassVar[str] = "braking"

    def __post_init__(self) -> None:
        object.__setattr__(self, "v0", require_positive("v0", self.v0))
        object.__setattr__(self, "decel", require_positive("decel", self.decel))
        object.__setattr__(self, "t_start", require_finite("t_start", self.t_start))

    @property
    def t_stop(self) -> float:
        """t_stop = t_start + v0/decel."""
        return self.t_start + self.v0 / self.decel

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = -decel on [t_start, t_stop), else 0."""
        times = _as_times(t)
        braking = (times >= self.t_start) & (times < self.t_stop)
        return np.where(braking, -self.decel, 0.0).astype(float)

    def breakpoints(self) -> tuple[float, ...]:
        """(t_start, t_stop)."""
        return (self.t_start, self.t_stop)

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """Always piecewise constant: split at t_start and t_stop."""
        start, end = _check_interval(t0, t1)
        return _split_constant(start, end, self.breakpoints(), lambda s: float(self(s)))

    def to_dict(self) -> dict[str, object]:
        """{'type': 'braking', 'v0', 'decel', 't_start'}."""
        return {"type": self.kind, "v0": self.v0, "decel": self.decel, "t_start": self.t_start}


@dataclass(frozen=True)
class Offset(AccelProfile):
    """a(t) = base(t) + offset: a road grade's g sin β on top of the car's a(t) (rigid.level_equivalent).

    Built in code only (never read from a scene file); the compiled kernels take it as its base's form.
    """

    base: AccelProfile
    offset: float
    kind: ClassVar[str] = "offset"

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset", require_finite("offset", self.offset))

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """a(t) = base(t) + offset."""
        return self.base(t) + self.offset

    def scalar(self, t: float) -> float:
        """a(t) = base(t) + offset for one float t."""
        return self.base.scalar(t) + self.offset

    def breakpoints(self) -> tuple[float, ...]:
        """The base's breakpoints."""
        return self.base.breakpoints()

    def constant_pieces(self, t0: float, t1: float) -> list[Piece] | None:
        """The base's pieces, each a + offset."""
        pieces = self.base.constant_pieces(t0, t1)
        return None if pieces is None else [(lo, hi, a + self.offset) for lo, hi, a in pieces]

    def max_abs(self, t0: float, t1: float) -> float:
        """max |a| over the pieces when piecewise constant, else the bound base.max_abs + |offset|."""
        pieces = self.constant_pieces(t0, t1)
        if pieces is not None:
            return max(abs(a) for _, _, a in pieces)
        return self.base.max_abs(t0, t1) + abs(self.offset)

    def to_dict(self) -> dict[str, object]:
        """{'type': 'offset', 'base': base.to_dict(), 'offset'} (for display; scene files never hold one)."""
        return {"type": self.kind, "base": self.base.to_dict(), "offset": self.offset}


def _interp(xp: Sequence[float], fp: Sequence[float], x: float) -> float:
    """np.interp(x, xp, fp) for one float x: fp[j] + s (x − xp[j]), s the slope of xp[j] ≤ x < xp[j+1].

    The same operations in the same order as numpy's, so the same bits; flat beyond the ends.
    """
    if x <= xp[0]:
        return float(fp[0])
    if x >= xp[-1]:
        return float(fp[-1])
    j = bisect.bisect_right(xp, x) - 1
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return float(slope * (x - xp[j]) + fp[j])


def scalar_accel(profile: AccelProfile, t0: float, t1: float) -> Callable[[float], float]:
    """t ↦ float a(t) on [t0, t1]: a table lookup when piecewise constant there, else profile.scalar."""
    pieces = profile.constant_pieces(t0, t1)
    if pieces is None:
        return profile.scalar
    if len(pieces) == 1:
        value = pieces[0][2]
        return lambda t: value
    inner_ends = [end for _, end, _ in pieces[:-1]]
    values = [a for _, _, a in pieces]
    # bisect_right puts a time equal to a breakpoint in the later piece, like the profiles do.
    return lambda t: values[bisect.bisect_right(inner_ends, t)]
