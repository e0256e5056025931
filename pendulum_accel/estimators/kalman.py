"""``kalman``: an extended Kalman filter on x = [θ, θ', a] with the pendulum as its process model.

    θ'' = −(g/l) sin θ + (a/l) cos θ − c θ' + w_ω,   a' = w_a,
    E[w_a w_a] = q_a δ (a random walk of a),  E[w_ω w_ω] = q_ω δ,   y = θ + v,  E[v²] = σ².

The filter separates the swing from the tilt a produces because the model knows how a swing looks.
q_a ((m/s²)²/s) is a property of the motion, not of the sensor: how fast a real a(t) wanders. Beside some
of its random-walk modes the default IMM runs trend modes, an integrated walk of a on [θ, θ', a, j]
(a' = j, j' = w_j, E[w_j w_j] = q_j δ), which predict the trend a random walk lags (MotionPreset.trends).
It is taken from a ``preset`` (:data:`PRESETS`), each fitted on the training split of the real-motion corpus
(``python -m benchmarks.real_motion --fit``), and may be overridden with ``q_accel``.

The published variance is the filter's own P_aa plus the sensor bias the filter cannot tell from a tilt,
(g sec²θ)² E[b²](t) (EstimatorConfig). No heuristic term is added: with q_a fitted to the motion,
P_aa is consistent (docs/estimators.md, "Calibration", and the benchmark's NEES columns).

``lag`` (s, ≥ 0) turns the filter into a fixed-lag smoother (``ekf_kernels``, module doc): each estimate
describes the sample ``lag`` earlier (Estimate.time), using the data up to now; lag = 0 is the filter.
The numerics live in :mod:`pendulum_accel.estimators.ekf_kernels` (the model, the IMM and its fixed-lag
pass); the streaming update and the batch pass call the same compiled steps, so they agree to the last
bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    bias_variance,
    bias_variance_array,
    check_batch_input,
)
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import require_finite, require_positive

linalg = lazy_module("scipy.linalg")  # imported on first use: start-up (docs/portability.md)


@dataclass(frozen=True)
class MotionPreset:
    """A process model of a(t) and the data it was fitted on.

    ``modes``: the IMM's q_a per mode ((m/s²)²/s), in increasing order; ``switch_time``: mean time (s)
    before the chain leaves a mode (to any other), or with ``down_time`` before it steps up to the next
    more agile mode, ``down_time`` the mean time before it steps down (ekf_kernels.chain_rates);
    ``q_accel``: the single-model q_a of the fixed-lag smoother (lag > 0); q_ω ((rad/s)²/s) on θ'.
    ``trends``: per mode, the q_j ((m/s³)²/s) of its trend partner, a mode whose a(t) is an integrated walk
    (a' = j, j' white of density q_j: it predicts a trend, which a random walk cannot), 0 for none; the
    pair swaps every ``cross_time`` s on average (ekf_kernels.with_trends). Empty: random walks only.
    """

    modes: tuple[float, ...]
    switch_time: float
    q_accel: float
    q_rate: float
    fitted_on: str
    down_time: float | None = None
    trends: tuple[float, ...] = ()
    cross_time: float = 10.0

    def imm(self, walks_only: bool = False) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """(q_a per IMM mode, q_j per mode or None without trend modes, the chain's R): the preset's IMM
        (ekf_kernels.chain_rates, with_trends); ``walks_only``: its random-walk modes alone."""
        qs = np.array(self.modes, dtype=float)
        rates = kern.chain_rates(qs.size, self.switch_time, self.down_time)
        if walks_only or not any(self.trends):
            return qs, None, rates
        return kern.with_trends(qs, rates, np.array(self.trends, dtype=float), self.cross_time)

    def chain(self) -> str:
        """The mode chain in words: 'switching every τ s' or 'up every τ s, down every τ_d s'."""
        if self.down_time is None:
            return f"switching every {self.switch_time:g} s"
        return f"stepping up every {self.switch_time:g} s, down every {self.down_time:g} s"


AUTO_MODES = (1e-9, 1e-7, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
"""(m/s²)²/s: auto's modes, from a constant (1e-9: over any recording a random walk this slow is a constant,
whose posterior variance shrinks as 1/n) through every hindsight optimum of the corpus (1e-4 … 100) to a
step (10) and an agile robot's bursts (100: the F1TENTH cars' |a| reach 10 m/s² within a second, where
a top mode of 10 leaves a third of the errors beyond 2σ), a decade apart where real motion lives."""

AUTO_TRENDS = (0.0, 0.0, 0.0, 0.01, 0.1, 1.0, 10.0, 0.0, 0.0, 0.0)
"""(m/s³)²/s: the q_j of each of auto's modes' trend partner (0: none), q_j = 100 q_a beside the modes
1e-4 … 0.1. Fitted by ``python -m benchmarks.real_motion --fit --quick`` (fit_trends) on auto's training
data (every training profile of benchmarks.corpus, both designs, the first 60 s, seed 0): of the spans
and factors of TREND_SPANS × TREND_FACTORS with at most MAX_TREND_PARTNERS partners (the cost bound) and
no training cell above RMS_SLACK × auto's random walks alone, those within RMS_SLACK of the least RMS,
the one with the least calibration miss."""

AUTO_CROSS_TIME = 10.0
"""s: mean time before auto's chain moves between a random-walk mode and its trend partner; picked from 1, 3
and 10 s for the least RMS on benchmarks.corpus's training split (docs/benchmarks/constants.md)."""

