"""Analysis of a bag: the estimate it recorded (live) and an offline re-run, each against the recorded truth.

A bag without a truth topic (a real sensor's recording: nobody knows a(t)) gets the figures that need
none: counts and holes, the estimates' mean and range and the median published σ; the error figures are
left out (null in JSON).

Error e(t) = â(t) − a(t) at the estimate's stamps (truth interpolated onto them). For each of the two
estimate streams (:class:`EstimateFigures`): how many angles got an estimate and where the stream has
holes (runs of angles without one), bias = mean e, RMS = √(mean e²), max |e| (over the samples after
``skip`` seconds that have an estimate), the settling time (from the truth's own last change, step or
end of ramp, to the time after which |e| stays within the tolerance to the end of the bag) and the same
figures over the settled samples. The re-run uses the estimator the bag was recorded with unless told.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.messages import (
    ACCEL_STAMPED,
    ACCEL_WITH_COVARIANCE_STAMPED,
    DIAGNOSTIC_ARRAY,
    JOINT_STATE,
    TOPIC_ACCEL_ESTIMATE,
    TOPIC_ACCEL_TRUTH,
    TOPIC_DIAGNOSTICS,
    TOPIC_JOINT_STATES,
    DiagnosticArrayMsg,
    deserialize_as,
)
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.shapes import TopicArrays
from pendulum_accel.bag.writer import CUSTOM_ESTIMATOR, CUSTOM_SCENE
from pendulum_accel.errors import BagError, PendulumAccelError
from pendulum_accel.estimators import (
    DEFAULT_ESTIMATOR,
    ESTIMATORS,
    TEACHING_NOTE,
    estimate_batch,
    make_estimator,
)
from pendulum_accel.estimators.kalman import DEFAULT_PRESET
from pendulum_accel.estimators.motion import MotionChoice
from pendulum_accel.recording import coverage
from pendulum_accel.recording.changes import CHANGE_WINDOW, after_change, change_rule
from pendulum_accel.recording.contract import angle_field, decode_chain, require_angles
from pendulum_accel.recording.settings import estimator_settings, motion_choice, uses_preset
from pendulum_accel.scene import Scene, scene_from_yaml, scene_text_without_motion
from pendulum_accel.sensor import noise_from_angles

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
class NeesStats:
    """NEES = e²/var: mean, median and the share with |e| > 2σ (NEES > 4) over n samples (NaN if n = 0),
    and the independent trials behind the share (``coverage``; NaN where they are not counted)."""

    mean: float
    median: float
    share_2sigma: float
    n: int
    trials: float = math.nan

    @classmethod
    def of(cls, nees: NDArray[np.float64], trials: float = math.nan) -> NeesStats:
        """Statistics of the finite entries of ``nees``."""
        z = nees[np.isfinite(nees)]
        if z.size == 0:
            return cls(math.nan, math.nan, math.nan, 0, math.nan)
        return cls(float(z.mean()), float(np.median(z)), float(np.mean(z > 4.0)), int(z.size), trials)

    def interval(self) -> tuple[float, float] | None:
        """The share's 95 % interval at its trials (coverage.wilson); None where they are not counted."""
        if self.n == 0 or not math.isfinite(self.trials):
            return None
        return coverage.wilson(self.share_2sigma, self.trials)

    def share_text(self) -> str:
        """'x % beyond 2σ (n=N, about K independent: 95 % lo–hi %)'; without counted trials, no 'about'."""
        span = self.interval()
        trials = (
            ""
            if span is None
            else f", about {self.trials:.0f} independent: 95 % {100 * span[0]:.1f}–{100 * span[1]:.1f} %"
        )
        return f"{100 * self.share_2sigma:.1f} % beyond 2σ (n={self.n}{trials})"


