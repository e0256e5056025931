"""The vectorised sweep engine agrees with single-trajectory simulate(), and its CLI writes one table."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant, Sinusoid, Step
from pendulum_accel.physics.rigid import theta_ddot
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.sweep import SweepSetup, batch_rigid_rhs, parse_values, run_batch
from test.figures import half_unit
from test.rounding import EPS

# The batch right-hand side is the amplitude-phase form of the same equation, so the batch and the
# single-trajectory RK4 runs differ only by rounding: a few ulps per step, ~1e-13 rad over the run.
SAME_STEP_TOL = 1e-12
# Against a tight DOP853 reference, the default RK4 step (hω ≤ 0.02) is accurate to this over 5 s.
DEFAULT_STEP_TOL = 1e-7


def _setup(
    profile: object,
    damping: float = 0.0,
    theta0: float = 0.3,
    duration: float = 5.0,
    theta_dot0: float = 0.1,
) -> SweepSetup:
    """A SweepSetup without a sensor (run_batch does not measure)."""
    t = np.linspace(0.0, duration, int(duration * 100) + 1)
    return SweepSetup(
        pendulum=Pendulum(1.0, damping=damping),
        profile=profile,  # type: ignore[arg-type]
        theta0=theta0,
        theta_dot0=theta_dot0,
        t=t,
        sensor=None,
        noise_std=0.0,
        rate_hz=100.0,
    )


@pytest.mark.parametrize(
    "profile",
    [Constant(2.0), Step(1.0, 0.0, 3.0), Sinusoid(1.5, 0.4, offset=0.5)],
    ids=["constant", "step", "sinusoid"],
)
@pytest.mark.parametrize("damping", [0.0, 0.4])
def test_length_sweep_matches_simulate(profile: object, damping: float) -> None:
    """Each variant of a length sweep equals simulate(model='rigid', method='rk4') with the same dt."""
    setup = _setup(profile, damping)
    lengths = np.array([0.3, 1.0, 2.5])
    theta, theta_dot, dt, steps = run_batch(setup, lengths, None)
    assert dt is not None and steps > 0
    for i, length in enumerate(lengths):
        single = simulate(
            Pendulum(float(length), damping=damping),
            setup.profile,
            setup.t,
            theta0=setup.theta0,
            theta_dot0=setup.theta_dot0,
            model="rigid",
            method="rk4",
            dt=dt,
        )
        assert np.max(np.abs(theta[i] - single.theta)) < SAME_STEP_TOL
        assert np.max(np.abs(theta_dot[i] - single.theta_dot)) < SAME_STEP_TOL * 10
        reference = simulate(
            Pendulum(float(length), damping=damping),
            setup.profile,
            setup.t,
            theta0=setup.theta0,
            theta_dot0=setup.theta_dot0,
            model="rigid",
            method="DOP853",
            rtol=1e-12,
            atol=1e-12,
        )
        assert np.max(np.abs(theta[i] - reference.theta)) < DEFAULT_STEP_TOL


def test_accel_sweep_matches_simulate_with_constant_profiles() -> None:
    """An accel sweep is a constant-a run per variant, starting from the scene's state."""
    setup = _setup(Step(1.0, 0.0, 3.0))
    accels = np.array([-4.0, 0.0, 2.0, 9.0])
    theta, _, dt, _ = run_batch(setup, np.full(accels.size, 1.0), accels)
    for i, a in enumerate(accels):
        single = simulate(
            setup.pendulum,
            Constant(float(a)),
            setup.t,
            theta0=setup.theta0,
            theta_dot0=setup.theta_dot0,
            model="rigid",
            method="rk4",
            dt=dt,
        )
        assert np.max(np.abs(theta[i] - single.theta)) < SAME_STEP_TOL


def test_batch_rhs_is_the_equation_of_motion() -> None:
    """(g_eff/l) sin(θ_eq − θ) − c θ' equals physics.rigid.theta_ddot to rounding, per variant."""
    rng = np.random.default_rng(7)
    lengths = rng.uniform(0.1, 5.0, 50)
    y = np.vstack((rng.uniform(-7, 7, 50), rng.uniform(-3, 3, 50)))
    g, c, a = 9.80665, 0.3, rng.uniform(-20, 20, 50)
    f = batch_rigid_rhs(lengths, g, c, a)(0.0, y)
    expected = np.array(
        [
            float(theta_ddot(Pendulum(length, gravity=g, damping=c), th, w, a_i))
            for length, th, w, a_i in zip(lengths, y[0], y[1], a, strict=True)
        ]
    )
    np.testing.assert_array_equal(f[0], y[1])
    np.testing.assert_allclose(f[1], expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


@pytest.mark.parametrize(
    ("field", "text", "expected"),
    [
        ("length", "0.5,1,2", (0.5, 1.0, 2.0)),
        ("accel", "-3, 0 ,3", (-3.0, 0.0, 3.0)),
        ("noise", "0:0.01:3", (0.0, 0.005, 0.01)),
    ],
)
def test_parse_values(field: str, text: str, expected: tuple[float, ...]) -> None:
    """Comma lists and start:stop:count ranges parse to floats."""
    assert parse_values(field, text) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("field", "text", "fragment"),
    [
        ("length", "1,abc", "'abc' is not a number"),
        ("length", "1,-2", "must be > 0"),
        ("length", "", "needs a comma-separated list"),
        ("noise", "-0.1", "must be >= 0"),
        ("accel", "1,nan", "finite"),
        ("accel", "0:1", "start:stop:count"),
        ("accel", "0:1:x", "integer"),
        ("accel", "0:1:0", "count must be in"),
        ("mass", "1", "unknown sweep field"),
    ],
)
def test_bad_values_raise_one_line(field: str, text: str, fragment: str) -> None:
    """A bad sweep list is a ParameterError whose one-line message names the problem."""
    with pytest.raises(ParameterError, match=fragment) as info:
        parse_values(field, text)
    assert "\n" not in str(info.value)


