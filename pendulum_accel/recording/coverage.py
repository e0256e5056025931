"""Whether a published σ describes its errors: NEES = e²/var in steady state and after a change of a(t)
(``nees_windows``, ``NeesStats``, ``Calibration``), and how much a share of errors beyond 2σ can tell: the
effective number of independent samples behind it, and the share's 95 % interval (``analyze`` prints them
beside each share, the benchmarks judge by them).

An estimator's error is correlated over its memory: the error at one sample is most of the error at the
next. A share counted over n samples is then not a binomial share of n trials, and a cell made of one
0.8 s steady stretch (an agile robot's) holds a few independent trials, not 80. A share is read, and
the benchmarks judge it against a band (TARGET, issue 33's 1–12 %), only as far as its trials allow:

    τ = 1 + 2 Σ_{k≥1} ρ_k of z = e²/var (NEES) within the window (its steady state, or its stretches
        after changes; pairs inside one stretch), Geyer's initial monotone sequence estimator;
    n_eff = Σ over the stretches of the window of max(1, L/τ) (a stretch shorter than τ is one trial);
    the interval: Wilson's score interval of the share at n_eff trials.

Why z = e²/var: for a Gaussian error u = e/σ the exceedance 1{|u| > 2} and u² are even functions of u, and
by Mehler's expansion corr(g(u_i), g(u_j)) = Σ_{even k ≥ 2} c_k² ρ^k / Σ c_k² ≤ ρ² = corr(u_i², u_j²) for
ρ ≥ 0. So τ of z bounds τ of the exceedances from above: n_eff is at most as many trials as there are,
and the interval errs wide, never narrow. A verdict of "outside" is therefore one the data forces. That
holds for the window's own errors only: each window gets its own τ (``window_trials``), since the errors of
a steady stretch and of a step's first second are two different series (integrated_time).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.recording.changes import CHANGE_WINDOW, after_change

Z95 = 1.959963984540054  # the standard normal's two-sided 95 % point, Φ⁻¹(0.975)
TARGET = (0.01, 0.12)  # the band of the share beyond 2σ
GAUSS_2SIGMA = math.erfc(2.0 / math.sqrt(2.0))  # P(|u| > 2) = erfc(2/√2) of a standard normal u
GAUSS_3SIGMA = math.erfc(3.0 / math.sqrt(2.0))  # P(|u| > 3) = erfc(3/√2): the tail a calibrated σ gives
GAUSS_NEES_MEDIAN = statistics.NormalDist().inv_cdf(0.75) ** 2  # the median of χ²₁: a calibrated σ's NEES
GAUSSIAN_NOTE = (
    f"a calibrated Gaussian σ gives NEES mean 1, median {GAUSS_NEES_MEDIAN:.3f}, "
    f"{100 * GAUSS_2SIGMA:.2f} % beyond 2σ, {100 * GAUSS_3SIGMA:.2f} % beyond 3σ"
)
"""The reference every calibration report states once (a footnote or a column header), not in every row."""


def integrated_time(z: NDArray[np.float64], mask: NDArray[np.bool_] | None = None) -> float:
    """τ = −1 + 2 Σ_{m<M} Γ_m, Γ_m = ρ_{2m} + ρ_{2m+1}: Geyer's initial monotone sequence estimate of the
    integrated autocorrelation time of z over the finite samples of ``mask`` (all of z without one), ρ_k from
    the pairs k apart inside one stretch of the mask (Γ_m summed while positive, each capped by the one
    before); 1 for a series too short or constant to estimate one.

    Pairs never span a gap: a window made of stretches cut from one recording (its steady state, or the
    2 s after each change) is judged by its own errors. τ over the whole recording would be set by the
    window whose NEES varies most: the spikes of a step's first samples, which decorrelate within a few
    samples, gave a braking's 14 s of steady state τ = 1.3 samples (1,848 trials) where its own errors have
    τ = 71 (34 trials)."""
    z = np.asarray(z, dtype=np.float64)
    use = np.isfinite(z) if mask is None else np.asarray(mask, dtype=bool) & np.isfinite(z)
    n = int(np.count_nonzero(use))
    if n < 4:
        return 1.0
    dev = z - float(np.mean(z[use]))
    edges = np.flatnonzero(np.diff(np.concatenate(([0], use.astype(np.int8), [0]))))
    starts, ends = edges[::2], edges[1::2]
    longest = int(np.max(ends - starts))
    cov = np.zeros(longest)
    # Σ over stretches of Σ_i dev_i dev_{i+k} for every k at once: each stretch's autocovariance through a
    # zero-padded FFT (no circular wrap-around, no pair across a gap), summed; over n as the usual biased
    # estimate, which keeps the sequence positive definite.
    for start, end in zip(starts, ends, strict=True):
        seg = dev[start:end]
        size = 1 << (2 * seg.size - 1).bit_length()
        spec = np.fft.rfft(seg, size)
        cov[: seg.size] += np.fft.irfft(spec * np.conj(spec), size)[: seg.size]
    var = float(cov[0])
    if not var > 0.0:
        return 1.0
    rho = cov / var
    total, cap = 0.0, math.inf
    for m in range(longest // 2):
        gamma = float(rho[2 * m] + rho[2 * m + 1])
        if gamma <= 0.0:
            break
        cap = min(cap, gamma)
        total += cap
    return max(1.0, 2.0 * total - 1.0)


def stretch_lengths(mask: NDArray[np.bool_]) -> NDArray[np.int64]:
    """L_s: the lengths (samples) of the maximal runs of True in ``mask``, in order."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0]))))
    return (edges[1::2] - edges[::2]).astype(np.int64)


