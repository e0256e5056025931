"""Allan deviation of a sensor stream and the noise figures read off it (white density, random walk).

The overlapping Allan deviation σ(τ) of the samples taken as rate-type ("freq") data is computed by
:func:`overlapping_adev`, allantools' ``oadev(data_type="freq", taus="octave")`` in a few numpy lines
(NIST SP 1065 eq. 11; test_allan checks it against allantools, a test dependency: allantools would pull
pytest and sphinx into the core install). For the IEEE 952 / Kalibr noise model of a reading

    σ²(τ) = N²/τ + K² τ/3 + (2 ln 2/π) B²,

N is the white-noise density (unit/√Hz: the −½ slope, N = σ(1 s) on it), K the bias random walk
(unit/√s: the +½ slope, K = σ(3 s) on it) and B the bias instability (the flat floor, σ_min/0.664).
N and K are fitted together by non-negative least squares on σ² = N²/τ + K²τ/3, each τ weighted by
its uncertainty, over the τ with at least ``MIN_CLUSTERS`` independent clusters; B is read off the
curve as usual, B = min σ / 0.664 (an upper bound when white noise or the walk still dominate there).

A sensor at rest whose bias wanders as a first-order Gauss-Markov process (the sensor model's dynamic
bias: d' = −d/T_c + σ_b w) has a bump the two slopes miss. Where they miss (χ²/dof above MISFIT_LIMIT)
and asked to (``gauss_markov``), the fit adds its term,

    σ²_GM(τ) = σ_b² T_c²/τ · [1 − T_c/(2τ) · (3 − 4 e^{−τ/T_c} + e^{−2τ/T_c})]

(El-Sheimy, Hou and Niu 2008, IEEE Trans. Instrum. Meas. 57(1), the Allan variance of exponentially
correlated noise, their amplitude q_c being σ_b: the driving white noise's variance over a short step dt
is σ_b² dt, as in the sensor model), T_c searched over the fitted τ; the term is taken when it brings
χ²/dof under the limit with T_c inside the fitted τ, where its bump is seen.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar, nnls
from scipy.stats import chi2

from pendulum_accel.errors import ParameterError

if TYPE_CHECKING:
    from pendulum_accel.bag.reader import Bag

FloatArray = NDArray[np.float64]

MIN_CLUSTERS = 9  # τ with fewer independent averages scatter too much to fit
FLICKER_FLOOR = math.sqrt(2.0 * math.log(2.0) / math.pi)  # σ_floor = 0.664 B
MIN_SAMPLES = 100
BOUND_LEVEL = 0.975  # one-sided confidence of the N and K bounds: σ² below its expectation this often
MISFIT_LIMIT = 20.0
"""χ²/dof of the fit above which σ(τ) is not white noise and a walk (a swing, or a Gauss-Markov bias the two
slopes lack: ``gauss_markov`` is tried then); set between the two on docs/benchmarks/constants.md."""
_WAIT_SLICE = 0.05  # s: the main thread's longest wait between two checks for Ctrl-C
T = TypeVar("T")


@dataclass(frozen=True)
class AllanResult:
    """σ(τ) (with its error σ/√n and number of terms n) of one signal, fitted N, K, B and the fit range."""

    label: str
    unit: str
    taus: FloatArray
    adev: FloatArray
    adev_err: FloatArray
    terms: FloatArray
    white_density: float
    random_walk: float
    instability: float
    fit_from: float
    fit_to: float
    random_walk_bound: float = math.inf
    """K no larger than this at BOUND_LEVEL (walk_bound at τ = fit_to): what a record that resolves no
    walk still says of it."""
    white_density_bound: float = math.inf
    """N no larger than this at BOUND_LEVEL (white_bound at τ = fit_from), likewise."""
    misfit: float = 0.0
    """χ²/dof of the fit, Σ((m − σ²)/(m √(τ/T)))² / (k − p) over the k fitted τ and p fitted figures:
    about 1 when σ(τ) is the model's, far above when the record holds motion or other noise
    (MISFIT_LIMIT)."""
    bias_drive: float = 0.0
    """σ_b (unit/√s) of a Gauss-Markov bias the fit resolved (0: none): its driving density's root, as the
    sensor model's dynamic_bias_stddev; the bias's own spread is σ_b √(T_c/2)."""
    bias_time: float = 0.0
    """T_c (s) of that bias, as the sensor model's dynamic_bias_correlation_time (0: none)."""

    @property
    def fits(self) -> bool:
        """True when σ(τ) is the model's within MISFIT_LIMIT (white noise, a walk and any Gauss-Markov
        bias resolved), so its figures are the record's."""
        return self.misfit <= MISFIT_LIMIT

    def model(self, taus: FloatArray) -> FloatArray:
        """σ(τ) = √(N²/τ + K²τ/3 + σ_b² g(τ; T_c)) of the fitted figures (g: gauss_markov_shape)."""
        var = self.white_density**2 / taus + self.random_walk**2 * taus / 3.0
        if self.bias_time > 0.0:
            var = var + self.bias_drive**2 * gauss_markov_shape(taus, self.bias_time)
        return np.sqrt(var)

    def lines(self) -> list[str]:
        """The figures, one per line."""
        out = [
            f"{self.label}: overlapping Allan deviation at {self.taus.size} τ from {self.taus[0]:.3g} "
            f"to {self.taus[-1]:.3g} s (fit over {self.fit_from:.3g} … {self.fit_to:.3g} s)",
            (
                f"  white noise density N  {self.white_density:.4g} {self.unit}/√Hz (σ at τ = 1 s, −½ line)"
                if self.white_density > 0.0
                # As for K below: the fit's −½ term at its bound 0 is no figure of N.
                else f"  white noise density N  ≤ {self.white_density_bound:.3g} {self.unit}/√Hz "
                f"(none resolved: no −½ slope from τ = {self.fit_from:.3g} s; the bound is σ there, "
                f"{BOUND_LEVEL:.1%} one-sided)"
            ),
            (
                f"  bias random walk    K  {self.random_walk:.4g} {self.unit}/√s  (σ at τ = 3 s, +½ line)"
                if self.random_walk > 0.0
                # The NNLS fit's +½ term at its bound 0: no walk resolved, which is not K = 0.
                else f"  bias random walk    K  ≤ {self.random_walk_bound:.3g} {self.unit}/√s "
                f"(none resolved: no +½ slope up to τ = {self.fit_to:.3g} s; the bound is σ there, "
                f"{BOUND_LEVEL:.1%} one-sided; a longer record lowers it)"
            ),
            f"  bias instability    B  {self.instability:.4g} {self.unit}     (floor σ_min / 0.664)",
        ]
        if self.bias_time > 0.0:
            spread = self.bias_drive * math.sqrt(0.5 * self.bias_time)
            out.append(
                f"  Gauss-Markov bias   σ_b {self.bias_drive:.4g} {self.unit}/√s, T_c {self.bias_time:.3g} s "
                f"(a scene's dynamic_bias_stddev and dynamic_bias_correlation_time; the bias's spread "
                f"σ_b √(T_c/2) = {spread:.3g} {self.unit}, its σ(τ) bump at τ ≈ 1.9 T_c)"
            )
        return out