def test_period_of_a_length_sweep_matches_small_angle_theory() -> None:
    """Small swings (0.02 rad) have the period 2π/√(g_eff/l) within 0.01 % (amplitude effect: 2.5e-5)."""
    from pendulum_accel.sweep import _periods

    setup = _setup(Constant(2.0), theta0=math.atan2(2.0, 9.80665) + 0.02, duration=20.0, theta_dot0=0.0)
    lengths = np.array([0.5, 1.0, 2.0])
    theta, _, _, _ = run_batch(setup, lengths, None)
    measured = _periods(setup.t, theta)
    expected = 2 * math.pi / np.sqrt(math.hypot(9.80665, 2.0) / lengths)
    np.testing.assert_allclose(measured, expected, rtol=1e-4)


def _read(path: Path) -> list[dict[str, str]]:
    """CSV rows as dicts."""
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_cli_writes_one_row_per_variant(tmp_path: Path) -> None:
    """`sweep lecture_constant --accel ... --plot` writes the table and a PNG; θ_eq = atan2(a, g) per row."""
    out = tmp_path / "table.csv"
    png = tmp_path / "sweep.png"
    argv = ["sweep", "lecture_constant", "--accel", "0,2,5", "--duration", "3", "--out", str(out),
            "--no-progress", "--plot", str(png)]  # fmt: skip
    assert main(argv) == 0
    assert png.read_bytes().startswith(b"\x89PNG")
    rows = _read(out)
    assert [float(r["accel"]) for r in rows] == [0.0, 2.0, 5.0]
    for r in rows:
        # printed to 12 digits (half a unit of the last) from np.arctan2, within a few ulp of math.atan2
        want = math.atan2(float(r["accel"]), 9.80665)
        assert float(r["theta_eq"]) == pytest.approx(want, abs=half_unit(r["theta_eq"]) + 4 * EPS * abs(want))
        # Released hanging: the swing is about θ_eq with amplitude θ_eq, so max |θ| ≈ 2 θ_eq.
        assert float(r["max_abs_theta"]) == pytest.approx(2 * float(r["theta_eq"]), abs=2e-3)
        assert math.isfinite(float(r["accel_estimate"]))


def test_noise_sweep_measures_one_trajectory(tmp_path: Path) -> None:
    """A noise sweep shares the true angle; only the measured-angle columns change with σ."""
    out = tmp_path / "noise.csv"
    argv = ["sweep", "step_start", "--noise", "0,0.05", "--duration", "4", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    quiet, noisy = _read(out)
    assert quiet["theta_mean"] == noisy["theta_mean"] and quiet["period"] == noisy["period"]
    assert float(quiet["noise_std"]) == 0.0 and float(noisy["noise_std"]) == 0.05
    assert quiet["accel_g_tan_mean"] != noisy["accel_g_tan_mean"]


def test_cli_prints_table_without_out(capsys: pytest.CaptureFixture[str]) -> None:
    """Without --out the table goes to stdout and the summary line to stderr."""
    argv = ["sweep", "lecture_constant", "--length", "0.5,2", "--duration", "1", "--estimator", "none",
            "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    captured = capsys.readouterr()
    lines = captured.out.strip().splitlines()
    assert lines[0].startswith("variant,length,") and len(lines) == 3
    assert "2 variants of length" in captured.err


@pytest.mark.parametrize(
    ("flags", "fragment"),
    [
        (["--length", "1,zero"], "'zero' is not a number"),
        (["--length", "0,1"], "must be > 0"),
        (["--noise", "-1"], "must be >= 0"),
        (["--accel", "1", "--estimator", "psychic"], "unknown estimator"),
        (["--accel", "1", "--method", "leapfrog"], "unknown method"),
        (["--accel", "1", "--dt", "2.0"], "stability limit"),
    ],
)
def test_cli_bad_input_is_one_line(
    flags: list[str], fragment: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Bad sweep lists and options: exit code 2 and one line on stderr naming the problem."""
    assert main(["sweep", "lecture_constant", "--duration", "1", "--no-progress", *flags]) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err and "\n" not in err and err.startswith("pendulum-accel sweep: error:")