@dataclass(frozen=True)
class Calibration:
    """NEES figures in steady state and within CHANGE_WINDOW s after a change of a (a calibrated σ:
    mean NEES ≈ 1, ≈ 5 % beyond 2σ)."""

    steady: NeesStats
    after_change: NeesStats

    def line(self, label: str) -> str:
        """'label: steady NEES mean m, median d, x % beyond 2σ (n, k independent: 95 % lo–hi %); after a
        change: …'."""

        def part(s: NeesStats) -> str:
            """One window's figures."""
            if s.n == 0:
                return "no samples"
            return f"NEES mean {s.mean:.3g}, median {s.median:.3g}, {s.share_text()}"

        after = part(self.after_change)
        return f"{label}: steady {part(self.steady)}; ≤{CHANGE_WINDOW:g} s after a change {after}"


def nees_windows(
    t: NDArray[np.float64],
    error: NDArray[np.float64],
    variance: NDArray[np.float64],
    t_truth: NDArray[np.float64],
    a_truth: NDArray[np.float64],
    t_from: float,
) -> tuple[tuple[NDArray[np.float64], float], tuple[NDArray[np.float64], float]]:
    """((steady NEES, its trials), (after-change NEES, its trials)): NEES = e²/var at stamps t ≥ t_from
    (NaN where var ≤ 0), split by recording.changes.after_change (within CHANGE_WINDOW s after
    |a(t) − a(t − 1 s)| > CHANGE_JUMP on the truth), each window with its independent trials
    n_eff = coverage.window_trials (its finite samples at the window's own integrated time τ)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        all_nees = np.where(variance > 0.0, error * error / variance, np.nan)
    keep = t >= t_from
    nees, after = all_nees[keep], after_change(t, t_truth, a_truth)[keep]
    return (
        (nees[~after], coverage.window_trials(nees, ~after)),
        (nees[after], coverage.window_trials(nees, after)),
    )


def calibration(
    t: NDArray[np.float64],
    error: NDArray[np.float64],
    variance: NDArray[np.float64],
    t_truth: NDArray[np.float64],
    a_truth: NDArray[np.float64],
    t_from: float,
) -> Calibration:
    """NeesStats of nees_windows' two windows: steady state and CHANGE_WINDOW s after a change of a(t),
    each with its independent trials."""
    steady, after = nees_windows(t, error, variance, t_truth, a_truth, t_from)
    return Calibration(NeesStats.of(*steady), NeesStats.of(*after))


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

    def as_dict(self) -> dict[str, object]:
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


@dataclass(frozen=True)
class Analysis:
    """Result of analyze_bag: the aligned series and the error figures."""

    path: Path
    scene: str | None
    estimator: str
    config: dict[str, float]
    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    accel_true: NDArray[np.float64]
    accel_est: NDArray[np.float64]
    variance: NDArray[np.float64]
    skip: float
    tolerance: float
    stats: ErrorStats
    settled_stats: ErrorStats
    settle_from: float
    settling_time: float | None
    recorded: ErrorStats | None
    problem: str | None
    offline_figures: EstimateFigures
    recorded_figures: EstimateFigures | None
    calibration: Calibration | None = None
    recorded_calibration: Calibration | None = None
    motion: MotionChoice | None = None
    """kalman's preset and why, for a method that takes one (None otherwise)."""
    motion_model: str | None = None
    """The motion model the re-run's estimate used, as its estimator names it (Estimator.motion_model),
    else the preset's name; None for a method without one."""
    has_truth: bool = True
    """False for a bag without a truth topic: accel_true is NaN and only the estimates' own figures exist."""
    noise_from_angles: bool = False
    """True when the re-run's noise_std was estimated from the angles (no stored scene, none given)."""

    @functools.cached_property
    def agreement(self) -> ErrorStats | None:
        """recorded â − re-run â at the recorded estimates' stamps (after ``skip``): whether the live node
        computed what the offline estimator does, a check that needs no truth; None without a recording.
        Cached: the text and the JSON each read it, and the arrays it compares never change."""
        rec = self.recorded_figures
        if rec is None:
            return None
        at = np.searchsorted(self.t, rec.t)
        found = (at < self.t.size) & (self.t[np.minimum(at, self.t.size - 1)] == rec.t)
        keep = found & (rec.t >= self.t[0] + self.skip)
        return ErrorStats.of(rec.accel[keep] - self.accel_est[at[keep]])

    @property
    def options(self) -> dict[str, object]:
        """What the re-run was given: the configuration, and the motion preset for a method that takes one."""
        return {**self.config, **({"preset": self.motion.preset} if self.motion is not None else {})}

    @property
    def error(self) -> NDArray[np.float64]:
        """e = â − a at every joint-state sample (NaN where the estimator gave nothing yet)."""
        return self.accel_est - self.accel_true

    def lines(self) -> list[str]:
        """Human-readable report: the bag, then the recorded and the re-run estimate side by side."""
        cfg = ", ".join(f"{k}={v:g}" for k, v in self.config.items())
        out = [
            f"bag:        {self.path}" + (f"  (scene {self.scene})" if self.scene else ""),
            f"angles:     {self.t.size} over {self.t[-1] - self.t[0]:.3f} s"
            + (f", figures after skipping {self.skip:g} s" if self.skip > 0 else "")
            + (
                f"; settling band ±{self.tolerance:.4f} m/s²"
                if self.has_truth
                else f"; no truth in the bag ({TOPIC_ACCEL_TRUTH}): the estimates' own figures only"
            ),
            f"re-run:     {self.estimator}  ({cfg})",
        ]
        if self.noise_from_angles:
            out.append(
                "            noise_std from the angles' third differences (no scene says it; --noise-std)"
            )
        if self.motion_model is not None:
            why = f" ({self.motion.line()})" if self.motion is not None else ""
            out.append(f"            motion model {self.motion_model}{why}")
        if self.estimator in ESTIMATORS and ESTIMATORS[self.estimator].teaching:
            out.append(f"            {TEACHING_NOTE}")
        columns = [f for f in (self.recorded_figures, self.offline_figures) if f is not None]
        if self.recorded_figures is None:
            out.append("recorded:   the bag holds no /car/accel/estimate")
        out += figure_table(columns, truth=self.has_truth)
        agreement = self.agreement
        if agreement is not None and agreement.n:
            out.append(
                f"recorded − re-run: RMS {agreement.rms:.3g}, max {agreement.max_abs:.3g} m/s² over "
                f"{agreement.n} estimates (0 when the live node computed what the re-run does)"
            )
        if self.calibration is not None or self.recorded_calibration is not None:
            out.append(f"changes:    {change_rule()} (the calibration's 'after a change')")
        if self.calibration is not None:
            out.append(self.calibration.line("calibration (re-run)"))
        if self.recorded_calibration is not None:
            out.append(self.recorded_calibration.line("calibration (recorded)"))
        return out


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