# auto (the default): a birth-death chain over AUTO_MODES, up every 3 s, down every 1 s, fitted by
# ``python -m benchmarks.real_motion --fit --quick`` (fit_auto) on every training profile of the corpus
# (benchmarks.corpus: cars, robots, acceleration tables, the lab's step and stop_and_go; both designs, the
# first 60 s, seed 0): of AUTO_CHAINS within 5 % of the least RMS, the best calibrated (docs/estimators.md).
# Its q_accel is car's (used only when a caller asks for the single model).
# Fitted by ``python -m benchmarks.real_motion --fit`` on the preset's training profiles only, both sensor
# designs (teaching l = 1 m, 100 Hz; short damped l = 5 cm, 200 Hz), seeds 0-1, on grids. q_accel (the
# single model): the least RMS (geometric mean over the designs). modes, switch_time (the IMM): of the
# candidates within 5 % of the least RMS, the one whose own variance is best calibrated (share of errors
# beyond 2σ, steady and after changes, closest to a Gaussian error's): the switch time sets how much of
# the manoeuvre mode's covariance the mixing hands the quiet mode each sample (docs/estimators.md).
# q_ω = 0: with the damping known there is no unmodelled torque to absorb.
PRESETS: dict[str, MotionPreset] = {
    "auto": MotionPreset(
        AUTO_MODES,
        3.0,
        0.0215,
        0.0,
        "every training profile of benchmarks.corpus (cars, robots, acceleration tables, the lab's step and "
        "stop_and_go), both designs, the first 60 s, seed 0",
        1.0,
        AUTO_TRENDS,
        AUTO_CROSS_TIME,
    ),
    "car": MotionPreset(
        (1e-4, 0.03), 200.0, 0.0215, 0.0, "UDDS 0-505 s (FTP-75 phase 1), both designs, seeds 0-1"
    ),
    "robot": MotionPreset(
        (1e-3, 0.03), 10.0, 0.00464, 0.0, "Husky odometry 0-195 s, both designs, seeds 0-1"
    ),
    "lab_steps": MotionPreset(
        (1e-3, 1.0), 200.0, 0.215, 0.0, "stop_and_go scene + a 0 → 3 m/s² step, both designs, seeds 0-1"
    ),
}
DEFAULT_PRESET = "auto"

LAG_VARIANCE_POWER = 2.6
"""γ of the IMM's fixed-lag variance, published as min(P_f (P_lag/P_f)^γ + κ d², P_lag) (``lag_variance``,
κ = LAG_REVISION_WEIGHT). Fitted with κ by ``python -m benchmarks.real_motion --fit --quick`` (fit_lag_map)
on every training profile of benchmarks.corpus (cars, robots, acceleration tables, the lab's step and
stop_and_go), the teaching and short_damped designs, the first 60 s, seed 0, lags 0.25 s and 1 s: of
LAG_POWERS × LAG_WEIGHTS, the pair whose shares beyond 2σ (steady and after changes), mean NEES and median
NEES are closest to a Gaussian error's (map_miss)."""

