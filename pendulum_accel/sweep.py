"""Run many variants of one scene at once: a list of lengths, accelerations or noise levels.

The variants are integrated together as one batch state of shape (2, n_variants) by the registry's
fixed-step integrators (RK4 by default), so the per-step Python cost is paid once for all of them.
The right-hand side is written in amplitude-phase form, which needs one sine per evaluation instead of
a sine and a cosine:

    θ'' = −(g/l) sin θ + (a/l) cos θ − c θ' = (g_eff/l) sin(θ_eq − θ) − c θ',
    g_eff = √(g² + a²),  θ_eq = atan2(a, g).

(physics.rigid.theta_ddot in another form; the tests hold the two to rounding.)

A noise sweep leaves the dynamics unchanged, so its single trajectory is integrated once and measured
by one sensor per noise level. Per-variant results (equilibrium angle, mean and max angle, period,
estimated acceleration) are written as one CSV table.
"""

from __future__ import annotations

import csv
import itertools
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

import numpy as np
from tqdm import tqdm

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.integrators import FIXED_STEP_METHODS, METHODS, default_step, integrate
from pendulum_accel.physics.params import Pendulum, require_finite, require_positive
from pendulum_accel.physics.profiles import AccelProfile, scalar_accel
from pendulum_accel.scene import Scene
from pendulum_accel.sensor import SensorModel

SWEEP_FIELDS: tuple[str, ...] = ("length", "accel", "noise")
DEFAULT_METHOD = "rk4"
# A sweep's default RK4 step is the shared rule (integrators.default_step) at 50 steps per radian, not
# simulate()'s 20: hω ≤ 0.02 keeps the global angle error near 1e-8 rad over a minute of swinging.
SWEEP_STEPS_PER_RADIAN = 50.0
# Enough progress-bar updates to be live, few enough that the chunking costs nothing measurable.
PROGRESS_CHUNKS = 50
MAX_VARIANTS = 1_000_000
# Cost limits checked before integrating: a sweep is a Python loop over steps with numpy over the
# variants, so these are minutes of work (docs/benchmarks/constants.md).
MAX_SWEEP_STEPS = 20_000_000
MAX_SWEEP_WORK = 2_000_000_000  # trajectory-steps: steps × variants
MAX_SWEEP_BYTES = 2 * 1024**3
# float64 arrays of (variants × samples) alive at once: θ and θ' of the batch, the copy handed back,
# one measured row per variant in turn and numpy's temporaries in the steady-state figures.
_ARRAYS_PER_CELL = 4

Rhs = Callable[[float, np.ndarray], np.ndarray]


def parse_values(field: str, text: str) -> tuple[float, ...]:
    """'v1,v2,...' or 'start:stop:count' (count evenly spaced values, ends included) → floats.

    Lengths must be > 0, noise levels ≥ 0, every value finite; a bad list raises ParameterError
    naming the field and the offending item.
    """
    if field not in SWEEP_FIELDS:
        raise ParameterError(f"unknown sweep field {field!r}; choose one of {', '.join(SWEEP_FIELDS)}")
    spec = text.strip()
    if not spec:
        raise ParameterError(f"--{field} needs a comma-separated list of numbers or start:stop:count, got ''")
    if ":" in spec:
        values = _parse_range(field, spec)
    else:
        values = tuple(_parse_number(field, item) for item in spec.split(","))
    for v in values:
        if field == "length" and v <= 0.0:
            raise ParameterError(f"--length values must be > 0 m, got {v!r}")
        if field == "noise" and v < 0.0:
            raise ParameterError(f"--noise values must be >= 0 rad, got {v!r}")
    return values


