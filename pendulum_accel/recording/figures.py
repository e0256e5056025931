"""The figures of one estimate stream against the truth: error statistics, the estimates' own range, holes
(runs of angles without an estimate), the settling time, and the text table ``analyze`` prints of them.

Error e(t) = â(t) − a(t) at the estimate's stamps. bias = mean e, RMS = √(mean e²), max |e| (over the samples
after ``skip`` seconds that have an estimate), the settling time (from the truth's own last change, step or
end of ramp, to the time after which |e| stays within the tolerance to the end of the bag) and the same
figures over the settled samples. Without a truth (a real sensor's recording) the error figures are NaN
and only the estimates' mean, range and median published σ remain.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray

DEFAULT_REL_TOLERANCE = 0.02
DEFAULT_ABS_TOLERANCE = 0.1  # m/s², about 1 % of g: below it sensor noise, not the method, dominates


@dataclass(frozen=True)
class ErrorStats:
    """bias = mean e, rms = √(mean e²), max_abs = max |e| over n samples (NaN when n = 0)."""

    bias: float
    rms: float
    max_abs: float
    n: int

    @classmethod
    def of(cls, error: NDArray[np.float64]) -> ErrorStats:
        """Statistics of the finite entries of ``error``."""
        e = error[np.isfinite(error)]
        if e.size == 0:
            return cls(math.nan, math.nan, math.nan, 0)
        return cls(float(e.mean()), float(np.sqrt(np.mean(e * e))), float(np.abs(e).max()), int(e.size))


@dataclass(frozen=True)
class EstimateRange:
    """mean, low = min and high = max of the finite estimates, and the median published σ = √var, over
    their n samples (NaN when n = 0): what a stream says without a truth to compare it with."""

    mean: float
    low: float
    high: float
    sigma_median: float
    n: int

    @classmethod
    def of(cls, accel: NDArray[np.float64], variance: NDArray[np.float64]) -> EstimateRange:
        """Figures of the samples where â is finite (σ: of those whose variance is finite and ≥ 0)."""
        finite = np.isfinite(accel)
        a = accel[finite]
        if a.size == 0:
            return cls(math.nan, math.nan, math.nan, math.nan, 0)
        var = variance[finite]
        var = var[np.isfinite(var) & (var >= 0.0)]
        sigma = float(np.sqrt(np.median(var))) if var.size else math.nan
        return cls(float(a.mean()), float(a.min()), float(a.max()), sigma, int(a.size))


@dataclass(frozen=True)
class Hole:
    """A run of angles without an estimate: from the first such angle's stamp to the next estimate's (s)."""

    start: float
    end: float
    missing: int

    @property
    def duration(self) -> float:
        """end − start (s)."""
        return self.end - self.start


class EstimateFiguresDict(TypedDict):
    """EstimateFigures.as_dict: one stream's figures in ``analyze --json`` (None: a figure that does not
    exist, JSON null)."""

    source: str
    estimator: str
    estimates: int
    angles: int
    missing: int
    holes: list[list[float]]
    """[start s, end s, missing angles] of each hole."""
    longest_hole: float
    bias: float | None
    rms: float | None
    max_error: float | None
    samples: int
    settling_time: float | None
    settled_bias: float | None
    settled_rms: float | None
    settled_max_error: float | None
    settled_samples: int
    estimate_mean: float | None
    estimate_min: float | None
    estimate_max: float | None
    sigma_median: float | None


@dataclass(frozen=True)
class EstimateFigures:
    """One estimate stream against the truth: counts, holes, all-sample and settled error figures."""

    source: str
    estimator: str
    angles: int
    t: NDArray[np.float64]
    accel: NDArray[np.float64]
    variance: NDArray[np.float64]
    holes: tuple[Hole, ...]
    stats: ErrorStats
    settled_stats: ErrorStats
    settle_from: float
    settling_time: float | None
    values: EstimateRange
    """The estimates' mean, range and median σ (after ``skip``): the figures that need no truth."""

    @property
    def count(self) -> int:
        """Number of finite estimates."""
        return int(np.isfinite(self.accel).sum())

    def as_dict(self) -> EstimateFiguresDict:
        """The figures as JSON-ready values (NaN as None)."""

        def num(x: float) -> float | None:
            """x, or None when not finite."""
            return x if math.isfinite(x) else None

        s, ss = self.stats, self.settled_stats
        longest = max(self.holes, key=lambda h: h.duration) if self.holes else None
        return {
            "source": self.source,
            "estimator": self.estimator,
            "estimates": self.count,
            "angles": self.angles,
            "missing": sum(h.missing for h in self.holes),
            "holes": [[h.start, h.end, h.missing] for h in self.holes],
            "longest_hole": longest.duration if longest is not None else 0.0,
            "bias": num(s.bias),
            "rms": num(s.rms),
            "max_error": num(s.max_abs),
            "samples": s.n,
            "settling_time": self.settling_time,
            "settled_bias": num(ss.bias),
            "settled_rms": num(ss.rms),
            "settled_max_error": num(ss.max_abs),
            "settled_samples": ss.n,
            "estimate_mean": num(self.values.mean),
            "estimate_min": num(self.values.low),
            "estimate_max": num(self.values.high),
            "sigma_median": num(self.values.sigma_median),
        }


def estimate_holes(angle_t: NDArray[np.float64], est_t: NDArray[np.float64]) -> tuple[Hole, ...]:
    """Runs of angle stamps with no estimate of that stamp (the estimator stamps each estimate with its
    input's stamp); a run ends at the next angle that has one, or at the last angle."""
    has = np.isin(angle_t, est_t)
    missing = ~has
    if not missing.any():
        return ()
    edges = np.flatnonzero(np.diff(np.concatenate(([0], missing.astype(np.int8), [0]))))
    holes = []
    for first, stop in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        end = angle_t[stop] if stop < angle_t.size else angle_t[-1]
        holes.append(Hole(float(angle_t[first]), float(end), stop - first))
    return tuple(holes)


