"""Allan deviation: a long static run recovers the configured white-noise density and random walk."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.allan import (
    MISFIT_LIMIT,
    allan_deviation,
    gauss_markov_shape,
    overlapping_adev,
    plot_allan,
)
from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError
from pendulum_accel.scene import scene_from_yaml

DENSITY = 1.0e-3  # rad/√Hz
WALK = 1.0e-3  # rad/√s
RATE = 50.0

SCENE = f"""
name: allan_static
description: still car, noisy drifting angle sensor
duration: 2000.0
pendulum: {{length: 1.0}}
acceleration: {{type: constant, a: 0.0}}
sensor: {{rate_hz: {RATE}, noise_density: {DENSITY}, bias_random_walk: {WALK}, seed: SEED}}
accuracy: {{max_angle_error: 1.0e-6}}
"""


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_static_run_recovers_density_and_random_walk_within_ten_percent(seed: int) -> None:
    """2000 s at 50 Hz: fitted N and K within ±10 % of the scene's noise_density and bias_random_walk."""
    scene = scene_from_yaml(SCENE.replace("SEED", str(seed)))
    assert scene.sensor.noise_std == pytest.approx(DENSITY * np.sqrt(RATE))  # σ = N·√f
    t = scene.sensor.sample_times(scene.duration)
    theta = scene.sensor.measure(t, np.zeros_like(t))
    result = allan_deviation(theta, RATE, unit="rad")
    assert result.white_density == pytest.approx(DENSITY, rel=0.10)
    assert result.random_walk == pytest.approx(WALK, rel=0.10)
    assert result.fits  # white noise and a walk: the model fits (χ²/dof near 1, MISFIT_LIMIT 20)
    # The −½ and +½ lines cross at τ = √3 N/K; the curve's minimum sits near there, above both lines.
    assert result.instability * 0.664 >= result.model(np.array([np.sqrt(3.0)]))[0] * 0.9


def test_white_noise_alone_gives_no_walk_and_a_minus_half_slope() -> None:
    """Pure white noise: K ≈ 0 (below 5 % of N in these units) and σ(τ)·√τ constant within 10 %."""
    rng = np.random.default_rng(5)
    values = 2e-3 * rng.standard_normal(200_000)
    result = allan_deviation(values, 100.0)
    assert result.white_density == pytest.approx(2e-3 / np.sqrt(100.0), rel=0.05)
    assert result.random_walk < 0.05 * result.white_density
    usable = result.taus <= 2000.0 / 100  # at least 100 independent averages (2000 s of data)
    scaled = result.adev[usable] * np.sqrt(result.taus[usable])
    assert np.ptp(scaled) / scaled.mean() < 0.1


def test_too_few_samples_is_a_clear_error() -> None:
    """Fewer than 100 samples: ParameterError naming the count. A constant reading (a quantised sensor
    whose noise is below its step) is said to be one, not called too short."""
    with pytest.raises(ParameterError, match="at least 100 samples"):
        allan_deviation(np.zeros(10), 10.0)
    with pytest.raises(ParameterError, match=r"all 10000 samples are 0\.001: a constant reading"):
        allan_deviation(np.full(10_000, 1e-3), 100.0)