def _parse_number(field: str, item: str) -> float:
    """One finite float from a list item, else ParameterError naming --field and the item."""
    try:
        value = float(item)
    except ValueError:
        raise ParameterError(f"--{field}: {item.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise ParameterError(f"--{field}: values must be finite, got {item.strip()!r}")
    return value


def _parse_range(field: str, spec: str) -> tuple[float, ...]:
    """'start:stop:count' → count evenly spaced values from start to stop inclusive."""
    parts = spec.split(":")
    if len(parts) != 3:
        raise ParameterError(f"--{field}: a range is start:stop:count, got {spec!r}")
    start, stop = _parse_number(field, parts[0]), _parse_number(field, parts[1])
    try:
        count = int(parts[2])
    except ValueError:
        raise ParameterError(f"--{field}: range count must be an integer, got {parts[2].strip()!r}") from None
    if not 1 <= count <= MAX_VARIANTS:
        raise ParameterError(f"--{field}: range count must be in 1..{MAX_VARIANTS}, got {count}")
    return tuple(float(v) for v in np.linspace(start, stop, count))


def batch_rigid_rhs(
    lengths: np.ndarray,
    gravity: float,
    damping: float,
    accel: Callable[[float], float] | np.ndarray,
) -> Rhs:
    """f(t, [θ, θ']) = [θ', (g_eff/l) sin(θ_eq − θ) − c θ'] for a batch state of shape (2, n).

    ``lengths`` has shape (n,); ``accel`` is either a scalar a(t) shared by every variant or an array
    (n,) of constant per-variant accelerations.
    """
    inv_l = 1.0 / np.asarray(lengths, dtype=float)
    n = inv_l.size
    c = float(damping)
    g = float(gravity)
    if isinstance(accel, np.ndarray):
        a = np.broadcast_to(accel.astype(float), (n,))
        k_const = np.hypot(g, a) * inv_l
        eq_const = np.arctan2(a, g)

        def coefficients(t: float) -> tuple[np.ndarray, np.ndarray | float]:
            """Per-variant (g_eff/l, θ_eq), constant in time."""
            return k_const, eq_const

    else:
        a_of_t = accel
        k_buf = np.empty(n)

        def coefficients(t: float) -> tuple[np.ndarray, np.ndarray | float]:
            """(g_eff(t)/l, θ_eq(t)) for the shared a(t)."""
            a_t = a_of_t(t)
            np.multiply(inv_l, math.hypot(g, a_t), out=k_buf)
            return k_buf, math.atan2(a_t, g)

    drag = np.empty(n)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        """[θ', (g_eff/l) sin(θ_eq − θ) − c θ'], computed in place in one new (2, n) array."""
        k, eq = coefficients(t)
        out = np.empty_like(y)
        out[0] = y[1]
        acc = out[1]
        np.subtract(eq, y[0], out=acc)
        np.sin(acc, out=acc)
        np.multiply(acc, k, out=acc)
        if c:
            np.multiply(y[1], c, out=drag)
            np.subtract(acc, drag, out=acc)
        return out

    return rhs


def integrate_batch(
    rhs: Rhs,
    y0: np.ndarray,
    t: np.ndarray,
    *,
    method: str = DEFAULT_METHOD,
    dt: float | None = None,
    breakpoints: Sequence[float] = (),
    omega: float | None = None,
    progress: bool = False,
    label: str = "sweep",
) -> np.ndarray:
    """y(t) of shape y0.shape + (len(t),), integrated in chunks of samples with a tqdm bar on stderr.

    Chunk edges are sample times, where the registry's integrators land exactly anyway, so the
    result is identical to a single call.
    """
    times = np.asarray(t, dtype=float)
    out = np.empty((*y0.shape, times.size))
    out[..., 0] = y0
    y = np.array(y0, dtype=float)
    edges = np.unique(np.linspace(0, times.size - 1, min(PROGRESS_CHUNKS, times.size - 1) + 1).astype(int))
    with tqdm(
        total=int(times.size - 1),
        desc=label,
        unit="sample",
        file=sys.stderr,
        disable=not progress,
        leave=False,
    ) as bar:
        for lo, hi in itertools.pairwise(edges):
            chunk = integrate(rhs, y, times[lo : hi + 1], method, dt, breakpoints=breakpoints, omega=omega)
            out[..., lo + 1 : hi + 1] = chunk.y[..., 1:]
            y = chunk.y[..., -1]
            bar.update(int(hi - lo))
    return out


@dataclass(frozen=True)
class SweepSetup:
    """The scene's physics and sensor that every variant starts from, plus the sample times."""

    pendulum: Pendulum
    profile: AccelProfile
    theta0: float
    theta_dot0: float
    t: np.ndarray
    sensor: SensorModel | None  # None: run_batch only (no measurement)
    noise_std: float
    rate_hz: float


def setup_from_scene(scene: Scene, *, duration: float | None = None) -> SweepSetup:
    """SweepSetup of a scene: its pendulum, a(t), initial state and sensor, sampled at the sensor rate.

    ``duration`` (s) overrides the scene's. The scene's forced model or accuracy target is not used:
    a sweep always steps the rigid model (see ``run_sweep``).
    """
    span = scene.duration if duration is None else require_positive("duration", duration)
    level = scene.on_level()  # a road grade is swept as its level equivalent
    return SweepSetup(
        pendulum=level.pendulum,
        profile=level.profile,
        theta0=scene.theta0,
        theta_dot0=scene.theta_dot0,
        t=scene.sensor.sample_times(span),
        sensor=scene.sensor,
        noise_std=scene.sensor.noise_std,
        rate_hz=scene.sensor.rate_hz,
    )


@dataclass(frozen=True)
class SweepResult:
    """One row per variant: ``columns`` maps a column name to an array of length n_variants.

    ``theta`` holds the true angle, shape (n_variants, len(t)); ``steps`` the number of fixed steps
    each trajectory took (0 for adaptive methods).
    """

    field: str
    values: np.ndarray
    t: np.ndarray
    theta: np.ndarray
    columns: dict[str, np.ndarray]
    method: str
    dt: float | None
    steps: int

    def write_csv(self, path: Path) -> None:
        """Write ``columns`` to ``path`` as CSV (see ``write_csv_to``)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="", encoding="utf-8") as handle:
            self.write_csv_to(handle)

    def write_csv_to(self, handle: TextIO) -> None:
        """CSV with a header row; an undefined value (e.g. no period in a short run) is an empty cell."""
        names = list(self.columns)
        writer = csv.writer(handle)
        writer.writerow(names)
        for row in zip(*(self.columns[name] for name in names), strict=True):
            writer.writerow([_cell(v) for v in row])


def _cell(value: object) -> str:
    """A CSV cell: integers as is, floats with 12 significant digits, NaN/inf as an empty cell."""
    if isinstance(value, int | np.integer):
        return str(int(value))
    # Rows hold numbers only (Python or numpy): float() of anything else is a bug, and raises.
    number = float(value)  # type: ignore[arg-type]
    return f"{number:.12g}" if math.isfinite(number) else ""


def default_dt(omega: float, sample_period: float) -> float:
    """dt = min(1/(50 ω), sample period): hω ≤ 0.02 for RK4."""
    return min(default_step(omega, SWEEP_STEPS_PER_RADIAN), sample_period)


def _periods(t: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Mean interval between upward crossings of each row's mean (NaN with fewer than two crossings)."""
    centred = theta - theta.mean(axis=1, keepdims=True)
    before, after = centred[:, :-1], centred[:, 1:]
    up = (before < 0.0) & (after >= 0.0)
    # Linear interpolation of the crossing instant inside each sample interval.
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(up, -before / (after - before), np.nan)
    crossing = t[:-1] + frac * np.diff(t)
    count = up.sum(axis=1)
    periods = np.full(theta.shape[0], np.nan)
    many = count >= 2
    if np.any(many):
        first = np.nanmin(crossing[many], axis=1)
        last = np.nanmax(crossing[many], axis=1)
        periods[many] = (last - first) / (count[many] - 1)
    return periods


def run_batch(
    setup: SweepSetup,
    lengths: np.ndarray,
    accels: np.ndarray | None,
    *,
    method: str = DEFAULT_METHOD,
    dt: float | None = None,
    progress: bool = False,
) -> tuple[np.ndarray, np.ndarray, float | None, int]:
    """(θ, θ') of shape (n, len(t)) for n rigid pendulums with the given lengths (and constant accels).

    ``accels`` None means every variant follows the scene's profile. Returns also the step used and the
    fixed steps per trajectory.
    """
    if method not in METHODS:
        raise ParameterError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    p = setup.pendulum
    t = setup.t
    t0, t1 = float(t[0]), float(t[-1])
    n = lengths.size
    if accels is None:
        a_max = setup.profile.max_abs(t0, t1)
        accel: Callable[[float], float] | np.ndarray = scalar_accel(setup.profile, t0, t1)
        breaks = setup.profile.breakpoints()
    else:
        a_max = float(np.max(np.abs(accels)))
        accel = accels
        breaks = ()
    omega = max(math.sqrt(math.hypot(p.gravity, a_max) / float(np.min(lengths))), p.damping)
    step: float | None = None
    steps = 0
    if method in FIXED_STEP_METHODS:
        sample_period = float(np.min(np.diff(t))) if t.size > 1 else t1 - t0
        step = default_dt(omega, sample_period) if dt is None else require_finite("dt", dt)
        if step <= 0.0:
            raise ParameterError(f"dt must be > 0, got {step!r}")
        steps = int(np.sum(np.maximum(1, np.ceil(np.diff(t) / step * (1.0 - 1e-12))))) if t.size > 1 else 0
        check_sweep_work(steps, n, step)
    rhs = batch_rigid_rhs(lengths, p.gravity, p.damping, accel)
    y0 = np.empty((2, n))
    y0[0] = setup.theta0
    y0[1] = setup.theta_dot0
    y = integrate_batch(
        rhs, y0, t, method=method, dt=step, breakpoints=breaks, omega=omega, progress=progress
    )
    return y[0], y[1], step, steps


def check_sweep_work(steps: int, variants: int, step: float) -> None:
    """ParameterError, before stepping, when steps > MAX_SWEEP_STEPS or steps·variants > MAX_SWEEP_WORK."""
    if steps > MAX_SWEEP_STEPS or steps * variants > MAX_SWEEP_WORK:
        raise ParameterError(
            f"dt = {step:g} s needs {steps:.3g} steps × {variants} variants = {steps * variants:.3g} "
            f"trajectory-steps, more than {MAX_SWEEP_STEPS:.0e} steps or {MAX_SWEEP_WORK:.0e} "
            "trajectory-steps; use a larger --dt, fewer variants or a shorter --duration"
        )


def check_sweep_memory(variants: int, samples: int) -> None:
    """ParameterError when variants × samples × 8 B × _ARRAYS_PER_CELL exceeds MAX_SWEEP_BYTES."""
    need = variants * samples * 8 * _ARRAYS_PER_CELL
    if need > MAX_SWEEP_BYTES:
        raise ParameterError(
            f"{variants} variants × {samples} samples need about {need / 1024**3:.1f} GiB, more than "
            f"{MAX_SWEEP_BYTES / 1024**3:g} GiB; use fewer variants or a shorter --duration"
        )


def run_sweep(
    setup: SweepSetup,
    field: str,
    values: Sequence[float],
    *,
    method: str = DEFAULT_METHOD,
    dt: float | None = None,
    estimator: str | None = None,
    progress: bool = False,
) -> SweepResult:
    """Integrate every variant of ``setup`` with ``field`` set to each value; one table row per variant.

    field 'length' sets l, 'accel' replaces the profile by a constant a, 'noise' sets the sensor's σ.
    ``estimator`` (default: the package's DEFAULT_ESTIMATOR; 'none' skips it) runs on each variant's
    measured angle through its batch path.
    """
    from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, estimate_batch

    if field not in SWEEP_FIELDS:
        raise ParameterError(f"unknown sweep field {field!r}; choose one of {', '.join(SWEEP_FIELDS)}")
    vals = np.array([require_finite(field, v) for v in values], dtype=float)
    if vals.size == 0:
        raise ParameterError(f"a sweep over {field} needs at least one value")
    n = vals.size
    p = setup.pendulum
    t = setup.t
    check_sweep_memory(n, t.size)
    lengths = vals if field == "length" else np.full(n, p.length)
    accels = vals if field == "accel" else None
    noises = vals if field == "noise" else np.full(n, setup.noise_std)
    if field == "noise":
        # The dynamics do not depend on the sensor: integrate the one trajectory, measure it n times.
        theta1, _, step, steps = run_batch(setup, lengths[:1], None, method=method, dt=dt, progress=progress)
        theta = np.broadcast_to(theta1, (n, t.size))
    else:
        theta, _, step, steps = run_batch(setup, lengths, accels, method=method, dt=dt, progress=progress)
    if not np.all(np.isfinite(theta)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(theta), axis=1))[0])
        raise ParameterError(
            f"variant {bad} ({field}={vals[bad]!r}) produced a non-finite angle; try a smaller dt"
        )

    tail = slice(t.size // 2, None)  # steady-state figures use the second half of the run
    # For a time-varying profile the steady-state figures compare with a(t) averaged over the same tail.
    a_steady = vals if field == "accel" else np.full(n, float(np.mean(setup.profile(t[tail]))))
    theta_eq = np.arctan2(a_steady, p.gravity)
    theta_mean = theta[:, tail].mean(axis=1)
    period = _periods(t[tail], theta[:, tail])
    small_period = 2.0 * math.pi / np.sqrt(np.hypot(p.gravity, a_steady) / lengths)

    name = DEFAULT_ESTIMATOR if estimator is None else estimator
    if name != "none" and name not in ESTIMATORS:
        raise ParameterError(f"unknown estimator {name!r}; choose one of {', '.join(ESTIMATORS)}, none")
    base_sensor = SensorModel(rate_hz=setup.rate_hz) if setup.sensor is None else setup.sensor
    a_est = np.full(n, np.nan)
    a_gtan = np.full(n, np.nan)
    for i in tqdm(
        range(n), desc="estimate", unit="variant", file=sys.stderr, disable=not progress, leave=False
    ):
        sensor = replace(base_sensor, noise_std=float(noises[i]))
        measured = sensor.measure(t, theta[i])
        a_gtan[i] = p.gravity * math.tan(float(np.mean(measured[tail])))
        if name != "none":
            a_hat, _ = estimate_batch(
                name,
                t,
                measured,
                length=float(lengths[i]),
                gravity=p.gravity,
                noise_std=float(noises[i]),
                rate_hz=setup.rate_hz,
                damping=p.damping,
            )
            a_est[i] = float(np.mean(a_hat[tail]))

    columns: dict[str, np.ndarray] = {
        "variant": np.arange(n),
        "length": lengths,
        "accel": a_steady,
        "noise_std": noises,
        "theta_eq": theta_eq,
        "theta_mean": theta_mean,
        "max_abs_theta": np.max(np.abs(theta), axis=1),
        "period": period,
        "period_small_angle": small_period,
        "accel_g_tan_mean": a_gtan,
        "accel_estimate": a_est,
        "accel_estimate_error": a_est - a_steady,
    }
    return SweepResult(
        field=field,
        values=vals,
        t=t,
        theta=np.asarray(theta),
        columns=columns,
        method=method,
        dt=step,
        steps=steps,
    )


__all__ = [
    "SWEEP_FIELDS",
    "SweepResult",
    "SweepSetup",
    "batch_rigid_rhs",
    "integrate_batch",
    "parse_values",
    "run_batch",
    "run_sweep",
    "setup_from_scene",
]
