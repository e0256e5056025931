"""Compiled (numba) IMM smoother of the pendulum EKF: the IMM filter forward, then a backward pass over
blocks, so a sample costs the same whatever the smoothing horizon.

The fixed-lag IMM of ``ekf_kernels`` re-mixes every buffered sample at every step: O(N) per sample for a
lag of N samples (425 µs a sample at 1 kHz for a 1 s lag). Here the forward pass keeps, for the last
``block + overlap`` samples, each mode's posterior x⁺_j, P⁺_j, its transition F_j, gain K_j, innovation
ν_j, S_j, and the mode probabilities μ_j; every ``block`` samples (and at a segment's end) a backward pass
runs over them from the newest and gives the oldest ``block`` their smoothed estimate. Each sample so
uses at least ``overlap`` samples of the data after it (all there is at a segment's end) and at most
``block + overlap``; a sample costs (block + overlap)/block backward steps, and the pass holds
block + overlap samples, whatever the recording's length.

The backward pass is Kim's IMM smoother (Kim 1994, "Dynamic linear models with Markov-switching",
J. Econometrics 60) written in the adjoint form of the modified Bryson–Frazier smoother (Bierman 1977,
"Factorization Methods for Discrete Sequential Estimation"): each mode carries λ̃_j, Λ̃_j with
xˢ_j = x⁺_j − P⁺_j λ̃_j and Pˢ_j = P⁺_j − P⁺_j Λ̃_j P⁺_j. The adjoint runs back through Fᵀ, where the RTS
form's gain G = P⁺ Fᵀ (P⁻)⁻¹ runs through F⁻¹: with the pendulum's damping (F contracts θ' by e^{−cΔt}
a step) the RTS form multiplies any difference between the modes by e^{cΔt} a step and blows up within a
second; the adjoint form damps it. For one mode it is the RTS smoother exactly. Step k → k − 1:

    λ̂_j = λ̃_j − Hᵀ (Kᵀ_j λ̃_j + ν_j/S_j),   Λ̂_j = Cᵀ_j Λ̃_j C_j + HᵀH/S_j,   C_j = I − K_j H,
    λ̌_j = Fᵀ_j λ̂_j,   Λ̌_j = Fᵀ_j Λ̂_j F_j                         (mode j's adjoint at sample k − 1),
    μ⁻_j = Σ_i Π_ij μ_i,   μˢ_i ∝ μ_i Σ_j Π_ij μˢ_j/μ⁻_j,   w_ij ∝ Π_ij μˢ_j/μ⁻_j (Σ_j w_ij = 1),
    λ̃_i = Σ_j w_ij λ̌_j,   Λ̃_i = Σ_j w_ij (Λ̌_j − (λ̌_j − λ̃_i)(λ̌_j − λ̃_i)ᵀ)

(μ, x⁺, P⁺ at k − 1; the last term is the spread of the pairs' means x⁺_i − P⁺_i λ̌_j). The estimate
combines the modes: âˢ = Σ_i μˢ_i xˢ_i[2], var = Σ_i μˢ_i (Pˢ_i[2,2] + (xˢ_i[2] − âˢ)²). The sums over j
run over the chain's band (Π_ij = 0 beyond it, as in the forward mixing).
"""

from __future__ import annotations

import math

import numpy as np

from pendulum_accel.estimators.ekf_kernels import _chain_step, _imm_step_into, chain_rates, imm_scratch
from pendulum_accel.physics.lazy import njit

MU_FLOOR = 1e-12
"""The forward pass's floor on μ (``ekf_kernels._update_modes``): the backward probabilities keep it too,
so no mode's ratio μˢ/μ⁻ is 0/0."""


@njit(cache=True)
def _band(rates: np.ndarray) -> int:
    """The chain's reach: max |i − j| over R_ij ≠ 0 (1 for a birth-death chain)."""
    m = rates.shape[0]
    band = 0
    for i in range(m):
        for j in range(m):
            if rates[i, j] != 0.0:
                band = max(band, abs(i - j))
    return band


@njit(cache=True)
def _smoothed(
    x: np.ndarray, p: np.ndarray, lam: np.ndarray, big: np.ndarray, xs: np.ndarray, ps: np.ndarray
) -> None:
    """xs ← x − P λ, ps ← P − P Λ P; the filtered x, P where that gives no variance (cancellation in a
    mode the data ruled out long ago: it carries nothing back, as ``ekf_kernels.rts`` keeps the filter)."""
    for a in range(3):
        xs[a] = x[a] - (p[a, 0] * lam[0] + p[a, 1] * lam[1] + p[a, 2] * lam[2])
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for c in range(3):
                acc += (p[a, 0] * big[0, c] + p[a, 1] * big[1, c] + p[a, 2] * big[2, c]) * p[c, b]
            ps[a, b] = p[a, b] - acc
    if not (ps[2, 2] > 0.0 and math.isfinite(ps[2, 2]) and math.isfinite(xs[2])):
        for a in range(3):
            xs[a] = x[a]
            for b in range(3):
                ps[a, b] = p[a, b]