LAG_REVISION_WEIGHT = 1.5
"""κ of the fixed-lag variance map: the weight of d² = (â_lag − â_f)², the revision the lag's samples made
to the filter's estimate of the same sample. Fitted with LAG_VARIANCE_POWER (see there)."""


SMOOTHER_VARIANCE_POWER = 2.9
"""γ of the smoother's variance, published as min(P_f (Pˢ/P_f)^γ + κ (âˢ − â_f)², Pˢ) (``lag_variance``, κ =
SMOOTHER_REVISION_WEIGHT; ``imm_smoother``: P_f and â_f its single-model pass's filtered ones). Fitted with κ
by ``python -m benchmarks.real_motion --fit --quick`` (fit_smoother_map) on the data LAG_VARIANCE_POWER was
fitted on (lag: the whole recording), by the same rule (map_miss over LAG_POWERS × LAG_WEIGHTS)."""

SMOOTHER_REVISION_WEIGHT = 0.5
"""κ of the smoother's variance map (see SMOOTHER_VARIANCE_POWER)."""


def lag_variance(
    var_lag: np.ndarray,
    var_filter: np.ndarray,
    a_lag: np.ndarray,
    a_filter: np.ndarray,
    power: float = LAG_VARIANCE_POWER,
    weight: float = LAG_REVISION_WEIGHT,
) -> np.ndarray:
    """min(P_f (P_lag/P_f)^γ + κ (â_lag − â_f)², P_lag) of 1-d columns, γ = ``power``, κ = ``weight``, the
    ratio clipped to [0, 1]: the fixed-lag variance as it matches real motion (docs/estimators.md, "Fixed
    lag"); ``ekf_kernels.lag_variance_one`` per sample, the formula the live fixed-lag output uses too.

    Under the random walk the IMM assumes, P_lag is the error variance (NEES 0.9 on a simulated walk). Real
    a(t) is smoother than a walk of the q_a that follows its changes: the filter's error is mostly its lag
    behind the trend, which the future samples remove, so the lagged error shrinks faster than P_lag/P_f.
    How much is left depends on the motion, and the motion shows in the revision d = â_lag − â_f that the
    lag's samples made: small where a(t) went as the filter predicted, large where it turned, and the error
    still left after a large revision is of its order. The first term shrinks the model's ratio hard
    (γ > 1); the second gives back a variance in proportion to the revision, so the errors after a turn,
    which the power alone left at up to 10⁵ times their variance, are covered; P_lag caps the sum, so the
    map is never wider than the model's own fixed-lag variance (which over-covers real motion already). It
    leaves P_f where the future adds nothing (ratio 1, d = 0: lag 0, a segment's end)."""
    # One output array and no copies of the inputs (the lag table's column views are read in place):
    # export maps a whole recording's column (a million samples and more) within its memory bound.
    out = np.empty(var_lag.shape, dtype=np.float64)
    kern.lag_variance_into(var_lag, var_filter, a_lag, a_filter, power, weight, out)
    return out