def test_cli_on_a_scene_prints_both_figures_and_plots(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``allan SCENE --duration`` prints N and K for the angle and the estimate and writes the plot."""
    path = tmp_path / "static.yaml"
    path.write_text(SCENE.replace("SEED", "4"), encoding="utf-8")
    out = tmp_path / "allan.png"
    assert main(["allan", str(path), "--duration", "300", "--plot", str(out)]) == 0
    text = capsys.readouterr().out
    assert "white noise density N" in text and "bias random walk" in text
    assert "estimate â (kalman)" in text
    assert out.stat().st_size > 10_000


def test_plot_marks_the_slopes(tmp_path: Path) -> None:
    """plot_allan writes a PNG for a fitted result."""
    rng = np.random.default_rng(1)
    result = allan_deviation(
        np.cumsum(rng.standard_normal(20_000)) * 1e-4 + rng.standard_normal(20_000), 10.0
    )
    assert plot_allan([result], tmp_path / "a.png").stat().st_size > 10_000


@pytest.mark.parametrize("size", [100, 1001, 4097, 30000])
def test_overlapping_adev_is_allantools_oadev(size: int) -> None:
    """The package's overlapping ADEV against allantools.oadev (a test dependency), white noise plus a walk:
    the same τ and term counts exactly; σ within n ε relative per τ. Both form the same n second
    differences and sum their squares with numpy; only the summation's rounding may differ (≤ n ε of the
    sum of squares, so ≤ n ε/2 of σ), here n ≤ 3e4: ≤ 7e-12."""
    import allantools

    rng = np.random.default_rng(size)
    y = rng.normal(size=size) + 1e-3 * rng.normal(size=size).cumsum()
    taus, adev, err, terms = overlapping_adev(y, RATE)
    ref = [
        np.asarray(x, dtype=np.float64)
        for x in allantools.oadev(y, rate=RATE, data_type="freq", taus="octave")
    ]
    np.testing.assert_array_equal(taus, ref[0])
    np.testing.assert_array_equal(terms, ref[3])
    eps = np.finfo(np.float64).eps
    np.testing.assert_array_less(np.abs(adev - ref[1]), terms * eps * ref[1] + 1e-300)
    np.testing.assert_array_less(np.abs(err - ref[2]), terms * eps * ref[2] + 1e-300)


def test_an_unresolved_walk_is_said_so_not_printed_as_zero() -> None:
    """A fit whose +½ term sits at its bound 0 (no walk resolved in the record) prints no K figure: a K of
    0 would read as a sensor without bias drift. A resolved K prints its value."""
    import dataclasses

    rng = np.random.default_rng(5)
    result = allan_deviation(2e-3 * rng.standard_normal(20_000), 100.0, unit="rad")
    unresolved = "\n".join(dataclasses.replace(result, random_walk=0.0).lines())
    assert "(none resolved: no +½ slope up to τ = " in unresolved
    bound = float(re.search(r"K  ≤ (\S+) rad/√s", unresolved).group(1))  # type: ignore[union-attr]
    # Printed to 3 significant digits: within 5e-3 of the field.
    assert bound == pytest.approx(result.random_walk_bound, rel=5e-3)
    no_white = "\n".join(dataclasses.replace(result, white_density=0.0).lines())
    white = re.search(r"N  ≤ (\S+) rad/√Hz \(none resolved: no −½ slope from τ = ", no_white)
    assert white is not None and float(white.group(1)) == pytest.approx(result.white_density_bound, rel=5e-3)
    resolved = "\n".join(dataclasses.replace(result, random_walk=1.5e-5).lines())
    assert "bias random walk    K  1.5e-05 rad/√s" in resolved


@pytest.mark.parametrize("walk", [0.0, 1e-5, 3e-5, 1e-4, 1e-3])
def test_the_walk_bound_holds_at_its_confidence(walk: float) -> None:
    """walk_bound and white_bound are upper bounds on the true K and N at BOUND_LEVEL (97.5 %), whether or
    not the fit resolves them: 200 s at 100 Hz of white noise σ 2e-3 (N = 2e-4/√Hz) plus a walk K, 200
    seeds (seen: at most 6 failures for K, 5 for N). Each bound
    fails for a given seed with probability ≤ 2.5 %, so the count of failures is at most binomial(200,
    0.025): mean 5, sd 2.2; 12 is its 99.9th percentile. A never-failing bound (K = 0) also says nothing,
    so its size is checked too: above (3σ²/τ)^½ at the last fitted τ by its χ² factor √(ν/χ²_ν(2.5 %)),
    which for ν ≥ 8 (at least 9 clusters) is at most √(8/2.18) = 1.92."""
    failures = white_failures = 0
    misfits = []
    for seed in range(200):
        rng = np.random.default_rng(seed)
        y = 2e-3 * rng.standard_normal(20_000) + walk * np.cumsum(rng.standard_normal(20_000)) / 10.0
        result = allan_deviation(y, 100.0, gauss_markov=True)
        assert result.bias_time == 0.0  # white noise and a walk: no Gauss-Markov bias is ever reported
        failures += walk > result.random_walk_bound
        white_failures += result.white_density_bound < 2e-4
        last = int(np.flatnonzero(result.taus == result.fit_to)[0])
        plain = np.sqrt(3.0 * result.adev[last] ** 2 / result.fit_to)
        assert plain <= result.random_walk_bound <= 1.92 * plain
        misfits.append(result.misfit)
    assert failures <= 12 and white_failures <= 12
    # At rest, whatever the walk: the fit's χ²/dof stays well under MISFIT_LIMIT (at most 7.7 here, at
    # the strongest walk).
    assert max(misfits) < MISFIT_LIMIT / 2, max(misfits)


@pytest.mark.parametrize(("scene", "at_rest"), [("at_rest", True), ("step_start", False), ("braking", False)])
def test_allan_says_when_the_model_misses_the_angle(
    scene: str, at_rest: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A bag whose bob swings (a step, braking) gets N and K that describe the swing: allan says the model
    misses the angle's σ(τ), naming the fit's χ²/dof (over 500 for these; white noise stays near 1). The
    at_rest scene's bag gets no such line."""
    from pendulum_accel.recording.generate import generate_bag

    generate_bag(scene, tmp_path / "bag")
    assert main(["allan", str(tmp_path / "bag")]) == 0
    text = capsys.readouterr().out
    found = re.search(r"model misfit: σ\(τ\) of the angle misses N²/τ \+ K²τ/3 by χ²/dof (\S+) ", text)
    if at_rest:
        assert found is None, text
    else:
        assert found is not None and float(found.group(1)) > MISFIT_LIMIT, text
    # A swing is no Gauss-Markov bias: that term, tried where N and K miss, leaves these far off too.
    assert "Gauss-Markov bias   σ_b" not in text, text


