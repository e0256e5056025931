"""InputGuard: every diagnostic state provoked (NaN, reorder, time jump, near 90°, stale) and the wrapper."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import make_estimator
from pendulum_accel.estimators.guard import Decision, GuardedEstimator, GuardReport, GuardState, InputGuard


def feed(guard: InputGuard, n: int, t0: float = 0.0, theta: float = 0.05) -> None:
    """n good samples at 200 Hz from t0."""
    for k in range(n):
        assert guard.check(t0 + k / 200.0, theta) is Decision.ACCEPT


def test_normal_input_is_ok_with_counters_as_key_values() -> None:
    guard = InputGuard(rate_hz=200.0)
    feed(guard, 10)
    report = guard.report()
    assert report.state is GuardState.OK and report.level == 0
    assert report.message == "input normal: 10 samples accepted"
    values = dict(report.values)
    assert values["accepted"] == "10" and values["dropped_nonfinite"] == "0"
    assert all(isinstance(k, str) and isinstance(v, str) for k, v in report.values)


@pytest.mark.parametrize(
    ("t", "theta"), [(0.1, math.nan), (0.1, math.inf), (math.nan, 0.1), (-math.inf, 0.0)]
)
def test_nonfinite_input_is_dropped_as_error(t: float, theta: float) -> None:
    guard = InputGuard()
    feed(guard, 3)
    assert guard.check(t, theta) is Decision.DROP
    report = guard.report()
    assert report.state is GuardState.ERROR and report.level == 2
    assert "non-finite" in report.message
    assert dict(report.values)["dropped_nonfinite"] == "1"


def test_worst_state_is_latched_until_reported_then_rearmed() -> None:
    """A NaN between two diagnostics publications is still reported, once."""
    guard = InputGuard()
    feed(guard, 3)
    guard.check(0.02, math.nan)
    feed(guard, 5, t0=0.03)
    assert guard.report().state is GuardState.ERROR
    assert guard.report().state is GuardState.OK


def test_small_reorder_and_duplicate_are_dropped_with_warning() -> None:
    guard = InputGuard(reset_jump=1.0)
    feed(guard, 10)  # last t = 0.045
    assert guard.check(0.045, 0.05) is Decision.DROP  # duplicate stamp
    assert guard.check(0.030, 0.05) is Decision.DROP  # 15 ms back
    report = guard.report()
    assert report.state is GuardState.WARN and report.level == 1
    assert "out-of-order" in report.message
    assert dict(report.values)["dropped_out_of_order"] == "2"
    assert guard.last_t == pytest.approx(0.045)


def test_large_jump_back_resets() -> None:
    """A looping bag: t goes from 12 s back to 0 s."""
    guard = InputGuard(reset_jump=1.0)
    feed(guard, 5, t0=12.0)
    assert guard.check(0.0, 0.05) is Decision.RESET
    report = guard.report()
    assert report.state is GuardState.RESET and report.level == 1
    assert "jumped back by 12.020 s" in report.message
    assert dict(report.values)["resets"] == "1"
    assert guard.check(0.005, 0.05) is Decision.ACCEPT  # the new timeline continues


@pytest.mark.parametrize(
    ("degrees", "words"), [(85.0, "ill-conditioned"), (90.0, "clamped"), (120.0, "clamped")]
)
def test_near_90_degrees_warns_but_accepts(degrees: float, words: str) -> None:
    guard = InputGuard(warn_angle=math.radians(80.0))
    assert guard.check(0.0, -math.radians(degrees)) is Decision.ACCEPT
    report = guard.report()
    assert report.state is GuardState.WARN and words in report.message
    assert f"{degrees:.1f}°" in report.message


def test_stale_after_silence_and_recovery() -> None:
    guard = InputGuard(rate_hz=200.0, stale_after=0.5)
    guard.check(0.0, 0.0, now=100.0)
    assert not guard.check_stale(100.4)
    assert guard.report().state is GuardState.OK
    assert guard.check_stale(100.8)
    report = guard.report()
    assert report.state is GuardState.STALE and report.level == 3
    assert "no input for 0.80 s" in report.message
    assert guard.check_stale(101.5)  # still stale on the next timer tick
    assert guard.report().state is GuardState.STALE
    guard.check(0.005, 0.0, now=101.6)
    assert not guard.check_stale(101.7)
    assert guard.report().state is GuardState.OK


def test_stale_when_nothing_ever_arrived() -> None:
    guard = InputGuard(stale_after=1.0)
    assert not guard.check_stale(5.0)  # first tick starts the clock
    assert guard.check_stale(6.5)
    assert guard.report().state is GuardState.STALE


def test_default_stale_threshold_and_validation() -> None:
    assert InputGuard(rate_hz=200.0).stale_after == 0.5
    assert InputGuard(rate_hz=10.0).stale_after == pytest.approx(2.0)
    with pytest.raises(ParameterError, match="rate_hz"):
        InputGuard(rate_hz=0.0)


def test_default_stale_limit_follows_a_changed_rate() -> None:
    """A node's rate_hz changed after start: the default limit is 20 periods of the new rate (a 10 Hz
    input had gone STALE after 0.5 s, the limit of the 200 Hz it was built with); a limit given stays."""
    guard = InputGuard(rate_hz=200.0)
    guard.rate_hz = 10.0
    assert guard.stale_after == pytest.approx(2.0)
    assert not guard.check_stale(0.0)
    assert not guard.check_stale(1.5)  # 15 periods of silence at 10 Hz: not stale
    assert guard.check_stale(2.5)
    given = InputGuard(rate_hz=200.0, stale_after=0.7)
    given.rate_hz = 10.0
    assert given.stale_after == 0.7
    with pytest.raises(ParameterError, match="rate_hz"):
        guard.rate_hz = -1.0
    with pytest.raises(ParameterError, match="reset_jump"):
        InputGuard(reset_jump=0.0)


def test_guarded_estimator_replays_a_looping_bag_identically_and_never_emits_nonfinite() -> None:
    rng = np.random.default_rng(5)
    t = np.arange(800) / 200.0
    theta = 0.2 + 0.05 * np.sin(4.4 * t) + 1e-3 * rng.standard_normal(t.size)
    theta[[100, 300]] = np.nan
    theta[500] = np.inf
    wrapped = GuardedEstimator(make_estimator("kalman", length=0.5, noise_std=1e-3, rate_hz=200.0))
    first = [wrapped.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    second = [wrapped.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    assert first == second  # the jump back reset the estimator, so the replay is bit-identical
    assert sum(o is None for o in first) == 3
    assert all(math.isfinite(o.a) and math.isfinite(o.variance) for o in first + second if o is not None)
    guard = wrapped.guard
    assert guard.resets == 1 and guard.dropped_nonfinite == 6
    assert guard.report().state is GuardState.ERROR  # worst since the last report


def test_saturated_readings_warn_and_are_counted() -> None:
    """With the sensor's range R, a reading at ±R is WARN 'saturated' and counted; inside it, OK."""
    guard = InputGuard(rate_hz=100.0, saturation_range=0.5)
    assert guard.check(0.00, 0.2) is Decision.ACCEPT
    assert guard.report().state is GuardState.OK
    guard.check(0.01, 0.5)
    guard.check(0.02, -0.5)
    report = guard.report()
    assert report.state is GuardState.WARN and "saturated" in report.message
    assert dict(report.values)["saturated"] == "2"
    with pytest.raises(ParameterError, match="saturation_range must be >= 0"):
        InputGuard(saturation_range=-1.0)