def imm_smoother(
    t: np.ndarray, theta: np.ndarray, params: np.ndarray, qs: np.ndarray, rates: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(âˢ, Pˢ_aa, P_f,aa, â_f): the RTS pass of the single model at q_a,k = Σ_j μˢ_k(j) q_j (ekf_kernels.rts
    over run_pass), μˢ the IMM's mode probabilities smoothed over the recording (ekf_kernels.smooth_modes),
    and that pass's own filtered P_aa and â. Where that pass broke down (rts leaves a hole: angles far out
    of the model, e.g. jumping across ±90°) the sample gets the IMM filter's â for both estimates and its P_aa
    for both variances, as the fixed-lag output gives a sample a restart lost.

    The mode mix the whole recording supports sets each interval's process noise, so a change gets the
    agile modes' q_a on both sides of it (a pass that weighed the modes by the past alone would carry the
    level after a step back across it), and a calm stretch the calm modes' q_a. One IMM pass, one single-model
    pass and one backward pass: the cost of the live filter plus two single-model passes."""
    band = kern.chain_band(rates)
    a_f, var_imm, mu = kern.run_imm(
        t, theta, params, qs, rates, np.empty(0), band, np.zeros(1, np.int64), True
    )
    kern.smooth_modes(t, mu, rates, float(params[6]), band)
    q = mu @ qs
    del mu
    _, _, xpr, ppr, xpo, ppo, fk, starts = kern.run_pass(t, theta, params, q)
    del q, _
    a, var = kern.rts(xpr, ppr, xpo, ppo, fk, starts)
    var_f = ppo[:, 2, 2].copy()
    a_pass = xpo[:, 2].copy()
    del xpr, ppr, xpo, ppo, fk, starts
    hole = np.isnan(a)
    if hole.any():
        a[hole] = a_pass[hole] = a_f[hole, 0]
        var[hole] = var_f[hole] = var_imm[hole, 0]
    return a, var, var_f, a_pass


def lag_samples(lag: float, rate_hz: float) -> int:
    """N = round(lag · f): the fixed lag in nominal sample periods."""
    return round(lag * rate_hz)


class KalmanEstimator(Estimator):
    """EKF on [θ, θ', a]; â = x₃ (clamped), var = P_aa + bias; with ``lag`` a fixed-lag smoother."""

    name: ClassVar[str] = "kalman"
    summary: ClassVar[str] = "EKF on [θ, θ', a] with the pendulum equation as process model"

    def __init__(
        self,
        config: EstimatorConfig,
        *,
        preset: str = DEFAULT_PRESET,
        q_accel: float | None = None,
        q_rate: float | None = None,
        init_angle_std: float = 0.3,
        reset_gap: float = 1.0,
        lag: float = 0.0,
    ) -> None:
        """preset names q_a, q_ω (PRESETS); q_accel/q_rate override them; A₀ = init_angle_std; lag (s)."""
        super().__init__(config)
        if preset not in PRESETS:
            raise ParameterError(f"unknown preset {preset!r}; choose one of {', '.join(PRESETS)}")
        self.preset = preset
        chosen = PRESETS[preset]
        self.q_accel = require_positive("q_accel", chosen.q_accel if q_accel is None else q_accel)
        self.q_rate = require_finite("q_rate", chosen.q_rate if q_rate is None else q_rate)
        if self.q_rate < 0.0:
            raise ParameterError(f"q_rate must be >= 0, got {self.q_rate!r}")
        self.init_angle_std = require_positive("init_angle_std", init_angle_std)
        self.reset_gap = require_positive("reset_gap", reset_gap)
        self.lag = require_finite("lag", lag)
        if self.lag < 0.0:
            raise ParameterError(f"lag must be >= 0 s, got {self.lag!r}")
        self.lag_n = lag_samples(self.lag, config.rate_hz)
        # Without a given q_a the filter is the IMM over the preset's modes, and a lag its fixed-lag smoother
        # (ekf_kernels._step, _lagged_step); a given q_a runs the single model (how the benchmark builds its
        # bound), as the IMM of that one mode (to the bit the one-model filter, ekf_kernels.step).
        self.modes: tuple[float, ...] = chosen.modes if q_accel is None else ()
        self.switch_time = chosen.switch_time
        self.chain = chosen.chain()
        self._qs = np.array(self.modes, dtype=float)
        self._rates = kern.chain_rates(max(len(self.modes), 1), self.switch_time, chosen.down_time)
        self._jerks = np.empty(0)  # q_j per IMM mode; empty: random-walk modes only
        self._walks = (self._qs, self._rates)  # the random-walk modes alone: the smoother's (imm_smoother)
        self.trends = tuple(q for q in chosen.trends if q > 0.0) if self.modes else ()
        if self.trends:
            self._qs, jerks, self._rates = chosen.imm()
            self._jerks = np.asarray(jerks)
            partners = [q for q, j in zip(self.modes, chosen.trends, strict=True) if j > 0.0]
            self.chain += (
                f"; trend modes q_j={'/'.join(f'{q:.3g}' for q in self.trends)} (m/s³)²/s beside the q_a "
                f"modes {'/'.join(f'{q:.3g}' for q in partners)}, swapped every {chosen.cross_time:g} s"
            )
        qs_run = self._qs if self.modes else np.array([self.q_accel])
        rates_run = self._rates if self.modes else np.zeros((1, 1))
        # What the passes run: q_a per mode, the chain's R, q_j per mode (empty: random walks only), its band.
        self._imm_inputs = (qs_run, rates_run, self._jerks, kern.chain_band(rates_run))
        self._a_max = config.gravity * math.tan(config.clamp_angle)
        self._params = np.array(
            [
                config.gravity,
                config.length,
                config.damping,
                config.sigma**2,
                self.q_rate,
                self.q_accel,
                self.reset_gap,
                config.clamp_angle,
                self.init_angle_std,
            ]
        )
        self.reset()

    def options(self) -> dict[str, float | str]:
        """The keyword options that rebuild this estimator (for a twin in batch)."""
        return {
            "preset": self.preset,
            "q_accel": self.q_accel,
            "q_rate": self.q_rate,
            "init_angle_std": self.init_angle_std,
            "reset_gap": self.reset_gap,
            "lag": self.lag,
        }

    def reset(self) -> None:
        """Forget the state and the lag's queue; the next sample initialises the filter at rest."""
        qs, _, jerks, band = self._imm_inputs
        self._buf, self._ibuf = kern.imm_buffer(qs, band, jerks)
        # MEMO[1] of the buffer: the last accepted time (ekf_kernels.ImmArrays), for _accepts.
        self._last_slot = int(kern.imm_layout(qs.size, band, int(self._ibuf[2]))[-2]) + 1
        self._ring = kern.ring_buffer(self.lag_n + 1, qs.size) if self.lag_n else np.empty(0)
        self._hist = np.zeros((self.lag_n + 1, 3))  # each buffered sample's stamp and filter â, var
        self._out = np.empty(3)  # the live step's (â, var, time of the sample it describes)
        self._first_t: float | None = None  # sensor turn-on, for the bias variance

    def warm(self) -> None:
        """Load the live step (ekf_kernels.warm_live), not every pass: a batch loads what it runs when it runs
        it, and loading all of them cost an estimator's every start about a second of CPU."""
        kern.warm_live()

    def update(self, t: float, theta: float) -> Estimate | None:
        """One sample in; out â and var for the sample lag earlier (None while the lag fills). One compiled
        call (ekf_kernels.live_step): the IMM's step, the fixed-lag pass and its variance map."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._first_t is None:
            self._first_t = t
        _, rates, jerks, _ = self._imm_inputs
        out = self._out
        mapped = bool(self.modes) and self.lag_n > 0  # the IMM's lag publishes the mapped variance
        if not kern.live_step(
            self._buf, self._ibuf, self._ring, self._hist, self.lag_n, t, theta, self._params, rates, jerks,
            mapped, LAG_VARIANCE_POWER, LAG_REVISION_WEIGHT, out,
        ):  # fmt: skip
            return None
        return self._estimate(float(out[0]), float(out[1]), float(out[2]))

    @property
    def _last_t(self) -> float | None:
        """The last accepted time stamp (None before the first)."""
        last = float(self._buf[self._last_slot])
        return None if math.isnan(last) else last

    def _estimate(self, a: float, var: float, t: float) -> Estimate:
        """Estimate(â clamped to ±g tan θ_max, P_aa + (g sec²θ)² E[b²], clamped, t) with tan θ = â/g."""
        cfg = self.config
        clamped = abs(a) > self._a_max
        if clamped:
            a = math.copysign(self._a_max, a)
        elapsed = 0.0 if self._first_t is None else t - self._first_t
        bias = bias_variance(cfg, math.atan2(a, cfg.gravity), elapsed)
        return Estimate(a, max(var, 0.0) + bias, clamped, t)

    def _publish(self, t: np.ndarray, a: np.ndarray, var: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(â clamped, var + bias) for arrays, as ``_estimate`` per sample."""
        cfg = self.config
        a = np.clip(a, -self._a_max, self._a_max)
        elapsed = t - t[0] if t.size else t
        return a, np.maximum(var, 0.0) + bias_variance_array(cfg, np.arctan2(a, cfg.gravity), elapsed)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(â, var) aligned to the samples they describe; equals streaming ``update`` wherever it emits.

        With a lag, the last N samples of each segment (which streaming never emits) use all the data
        there is, and a sample a divergence restart lost gets the filter's value.
        """
        t, theta = check_batch_input(t, theta)
        a, var = self.lagged(t, theta, (self.lag_n,))
        return a[:, 0], var[:, 0]

    def mode_probabilities(self, t: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """μ (n × modes): the IMM's probability of each mode after each sample (one column without modes;
        with trend modes, in ekf_kernels.with_trends' order: each random-walk mode, then its partner)."""
        t, theta = check_batch_input(t, theta)
        qs, rates, jerks, band = self._imm_inputs
        result: np.ndarray = kern.run_imm(
            t, theta, self._params, qs, rates, jerks, band, np.zeros(1, np.int64), True
        )[2]
        return result

    def lagged(
        self, t: np.ndarray, theta: np.ndarray, lags: tuple[int, ...]
    ) -> tuple[np.ndarray, np.ndarray]:
        """(â, var) of the fixed-lag smoother (the IMM's with modes, its variance mapped by ``lag_variance``;
        else the single model's at q_accel) with one column per lag (in samples), each aligned to the sample
        it describes."""
        lag_arr = np.array((0, *lags), dtype=np.int64)
        qs, rates, jerks, band = self._imm_inputs
        a, var, _ = kern.run_imm(t, theta, self._params, qs, rates, jerks, band, lag_arr, False)
        for m in range(1, lag_arr.size):  # NaN only where a divergence restart lost a sample
            lost = np.isnan(a[:, m])
            a[lost, m], var[lost, m] = a[lost, 0], var[lost, 0]
            if self.modes and lag_arr[m]:
                var[:, m] = lag_variance(var[:, m], var[:, 0], a[:, m], a[:, 0])
        published = [self._publish(t, a[:, m], var[:, m]) for m in range(1, lag_arr.size)]
        del a, var
        if len(published) == 1:  # the usual single lag: its columns as they are, no second copy
            return published[0][0][:, None], published[0][1][:, None]
        if not published:
            return np.empty((t.size, 0)), np.empty((t.size, 0))
        return np.column_stack([p[0] for p in published]), np.column_stack([p[1] for p in published])

    def smoothed(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(âˢ, var) of the fixed-interval RTS smoother on the same model (ekf_kernels.rts)."""
        t, theta = check_batch_input(t, theta)
        if t.size == 0:
            return np.empty(0), np.empty(0)
        _, _, xpr, ppr, xpo, ppo, fk, starts = kern.run_pass(t, theta, self._params, np.empty(0))
        a, var = kern.rts(xpr, ppr, xpo, ppo, fk, starts)
        return self._publish(t, a, var)

    def steady_state(
        self, accel: float, q_accel: float | None = None, q_jerk: float = 0.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F, K, P⁺) at rest at θ_eq(a): DARE prior P⁻, K = P⁻Hᵀ/S, P⁺ = (I − KH)P⁻, F = e^{J Δt}, Q as the
        kernels' (ekf_kernels.trend_noise, whose leading block is ``predict``'s), at q_a = ``q_accel``
        (default: the single model's, or the IMM's quiet mode, which holds nearly all μ at rest); on
        [θ, θ', a], or with ``q_jerk`` > 0 a trend mode's, on [θ, θ', a, j]."""
        cfg = self.config
        dt = 1.0 / cfg.rate_hz
        th = math.atan2(accel, cfg.gravity)
        j12 = math.cos(th) / cfg.length
        if q_accel is None:
            q_accel = self.modes[0] if self.modes else self.q_accel
        d = 4 if q_jerk > 0.0 else 3
        jac = np.zeros((4, 4))
        jac[0, 1], jac[1, 1], jac[1, 2], jac[2, 3] = 1.0, -cfg.damping, j12, 1.0
        jac[1, 0] = -(cfg.gravity * math.cos(th) + accel * math.sin(th)) / cfg.length
        F = linalg.expm(jac[:d, :d] * dt)
        Q = np.empty((4, 4))
        kern.trend_noise(Q, j12, dt, q_accel, q_jerk, self.q_rate)
        H = np.eye(d)[:1]
        R = np.array([[cfg.sigma**2]])
        prior = linalg.solve_discrete_are(F.T, H.T, Q[:d, :d], R)
        K = prior @ H.T / (H @ prior @ H.T + R)
        return F, K[:, 0], (np.eye(d) - K @ H) @ prior

    def stationary_modes(self) -> np.ndarray:
        """π: the mode chain's stationary probabilities, πᵀ G = 0 with G = R − diag(Σ_j R_ij), Σ π = 1
        (a birth-death chain: π_{i+1}/π_i = down_time/up_time); [1] for the single model."""
        if not self.modes:
            return np.ones(1)
        gen = self._rates - np.diag(self._rates.sum(axis=1))
        system = np.vstack((gen.T, np.ones(self._qs.size)))
        rhs = np.zeros(self._qs.size + 1)
        rhs[-1] = 1.0
        result: np.ndarray = np.linalg.lstsq(system, rhs, rcond=None)[0]
        return result

    def _closed_loop(self, accel: float) -> tuple[float, float, float]:
        """(Σw, Σw², Σ j w_j) of the steady filter's impulse response w = Σ_m π_m w⁽ᵐ⁾, w⁽ᵐ⁾_j = e₃ᵀ M_mʲ K_m,
        M_m = (I − K_m H) F: the single model's, or for the IMM the mix of its modes' steady filters weighted
        by the chain's stationary probabilities π (``stationary_modes``). Σ_j w⁽ᵐ⁾_j w⁽ⁿ⁾_j = e₃ᵀ X e₃ with
        X = M_m X M_nᵀ + K_m K_nᵀ, solved as vec X = (I − M_n ⊗ M_m)⁻¹ vec(K_m K_nᵀ)."""
        qs = self._qs if self.modes else np.array([self.q_accel])
        jerks = self._jerks if self._jerks.size else np.zeros(qs.size)
        weights = self.stationary_modes()
        loops = []
        for q, q_j in zip(qs, jerks, strict=True):  # a trend mode's loop has four states
            F, K, _ = self.steady_state(accel, float(q), float(q_j))
            loops.append(((np.eye(K.size) - np.outer(K, np.eye(K.size)[0])) @ F, K))
        total, moment, energy = 0.0, 0.0, 0.0
        for (M, K), w in zip(loops, weights, strict=True):
            inv = np.linalg.inv(np.eye(K.size) - M)
            total += w * float((inv @ K)[2])
            moment += w * float((M @ inv @ inv @ K)[2])
            for (M2, K2), w2 in zip(loops, weights, strict=True):
                size = K.size * K2.size
                vec = np.linalg.solve(np.eye(size) - np.kron(M2, M), np.outer(K, K2).reshape(-1, order="F"))
                energy += w * w2 * float(vec.reshape(K.size, K2.size, order="F")[2, 2])
        return total, energy, moment

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (Σw)²/Σw² of the steady-state impulse response (``_closed_loop``; an EWMA of gain k gives
        (2 − k)/k)."""
        total, energy, _ = self._closed_loop(accel)
        return total * total / energy

    def nominal_delay(self, accel: float) -> float:
        """Σ j w_j / Σ w_j samples − lag: the DC group delay of the steady-state response (``_closed_loop``:
        for the IMM its modes' mix at the chain's stationary probabilities) less the lag, in s."""
        total, _, moment = self._closed_loop(accel)
        return moment / total / self.config.rate_hz - self.lag_n / self.config.rate_hz

    def mode_delays(self, accel: float) -> tuple[float, float]:
        """(d_agile, d_calm): the DC group delay (s, less the lag) of the steady filter of the most agile
        and of the calmest mode; the IMM's delay moves between them with μ."""
        delays = []
        for q in (self.modes[-1], self.modes[0]):
            F, K, _ = self.steady_state(accel, q)
            M = (np.eye(3) - np.outer(K, np.array([1.0, 0.0, 0.0]))) @ F
            inv = np.linalg.inv(np.eye(3) - M)
            delays.append(float((M @ inv @ inv @ K)[2] / (inv @ K)[2]) - self.lag_n)
        return delays[0] / self.config.rate_hz, delays[1] / self.config.rate_hz

    def motion_model(self) -> str | None:
        """The preset the filter runs (PRESETS)."""
        return self.preset

    def describe(self) -> str:
        """The base line (for the IMM: N_eff and delay of its stationary mode mix, with the per-mode delay
        range), the preset, the process model and the latency (the lag)."""
        model = (
            f"IMM q_a={'/'.join(f'{q:.3g}' for q in self.modes)} (m/s²)²/s, {self.chain}"
            if self.modes
            else f"q_a={self.q_accel:.3g} (m/s²)²/s"
        )
        line = super().describe()
        if self.modes:
            agile, calm = self.mode_delays(0.0)
            line += (
                " (the mix of the IMM's modes at the chain's stationary probabilities; per mode from "
                f"{agile:.3f} s in the most agile to {calm:.3g} s in the calmest: the delay follows μ)"
            )
        latency = self.lag_n / self.config.rate_hz
        return f"{line}; preset {self.preset} ({model}), latency {latency:.3f} s (lag)"


class SmootherEstimator(KalmanEstimator):
    """The kalman model's smoother: offline only (batch), on the preset's random-walk modes (its trend modes
    have no backward pass with a calibrated variance yet: docs/estimators.md, "smoother").

    Without ``q_accel``: the RTS smoother at the mode mix the whole recording supports (``imm_smoother``),
    its variance min(P_f (Pˢ/P_f)^γ + κ (âˢ − â_f)², Pˢ), γ = SMOOTHER_VARIANCE_POWER, κ =
    SMOOTHER_REVISION_WEIGHT.
    With ``q_accel``: the fixed-interval RTS smoother of the single model (ekf_kernels.rts).
    """

    name: ClassVar[str] = "smoother"
    summary: ClassVar[str] = "the kalman model's smoother (offline only)"
    offline_only: ClassVar[bool] = True

    def update(self, t: float, theta: float) -> Estimate | None:
        """Refused: a smoother needs the recording."""
        raise ParameterError("smoother is offline only; use lag for live")

    def __init__(
        self,
        config: EstimatorConfig,
        *,
        preset: str = DEFAULT_PRESET,
        q_accel: float | None = None,
        q_rate: float | None = None,
        init_angle_std: float = 0.3,
        reset_gap: float = 1.0,
    ) -> None:
        """As KalmanEstimator (no lag option: it has the recording)."""
        super().__init__(
            config,
            preset=preset,
            q_accel=q_accel,
            q_rate=q_rate,
            init_angle_std=init_angle_std,
            reset_gap=reset_gap,
        )

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(âˢ, var âˢ): the RTS pass at the smoothed mode mix (``imm_smoother``), or with q_accel the single
        model's RTS pass."""
        t, theta = check_batch_input(t, theta)
        if not self.modes:
            return self.smoothed(t, theta)
        if t.size == 0:
            return np.empty(0), np.empty(0)
        # With trend modes too, the backward pass is the random walks' (there is no four-state RTS pass): the
        # smoother of the preset's random-walk modes alone.
        a, var_s, var_f, a_f = imm_smoother(t, theta, self._params, *self._walks)
        var = lag_variance(var_s, var_f, a, a_f, SMOOTHER_VARIANCE_POWER, SMOOTHER_REVISION_WEIGHT)
        return self._publish(t, a, var)

    def nominal_delay(self, accel: float) -> float:
        """0: a smoother has no lag (its latency is the recording)."""
        return 0.0