GM_NOISE = 1.0e-3  # rad: white σ of the Gauss-Markov runs (N = σ/√f = 1.41e-4 rad/√Hz at 50 Hz)
GM_SCENE = SCENE.replace(f"noise_density: {DENSITY}", f"noise_std: {GM_NOISE}").replace(
    "bias_random_walk: " + str(WALK), "dynamic_bias_stddev: SB, dynamic_bias_correlation_time: TC"
)


def test_a_gauss_markov_bias_is_resolved_where_noise_and_a_walk_miss() -> None:
    """A sensor at rest whose bias is Gauss-Markov (the sensor model's dynamic bias; 2000 s at 50 Hz, white
    σ 1 mrad) is not white noise and a walk: N and K alone miss it by χ²/dof far above MISFIT_LIMIT
    (97–2700). With gauss_markov the fit adds the bias's term and gives back σ_b and T_c, N beside them,
    and a χ²/dof near 1.

    Tolerances: σ² at τ scatters by √(τ/T) of itself (SP 1065), so at the bump τ ≈ 2 T_c = 6 s of a 2000 s
    record by 5.5 %, 2.7 % in σ; σ_b and T_c rest on the few τ around the bump, and T_c moves it sideways,
    where σ changes slowly. Over 20 seeds per case (σ_b, T_c = 3 mrad/√s, 1 s; 1, 3; 1, 0.3) the worst
    seen were 6.4 % for σ_b and 16.5 % for T_c, sd 3.3 % and 6.5 %: 15 % and 35 % are over twice the worst
    and above 4 sd. N is the white noise's alone: the same 10 % as the walk-free runs above."""
    for drive, time in ((3e-3, 1.0), (1e-3, 3.0), (1e-3, 0.3)):
        for seed in range(3):
            yaml = GM_SCENE.replace("SEED", str(seed)).replace("SB", str(drive)).replace("TC", str(time))
            scene = scene_from_yaml(yaml)
            t = scene.sensor.sample_times(scene.duration)
            theta = scene.sensor.measure(t, np.zeros_like(t))
            plain = allan_deviation(theta, RATE, unit="rad")
            assert not plain.fits and plain.bias_time == 0.0  # χ²/dof 97–2700 here
            result = allan_deviation(theta, RATE, unit="rad", gauss_markov=True)
            assert result.fits and result.misfit < 5.0, result.misfit
            assert result.bias_drive == pytest.approx(drive, rel=0.15)
            assert result.bias_time == pytest.approx(time, rel=0.35)
            assert result.white_density == pytest.approx(GM_NOISE / np.sqrt(RATE), rel=0.10)