def overlapping_adev(
    values: FloatArray, rate_hz: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(τ, σ(τ), σ/√n, n) at τ = m/f, m = 1, 2, 4, … < len(x), of rate-type samples y at f Hz.

    Phase x = [0, cumsum(y − ȳ)/f] (N + 1 points), then per m the overlapping second differences
    σ²(mτ₀) = Σ (x_{i+2m} − 2x_{i+m} + x_i)² / (2 n (mτ₀)²), n = len(x) − 2m terms (NIST SP 1065 eq. 11);
    a τ with n ≤ 1 is dropped. The same operations, in the same order, as allantools.oadev.
    """
    dt = 1.0 / float(rate_hz)
    phase = np.insert(np.cumsum(values - np.mean(values)) * dt, 0, 0.0)
    octaves = 2 ** np.arange(int(np.floor(np.log2(phase.size))) + 1)
    rows = []
    for m in octaves[octaves < phase.size]:
        n = phase.size - 2 * m
        if n <= 1:
            continue
        second = phase[2 * m :] - 2 * phase[m : m + n] + phase[:n]
        dev = np.sqrt(np.sum(second * second) / (2.0 * n)) / m * rate_hz
        rows.append((m / rate_hz, dev, dev / np.sqrt(n), float(n)))
    taus, adev, err, terms = (np.array(column, dtype=np.float64) for column in zip(*rows, strict=True))
    return taus, adev, err, terms


def allan_deviation(
    samples: FloatArray,
    rate_hz: float,
    *,
    label: str = "signal",
    unit: str = "",
    fit_from: float = 0.0,
    gauss_markov: bool = False,
) -> AllanResult:
    """σ(τ) at octave τ of ``samples`` taken at ``rate_hz`` and the NNLS fit of N, K, B over τ ≥ fit_from;
    with ``gauss_markov``, a Gauss-Markov bias's term where N and K alone miss (module doc)."""
    values = np.asarray(samples, dtype=np.float64)
    if values.ndim != 1 or values.size < MIN_SAMPLES:
        raise ParameterError(f"Allan deviation needs at least {MIN_SAMPLES} samples, got {values.size}")
    if not np.isfinite(values).all():
        raise ParameterError("Allan deviation needs finite samples, got NaN or inf")
    if not (math.isfinite(rate_hz) and rate_hz > 0.0):
        raise ParameterError(f"Allan deviation needs a sample rate > 0 Hz, got {rate_hz!r}")
    if np.ptp(values) == 0.0:
        # σ(τ) is 0 at every τ: "too short" would send the user after a longer record of the same.
        raise ParameterError(
            f"all {values.size} samples are {values[0]:g}: a constant reading has no σ(τ) to fit (its noise, "
            "if any, is below the reading's resolution)"
        )
    taus, adev, err, ns = overlapping_adev(values, rate_hz)
    keep = adev > 0.0
    taus, adev, err, ns = taus[keep], adev[keep], err[keep], ns[keep]
    duration = values.size / rate_hz
    fit = (taus >= fit_from) & (duration / taus >= MIN_CLUSTERS)
    if fit.sum() < 3:
        raise ParameterError(
            f"too short for an Allan fit: {duration:.1f} s leaves {int(fit.sum())} usable τ (need 3)"
        )
    n2, k2, misfit = _fit(taus[fit], adev[fit], duration)
    drive, time = 0.0, 0.0
    if gauss_markov and misfit > MISFIT_LIMIT and fit.sum() > GM_FIGURES:
        found = _fit_gauss_markov(taus[fit], adev[fit], duration)
        if found is not None:
            n2, k2, drive, time, misfit = found
    first, last = (int(i) for i in np.flatnonzero(fit)[[0, -1]])
    return AllanResult(
        label=label,
        unit=unit,
        taus=taus,
        adev=adev,
        adev_err=err,
        terms=ns,
        white_density=math.sqrt(n2),
        random_walk=math.sqrt(k2),
        instability=float(adev[fit].min()) / FLICKER_FLOOR,
        fit_from=float(taus[fit][0]),
        fit_to=float(taus[fit][-1]),
        random_walk_bound=walk_bound(float(adev[last]), float(taus[last]), values.size, rate_hz),
        white_density_bound=white_bound(float(adev[first]), float(taus[first]), values.size, rate_hz),
        misfit=misfit,
        bias_drive=drive,
        bias_time=time,
    )


def _variance_bound(adev: float, tau: float, size: int, rate_hz: float) -> float:
    """E σ²(τ) ≤ σ² ν / χ²_ν(1 − BOUND_LEVEL): at that confidence, σ² being χ²_ν/ν distributed about its
    expectation, with ν = min(size/m − 1, ν_white), m = τ f.

    size/m − 1 is the count of independent τ-clusters less one. Where m is large it is fewer than the
    overlapping estimator's equivalent degrees of freedom for white noise, NIST SP 1065 Table 5's
    ν_white = (3(M − 1)/(2m) − 2(M − 2)/M) · 4m²/(4m² + 5), M = size + 1 (about 1.5 times as many), and
    stays below the fewer a walk leaves; where m is small the overlapping terms are correlated and ν_white
    is the fewer (two thirds of the samples at m = 1). Over 200 s records of white noise with walks K from
    0 (never resolved) to 5 N (always), 200 seeds each, the N and K bounds each failed in at most 3 % of
    them (test_allan)."""
    m = tau * rate_hz
    phases = size + 1
    white = (3.0 * (phases - 1) / (2.0 * m) - 2.0 * (phases - 2) / phases) * 4.0 * m * m / (4.0 * m * m + 5.0)
    edf = min(size / m - 1.0, white)
    return adev * adev * edf / float(chi2.ppf(1.0 - BOUND_LEVEL, edf))


def walk_bound(adev: float, tau: float, size: int, rate_hz: float) -> float:
    """K ≤ √(3 E σ²(τ) / τ): every term of σ² = N²/τ + K²τ/3 + … is ≥ 0 (E σ² from _variance_bound)."""
    return math.sqrt(3.0 * _variance_bound(adev, tau, size, rate_hz) / tau)


def white_bound(adev: float, tau: float, size: int, rate_hz: float) -> float:
    """N ≤ √(τ E σ²(τ)), for the same reason (E σ² from _variance_bound)."""
    return math.sqrt(tau * _variance_bound(adev, tau, size, rate_hz))


def _fit(taus: FloatArray, adev: FloatArray, duration: float) -> tuple[float, float, float]:
    """(N², K², χ²/dof): N², K² ≥ 0 minimising Σ ((m(τ) − σ²)/(m(τ) √(τ/T)))², m = N²/τ + K²τ/3, T the
    record length; χ²/dof that sum at the fitted m over the k − 2 degrees of freedom left (_weighted_nnls)."""
    coeffs, misfit = _weighted_nnls(np.column_stack([1.0 / taus, taus / 3.0]), adev * adev, taus, duration)
    return float(coeffs[0]), float(coeffs[1]), misfit


def _weighted_nnls(
    basis: FloatArray, var: FloatArray, taus: FloatArray, duration: float
) -> tuple[FloatArray, float]:
    """(c ≥ 0, χ²/dof) minimising Σ ((m − σ²)/(m √(τ/T)))², m = basis · c, over the k − p degrees of
    freedom left by p columns.

    σ² at τ scatters by about √(τ/T) of its expected value (one over the root of the independent
    clusters). The weights use the model, not the measured σ², which would favour the low
    scatter and bias the fit low; three reweighted passes converge.
    """
    expected = var
    coeffs = np.zeros(basis.shape[1])
    for _ in range(3):
        scale = np.maximum(expected, 1e-300) * np.sqrt(taus / duration)
        coeffs, _ = nnls(basis / scale[:, None], var / scale)
        expected = basis @ coeffs
    residual = (expected - var) / (np.maximum(expected, 1e-300) * np.sqrt(taus / duration))
    return coeffs, float(np.sum(residual * residual)) / (taus.size - basis.shape[1])


GM_FIGURES = 4  # N², K², σ_b² and T_c: a Gauss-Markov fit needs more τ than these
GM_GRID = 12  # T_c tried per decade of the fitted τ before the refinement between two neighbours


def gauss_markov_shape(taus: FloatArray, time: float) -> FloatArray:
    """g(τ; T_c) = T_c²/τ · [1 − T_c/(2τ) (3 − 4 e^{−τ/T_c} + e^{−2τ/T_c})]: σ²(τ) per unit σ_b² of a
    first-order Gauss-Markov process of correlation time T_c (module doc); ≈ τ/3 for τ ≪ T_c (a walk),
    T_c²/τ for τ ≫ T_c (white)."""
    x = np.asarray(taus, dtype=np.float64) / time
    # 3 − 4e^{−x} + e^{−2x} = 2x − 2x³/3 + x⁴/2 − …, so the bracket is x²/3 − x³/4 + O(x⁴). Formed as
    # 1 − inner/(2x) it loses log10(3/x²) digits to cancellation (inner as −4 expm1(−x) + expm1(−2x) keeps
    # its own): below x = 1e-4 the series' two terms instead, whose dropped x⁴ term is ~1e-8 of it there,
    # as is the closed form's cancellation error (ε 2.2e-16 over x²/3 = 3.3e-9: 7e-8) just above.
    inner = -4.0 * np.expm1(-x) + np.expm1(-2.0 * x)
    small = x < 1e-4
    safe = np.where(small, 1.0, x)
    bracket = np.where(small, x * x / 3.0 - x**3 / 4.0, 1.0 - inner / (2.0 * safe))
    return time * time / np.asarray(taus, dtype=np.float64) * bracket


def _fit_gauss_markov(
    taus: FloatArray, adev: FloatArray, duration: float
) -> tuple[float, float, float, float, float] | None:
    """(N², K², σ_b, T_c, χ²/dof) of σ² = N²/τ + K²τ/3 + σ_b² g(τ; T_c), or None where no such term fits.

    T_c is searched over the fitted τ, GM_GRID a decade, then refined between its grid neighbours (a
    bounded scalar search on ln T_c); the amplitudes are _weighted_nnls's at each T_c. None unless σ_b > 0,
    χ²/dof ≤ MISFIT_LIMIT and T_c lies inside the grid, not at an end: a bump at an end of the τ range is a
    walk's or white noise's shape there, not a resolved bias.
    """
    var = adev * adev

    def misfit(log_time: float) -> float:
        basis = np.column_stack([1.0 / taus, taus / 3.0, gauss_markov_shape(taus, math.exp(log_time))])
        return _weighted_nnls(basis, var, taus, duration)[1]

    lo, hi = math.log(float(taus[0])), math.log(float(taus[-1]))
    grid = np.linspace(lo, hi, max(3, round(GM_GRID * (hi - lo) / math.log(10.0)) + 1))
    scores = [misfit(float(g)) for g in grid]
    best = int(np.argmin(scores))
    if best in (0, grid.size - 1):
        return None
    refined = minimize_scalar(
        misfit,
        bounds=(float(grid[best - 1]), float(grid[best + 1])),
        method="bounded",
        options={"xatol": 1e-3},
    )
    log_time = float(refined.x) if refined.fun <= scores[best] else float(grid[best])
    time = math.exp(log_time)
    basis = np.column_stack([1.0 / taus, taus / 3.0, gauss_markov_shape(taus, time)])
    coeffs, chi = _weighted_nnls(basis, var, taus, duration)
    if coeffs[2] <= 0.0 or chi > MISFIT_LIMIT:
        return None
    return float(coeffs[0]), float(coeffs[1]), math.sqrt(float(coeffs[2])), time, chi


def plot_allan(results: list[AllanResult], out: Path | str) -> Path:
    """Log-log σ(τ) per result with its ±error, the fitted model, the −½ and +½ slope lines and a resolved
    Gauss-Markov bias's bump."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(6.5 * len(results), 5), constrained_layout=True)
    for ax, res in zip(np.atleast_1d(axes), results, strict=True):
        ax.errorbar(res.taus, res.adev, yerr=res.adev_err, fmt="o", ms=3, color="black", label="σ(τ) (oadev)")
        dense = np.geomspace(res.taus[0], res.taus[-1], 200)
        ax.loglog(dense, res.model(dense), color="tab:gray", lw=1, label="fit")
        # The −½ (N) and +½ (K) lines: dashed with the value's marker when fitted, dotted for the bound
        # the true figure lies under when the fit did not resolve it.
        slopes = (
            (
                "−½",
                "N",
                "√Hz",
                res.white_density,
                res.white_density_bound,
                1.0 / np.sqrt(dense),
                1.0,
                "tab:blue",
            ),
            ("+½", "K", "√s", res.random_walk, res.random_walk_bound, np.sqrt(dense / 3.0), 3.0, "tab:red"),
        )
        if res.bias_time > 0.0:
            shape_gm = np.sqrt(gauss_markov_shape(dense, res.bias_time))
            label = f"Gauss-Markov: σ_b = {res.bias_drive:.3g} {res.unit}/√s, T_c = {res.bias_time:.3g} s"
            ax.loglog(dense, res.bias_drive * shape_gm, "-.", color="tab:purple", label=label)
        for slope, name, per, value, bound, shape, at, color in slopes:
            if value > 0:
                label = f"{slope}: {name} = {value:.3g} {res.unit}/{per}"
                ax.loglog(dense, value * shape, "--", color=color, label=label)
                ax.plot([at], [value], "s", color=color)
            elif math.isfinite(bound):
                label = f"{slope} bound: {name} ≤ {bound:.3g} {res.unit}/{per}"
                ax.loglog(dense, bound * shape, ":", color=color, label=label)
        if res.instability > 0:
            ax.axhline(
                FLICKER_FLOOR * res.instability,
                ls=":",
                color="tab:green",
                label=f"floor: B = {res.instability:.3g} {res.unit}",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        lo, hi = float(res.adev.min()), float(res.adev.max())
        ax.set_ylim(lo / 3.0, hi * 3.0)
        ax.set_xlabel("τ (s)")
        ax.set_ylabel(f"Allan deviation ({res.unit})")
        ax.set_title(res.label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


@dataclass(frozen=True)
class StaticSeries:
    """A still car's angles θ_k (rad) and estimates â_k (m/s²) at rate f (Hz), and where they came from."""

    source: str
    rate_hz: float
    theta: FloatArray
    accel: FloatArray | None
    estimator: str | None


def scene_series(scene_name: str, duration: float, estimator: str | None = None) -> StaticSeries:
    """A generated static run of the scene's pendulum and sensor: a = 0, bob hanging still, ``duration`` s."""
    from dataclasses import replace

    from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
    from pendulum_accel.physics.profiles import Constant
    from pendulum_accel.recording.settings import estimator_options
    from pendulum_accel.scene import load_scene
    from pendulum_accel.scene_run import run_scene

    if not (math.isfinite(duration) and duration > 0.0):
        raise ParameterError(f"duration must be > 0 s, got {duration!r}")
    base = load_scene(scene_name)
    scene = replace(
        base,
        profile=Constant(0.0),
        theta0=0.0,
        theta_dot0=0.0,
        duration=float(duration),
        outputs=("angle",),
        model=None,
        method=None,
    )
    method = estimator or DEFAULT_ESTIMATOR

    def compute() -> tuple[FloatArray, FloatArray]:
        """The run's measured angles and the estimate on them."""
        run = run_scene(scene)
        accel, _ = estimate_batch(method, run.t, run.theta_measured, **estimator_options(scene, method))
        return run.theta_measured, np.asarray(accel, dtype=np.float64)

    theta, accel = interruptible(compute)
    return StaticSeries(
        f"scene {base.name}, static for {duration:g} s",
        scene.sensor.rate_hz,
        theta,
        accel,
        method,
    )


def interruptible(work: Callable[[], T]) -> T:
    """``work()`` in a worker thread while this (the main) thread waits in short slices, so Ctrl-C is
    handled within one slice even while the work sits in one long numpy call or compiled loop (those
    release the GIL: numpy's large-array loops, the estimators' batch kernels). The worker is a daemon:
    after an interrupt the command exits (cli.main) without waiting for it."""
    results: list[T] = []
    errors: list[BaseException] = []

    def run() -> None:
        """Thread body: keep the result or the exception for the main thread."""
        try:
            results.append(work())
        except BaseException as err:  # re-raised in the main thread
            errors.append(err)

    worker = threading.Thread(target=run, name="allan-work", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(_WAIT_SLICE)  # a lock wait: a signal interrupts it
    if errors:
        raise errors[0]
    return results[0]


def bag_series(path: str | Bag) -> StaticSeries:
    """The recorded angles and (when recorded) estimates of a bag (read here, refused when damaged, or
    already read), at the rate of the angle stamps."""
    from pendulum_accel.bag.messages import (
        ACCEL_WITH_COVARIANCE_STAMPED,
        JOINT_STATE,
        TOPIC_ACCEL_ESTIMATE,
    )
    from pendulum_accel.bag.reader import Bag, read_bag
    from pendulum_accel.recording.contract import angle_field, decode_chain, require_angles

    bag = path if isinstance(path, Bag) else read_bag(path, salvage=False)
    path = str(bag.path)
    angles, estimate = require_angles(bag), bag.chain_topic(TOPIC_ACCEL_ESTIMATE)
    stamp = ["header.stamp.sec", "header.stamp.nanosec"]
    theta_field = angle_field(bag)
    requests: dict[str, tuple[str | None, list[str] | None]] = {angles: (JOINT_STATE, [*stamp, theta_field])}
    with_estimate = estimate in bag.topics and bag.topics[estimate].count >= MIN_SAMPLES
    if with_estimate and estimate != angles:
        requests[estimate] = (ACCEL_WITH_COVARIANCE_STAMPED, [*stamp, "accel.accel.linear.x"])
    decoded = decode_chain(bag, requests)  # the angles, the estimate and the contract in one pass
    js = decoded[angles]
    if len(js) < MIN_SAMPLES:
        raise ParameterError(
            f"bag {path} holds {len(js)} angle samples; the Allan deviation needs {MIN_SAMPLES}"
        )
    t = js.stamp
    order = np.argsort(t, kind="stable")
    dt = np.diff(t[order])
    rate = float(1.0 / np.median(dt[dt > 0])) if np.any(dt > 0) else 0.0
    accel = None
    if estimate in decoded:
        est = decoded[estimate]
        accel = est["accel.accel.linear.x"][np.argsort(est.stamp, kind="stable")]
    return StaticSeries(
        f"bag {path}", rate, js[theta_field][order], accel, "recorded" if accel is not None else None
    )
