"""Sensor model: sample times, Gazebo-style noise knobs, determinism, and clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendulum_accel.errors import ParameterError
from pendulum_accel.sensor import SensorModel


def test_sample_times_cover_the_duration_at_the_rate() -> None:
    """t_k = k/f on [0, T]: 1001 samples for 10 s at 100 Hz, spacing 1/f to 1e-12 s."""
    t = SensorModel(100.0).sample_times(10.0)
    assert t.size == 1001
    assert t[0] == 0.0
    # t_k = k/f rounded once: ulp(10) = 1.8e-15
    assert t[-1] == pytest.approx(10.0, abs=1e-12)
    assert np.allclose(np.diff(t), 0.01, atol=1e-12)
    # A duration that is not a whole number of periods stops at the last sample inside it.
    assert SensorModel(3.0).sample_times(1.0).size == 4
    assert SensorModel(3.0).sample_times(1.2).size == 4


def test_noise_free_sensor_returns_the_angle_exactly() -> None:
    """All knobs 0: y = θ bit for bit."""
    t = np.linspace(0.0, 1.0, 101)
    theta = np.sin(t)
    assert np.array_equal(SensorModel(100.0).measure(t, theta), theta)


def test_same_seed_same_bits_and_other_seed_differs() -> None:
    """Determinism: identical output for one seed; a different seed gives different noise."""
    sensor = SensorModel(100.0, noise_std=1e-3, bias=2e-3, bias_random_walk=1e-4, quantization=1e-5, seed=42)
    t = sensor.sample_times(5.0)
    theta = 0.1 * np.cos(3.0 * t)
    first = sensor.measure(t, theta)
    assert np.array_equal(first, sensor.measure(t, theta))
    other = SensorModel(100.0, noise_std=1e-3, bias=2e-3, bias_random_walk=1e-4, quantization=1e-5, seed=43)
    assert not np.array_equal(first, other.measure(t, theta))


def test_white_noise_and_bias_statistics() -> None:
    """σ within 2% (n = 200 000, the std's own 1σ spread is 0.16%) and mean = bias within 5σ/√n."""
    sensor = SensorModel(1000.0, noise_std=2e-3, bias=5e-3, seed=7)
    t = sensor.sample_times(199.999)
    error = sensor.measure(t, np.zeros_like(t))
    assert np.std(error) == pytest.approx(2e-3, rel=0.02)
    assert abs(np.mean(error) - 5e-3) < 5 * 2e-3 / math.sqrt(t.size)


def test_bias_random_walk_increments_have_sigma_b_sqrt_dt() -> None:
    """β_k − β_{k−1} ~ N(0, σ_b² Δt): increment std within 2% of σ_b √Δt; the walk starts at 0."""
    sensor = SensorModel(100.0, bias_random_walk=1e-3, seed=3)
    t = sensor.sample_times(1000.0)
    walk = sensor.measure(t, np.zeros_like(t))
    assert walk[0] == 0.0
    assert np.std(np.diff(walk)) == pytest.approx(1e-3 * math.sqrt(0.01), rel=0.02)


def test_knobs_share_the_same_draws() -> None:
    """Turning the bias walk on does not change the white-noise draws (fixed draw order)."""
    t = np.linspace(0.0, 1.0, 11)
    white = SensorModel(10.0, noise_std=1e-3, seed=5).measure(t, np.zeros_like(t))
    both = SensorModel(10.0, noise_std=1e-3, bias_random_walk=1e-2, seed=5).measure(t, np.zeros_like(t))
    walk = SensorModel(10.0, bias_random_walk=1e-2, seed=5).measure(t, np.zeros_like(t))
    # the same draws added in another order: 1 rounding of |white + walk| ≤ ~0.05 rad (≈ 7e-18) each way
    assert np.allclose(both, white + walk, rtol=0.0, atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(
    q=st.floats(1e-6, 1e-1),
    values=st.lists(st.floats(-10.0, 10.0), min_size=1, max_size=50),
)
def test_quantization_rounds_to_the_nearest_step(q: float, values: list[float]) -> None:
    """Q(x) = q round(x/q): every output is a multiple of q and within q/2 (+1 ulp slack) of the input."""
    theta = np.array(values)
    t = np.arange(theta.size, dtype=float)
    y = SensorModel(1.0, quantization=q).measure(t, theta)
    assert np.all(np.abs(y - theta) <= 0.5 * q * (1 + 1e-9) + 1e-15)
    assert np.allclose(y / q, np.round(y / q), rtol=0.0, atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"rate_hz": math.nan}, "rate_hz"),
        ({"rate_hz": 10.0, "noise_std": -1e-3}, "noise_std"),
        ({"rate_hz": 10.0, "bias": math.inf}, "bias"),
        ({"rate_hz": 10.0, "bias_random_walk": -1.0}, "bias_random_walk"),
        ({"rate_hz": 10.0, "quantization": -1.0}, "quantization"),
        ({"rate_hz": 10.0, "seed": -1}, "seed"),
        ({"rate_hz": 10.0, "seed": True}, "seed"),
        ({"rate_hz": 10.0, "seed": 1.5}, "seed"),
    ],
)
def test_bad_settings_name_the_field(kwargs: dict[str, float], field: str) -> None:
    """A bad knob is a ParameterError whose one-line message names it."""
    with pytest.raises(ParameterError, match=field) as info:
        SensorModel(**kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


def test_non_finite_angle_is_refused() -> None:
    """NaN in the input angle is an error, never a NaN reading."""
    with pytest.raises(ParameterError, match="finite"):
        SensorModel(10.0).measure(np.array([0.0, 0.1]), np.array([0.0, math.nan]))
    with pytest.raises(ParameterError, match="shape"):
        SensorModel(10.0).measure(np.array([0.0, 0.1]), np.array([0.0]))
    with pytest.raises(ParameterError, match="samples"):
        SensorModel(1e6).sample_times(1e6)


def test_new_knobs_absent_leave_the_old_readings_bit_for_bit() -> None:
    """Turn-on, Gauss-Markov and range at their defaults: the readings equal the older model's formula."""
    sensor = SensorModel(200.0, noise_std=1e-3, bias_random_walk=1e-4, quantization=1e-4, seed=5)
    t = sensor.sample_times(3.0)
    theta = 0.05 * np.sin(2.0 * t)
    rng = np.random.Generator(np.random.PCG64(5))
    walk = rng.standard_normal(t.size - 1)
    white = rng.standard_normal(t.size)
    expected = theta.copy()
    expected[1:] += np.cumsum(1e-4 * np.sqrt(np.diff(t)) * walk)
    expected = 1e-4 * np.round((expected + 1e-3 * white) / 1e-4)
    assert np.array_equal(sensor.measure(t, theta), expected)


def test_gauss_markov_bias_has_gz_stationary_std_and_correlation() -> None:
    """d_{k+1} = φ d_k + σ_b √(τ/2 (1 − φ²)) v: std σ_b √(τ/2) (within 5 %), lag-τ autocorrelation e^{-1}."""
    tau, sigma_b = 2.0, 1e-3
    sensor = SensorModel(50.0, dynamic_bias_stddev=sigma_b, dynamic_bias_correlation_time=tau, seed=9)
    t = sensor.sample_times(4000.0)
    d = sensor.measure(t, np.zeros_like(t))
    assert np.std(d) == pytest.approx(sigma_b * math.sqrt(tau / 2.0), rel=0.05)
    lag = int(tau * 50.0)
    rho = np.corrcoef(d[:-lag], d[lag:])[0, 1]
    assert rho == pytest.approx(math.exp(-1.0), abs=0.05)


def test_turn_on_bias_is_drawn_per_seed_with_either_sign() -> None:
    """bias_mean 0.01, bias_stddev 0: each seed starts at ±0.01 rad, and both signs occur over seeds."""
    starts = set()
    for seed in range(12):
        y = SensorModel(100.0, bias_mean=0.01, seed=seed).measure(np.array([0.0, 0.01]), np.zeros(2))
        assert abs(y[0]) == pytest.approx(0.01) and y[0] == y[1]
        starts.add(math.copysign(1.0, y[0]))
    assert starts == {1.0, -1.0}


def test_range_saturates_and_is_flagged() -> None:
    """Readings beyond ±R read exactly ±R and ``saturated`` marks them; R = 0 never saturates."""
    sensor = SensorModel(100.0, range=0.5)
    theta = np.array([-0.7, -0.5, 0.2, 0.49, 0.9])
    y = sensor.measure(np.arange(5) * 0.01, theta)
    assert list(y) == [-0.5, -0.5, 0.2, 0.49, 0.5]
    assert list(sensor.saturated(y)) == [True, True, False, False, True]
    assert not SensorModel(100.0).saturated(np.array([10.0])).any()


def test_gauss_markov_without_correlation_time_is_refused() -> None:
    """dynamic_bias_stddev without a correlation time: one-line ParameterError pointing at the walk."""
    with pytest.raises(ParameterError, match="dynamic_bias_correlation_time must be > 0"):
        SensorModel(100.0, dynamic_bias_stddev=1e-3)


def test_measured_rate_carries_the_sensor_noise_not_the_truth() -> None:
    """The published rate: backward differences of the measured angle.

    Noise-free, on θ = 0.1 sin(ωt) at 100 Hz, it is θ' at the interval's midpoint, so it differs from
    θ'(t_k) by at most ω²·0.1·Δt/2 (the half-step lag) plus the O(Δt²) curvature term: 5e-3 rad/s bound.
    With σ = 1 mrad its scatter about that is σ√2/Δt = 0.141 rad/s: the sample std lies within ±10 %
    (≈ 1000 samples: the std of a std estimate is 1/√(2N) ≈ 2 %, so 10 % is 5 of those).
    """
    from pendulum_accel.sensor import measured_rate

    t = np.arange(1001) * 0.01
    omega = 3.0
    theta = 0.1 * np.sin(omega * t)
    truth = 0.1 * omega * np.cos(omega * t)
    clean = measured_rate(t, SensorModel(rate_hz=100.0).measure(t, theta))
    assert np.max(np.abs(clean[1:] - truth[1:])) <= 5e-3
    noisy = measured_rate(t, SensorModel(rate_hz=100.0, noise_std=1e-3, seed=4).measure(t, theta))
    assert abs(np.std(noisy[1:] - clean[1:]) / (1e-3 * np.sqrt(2) / 0.01) - 1.0) <= 0.1
    assert measured_rate(t[:1], theta[:1]).tolist() == [0.0]


@pytest.mark.parametrize(
    ("length", "damping", "rate_hz", "noise"),
    [(0.05, 19.8, 200.0, 2e-3), (1.0, 0.0, 100.0, 1e-3), (0.1, 0.0, 200.0, 1e-4), (0.02, 8.8, 1000.0, 3e-3)],
)
def test_the_angle_noise_is_measured_from_third_differences(
    length: float, damping: float, rate_hz: float, noise: float
) -> None:
    """A pendulum swinging after a 3 m/s² step, under white noise σ: noise_from_angles gives σ within
    10 % (a MAD of ≥ 3000 third differences: a few % standard error). The swing's own third differences,
    (ω Δt)³ θ, are under 1 % of the noise's √20 σ but in the 0.1 m, 0.1 mrad design (up to 16 %, at the
    swing's extremes only, which the median passes over). Fewer than 8 angles: None."""
    from pendulum_accel.physics.params import Pendulum
    from pendulum_accel.physics.profiles import Step
    from pendulum_accel.physics.simulate import simulate
    from pendulum_accel.sensor import noise_from_angles

    t = np.arange(0.0, 30.0, 1.0 / rate_hz)
    swing = simulate(Pendulum(length, damping=damping), Step(2.0, 0.0, 3.0), t, theta0=0.0).theta
    measured = noise_from_angles(swing + np.random.default_rng(11).normal(0.0, noise, t.size))
    assert measured == pytest.approx(noise, rel=0.10)
    assert noise_from_angles(np.zeros(7)) is None
