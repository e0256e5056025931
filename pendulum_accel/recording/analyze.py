"""Analysis of a bag: the estimate it recorded (live) and an offline re-run, each against the recorded truth.

A bag without a truth topic (a real sensor's recording: nobody knows a(t)) gets the figures that need
none: counts and holes, the estimates' mean and range and the median published σ; the error figures are
left out (null in JSON).

Error e(t) = â(t) − a(t) at the estimate's stamps (truth interpolated onto them). For each of the two
estimate streams (:class:`EstimateFigures`): how many angles got an estimate and where the stream has
holes (runs of angles without one), bias = mean e, RMS = √(mean e²), max |e| (over the samples after
``skip`` seconds that have an estimate), the settling time (from the truth's own last change, step or
end of ramp, to the time after which |e| stays within the tolerance to the end of the bag) and the same
figures over the settled samples (recording.figures), and the calibration of each stream's published σ
(recording.coverage). The re-run uses the estimator the bag was recorded with unless told, configured from
the bag's stored scene (recording.stored_scene).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

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
    DiagnosticArrayMsg,
    deserialize_as,
)
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.shapes import TopicArrays
from pendulum_accel.bag.writer import CUSTOM_ESTIMATOR, CUSTOM_SCENE
from pendulum_accel.errors import BagError, ParameterError
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, TEACHING_NOTE, make_estimator
from pendulum_accel.estimators.motion import MotionChoice
from pendulum_accel.recording.changes import change_rule
from pendulum_accel.recording.contract import angle_field, decode_chain, require_angles
from pendulum_accel.recording.coverage import GAUSSIAN_NOTE, Calibration, calibration, nees_cells
from pendulum_accel.recording.figures import (
    DEFAULT_ABS_TOLERANCE,
    ErrorStats,
    EstimateFigures,
    EstimateFiguresDict,
    default_tolerance,
    estimate_figures,
    figure_table,
)
from pendulum_accel.recording.settings import uses_preset
from pendulum_accel.recording.stored_scene import bag_motion, estimator_config, stored_scene_name


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
        if self.calibration is not None or self.recorded_calibration is not None:
            out.append(f"            ({GAUSSIAN_NOTE})")
        return out


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
        raise ParameterError(f"skip must be >= 0 s, got {skip!r}")
    if not (math.isfinite(lag) and lag >= 0.0):
        raise ParameterError(f"lag must be a finite number of seconds >= 0, got {lag!r}")
    if tolerance is not None and not tolerance > 0.0:
        raise ParameterError(f"tolerance must be > 0 m/s², got {tolerance!r}")
    data = bag if isinstance(bag, Bag) else read_bag(bag)
    if lag > max(data.duration_s, 0.0):
        # No estimate can use more later data than the recording holds (and the lag's ring of
        # lag·rate samples would not fit in memory long before 1e300 s).
        raise ParameterError(
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
        raise ParameterError(f"--tolerance is a settling band around the truth, and bag {data.path} has none")
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
    method = (
        make_estimator(name, **cfg) if motion is None else make_estimator(name, **cfg, preset=motion.preset)
    )
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


class AnalysisDict(TypedDict):
    """analysis_dict: the figures ``analyze --json`` prints (None: a figure that does not exist, JSON null;
    a NaN figure is written as null too, by cli.output.json_text). The nees_* keys are the re-run's
    calibration windows (coverage.nees_cells), the recorded_nees_* ones the recorded estimate's."""

    bag: str
    scene: str | None
    estimator: str
    motion_model: str | None
    motion_reason: str | None
    truth: bool
    noise_std_from_angles: bool
    change_rule: str
    bias: float
    rms: float
    max_error: float
    settling_time: float | None
    tolerance: float | None
    samples: int
    recorded: EstimateFiguresDict | None
    recorded_vs_offline_rms: float | None
    recorded_vs_offline_max: float | None
    recorded_vs_offline_samples: int
    offline: EstimateFiguresDict
    nees_steady_mean: float | None
    nees_steady_median: float | None
    nees_steady_share_2sigma: float | None
    nees_steady_trials: float | None
    nees_steady_share_2sigma_low: float | None
    nees_steady_share_2sigma_high: float | None
    nees_steady_share_3sigma: float | None
    nees_after_change_mean: float | None
    nees_after_change_median: float | None
    nees_after_change_share_2sigma: float | None
    nees_after_change_trials: float | None
    nees_after_change_share_2sigma_low: float | None
    nees_after_change_share_2sigma_high: float | None
    nees_after_change_share_3sigma: float | None
    recorded_nees_steady_mean: float | None
    recorded_nees_steady_median: float | None
    recorded_nees_steady_share_2sigma: float | None
    recorded_nees_steady_trials: float | None
    recorded_nees_steady_share_2sigma_low: float | None
    recorded_nees_steady_share_2sigma_high: float | None
    recorded_nees_steady_share_3sigma: float | None
    recorded_nees_after_change_mean: float | None
    recorded_nees_after_change_median: float | None
    recorded_nees_after_change_share_2sigma: float | None
    recorded_nees_after_change_trials: float | None
    recorded_nees_after_change_share_2sigma_low: float | None
    recorded_nees_after_change_share_2sigma_high: float | None
    recorded_nees_after_change_share_3sigma: float | None