@njit(cache=True)
def _backward(
    t: np.ndarray,
    first: int,
    last: int,
    out_end: int,
    hist: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    rates: np.ndarray,
    band: int,
    out_a: np.ndarray,
    out_v: np.ndarray,
) -> None:
    """The backward pass (module doc) from sample ``last`` (smoothed = filtered there: λ̃ = 0, Λ̃ = 0)
    down to ``first``; samples first … out_end get âˢ, var. Sample k's forward values are at slot
    k mod len(hist)."""
    hx, hp, hmu, hf, hk, hns = hist
    size, m = hmu.shape[0], hmu.shape[1]
    lam = np.zeros((m, 3))  # λ̃_j at the current sample
    big = np.zeros((m, 3, 3))  # Λ̃_j
    lam_b = np.empty((m, 3))  # λ̌_j
    big_b = np.empty((m, 3, 3))  # Λ̌_j
    lh = np.empty(3)
    bh = np.empty((3, 3))
    tmp = np.empty((3, 3))
    u = np.empty(3)
    smu = np.empty(m)
    nmu = np.empty(m)
    ratio = np.empty(m)
    pi = np.empty((m, m))
    xs = np.empty(3)
    ps = np.empty((3, 3))
    slot = last % size
    for i in range(m):
        smu[i] = hmu[slot, i]
    memo_dt = math.nan
    for k in range(last, first - 1, -1):
        slot = k % size
        if k <= out_end:
            a = 0.0
            for i in range(m):
                _smoothed(hx[slot, i], hp[slot, i], lam[i], big[i], xs, ps)
                a += smu[i] * xs[2]
            v = 0.0
            for i in range(m):
                _smoothed(hx[slot, i], hp[slot, i], lam[i], big[i], xs, ps)
                d = xs[2] - a
                v += smu[i] * (ps[2, 2] + d * d)
            if math.isfinite(a) and math.isfinite(v) and v > 0.0:
                out_a[k], out_v[k] = a, v
        if k == first:
            break
        for j in range(m):  # mode j's adjoint back through its update at k and its prediction into k
            kj, fj = hk[slot, j], hf[slot, j]
            nu, s = hns[slot, j, 0], hns[slot, j, 1]
            kl = kj[0] * lam[j, 0] + kj[1] * lam[j, 1] + kj[2] * lam[j, 2]
            lh[0], lh[1], lh[2] = lam[j, 0] - kl - nu / s, lam[j, 1], lam[j, 2]
            for a in range(3):  # u = Λ̃ K, then Λ̃ C = Λ̃ − u H (column 0), then Cᵀ (Λ̃ C) (row 0)
                u[a] = big[j, a, 0] * kj[0] + big[j, a, 1] * kj[1] + big[j, a, 2] * kj[2]
            for a in range(3):
                for b in range(3):
                    tmp[a, b] = big[j, a, b] - (u[a] if b == 0 else 0.0)
            for b in range(3):
                row = kj[0] * tmp[0, b] + kj[1] * tmp[1, b] + kj[2] * tmp[2, b]
                for a in range(3):
                    bh[a, b] = tmp[a, b] - (row if a == 0 else 0.0)
            bh[0, 0] += 1.0 / s
            for a in range(3):
                lam_b[j, a] = fj[0, a] * lh[0] + fj[1, a] * lh[1] + fj[2, a] * lh[2]
            for a in range(3):  # tmp = Λ̂ F, then Fᵀ tmp
                for b in range(3):
                    tmp[a, b] = bh[a, 0] * fj[0, b] + bh[a, 1] * fj[1, b] + bh[a, 2] * fj[2, b]
            for a in range(3):
                for b in range(3):
                    big_b[j, a, b] = fj[0, a] * tmp[0, b] + fj[1, a] * tmp[1, b] + fj[2, a] * tmp[2, b]
        prev = (k - 1) % size
        dt = t[k] - t[k - 1]
        if dt != memo_dt:
            _chain_step(rates, dt, pi)
            memo_dt = dt
        for j in range(m):
            pred = 0.0
            for i in range(max(0, j - band), min(m, j + band + 1)):
                pred += pi[i, j] * hmu[prev, i]
            ratio[j] = smu[j] / max(pred, MU_FLOOR)
        total = 0.0
        for i in range(m):
            lo, hi = max(0, i - band), min(m, i + band + 1)
            wsum = 0.0
            for j in range(lo, hi):
                wsum += pi[i, j] * ratio[j]
            nmu[i] = max(hmu[prev, i] * wsum, MU_FLOOR)
            total += nmu[i]
            for a in range(3):
                acc = 0.0
                for j in range(lo, hi):
                    acc += pi[i, j] * ratio[j] * lam_b[j, a]
                lam[i, a] = acc / wsum
            for a in range(3):
                for b in range(3):
                    acc = 0.0
                    for j in range(lo, hi):
                        da, db = lam_b[j, a] - lam[i, a], lam_b[j, b] - lam[i, b]
                        acc += pi[i, j] * ratio[j] * (big_b[j, a, b] - da * db)
                    big[i, a, b] = acc / wsum
        for i in range(m):
            smu[i] = nmu[i] / total