def _fed(rate_hz: float, stamps: np.ndarray) -> InputGuard:
    """A guard at ``rate_hz`` that accepted a sample at each of ``stamps``."""
    guard = InputGuard(rate_hz=rate_hz)
    for t in stamps:
        assert guard.check(float(t), 0.01) is Decision.ACCEPT
    return guard


def test_an_input_rate_other_than_rate_hz_warns_and_is_reported() -> None:
    """A 400 Hz sensor read by a node at rate_hz 100 (the fixed lag would be a quarter as long as asked):
    WARN naming both rates; the measured rate is a diagnostics value. At the configured rate, with 30 %
    of the samples lost and ±20 % jitter, the median interval is the sensor's: OK. Before a full window the
    rate is shown, not warned about."""
    guard = _fed(100.0, np.arange(200) / 400.0)
    report = guard.report()
    assert report.state is GuardState.WARN
    assert "input at 400 Hz by its stamps, not rate_hz 100 Hz" in report.message
    # 1/400 s steps of integer multiples: the median Δt is 1/400 s to a few ulps of the stamps' division.
    assert float(dict(report.values)["input_rate_hz"]) == pytest.approx(400.0, rel=1e-9)
    rng = np.random.default_rng(3)
    stamps = np.arange(400) / 100.0 + rng.uniform(-0.002, 0.002, 400)  # ±20 % of a period
    kept = np.sort(stamps[rng.random(400) > 0.3])
    lossy = _fed(100.0, kept)
    report = lossy.report()
    assert report.state is GuardState.OK, report.message
    rate = float(dict(report.values)["input_rate_hz"])
    assert abs(rate / 100.0 - 1.0) <= 0.1  # within the tolerance that warns
    early = _fed(
        100.0, np.arange(10) / 400.0
    ).report()  # shown from the second sample, warned on a full window
    assert early.state is GuardState.OK and float(dict(early.values)["input_rate_hz"]) == pytest.approx(400.0)
    assert dict(_fed(100.0, np.zeros(1)).report().values)["input_rate_hz"] == "none"


def test_an_angle_noise_other_than_noise_std_warns_and_is_reported() -> None:
    """A 4 mrad sensor read by a node told noise_std 1 mrad (the published variance 16× too small in its
    noise part): WARN naming both; the measured noise is a diagnostics value. Told 4 mrad, or 3 mrad (within
    the factor 2): OK. A quantised angle at rest (third differences all 0) and no noise_std: no check."""
    t = np.arange(600) / 100.0
    swing = 0.2 * np.sin(2.0 * np.pi * 0.5 * t)  # a slow swing: its third differences are ~1e-5 rad
    theta = swing + np.random.default_rng(2).normal(0.0, 4e-3, t.size)

    def report(noise_std: float | None, angles: np.ndarray) -> GuardReport:
        guard = InputGuard(rate_hz=100.0, noise_std=noise_std)
        for ti, th in zip(t, angles, strict=True):
            assert guard.check(float(ti), float(th)) is Decision.ACCEPT
        return guard.report()

    told_less = report(1e-3, theta)
    assert (
        told_less.state is GuardState.WARN and "not noise_std 0.001 rad: set noise_std" in told_less.message
    )
    # A robust scale of 256 third differences: ~7 % standard error; 25 % is over three of them.
    assert float(dict(told_less.values)["angle_noise_rad"]) == pytest.approx(4e-3, rel=0.25)
    assert report(4e-3, theta).state is GuardState.OK
    assert report(3e-3, theta).state is GuardState.OK
    assert report(1e-3, np.zeros(t.size)).state is GuardState.OK
    assert report(None, theta).state is GuardState.OK