def analyze_bag(
    bag: Bag | Path | str,
    *,
    estimator: str | None = None,
    config: dict[str, float] | None = None,
    skip: float = 0.0,
    tolerance: float | None = None,
    lag: float = 0.0,
) -> Analysis:
    """Re-run ``estimator`` (default: the one the bag was recorded with, else the package default) on the
    bag's angles; compare it and the recorded estimate with the truth (a bag without a truth topic: the
    estimates' own figures only, ``Analysis.has_truth`` False).

    ``config`` overrides the estimator configuration taken from the bag's scene (length, gravity,
    noise_std, rate_hz); without a stored scene, ``length`` must be given. ``lag`` > 0 s re-runs the
    estimator as a fixed-lag smoother (kalman), each estimate aligned to the sample it describes.
    """
    if not skip >= 0.0:
        raise BagError(f"skip must be >= 0 s, got {skip!r}")
    if not (math.isfinite(lag) and lag >= 0.0):
        raise BagError(f"lag must be a finite number of seconds >= 0, got {lag!r}")
    if tolerance is not None and not tolerance > 0.0:
        raise BagError(f"tolerance must be > 0 m/s², got {tolerance!r}")
    data = bag if isinstance(bag, Bag) else read_bag(bag)
    if lag > max(data.duration_s, 0.0):
        # No estimate can use more later data than the recording holds (and the lag's ring of
        # lag·rate samples would not fit in memory long before 1e300 s).
        raise BagError(
            f"lag {lag:g} s is longer than the recording ({data.duration_s:.3f} s of {data.path}); "
            "for the whole recording use --estimator smoother"
        )
    joint_topic, truth_topic, estimate_topic = (
        require_angles(data),
        data.chain_topic(TOPIC_ACCEL_TRUTH),
        data.chain_topic(TOPIC_ACCEL_ESTIMATE),
    )
    stamp = ["header.stamp.sec", "header.stamp.nanosec"]
    has_truth = truth_topic in data.topics and truth_topic != joint_topic  # a real sensor's bag has none
    theta_field = angle_field(data)
    requests: dict[str, tuple[str | None, list[str] | None]] = {
        joint_topic: (JOINT_STATE, [*stamp, theta_field]),
    }
    if has_truth:
        requests[truth_topic] = (ACCEL_STAMPED, [*stamp, "accel.linear.x"])
    recorded_in_step = estimate_topic not in requests and _has_messages(data, estimate_topic)
    if recorded_in_step:
        requests[estimate_topic] = (ACCEL_WITH_COVARIANCE_STAMPED, [*stamp, *_ESTIMATE_FIELDS])
    decoded = decode_chain(data, requests)  # one pass over the file, the chain contract's check with it
    js = decoded[joint_topic]
    truth = decoded.get(truth_topic) if has_truth else None
    est = decoded.get(estimate_topic) if recorded_in_step else None
    del decoded
    if len(js) < 2:
        raise BagError(f"bag {data.path} holds {len(js)} joint states; at least 2 are needed")
    if truth is not None and len(truth) == 0:
        raise BagError(f"bag {data.path} holds no {TOPIC_ACCEL_TRUTH} messages to compare with")
    if truth is None and tolerance is not None:
        raise BagError(f"--tolerance is a settling band around the truth, and bag {data.path} has none")
    t = js.stamp
    order = np.argsort(t, kind="stable")
    t, theta = t[order], js[theta_field][order]
    del js, order
    truth_t: NDArray[np.float64] | None = None
    truth_a: NDArray[np.float64] | None = None
    if truth is not None:
        t_order = np.argsort(truth.stamp, kind="stable")
        truth_t, truth_a = truth.stamp[t_order], truth["accel.linear.x"][t_order]
        del t_order
    del truth  # the decoded columns: a long bag's memory goes to the re-run
    a_true = (
        np.full(t.size, math.nan) if truth_t is None or truth_a is None else np.interp(t, truth_t, truth_a)
    )
    given = config or {}
    measure = theta if "noise_std" not in given else None  # a σ given is not measured as well
    cfg = {**estimator_config(data, t, measure), **given}
    noise_measured = measure is not None and not data.custom_data.get(CUSTOM_SCENE) and "noise_std" in cfg
    if "length" not in cfg:
        raise BagError(f"bag {data.path} stores no scene: give the pendulum length (--length)")
    has_recorded = recorded_in_step or _has_messages(data, estimate_topic)
    recorded_method = recorded_estimator(data) if not estimator or has_recorded else None
    name = estimator or recorded_method or DEFAULT_ESTIMATOR
    if lag > 0.0:
        cfg["lag"] = lag
    motion = bag_motion(data) if uses_preset(name) else None
    options: dict[str, object] = {} if motion is None else {"preset": motion.preset}
    method = make_estimator(name, **cfg, **options)  # type: ignore[arg-type]
    if tolerance is not None:
        tol = float(tolerance)
    else:
        tol = default_tolerance(a_true) if truth_t is not None else DEFAULT_ABS_TOLERANCE
    recorded, recorded_cal = None, None
    if has_recorded:
        if est is None:  # its topic is also another role's: decoded on its own, as the contract allowed
            est = _decode_estimate(data, estimate_topic)
        # Before the re-run: its decoded columns are let go before the estimator's arrays are made.
        if truth_t is not None and truth_a is not None:
            recorded_cal = _recorded_calibration(est, truth_t, truth_a, t[0] + skip)
        recorded = _recorded_figures(est, recorded_method, t, truth_t, truth_a, tol, t[0] + skip)
        del est
    a_est, variance = method.batch(t, theta)
    motion_model = method.motion_model() or (motion.preset if motion is not None else None)
    a_est = np.asarray(a_est, dtype=np.float64)
    variance = np.asarray(variance, dtype=np.float64)
    offline = estimate_figures(
        "offline re-run", name, t, t, a_est, variance, None if truth_t is None else a_true, tol, t[0] + skip
    )
    return Analysis(
        path=data.path,
        scene=stored_scene_name(data),
        estimator=name,
        config=cfg,
        t=t,
        theta=theta,
        accel_true=a_true,
        accel_est=a_est,
        variance=variance,
        skip=skip,
        tolerance=tol,
        stats=offline.stats,
        settled_stats=offline.settled_stats,
        settle_from=offline.settle_from,
        settling_time=offline.settling_time,
        recorded=recorded.stats if recorded is not None else None,
        problem=data.problem,
        offline_figures=offline,
        recorded_figures=recorded,
        calibration=(
            None
            if truth_t is None or truth_a is None
            else calibration(t, a_est - a_true, variance, truth_t, truth_a, t[0] + skip)
        ),
        recorded_calibration=recorded_cal,
        motion=motion,
        motion_model=motion_model,
        has_truth=truth_t is not None,
        noise_from_angles=noise_measured,
    )