def analysis_dict(result: Analysis) -> AnalysisDict:
    """Figures of an analysis for tables and JSON: the re-run's main figures at the top level (as before),
    then "recorded" and "offline" with every figure of each stream (recorded: None without estimates),
    the recorded − re-run agreement, and both calibrations' NEES windows (None without a truth)."""
    agreement = result.agreement
    agreed = agreement if agreement is not None and agreement.n > 0 else None
    cal, rec_cal = result.calibration, result.recorded_calibration
    steady = nees_cells(None if cal is None else cal.steady)
    after = nees_cells(None if cal is None else cal.after_change)
    rec_steady = nees_cells(None if rec_cal is None else rec_cal.steady)
    rec_after = nees_cells(None if rec_cal is None else rec_cal.after_change)
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
        # Analysis.agreement's figures; None (0 samples) without a recording to compare.
        "recorded_vs_offline_rms": agreed.rms if agreed is not None else None,
        "recorded_vs_offline_max": agreed.max_abs if agreed is not None else None,
        "recorded_vs_offline_samples": agreed.n if agreed is not None else 0,
        "offline": result.offline_figures.as_dict(),
        "nees_steady_mean": steady.mean,
        "nees_steady_median": steady.median,
        "nees_steady_share_2sigma": steady.share_2sigma,
        "nees_steady_trials": steady.trials,
        "nees_steady_share_2sigma_low": steady.share_2sigma_low,
        "nees_steady_share_2sigma_high": steady.share_2sigma_high,
        "nees_steady_share_3sigma": steady.share_3sigma,
        "nees_after_change_mean": after.mean,
        "nees_after_change_median": after.median,
        "nees_after_change_share_2sigma": after.share_2sigma,
        "nees_after_change_trials": after.trials,
        "nees_after_change_share_2sigma_low": after.share_2sigma_low,
        "nees_after_change_share_2sigma_high": after.share_2sigma_high,
        "nees_after_change_share_3sigma": after.share_3sigma,
        "recorded_nees_steady_mean": rec_steady.mean,
        "recorded_nees_steady_median": rec_steady.median,
        "recorded_nees_steady_share_2sigma": rec_steady.share_2sigma,
        "recorded_nees_steady_trials": rec_steady.trials,
        "recorded_nees_steady_share_2sigma_low": rec_steady.share_2sigma_low,
        "recorded_nees_steady_share_2sigma_high": rec_steady.share_2sigma_high,
        "recorded_nees_steady_share_3sigma": rec_steady.share_3sigma,
        "recorded_nees_after_change_mean": rec_after.mean,
        "recorded_nees_after_change_median": rec_after.median,
        "recorded_nees_after_change_share_2sigma": rec_after.share_2sigma,
        "recorded_nees_after_change_trials": rec_after.trials,
        "recorded_nees_after_change_share_2sigma_low": rec_after.share_2sigma_low,
        "recorded_nees_after_change_share_2sigma_high": rec_after.share_2sigma_high,
        "recorded_nees_after_change_share_3sigma": rec_after.share_3sigma,
    }