def estimate_figures(
    source: str,
    estimator: str,
    angle_t: NDArray[np.float64],
    t: NDArray[np.float64],
    accel: NDArray[np.float64],
    variance: NDArray[np.float64],
    truth: NDArray[np.float64] | None,
    tolerance: float,
    skip_until: float,
) -> EstimateFigures:
    """Figures of estimates ``accel`` (variance ``variance``) at stamps ``t`` (NaN: none) against ``truth``
    at the same stamps; without a truth (None), the error figures are NaN and there is no settling."""
    finite = np.isfinite(accel)
    window = t >= skip_until
    settled = np.zeros(t.size, dtype=bool)
    if truth is None:
        error = np.full(t.size, math.nan)
        settle_from, settling_time = float(t[0]), None
    else:
        error = accel - truth
        settle_from, settling_time = settling(t, error, truth, tolerance)
    if settling_time is not None:
        settled = t >= settle_from + settling_time
    return EstimateFigures(
        source=source,
        estimator=estimator,
        angles=int(angle_t.size),
        t=t,
        accel=accel,
        variance=variance,
        holes=estimate_holes(angle_t, t[finite]),
        stats=ErrorStats.of(error[window]),
        settled_stats=ErrorStats.of(error[settled & window]),
        settle_from=settle_from,
        settling_time=settling_time,
        values=EstimateRange.of(accel[window], variance[window]),
    )


def _hole_text(f: EstimateFigures) -> str:
    """'none' or 'K (M angles), longest D s at t=T'."""
    if not f.holes:
        return "none"
    longest = max(f.holes, key=lambda h: h.duration)
    return (
        f"{len(f.holes)} ({sum(h.missing for h in f.holes)} angles), "
        f"longest {longest.duration:.3f} s at t={longest.start:.3f}"
    )


def figure(x: float, spec: str, unit: str = " m/s²") -> str:
    """``format(x, spec)`` and the unit, or "—" where there is no figure (NaN: no samples, as after an
    estimate that never settled)."""
    return f"{x:{spec}}{unit}" if math.isfinite(x) else "—"


def figure_table(columns: list[EstimateFigures], truth: bool = True) -> list[str]:
    """Rows 'name  value  value' of the figures of each estimate stream, one column per stream; the error
    rows only with a ``truth``."""

    def settle(f: EstimateFigures) -> str:
        """Settling time after the truth's last change, or 'never'."""
        if f.settling_time is None:
            return "never"
        return f"{f.settling_time:.3f} s (from t={f.settle_from:.3f})"

    rows: list[tuple[str, list[str]]] = [
        ("", [f"{f.source} ({f.estimator})" for f in columns]),
        ("estimates", [f"{f.count} of {f.angles} angles" for f in columns]),
        ("holes", [_hole_text(f) for f in columns]),
        ("mean â", [figure(f.values.mean, "+.5f") for f in columns]),
        (
            "â from",
            [f"{figure(f.values.low, '+.4f', '')} to {figure(f.values.high, '+.4f')}" for f in columns],
        ),
        ("median σ", [figure(f.values.sigma_median, ".5f") for f in columns]),
    ]
    if truth:
        rows += _error_rows(columns, settle)
    width = max(len(v) for _, values in rows for v in values) + 2
    return [f"{name + ':' if name else '':<14}" + "".join(f"{v:<{width}}" for v in values).rstrip()
            for name, values in rows]  # fmt: skip


def _error_rows(
    columns: list[EstimateFigures], settle: Callable[[EstimateFigures], str]
) -> list[tuple[str, list[str]]]:
    """The figure table's rows against the truth: bias, RMS, max error, settling and the settled ones."""
    return [
        ("bias", [figure(f.stats.bias, "+.5f") for f in columns]),
        ("RMS", [figure(f.stats.rms, ".5f") for f in columns]),
        ("max error", [figure(f.stats.max_abs, ".5f") for f in columns]),
        ("settling", [settle(f) for f in columns]),
        ("settled bias", [figure(f.settled_stats.bias, "+.5f") for f in columns]),
        ("settled RMS", [figure(f.settled_stats.rms, ".5f") for f in columns]),
        (
            "settled max",
            [f"{figure(f.settled_stats.max_abs, '.5f')} (n={f.settled_stats.n})" for f in columns],
        ),
    ]


def settling(
    t: NDArray[np.float64], error: NDArray[np.float64], truth: NDArray[np.float64], tolerance: float
) -> tuple[float, float | None]:
    """(t_ref, t_s − t_ref): t_s = first sample after the last one with |e| > tol (or no estimate);
    t_ref = first sample after the truth last differed from its final value by more than tol (its
    last step, the end of its last ramp), else t[0]. None when |e| > tol at the last sample."""
    bad = ~(np.abs(error) <= tolerance)  # NaN counts as out of tolerance
    if bad[-1]:
        return float(t[0]), None
    last_bad = np.flatnonzero(bad)
    i_s = int(last_bad[-1]) + 1 if last_bad.size else 0
    moving = np.flatnonzero(np.abs(truth - truth[-1]) > tolerance)
    t_ref = float(t[int(moving[-1]) + 1]) if moving.size else float(t[0])
    return t_ref, max(0.0, float(t[i_s]) - t_ref)


def default_tolerance(truth: NDArray[np.float64]) -> float:
    """max(2 % of max |a|, 0.1 m/s²)."""
    peak = float(np.abs(truth).max()) if truth.size else 0.0
    return max(DEFAULT_REL_TOLERANCE * peak, DEFAULT_ABS_TOLERANCE)