_ESTIMATE_FIELDS = ["accel.accel.linear.x", "accel.covariance[0]"]
"""The recorded estimate's fields analyze reads (besides its stamp): â and its variance."""


def _has_messages(bag: Bag, topic: str) -> bool:
    """True when the bag holds ``topic`` with at least one message."""
    return topic in bag.topics and bag.topics[topic].count > 0


def _decode_estimate(bag: Bag, topic: str) -> TopicArrays:
    """The recorded estimate's stamps, â and variance (log-time order)."""
    return bag.decode(
        topic,
        ACCEL_WITH_COVARIANCE_STAMPED,
        fields=["header.stamp.sec", "header.stamp.nanosec", *_ESTIMATE_FIELDS],
    )


def _recorded_calibration(
    est: TopicArrays, t_truth: NDArray[np.float64], a_truth: NDArray[np.float64], t_from: float
) -> Calibration:
    """NEES figures of the recorded estimate ``est`` (log-time order) and its covariance[0]."""
    te = est.stamp
    error = est["accel.accel.linear.x"] - np.interp(te, t_truth, a_truth)
    return calibration(te, error, est["accel.covariance[0]"], t_truth, a_truth, t_from)


def recorded_estimator(bag: Bag) -> str | None:
    """The method that produced the bag's estimates: custom_data's, else the first /diagnostics report's
    ``method`` value (the estimator node reports it), None when neither says."""
    stored = bag.custom_data.get(CUSTOM_ESTIMATOR)
    if stored in ESTIMATORS:
        return stored
    topic = bag.chain_topic(TOPIC_DIAGNOSTICS)
    if topic not in bag.topics:
        return None
    for data in itertools.islice(bag.raw_payloads(topic), 10):  # reads no further than the first that says
        try:
            msg = deserialize_as(data, DIAGNOSTIC_ARRAY, DiagnosticArrayMsg)
        except BagError:
            continue
        for status in msg.status:
            for kv in status.values:
                if kv.key == "method" and kv.value in ESTIMATORS:
                    return str(kv.value)
    return None