def test_the_gauss_markov_shape_has_its_limits_and_no_cancellation() -> None:
    """g(τ; T_c) = T_c²/τ [1 − T_c/(2τ)(3 − 4e^{−x} + e^{−2x})], x = τ/T_c: a walk's τ/3 (1 − 3x/4 + …) for
    τ ≪ T_c, white noise's T_c²/τ (1 − 3/(2x) + …) for τ ≫ T_c, and at x = 1 its closed form (no
    cancellation there: ε-level). Across the series' switch at x = 1e-4 both sides agree to 1e-7 (each
    ~1e-8 off there: the series' dropped x⁴ term, the closed form's cancellation ε/(x²/3))."""
    small = np.array([1e-9, 1e-7])
    # the next terms, O(x²) relative: 1e-14 at most here
    assert np.allclose(gauss_markov_shape(small, 1.0) / (small / 3.0), 1.0 - 0.75 * small, rtol=1e-12)
    large = np.array([1e7, 1e9])
    # 1 − 3/(2x) + O(e^{−x}/x): the dropped part is far below ε; the division and the bracket ~ε each
    assert np.allclose(gauss_markov_shape(large, 1.0) / (1.0 / large), 1.0 - 1.5 / large, rtol=1e-12)
    exact = 1.0 - 0.5 * (3.0 - 4.0 * math.exp(-1.0) + math.exp(-2.0))
    # a few roundings of O(1) terms either way: 1e-14 is tens of ε
    assert gauss_markov_shape(np.array([2.0]), 2.0)[0] == pytest.approx(2.0 * exact, rel=1e-14)
    edge = np.array([1e-4 * (1.0 - 1e-9), 1e-4 * (1.0 + 1e-9)])
    below, above = gauss_markov_shape(edge, 1.0)
    assert above / below - 1.0 == pytest.approx(2e-9, abs=1e-7)  # g ∝ x² there: 2 · 1e-9 apart


def test_allan_prints_the_gauss_markov_bias_of_a_scene_at_rest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """allan SCENE on a sensor with a dynamic bias (1 mrad/√s, 3 s) prints its σ_b and T_c as the scene's
    fields name them, parsed back within the tolerances above, and no misfit line."""
    yaml = GM_SCENE.replace("SEED", "7").replace("SB", "1.0e-3").replace("TC", "3.0")
    path = tmp_path / "gm.yaml"
    path.write_text(yaml, encoding="utf-8")
    assert main(["allan", str(path), "--duration", "2000"]) == 0
    text = capsys.readouterr().out
    found = re.search(
        r"Gauss-Markov bias   σ_b (\S+) rad/√s, T_c (\S+) s \(a scene's dynamic_bias_stddev", text
    )
    assert found is not None, text
    assert float(found.group(1)) == pytest.approx(1e-3, rel=0.15)
    assert float(found.group(2)) == pytest.approx(3.0, rel=0.35)
    assert "model misfit" not in text


@pytest.mark.parametrize(
    ("frequency", "amplitude", "decay"),
    [(0.05, 3e-4, math.inf), (0.5, 1e-3, math.inf), (2.0, 3e-4, math.inf), (0.5, 5e-3, 20.0)],
)
def test_a_swing_at_rest_is_no_gauss_markov_bias(frequency: float, amplitude: float, decay: float) -> None:
    """A bob still swinging in a record at rest (a sinusoid, steady or dying away, over 1 mrad of white noise,
    2000 s at 50 Hz) misses N and K (χ²/dof 148 and over), and no Gauss-Markov term brings it under the
    limit: σ(τ) of a sinusoid has nulls at τ = k/f that a bump cannot follow. No bias is reported."""
    t = np.arange(100_000) / RATE
    rng = np.random.default_rng(1)
    swing = amplitude * np.exp(-t / decay) * np.sin(2.0 * np.pi * frequency * t)
    result = allan_deviation(1e-3 * rng.standard_normal(t.size) + swing, RATE, gauss_markov=True)
    assert result.bias_time == 0.0 and not result.fits, result.misfit