def effective_samples(mask: NDArray[np.bool_], tau: float) -> float:
    """n_eff = Σ_s max(1, L_s/τ) over the stretches of ``mask`` (0 for an empty mask)."""
    lengths = stretch_lengths(mask)
    return float(np.sum(np.maximum(1.0, lengths / max(tau, 1.0)))) if lengths.size else 0.0


def window_trials(z: NDArray[np.float64], mask: NDArray[np.bool_]) -> float:
    """n_eff of a window: effective_samples of its finite samples at the window's own τ (integrated_time of
    z over those samples' stretches)."""
    use = np.asarray(mask, dtype=bool) & np.isfinite(z)
    return effective_samples(use, integrated_time(z, use))


def wilson(share: float, n: float, z: float = Z95) -> tuple[float, float]:
    """(lo, hi) = (p̂ + z²/2n ∓ z √(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n): Wilson's score interval of a share p̂
    of n trials (n need not be whole: effective trials); (0, 1) without trials. The interval always holds p̂;
    at p̂ = 0 (or 1) its bound is p̂ itself, which the square root's rounding can miss by an ulp (1e-17 at
    n = 22.17), so each bound is clipped to p̂."""
    if not n > 0.0 or not math.isfinite(share):
        return 0.0, 1.0
    z2 = z * z
    centre = share + z2 / (2.0 * n)
    half = z * math.sqrt(max(share * (1.0 - share), 0.0) / n + z2 / (4.0 * n * n))
    scale = 1.0 + z2 / n
    low, high = max(0.0, (centre - half) / scale), min(1.0, (centre + half) / scale)
    return min(low, share), max(high, share)


def share_interval_cells(
    share: float, trials: float, share_key: str, trials_key: str
) -> dict[str, float | None]:
    """{share_key: p̂, trials_key: n_eff, share_key_low: lo, share_key_high: hi}, (lo, hi) = wilson(p̂, n_eff):
    a share beyond 2σ, its independent trials and its 95 % interval as table cells. A cell is None where its
    figure is not a finite number (a window without samples, trials not counted), the interval where either is
    not: a table's null, never NaN."""
    low, high = wilson(share, trials) if math.isfinite(share) and math.isfinite(trials) else (None, None)
    return {
        share_key: float(share) if math.isfinite(share) else None,
        trials_key: float(trials) if math.isfinite(trials) else None,
        f"{share_key}_low": low,
        f"{share_key}_high": high,
    }


def verdict(share: float, n_eff: float, target: tuple[float, float] = TARGET) -> str:
    """'in' (p̂ within the band), 'out' (the 95 % interval misses the band), or 'unsure' (p̂ outside it, but
    its interval reaches it: too few independent trials to tell); '—' without samples."""
    if not math.isfinite(share) or not n_eff > 0.0:
        return "—"
    if target[0] <= share <= target[1]:
        return "in"
    lo, hi = wilson(share, n_eff)
    return "out" if hi < target[0] or lo > target[1] else "unsure"