def _recorded_figures(
    est: TopicArrays,
    method: str | None,
    angle_t: NDArray[np.float64],
    t_truth: NDArray[np.float64] | None,
    a_truth: NDArray[np.float64] | None,
    tolerance: float,
    skip_until: float,
) -> EstimateFigures:
    """Figures of the estimate ``est`` recorded in the bag (the live estimator, ``method``), against the
    truth (t_truth, a_truth) when the bag has one."""
    order = np.argsort(est.stamp, kind="stable")
    te = est.stamp[order]
    ae = est["accel.accel.linear.x"][order]
    ve = est["accel.covariance[0]"][order]
    truth = None if t_truth is None or a_truth is None else np.interp(te, t_truth, a_truth)
    return estimate_figures(
        "recorded", method or "unknown", angle_t, te, ae, ve, truth, tolerance, skip_until
    )


def smoothable(bag: Bag, config: Mapping[str, float] | None = None) -> bool:
    """True when the bag has at least 2 angles and a sensor to configure the smoother with: its stored
    scene, or a ``config`` naming the length (a real sensor's bag): what smoothed_estimate needs."""
    angles = bag.topics.get(bag.chain_topic(TOPIC_JOINT_STATES))
    told = config is not None and "length" in config
    return angles is not None and angles.count >= 2 and (told or bool(bag.custom_data.get(CUSTOM_SCENE)))


