"""A reliability diagram's bins: does the σ an estimate publishes match the error it makes at that σ?

The samples are sorted by their published σ and cut into ``bins`` groups of (nearly) equal count (deciles
by default); in each, the root-mean-square of the σ they published is set against the RMS of the errors
they made. A calibrated σ puts every bin on the diagonal (observed = predicted); a bin below it is a σ too
wide there, above it too narrow. Users read calibration from this picture better than from a table of
shares: it says *where* (at small σ, in calm stretches; at large σ, after a change) a σ misleads.

numpy only: the plots (recording.analysis_plot, the real-motion benchmark) draw what ``reliability_bins``
returns.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

DECILES = 10  # bins of a reliability diagram: the deciles of the published σ


class ReliabilityBins(NamedTuple):
    """One row per bin, ascending σ: predicted √(mean σ²), observed √(mean e²), and the samples in it."""

    predicted: NDArray[np.float64]
    observed: NDArray[np.float64]
    samples: NDArray[np.int64]


def reliability_bins(error: ArrayLike, variance: ArrayLike, bins: int = DECILES) -> ReliabilityBins:
    """predicted_k = √(mean_{i∈B_k} var_i), observed_k = √(mean_{i∈B_k} e_i²), B_k the k-th of ``bins``
    equal-count groups of the samples sorted by var (np.array_split: sizes differ by at most one), over the
    samples whose e and var are finite and var > 0. Fewer samples than bins give one bin per sample; none
    give empty arrays.

    RMS, not mean, of σ in a bin: a calibrated σ has E[e²] = var sample by sample, so the bin's mean e²
    estimates its mean var, and the two roots are on the diagonal whatever the spread of σ in the bin."""
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins}")
    e = np.asarray(error, dtype=np.float64).ravel()
    var = np.asarray(variance, dtype=np.float64).ravel()
    if e.shape != var.shape:
        raise ValueError(f"error and variance differ in size: {e.size} and {var.size}")
    keep = np.isfinite(e) & np.isfinite(var) & (var > 0.0)
    e, var = e[keep], var[keep]
    order = np.argsort(var, kind="stable")
    groups = [g for g in np.array_split(order, min(bins, order.size)) if g.size] if order.size else []
    predicted = np.array([np.sqrt(np.mean(var[g])) for g in groups], dtype=np.float64)
    observed = np.array([np.sqrt(np.mean(e[g] ** 2)) for g in groups], dtype=np.float64)
    samples = np.array([g.size for g in groups], dtype=np.int64)
    return ReliabilityBins(predicted, observed, samples)