@dataclass(frozen=True)
class NeesStats:
    """NEES = e²/var: mean, median, the share with |e| > 2σ (NEES > 4) and the share with |e| > 3σ
    (NEES > 9) over n samples (NaN if n = 0), and the independent trials behind the 2σ share
    (window_trials; NaN where they are not counted)."""

    mean: float
    median: float
    share_2sigma: float
    n: int
    trials: float = math.nan
    share_3sigma: float = math.nan

    @classmethod
    def of(cls, nees: NDArray[np.float64], trials: float = math.nan) -> NeesStats:
        """Statistics of the finite entries of ``nees``."""
        z = nees[np.isfinite(nees)]
        if z.size == 0:
            return cls(math.nan, math.nan, math.nan, 0, math.nan)
        return cls(
            float(z.mean()),
            float(np.median(z)),
            float(np.mean(z > 4.0)),
            int(z.size),
            trials,
            float(np.mean(z > 9.0)),
        )

    def interval(self) -> tuple[float, float] | None:
        """The share's 95 % interval at its trials (wilson); None where they are not counted."""
        if self.n == 0 or not math.isfinite(self.trials):
            return None
        return wilson(self.share_2sigma, self.trials)

    def share_text(self) -> str:
        """'x % beyond 2σ (n=N, about K independent: 95 % lo–hi %), y % beyond 3σ'; without counted trials,
        no 'about'."""
        span = self.interval()
        trials = (
            ""
            if span is None
            else f", about {self.trials:.0f} independent: 95 % {100 * span[0]:.1f}–{100 * span[1]:.1f} %"
        )
        return (
            f"{100 * self.share_2sigma:.1f} % beyond 2σ (n={self.n}{trials}), "
            f"{100 * self.share_3sigma:.2f} % beyond 3σ"
        )


@dataclass(frozen=True)
class Calibration:
    """NEES figures in steady state and within CHANGE_WINDOW s after a change of a (a calibrated σ:
    GAUSSIAN_NOTE)."""

    steady: NeesStats
    after_change: NeesStats

    def line(self, label: str) -> str:
        """'label: steady NEES mean m, median d, x % beyond 2σ (n, k independent: 95 % lo–hi %), y % beyond
        3σ; after a change: …'."""

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
    n_eff = window_trials (its finite samples at the window's own integrated time τ)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        all_nees = np.where(variance > 0.0, error * error / variance, np.nan)
    keep = t >= t_from
    nees, after = all_nees[keep], after_change(t, t_truth, a_truth)[keep]
    return (
        (nees[~after], window_trials(nees, ~after)),
        (nees[after], window_trials(nees, after)),
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


class NeesCells(NamedTuple):
    """One NEES window's figures as table cells (nees_cells): None where a figure does not exist."""

    mean: float | None
    median: float | None
    share_2sigma: float | None
    trials: float | None
    share_2sigma_low: float | None
    share_2sigma_high: float | None
    share_3sigma: float | None


def nees_cells(stats: NeesStats | None) -> NeesCells:
    """(mean, median, p̂₂, n_eff, lo, hi, p̂₃) of one window, (lo, hi) the 2σ share's 95 % interval
    (share_interval_cells), p̂₃ the share beyond 3σ; None throughout without the window, None where a share or
    its trials is missing, and a mean or median the window lacks stays NaN (cli.output.json_text writes both
    as null)."""
    if stats is None:
        return NeesCells(None, None, None, None, None, None, None)
    cells = share_interval_cells(stats.share_2sigma, stats.trials, "share", "trials")
    beyond3 = float(stats.share_3sigma) if math.isfinite(stats.share_3sigma) else None
    return NeesCells(
        stats.mean,
        stats.median,
        cells["share"],
        cells["trials"],
        cells["share_low"],
        cells["share_high"],
        beyond3,
    )


def nees_fields(key: str, stats: NeesStats | None) -> dict[str, float | None]:
    """{key}_{mean,median,share_2sigma,trials,share_2sigma_low,share_2sigma_high,share_3sigma}: nees_cells of
    one window under a table's keys."""
    return {f"{key}_{name}": value for name, value in zip(NeesCells._fields, nees_cells(stats), strict=True)}