def smoothed_estimate(
    bag: Bag, config: Mapping[str, float] | None = None
) -> dict[str, NDArray[np.float64]] | None:
    """{t, a, variance}: the kalman model's smoother (``smoother``) over the bag's angles, configured from
    its stored scene with ``config`` overriding it (length, noise_std); None when neither gives a length
    or the bag has fewer than 2 angles (nothing to configure or smooth)."""
    if not smoothable(bag, config):
        return None
    field = angle_field(bag)
    js = bag.decode(
        bag.chain_topic(TOPIC_JOINT_STATES),
        JOINT_STATE,
        fields=["header.stamp.sec", "header.stamp.nanosec", field],
    )
    if len(js) < 2:
        return None
    t, theta = js.stamp, js[field]
    del js  # only t and θ are held while the smoother runs
    if np.any(np.diff(t) < 0.0):
        order = np.argsort(t, kind="stable")
        t, theta = t[order], theta[order]
    keep = np.concatenate(([True], np.diff(t) > 0.0))  # a repeated stamp: the first sample only
    if not keep.all():
        t, theta = t[keep], theta[keep]
    del keep
    given = config or {}
    cfg = {**estimator_config(bag, t, theta if "noise_std" not in given else None), **given}
    a, var = estimate_batch("smoother", t, theta, **cfg, preset=bag_motion(bag).preset)
    return {"t": t, "a": np.asarray(a, dtype=np.float64), "variance": np.asarray(var, dtype=np.float64)}


def bag_motion(bag: Bag) -> MotionChoice:
    """kalman's preset for the bag's re-run: its stored scene's (recording.settings.motion_choice), which is
    the one its recording chose; without a stored scene, the default preset."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    if not text:
        return MotionChoice(DEFAULT_PRESET, "the bag stores no scene: the default preset")
    return motion_choice(scene_but_motion(text))


def estimator_config(
    bag: Bag, t: NDArray[np.float64], theta: NDArray[np.float64] | None = None
) -> dict[str, float]:
    """length, gravity, noise_std, rate_hz from the bag's stored scene; otherwise the rate from the stamps
    and, given the angles ``theta``, noise_std from them (sensor.noise_from_angles: a real sensor's bag
    says neither, and a default σ would make the published variance a guess)."""
    cfg: dict[str, float] = {}
    dt = np.diff(t)
    dt = dt[dt > 0]
    if dt.size:
        cfg["rate_hz"] = float(1.0 / np.median(dt))
    text = bag.custom_data.get(CUSTOM_SCENE)
    if text:
        cfg.update(_scene_config(text))
    elif theta is not None and (noise := noise_from_angles(theta)) is not None:
        cfg["noise_std"] = noise
    return cfg


def _scene_config(text: str) -> dict[str, float]:
    """Estimator settings of a scene stored as YAML text; BagError when it no longer loads."""
    return estimator_settings(scene_but_motion(text))


@functools.lru_cache(maxsize=4)
def scene_but_motion(text: str) -> Scene:
    """The stored scene with a(t) = 0 in place of its profile (scene.scene_text_without_motion), for what
    does not depend on a(t): its name, estimator settings and motion key; the whole scene when the text
    is not laid out as recorders write it. BagError when it no longer loads."""
    light = scene_text_without_motion(text)
    return _stored_scene(text if light is None else light)


def stored_scene_name(bag: Bag) -> str | None:
    """The name of the scene the bag stores, None when it stores none or it no longer loads."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    if not text:
        return None
    try:
        return scene_but_motion(text).name
    except BagError:
        return None