@njit(cache=True, nogil=True)  # a long batch leaves the GIL: Ctrl-C reaches the main thread
def run_imm_smoother(
    t: np.ndarray,
    y: np.ndarray,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    block: int,
    overlap: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(âˢ, var âˢ, â, var â) over a recording: the IMM smoother (module doc) and the IMM filter it runs
    forward (``ekf_kernels.imm_step`` per sample, as ``run_imm``'s lag-0 column). Segments (a restart
    after a gap or a divergence) are smoothed apart; where the backward pass gives no finite estimate,
    the sample keeps the filter's."""
    n = t.size
    m = qs.size
    block = max(1, min(block, n))  # a block longer than the recording holds the recording
    overlap = max(0, min(overlap, n))
    size = block + overlap + 1
    a_f = np.empty(n)
    v_f = np.empty(n)
    a_s = np.empty(n)
    v_s = np.empty(n)
    hist = (
        np.zeros((size, m, 3)),
        np.zeros((size, m, 3, 3)),
        np.zeros((size, m)),
        np.zeros((size, m, 3, 3)),
        np.zeros((size, m, 3)),
        np.ones((size, m, 2)),
    )
    hx, hp, hmu, hf, hk, hns = hist
    xs = np.zeros((m, 3))
    ps = np.zeros((m, 3, 3))
    mu = np.full(m, 1.0 / m)
    x = np.zeros(3)
    p = np.zeros((3, 3))
    ra = np.zeros((m, 1))
    rv = np.zeros((m, 1))
    rc = np.zeros((m, 1, 3))
    state = np.array([np.nan, 0.0])
    scratch = imm_scratch(m)
    f_modes, k_modes, nu_s = scratch[12], scratch[13], scratch[14]
    band = _band(rates)
    first = 0  # the oldest sample without its smoothed estimate yet
    for i in range(n):
        restarted = _imm_step_into(
            xs, ps, mu, x, p, ra, rv, rc, state, t[i], y[i], params, qs, rates, scratch
        )
        if restarted and i > first:  # the segment before ends at i − 1: smooth all of it
            _backward(t, first, i - 1, i - 1, hist, rates, band, a_s, v_s)
            first = i
        a_f[i], v_f[i] = x[2], p[2, 2]
        a_s[i], v_s[i] = x[2], p[2, 2]  # the backward pass overwrites it where it gives a finite estimate
        slot = i % size
        for j in range(m):
            hmu[slot, j] = mu[j]
            hns[slot, j, 0], hns[slot, j, 1] = nu_s[j, 0], nu_s[j, 1]
            for a in range(3):
                hx[slot, j, a] = xs[j, a]
                hk[slot, j, a] = k_modes[j, a]
                for b in range(3):
                    hp[slot, j, a, b] = ps[j, a, b]
                    hf[slot, j, a, b] = f_modes[j, a, b]
        if i - first + 1 == block + overlap:
            _backward(t, first, i, first + block - 1, hist, rates, band, a_s, v_s)
            first += block
    if n > first:
        _backward(t, first, n - 1, n - 1, hist, rates, band, a_s, v_s)
    return a_s, v_s, a_f, v_f


def warm() -> None:
    """Compile (or load from the cache) the smoother: a few samples through it."""
    t = np.arange(30) / 100.0
    y = np.zeros(30)
    params = np.array([9.80665, 1.0, 0.05, 1e-6, 0.0, 0.01, 1.0, 1.55, 0.3])
    run_imm_smoother(t, y, params, np.array([1e-3, 0.1]), chain_rates(2, 5.0), 8, 4)


if __name__ == "__main__":
    warm()