@functools.lru_cache(maxsize=4)
def _stored_scene(text: str) -> Scene:
    """The scene a bag stores as YAML text; BagError when it no longer loads."""
    try:
        return scene_from_yaml(text, label="the scene stored in the bag")
    except PendulumAccelError as err:
        raise BagError(f"{err}; give --length (and --noise-std) instead") from None


def stored_scene(bag: Bag) -> Scene | None:
    """The scene the bag was recorded from (custom data), None when it stores none."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    return _stored_scene(text) if text else None


def plot_analysis(result: Analysis, out: Path | str) -> Path:
    """Three panels, shared time axis: θ (deg); truth, recorded estimate (holes shaded) and re-run; both
    errors with the ±tolerance band (without a truth: each stream's published 2σ instead)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True, constrained_layout=True)
    t = result.t
    axes[0].plot(t, np.degrees(result.theta), lw=0.8, color="tab:gray")
    axes[0].set_ylabel("θ (deg)")
    shown = "recorded estimate and " if result.recorded_figures is not None else ""
    title = f"{result.scene or result.path.name}: {shown}{result.estimator} re-run"
    axes[0].set_title(title)
    rec = result.recorded_figures
    if result.has_truth:
        axes[1].plot(t, result.accel_true, lw=1.5, color="black", label="truth a(t)")
    if rec is not None:
        axes[1].plot(rec.t, rec.accel, lw=1.6, color="tab:orange", label=f"recorded ({rec.estimator})")
        for hole in rec.holes:
            axes[1].axvspan(hole.start, hole.end, color="tab:red", alpha=0.12)
    axes[1].plot(t, result.accel_est, lw=0.9, color="tab:blue", label=f"offline re-run ({result.estimator})")
    axes[1].set_ylabel("a (m/s²)")
    axes[1].legend(loc="best")
    if not result.has_truth:
        _plot_sigma(axes[2], result)
        return _save(fig, out)
    if rec is not None:
        rec_error = rec.accel - np.interp(rec.t, t, result.accel_true)
        axes[2].plot(rec.t, rec_error, lw=1.2, color="tab:orange", label="recorded â − a")
    axes[2].plot(t, result.error, lw=0.8, color="tab:blue", label="re-run â − a")
    axes[2].axhspan(-result.tolerance, result.tolerance, color="tab:green", alpha=0.15, label="± tolerance")
    if result.settling_time is not None:
        axes[2].axvline(
            result.settle_from + result.settling_time,
            color="tab:green",
            ls="--",
            lw=1,
            label="re-run settled",
        )
    axes[2].set_ylabel("error (m/s²)")
    axes[2].set_xlabel("t (s)")
    axes[2].legend(loc="best")
    titles = [f"{f.source}: RMS {f.stats.rms:.4f}, max {f.stats.max_abs:.4f} m/s²"
              for f in (rec, result.offline_figures) if f is not None]  # fmt: skip
    axes[2].set_title("; ".join(titles), fontsize=9)
    return _save(fig, out)


def _plot_sigma(ax: Any, result: Analysis) -> None:
    """The error panel of a bag without a truth: each stream's published 2σ = 2√var over time."""
    for f, lw, color in (
        (result.recorded_figures, 1.2, "tab:orange"),
        (result.offline_figures, 0.8, "tab:blue"),
    ):
        if f is not None:
            sigma = np.sqrt(np.where(f.variance >= 0.0, f.variance, np.nan))
            ax.plot(f.t, 2.0 * sigma, lw=lw, color=color, label=f"{f.source} 2σ")
    ax.set_ylabel("2σ (m/s²)")
    ax.set_xlabel("t (s)")
    ax.set_title(f"no truth in the bag ({TOPIC_ACCEL_TRUTH}): the estimates' published 2σ", fontsize=9)
    ax.legend(loc="best")


def _save(fig: Any, out: Path | str) -> Path:
    """Grid on every panel, save at 110 dpi (parent directories made), close; the path."""
    import matplotlib.pyplot as plt

    for ax in fig.axes:
        ax.grid(True, alpha=0.3)
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def analysis_dict(result: Analysis) -> dict[str, object]:
    """Figures of an analysis for tables and JSON: the re-run's main figures at the top level (as before),
    then "recorded" and "offline" with every figure of each stream (recorded: None without estimates)."""
    return {
        "bag": str(result.path),
        "scene": result.scene,
        "estimator": result.estimator,
        "motion_model": result.motion_model,
        "motion_reason": result.motion.reason if result.motion is not None else None,
        "truth": result.has_truth,
        "noise_std_from_angles": result.noise_from_angles,
        "change_rule": change_rule(),
        "bias": result.stats.bias,
        "rms": result.stats.rms,
        "max_error": result.stats.max_abs,
        "settling_time": result.settling_time,
        "tolerance": result.tolerance if result.has_truth else None,
        "samples": result.stats.n,
        "recorded": result.recorded_figures.as_dict() if result.recorded_figures is not None else None,
        **_agreement_fields(result.agreement),
        "offline": result.offline_figures.as_dict(),
        **_calibration_fields("", result.calibration),
        **_calibration_fields("recorded_", result.recorded_calibration),
    }


def _agreement_fields(stats: ErrorStats | None) -> dict[str, float | int | None]:
    """recorded_vs_offline_{rms,max,samples}: Analysis.agreement's figures; None without a recording."""
    if stats is None or stats.n == 0:
        return {
            "recorded_vs_offline_rms": None,
            "recorded_vs_offline_max": None,
            "recorded_vs_offline_samples": 0,
        }
    return {
        "recorded_vs_offline_rms": stats.rms,
        "recorded_vs_offline_max": stats.max_abs,
        "recorded_vs_offline_samples": stats.n,
    }


def _calibration_fields(prefix: str, cal: Calibration | None) -> dict[str, str | float | int | None]:
    """nees_fields of both windows under {prefix}nees_{steady,after_change}; None without a calibration."""
    out: dict[str, str | float | int | None] = {}
    for window in ("steady", "after_change"):
        out.update(nees_fields(f"{prefix}nees_{window}", None if cal is None else getattr(cal, window)))
    return out


def nees_fields(key: str, stats: NeesStats | None) -> dict[str, str | float | int | None]:
    """{key}_{mean,median,share_2sigma,trials,share_2sigma_low,share_2sigma_high}: one window's figures,
    the share's independent trials and 95 % interval (coverage.share_interval_cells); None without the
    window or where a share or its trials is missing, and a mean or median the window lacks stays NaN
    (cli.output.json_text writes both as null)."""
    out: dict[str, str | float | int | None] = {}
    for name in ("mean", "median"):
        out[f"{key}_{name}"] = None if stats is None else getattr(stats, name)
    share, trials = (math.nan, math.nan) if stats is None else (stats.share_2sigma, stats.trials)
    out.update(coverage.share_interval_cells(share, trials, f"{key}_share_2sigma", f"{key}_trials"))
    return out
