"""Compiled (numba) passes of the pendulum EKF on x = [θ, θ', a]: filter, fixed-lag smoother, RTS smoother.

Model (physics.rigid.theta_ddot written out in scalar form, as in physics.kernels):

    θ'' = (a cos θ − g sin θ)/l − c θ',   a' = w_a, E[w_a w_a] = q_a δ (a random walk of a),
    θ''' noise: E[w_ω w_ω] = q_ω δ on θ' (unmodelled torque),   y = θ + v, E[v²] = r.

Prediction over Δt: sub-steps h ≤ ``MAX_STEP``; per sub-step x ← one classic RK4 step with a held,
F_h = I + J h + J² h²/2 (J the Jacobian at the prior state), P ← F_h P F_hᵀ + Q_h with Q_h the
integrated random walk of a through θ'' ≈ j₁₂ a (j₁₂ = cos θ / l): q_a [h⁵j²/20, h⁴j²/8, h³j/6; ·, h³j²/3,
h²j/2; ·, ·, h] plus q_ω h on θ'θ'. The transition kept for the smoothers is the product of the F_h.

Fixed-lag smoothing (Anderson & Moore's augmented state, for a only): for every buffered sample i ≤ k
the pass keeps â_{i|k}, its variance and the cross-covariance row c_i = Cov(a_i, x_k | y_{..k}).
A measurement with innovation ν, S = P⁻₀₀ + r, gain K moves â_i by c_i[0] ν/S and its variance by
−c_i[0]²/S, then c_i ← c_i − c_i[0] K; a prediction maps c_i ← F c_i. One pass gives every lag at once
(O(N) per sample for a lag of N samples). The RTS pass is the fixed-interval limit.

Trend modes (the IMM only): x = [θ, θ', a, j] with a' = j, j' = w_j, E[w_j w_j] = q_j δ, an integrated
walk of a that predicts a trend (``predict_trend``, ``trend_noise``); the IMM then holds every mode on four
states, a random-walk mode's j ≡ 0 with no covariance (``with_trends``, ``_mix``), and the fixed-lag rows
c_i carry a fourth entry.

The first call compiles (≈ 20 s) into numba's on-disk cache beside this file (``make setup`` warms it:
``python -m pendulum_accel.estimators.ekf_kernels``).
"""

from __future__ import annotations

import math

import numpy as np

from pendulum_accel.physics.lazy import njit

MAX_STEP = 0.01  # s; longer intervals are propagated in sub-steps so RK4 and F stay accurate
INIT_JERK_STD = 10.0  # m/s³: a trend mode's prior on j, a hard braking reached within 1 s (set, not fitted)


@njit(cache=True, inline="always")
def _accel(th: float, om: float, ac: float, g: float, linv: float, c: float) -> float:
    """θ'' = (a cos θ − g sin θ)/l − c θ'."""
    return (ac * math.cos(th) - g * math.sin(th)) * linv - c * om


@njit(cache=True, inline="always")
def _rk4(
    th: float, om: float, a0: float, a_mid: float, a_end: float, h: float, g: float, linv: float, c: float
) -> tuple[float, float]:
    """(θ, θ') after one classic RK4 step h of θ'' = (a cos θ − g sin θ)/l − c θ', with a = a0, a_mid and
    a_end at the step's start, middle and end (held: all three equal; a trend: a + j s)."""
    half = 0.5 * h
    w1 = _accel(th, om, a0, g, linv, c)
    th2, om2 = th + half * om, om + half * w1
    w2 = _accel(th2, om2, a_mid, g, linv, c)
    th3, om3 = th + half * om2, om + half * w2
    w3 = _accel(th3, om3, a_mid, g, linv, c)
    th4, om4 = th + h * om3, om + h * w3
    w4 = _accel(th4, om4, a_end, g, linv, c)
    sixth = h / 6.0
    return th + sixth * (om + 2.0 * om2 + 2.0 * om3 + om4), om + sixth * (w1 + 2.0 * w2 + 2.0 * w3 + w4)


@njit(cache=True, inline="always")
def _flow_rows(j10: float, j12: float, c: float, h: float) -> tuple[float, float, float, float, float, float]:
    """(f00, f01, f02, f10, f11, f12): the θ and θ' rows of F_h = I + J h + J² h²/2 on [θ, θ', a] (a held),
    J's rows (0, 1, 0) and (j₁₀, −c, j₁₂)."""
    h2 = 0.5 * h * h
    return (
        1.0 + j10 * h2, h - c * h2, j12 * h2,
        j10 * h - c * j10 * h2, 1.0 - c * h + (j10 + c * c) * h2, j12 * h - c * j12 * h2,
    )  # fmt: skip


@njit(cache=True)
def predict(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    dt: float,
    g: float,
    linv: float,
    c: float,
    q_rate: float,
    q_accel: float,
) -> None:
    """In place: x ← RK4 sub-steps (a held), P ← F_h P F_hᵀ + Q_h per sub-step, f ← Π F_h (module doc)."""
    steps = max(1, math.ceil(dt / MAX_STEP))
    h = dt / steps
    for i in range(3):
        for j in range(3):
            f[i, j] = 1.0 if i == j else 0.0
    # Scalars only (F_h's third row is e₃): no temporary arrays in the per-sample path.
    for _ in range(steps):
        th, om, ac = x[0], x[1], x[2]
        cos_th, sin_th = math.cos(th), math.sin(th)
        j10 = -(g * cos_th + ac * sin_th) * linv
        j12 = cos_th * linv
        f00, f01, f02, f10, f11, f12 = _flow_rows(j10, j12, c, h)
        x[0], x[1] = _rk4(th, om, ac, ac, ac, h, g, linv, c)
        # A = F_h P (row 2 of A is row 2 of P), then P ← A F_hᵀ.
        a00 = f00 * p[0, 0] + f01 * p[1, 0] + f02 * p[2, 0]
        a01 = f00 * p[0, 1] + f01 * p[1, 1] + f02 * p[2, 1]
        a02 = f00 * p[0, 2] + f01 * p[1, 2] + f02 * p[2, 2]
        a10 = f10 * p[0, 0] + f11 * p[1, 0] + f12 * p[2, 0]
        a11 = f10 * p[0, 1] + f11 * p[1, 1] + f12 * p[2, 1]
        a12 = f10 * p[0, 2] + f11 * p[1, 2] + f12 * p[2, 2]
        a20, a21, a22 = p[2, 0], p[2, 1], p[2, 2]
        p00 = a00 * f00 + a01 * f01 + a02 * f02
        p01 = a00 * f10 + a01 * f11 + a02 * f12
        p11 = a10 * f10 + a11 * f11 + a12 * f12
        p20 = a20 * f00 + a21 * f01 + a22 * f02
        p21 = a20 * f10 + a21 * f11 + a22 * f12
        # + Q_h: the random walk of a integrated through θ'' ≈ j₁₂ a, and q_ω on θ'.
        qa = q_accel
        h3 = h * h * h
        p[0, 0] = p00 + qa * j12 * j12 * h3 * h * h / 20.0
        p[0, 1] = p01 + qa * j12 * j12 * h3 * h / 8.0
        p[0, 2] = p20 + qa * j12 * h3 / 6.0
        p[1, 1] = p11 + qa * j12 * j12 * h3 / 3.0 + q_rate * h
        p[1, 2] = p21 + qa * j12 * h * h / 2.0
        p[2, 2] = a22 + qa * h
        p[1, 0], p[2, 0], p[2, 1] = p[0, 1], p[0, 2], p[1, 2]
        # f ← F_h f
        for j in range(3):
            r0, r1, r2 = f[0, j], f[1, j], f[2, j]
            f[0, j] = f00 * r0 + f01 * r1 + f02 * r2
            f[1, j] = f10 * r0 + f11 * r1 + f12 * r2


@njit(cache=True)
def trend_noise(q: np.ndarray, j12: float, h: float, q_accel: float, q_jerk: float, q_rate: float) -> None:
    """q ← Q_h of ``predict_trend`` (both triangles): the random walk of a (q_a, as ``predict``), q_ω on θ'
    and the integrated walk of a (q_j) through θ'' ≈ j₁₂ a, Q_ab = q_j ∫₀ʰ g_a(u) g_b(u) du with
    g = (j₁₂ u³/6, j₁₂ u²/2, u, 1)."""
    h3 = h * h * h
    h4, h5 = h3 * h, h3 * h * h
    # Q_h: the random walk of a (as ``predict``), q_ω on θ', and the integrated walk of a.
    qa, qj = q_accel, q_jerk
    q[0, 0] = qa * j12 * j12 * h5 / 20.0 + qj * j12 * j12 * h5 * h * h / 252.0
    q[0, 1] = qa * j12 * j12 * h4 / 8.0 + qj * j12 * j12 * h3 * h3 / 72.0
    q[0, 2] = qa * j12 * h3 / 6.0 + qj * j12 * h5 / 30.0
    q[0, 3] = qj * j12 * h4 / 24.0
    q[1, 1] = qa * j12 * j12 * h3 / 3.0 + qj * j12 * j12 * h5 / 20.0 + q_rate * h
    q[1, 2] = qa * j12 * h * h / 2.0 + qj * j12 * h4 / 8.0
    q[1, 3] = qj * j12 * h3 / 6.0
    q[2, 2] = qa * h + qj * h3 / 3.0
    q[2, 3] = qj * h * h / 2.0
    q[3, 3] = qj * h
    for i in range(4):
        for j in range(i):
            q[i, j] = q[j, i]


@njit(cache=True)
def predict_trend(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    dt: float,
    g: float,
    linv: float,
    c: float,
    q_rate: float,
    q_accel: float,
    q_jerk: float,
    work: np.ndarray,
) -> None:
    """In place, on x = [θ, θ', a, j] (a' = j, j' = w_j, E[w_j w_j] = q_j δ: an integrated walk of a, which
    predicts a trend): x ← RK4 sub-steps with a(s) = a + j s, a ← a + j h; P ← F_h P F_hᵀ + Q_h, f ← Π F_h.

    F_h = I + J h + J² h²/2 as ``predict``, its fourth column (0, j₁₂ h²/2, h, 1)ᵀ. Q_h (``trend_noise``):
    ``predict``'s random walk of a (q_a) plus the integrated walk through θ'' ≈ j₁₂ a, the chain
    j → a → θ' → θ with impulse responses 1, u, j₁₂ u²/2, j₁₂ u³/6 (u the time since the kick):
    Q_ab = q_j ∫₀ʰ g_a(u) g_b(u) du, e.g. Q_θθ = q_j j₁₂² h⁷/252, Q_aj = q_j h²/2, Q_jj = q_j h.
    ``work``: 3 × 4 × 4 scratch (F_h, Q_h, F_h P), kept by the caller so a sample allocates nothing."""
    steps = max(1, math.ceil(dt / MAX_STEP))
    h = dt / steps
    for i in range(4):
        for j in range(4):
            f[i, j] = 1.0 if i == j else 0.0
    fh, q, tmp = work[0], work[1], work[2]
    for _ in range(steps):
        th, om, ac, jk = x[0], x[1], x[2], x[3]
        cos_th, sin_th = math.cos(th), math.sin(th)
        j10 = -(g * cos_th + ac * sin_th) * linv
        j12 = cos_th * linv
        for i in range(4):
            for j in range(4):
                fh[i, j] = 0.0
        fh[0, 0], fh[0, 1], fh[0, 2], fh[1, 0], fh[1, 1], fh[1, 2] = _flow_rows(j10, j12, c, h)
        fh[1, 3] = j12 * (0.5 * h * h)
        fh[2, 2], fh[2, 3], fh[3, 3] = 1.0, h, 1.0
        a_end = ac + h * jk
        x[0], x[1] = _rk4(th, om, ac, ac + 0.5 * h * jk, a_end, h, g, linv, c)
        x[2] = a_end
        trend_noise(q, j12, h, q_accel, q_jerk, q_rate)
        for i in range(4):
            for j in range(4):
                acc = 0.0
                for k in range(4):
                    acc += fh[i, k] * p[k, j]
                tmp[i, j] = acc
        for i in range(4):
            for j in range(i, 4):
                acc = q[i, j]
                for k in range(4):
                    acc += tmp[i, k] * fh[j, k]
                p[i, j] = acc
                p[j, i] = acc
        if steps == 1:  # f = F_h: no product to form
            for i in range(4):
                for j in range(4):
                    f[i, j] = fh[i, j]
            continue
        for j in range(4):
            col = (f[0, j], f[1, j], f[2, j], f[3, j])
            for i in range(4):
                f[i, j] = fh[i, 0] * col[0] + fh[i, 1] * col[1] + fh[i, 2] * col[2] + fh[i, 3] * col[3]


@njit(cache=True)
def correct(x: np.ndarray, p: np.ndarray, k: np.ndarray, y: float, r: float) -> tuple[float, float]:
    """In place: K = P Hᵀ/S, x ← x + K ν, P ← P − K Kᵀ S (H = [1, 0, …], S = P₀₀ + r); returns (ν, S).
    Any state size (x.size): three states, or four with the trend's j (``predict_trend``)."""
    s = p[0, 0] + r
    nu = y - x[0]
    d = x.size
    for i in range(d):
        k[i] = p[i, 0] / s
    for i in range(d):
        x[i] += k[i] * nu
    for i in range(d):
        for j in range(d):
            p[i, j] -= k[i] * k[j] * s
    return nu, s


@njit(cache=True)
def initialise(
    x: np.ndarray, p: np.ndarray, y: float, g: float, length: float, r: float, clamp: float, amp: float
) -> None:
    """x = [θ, 0, g tan θ_c]; P = diag(r, (ω₀ A)², (g sec²θ_c A)²), θ_c = θ clipped to ±clamp, A = amp."""
    th = min(max(y, -clamp), clamp)
    x[0], x[1], x[2] = y, 0.0, g * math.tan(th)
    for i in range(3):
        for j in range(3):
            p[i, j] = 0.0
    cos_th = math.cos(th)
    p[0, 0] = r
    p[1, 1] = (math.sqrt(g / length) * amp) ** 2
    p[2, 2] = (g / (cos_th * cos_th) * amp) ** 2


@njit(cache=True)
def _finite(x: np.ndarray, p: np.ndarray) -> bool:
    """True when every entry of x and P is finite."""
    total = 0.0
    for i in range(3):
        total += x[i]
        for j in range(3):
            total += p[i, j]
    return math.isfinite(total)


@njit(cache=True)
def step(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    k: np.ndarray,
    prior_x: np.ndarray,
    prior_p: np.ndarray,
    ring_a: np.ndarray,
    ring_v: np.ndarray,
    ring_c: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
) -> bool:
    """One sample into the filter and the fixed-lag buffer; True when the filter (re)started here.

    ``state`` = [last t (NaN before the first sample), samples in the current segment]; ``params`` =
    [g, l, c, r, q_ω, q_a, reset_gap, clamp, init amplitude]. The buffer (size N + 1) holds â, var and
    c for the last N + 1 samples, sample i at slot i mod (N + 1); a restart empties it (state[1] = 1).
    The prior x⁻, P⁻ of the sample is left in prior_x, prior_p and the transition from the last in f.
    """
    g, length, c, r = params[0], params[1], params[2], params[3]
    q_rate, q_accel, reset_gap = params[4], params[5], params[6]
    size = ring_a.size
    last_t = state[0]
    if needs_restart(state, t, reset_gap):
        _start(x, p, f, prior_x, prior_p, ring_a, ring_v, ring_c, state, t, y, params)
        return True
    predict(x, p, f, t - last_t, g, 1.0 / length, c, q_rate, q_accel)
    _copy3(x, p, prior_x, prior_p)
    count = int(state[1])
    held = min(count, size - 1)
    # Cross-covariances of the buffered a's with the new state: c ← F c.
    for j in range(1, held + 1):
        slot = (count - j) % size
        c0, c1, c2 = ring_c[slot, 0], ring_c[slot, 1], ring_c[slot, 2]
        for i in range(3):
            ring_c[slot, i] = f[i, 0] * c0 + f[i, 1] * c1 + f[i, 2] * c2
    slot = count % size
    ring_a[slot], ring_v[slot] = x[2], p[2, 2]
    for i in range(3):
        ring_c[slot, i] = p[2, i]
    nu, s = correct(x, p, k, y, r)
    for j in range(0, held + 1):
        slot = (count - j) % size
        c0 = ring_c[slot, 0]
        ring_a[slot] += c0 * nu / s
        ring_v[slot] -= c0 * c0 / s
        for i in range(3):
            ring_c[slot, i] -= c0 * k[i]
    if _finite(x, p):
        state[0], state[1] = t, count + 1
        return False
    # A diverged filter restarts rather than publish inf/NaN.
    _start(x, p, f, prior_x, prior_p, ring_a, ring_v, ring_c, state, t, y, params)
    return True


@njit(cache=True)
def needs_restart(state: np.ndarray, t: float, reset_gap: float) -> bool:
    """True before the first sample and after a gap longer than reset_gap."""
    last_t = state[0]
    return last_t != last_t or t - last_t > reset_gap  # NaN != NaN: no sample yet


@njit(cache=True)
def _start(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    prior_x: np.ndarray,
    prior_p: np.ndarray,
    ring_a: np.ndarray,
    ring_v: np.ndarray,
    ring_c: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
) -> None:
    """Initialise the filter from y (``initialise``) and the buffer with it as sample 0 of a segment."""
    initialise(x, p, y, params[0], params[1], params[3], params[7], params[8])
    prior_x[:] = x
    prior_p[:, :] = p
    for i in range(3):
        for j in range(3):
            f[i, j] = 1.0 if i == j else 0.0
    ring_a[0], ring_v[0] = x[2], p[2, 2]
    for i in range(3):
        ring_c[0, i] = p[2, i]
    state[0], state[1] = t, 1.0


@njit(cache=True)
def _flush(
    out_a: np.ndarray,
    out_v: np.ndarray,
    ring_a: np.ndarray,
    ring_v: np.ndarray,
    last: int,
    count: int,
    lags: np.ndarray,
) -> None:
    """At a segment's end (sample ``last``): samples whose lag reaches past it get their latest â, var."""
    size = ring_a.size
    for j in range(min(count, size)):
        slot = (count - 1 - j) % size
        for m in range(lags.size):
            if lags[m] > j:
                out_a[last - j, m] = ring_a[slot]
                out_v[last - j, m] = ring_v[slot]


@njit(cache=True, nogil=True)  # a long batch leaves the GIL: Ctrl-C reaches the main thread
def run_pass(
    t: np.ndarray,
    y: np.ndarray,
    params: np.ndarray,
    lags: np.ndarray,
    keep: bool,
    q_accel: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Filter and fixed-lag pass over a recording (``step`` per sample).

    Returns (â_lag, var_lag) of shape (n, len(lags)): column m holds â_{i | i + lags[m]}, aligned to the
    sample i it describes (NaN where a divergence restart lost it; the last lags[m] samples of a segment
    use all the data there is), and, when ``keep``, what the RTS pass needs: priors x⁻, P⁻, posteriors
    x⁺, P⁺, transitions F (from the previous sample) and the restart flags. ``q_accel``: q_a of the
    interval into each sample (n values), or empty for params[5] throughout.
    """
    n = t.size
    varying = q_accel.size == n
    params = params.copy()  # params[5] takes each sample's q_a when it varies
    size = int(lags.max()) + 1 if lags.size else 1
    out_a = np.full((n, lags.size), np.nan)
    out_v = np.full((n, lags.size), np.nan)
    m_keep = n if keep else 0
    xpr = np.empty((m_keep, 3))
    ppr = np.empty((m_keep, 3, 3))
    xpo = np.empty((m_keep, 3))
    ppo = np.empty((m_keep, 3, 3))
    fk = np.empty((m_keep, 3, 3))
    starts = np.zeros(m_keep, dtype=np.bool_)
    x = np.zeros(3)
    p = np.zeros((3, 3))
    f = np.eye(3)
    k = np.zeros(3)
    prior_x = np.zeros(3)
    prior_p = np.zeros((3, 3))
    ring_a = np.zeros(size)
    ring_v = np.zeros(size)
    ring_c = np.zeros((size, 3))
    state = np.array([np.nan, 0.0])
    reset_gap = params[6]
    for i in range(n):
        if i > 0 and needs_restart(state, t[i], reset_gap):
            _flush(out_a, out_v, ring_a, ring_v, i - 1, int(state[1]), lags)
        if varying:
            params[5] = q_accel[i]
        restarted = step(x, p, f, k, prior_x, prior_p, ring_a, ring_v, ring_c, state, t[i], y[i], params)
        if keep:
            starts[i] = restarted
            _copy3(x, p, xpo[i], ppo[i])
            _copy3(prior_x, prior_p, xpr[i], ppr[i])
            for r in range(3):
                for col in range(3):
                    fk[i, r, col] = f[r, col]
        count = int(state[1])
        for m in range(lags.size):
            lag = lags[m]
            if lag < count:
                slot = (count - 1 - lag) % size
                out_a[i - lag, m] = ring_a[slot]
                out_v[i - lag, m] = ring_v[slot]
    _flush(out_a, out_v, ring_a, ring_v, n - 1, int(state[1]), lags)
    return out_a, out_v, xpr, ppr, xpo, ppo, fk, starts


@njit(cache=True)
def _copy3(x: np.ndarray, p: np.ndarray, x_out: np.ndarray, p_out: np.ndarray) -> None:
    """x_out ← x (3), p_out ← p (3×3), element by element (a slice assignment costs more per sample)."""
    for i in range(3):
        x_out[i] = x[i]
        for j in range(3):
            p_out[i, j] = p[i, j]


@njit(cache=True)
def _inverse3(m: np.ndarray, inv: np.ndarray) -> bool:
    """inv ← M⁻¹ of a 3×3 matrix by cofactors (adjugate / determinant), into a buffer (no allocation);
    False (inv untouched past the cofactors) when det M is 0 or not finite: M has no usable inverse."""
    inv[0, 0] = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
    inv[0, 1] = m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]
    inv[0, 2] = m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]
    inv[1, 0] = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
    inv[1, 1] = m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]
    inv[1, 2] = m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]
    inv[2, 0] = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
    inv[2, 1] = m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]
    inv[2, 2] = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    det = m[0, 0] * inv[0, 0] + m[0, 1] * inv[1, 0] + m[0, 2] * inv[2, 0]
    if det == 0.0 or not math.isfinite(det):
        return False
    for i in range(3):
        for j in range(3):
            inv[i, j] = inv[i, j] / det
    return True


@njit(cache=True)
def rts(
    xpr: np.ndarray, ppr: np.ndarray, xpo: np.ndarray, ppo: np.ndarray, fk: np.ndarray, starts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rauch-Tung-Striebel pass, per segment: G = P⁺_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹,
    xˢ_k = x⁺_k + G (xˢ_{k+1} − x⁻_{k+1}), Pˢ_k = P⁺_k + G (Pˢ_{k+1} − P⁻_{k+1}) Gᵀ; returns (âˢ, var âˢ),
    NaN (a hole) where not even the filter has a positive P_aa."""
    n = xpo.shape[0]
    a = np.empty(n)
    v = np.empty(n)
    xs = np.zeros(3)
    ps = np.zeros((3, 3))
    pf = np.empty((3, 3))
    gain = np.empty((3, 3))
    dx = np.empty(3)
    dp = np.empty((3, 3))
    tmp = np.empty((3, 3))
    inv = np.empty((3, 3))
    for k in range(n - 1, -1, -1):
        # A prior with no inverse (a filter driven far out of its model, e.g. angles that jump across
        # ±90° every sample) carries nothing back: the pass restarts there from the filtered estimate,
        # as at a segment start.
        if k == n - 1 or starts[k + 1] or not _inverse3(ppr[k + 1], inv):
            xs[:] = xpo[k]
            ps[:, :] = ppo[k]
        else:
            for i in range(3):  # P⁺ Fᵀ
                for j in range(3):
                    pf[i, j] = (
                        ppo[k, i, 0] * fk[k + 1, j, 0]
                        + ppo[k, i, 1] * fk[k + 1, j, 1]
                        + ppo[k, i, 2] * fk[k + 1, j, 2]
                    )
            for i in range(3):
                for j in range(3):
                    gain[i, j] = pf[i, 0] * inv[0, j] + pf[i, 1] * inv[1, j] + pf[i, 2] * inv[2, j]
            for i in range(3):
                dx[i] = xs[i] - xpr[k + 1, i]
                for j in range(3):
                    dp[i, j] = ps[i, j] - ppr[k + 1, i, j]
            for i in range(3):
                xs[i] = xpo[k, i] + gain[i, 0] * dx[0] + gain[i, 1] * dx[1] + gain[i, 2] * dx[2]
            for i in range(3):
                for j in range(3):
                    tmp[i, j] = gain[i, 0] * dp[0, j] + gain[i, 1] * dp[1, j] + gain[i, 2] * dp[2, j]
            for i in range(3):
                for j in range(3):
                    ps[i, j] = (
                        ppo[k, i, j]
                        + tmp[i, 0] * gain[j, 0]
                        + tmp[i, 1] * gain[j, 1]
                        + tmp[i, 2] * gain[j, 2]
                    )
            if not (ps[0, 0] > 0.0 and ps[1, 1] > 0.0 and ps[2, 2] > 0.0 and math.isfinite(xs[2])):
                # Cancellation in an ill-conditioned prior gave no covariance (or no state) at all:
                # keep the filtered estimate there, as for a prior with no inverse.
                xs[:] = xpo[k]
                ps[:, :] = ppo[k]
        if ps[2, 2] > 0.0 and math.isfinite(ps[2, 2]) and math.isfinite(xs[2]):
            a[k] = xs[2]
            v[k] = ps[2, 2]
        else:  # the filter itself broke down here (its P_aa is no variance): no estimate, a hole
            a[k] = math.nan
            v[k] = math.nan
    return a, v


ImmScratch = tuple[
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
]  # fmt: skip


@njit(cache=True)
def imm_scratch(m: int, size: int = 1, d: int = 3) -> ImmScratch:
    """Work arrays of one imm_step for m modes of d states (3, or 4 with trend modes) and a buffer of
    ``size`` samples: (c, x⁰, P⁰, F, K, log-likelihoods, Π, mixing weights w, the buffer's mixed â, var
    (m × size) and c (m × d × size), [the Δt Π was computed for, the chain's band]: at a steady rate Π
    and the band are computed once, and ``predict_trend``'s work arrays)."""
    return (
        np.zeros(m), np.zeros((m, d)), np.zeros((m, d, d)), np.empty((d, d)), np.empty(d), np.empty(m),
        np.empty((m, m)), np.empty((m, m)), np.zeros((m, size)), np.zeros((m, size)),
        np.zeros((m, d, size)), np.array([np.nan, -1.0]), np.empty((3, 4, 4)),
    )  # fmt: skip


@njit(cache=True)
def imm_step(
    xs: np.ndarray,
    ps: np.ndarray,
    mu: np.ndarray,
    x: np.ndarray,
    p: np.ndarray,
    ra: np.ndarray,
    rv: np.ndarray,
    rc: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    jerks: np.ndarray,
    scratch: ImmScratch,
) -> bool:
    """One sample into the interacting-multiple-model filter (Blom & Bar-Shalom); True when it (re)started.

    Model j is the EKF above with q_a = qs[j]. With ``jerks`` (one q_j per mode; empty: none) the modes
    carry a fourth state, the trend j of a: a mode with q_j > 0 is the integrated walk (``predict_trend``),
    one with q_j = 0 a random walk whose j and its covariance are zeroed after the mixing (it never
    carries a trend another mode handed it). The mode follows a continuous-time Markov chain with jump
    rates R_ij (1/s, ``chain_rates``): over Δt it stays with Π_ii = e^{−r_i Δt}, r_i = Σ_j R_ij, and moves
    to j with Π_ij = (1 − e^{−r_i Δt}) R_ij / r_i. Per sample:
    mix (c_j = Σ_i Π_ij μ_i, x⁰_j = Σ_i Π_ij μ_i x_i / c_j, P⁰_j likewise plus the spread of the x_i), predict
    and correct each model, μ_j ∝ c_j N(ν_j; 0, S_j), and combine: x = Σ μ_j x_j,
    P = Σ μ_j (P_j + (x_j − x)(x_j − x)ᵀ). ``state``, ``params``: as ``step``; x, p receive the combination.

    Fixed lag (each mode keeps ``step``'s buffer, ra, rv: modes × (N + 1), rc: modes × 3 × (N + 1), for a
    lag of N samples; the buffer is the innermost axis, so its loops run as vector arithmetic): the mixing
    mixes each buffered sample's â, var and cross-covariance row like the state (``_mix_ring``: the
    augmented state's IMM mixing, restricted to the blocks the update reads), each mode's prediction and
    update move them as ``step`` does, and ``imm_lagged`` combines a sample over the modes. N = 0 (a
    buffer of one) is the filter alone. ``scratch``: work arrays (``imm_scratch``), kept by the caller so
    a sample allocates nothing; xs, ps, rc and the scratch have the modes' state size (4 with jerks).
    """
    return _imm_step_into(xs, ps, mu, x, p, ra, rv, rc, state, t, y, params, qs, rates, jerks, scratch)


@njit(cache=True)
def _chain_step(rates: np.ndarray, dt: float, pi: np.ndarray) -> None:
    """pi ← the chain's transition matrix over dt: Π_ii = e^{−r_i Δt}, Π_ij = (1 − e^{−r_i Δt}) R_ij / r_i."""
    m = pi.shape[0]
    for i in range(m):
        out = 0.0
        for j in range(m):
            out += rates[i, j] if j != i else 0.0
        stay = math.exp(-out * dt)
        for j in range(m):
            pi[i, j] = stay if j == i else ((1.0 - stay) * rates[i, j] / out if out > 0.0 else 0.0)


@njit(cache=True)
def _mix(
    xs: np.ndarray,
    ps: np.ndarray,
    mu: np.ndarray,
    pi: np.ndarray,
    cj: np.ndarray,
    w: np.ndarray,
    x0: np.ndarray,
    p0: np.ndarray,
    band: int,
    jerks: np.ndarray,
) -> None:
    """IMM mixing: c_j = Σ_i Π_ij μ_i, w_ij = Π_ij μ_i / c_j, x⁰_j = Σ_i w_ij x_i,
    P⁰_j = Σ_i w_ij (P_i + (x_i − x⁰_j)(x_i − x⁰_j)ᵀ); the sums over |i − j| ≤ band only (Π_ij = 0
    beyond the chain's reach, so the terms left out are exact zeros). Over d = xs.shape[1] states; with
    trend modes, a random-walk mode (jerks[j] = 0) then has its j and j's covariance set to 0."""
    m = mu.size
    d = xs.shape[1]
    for j in range(m):
        lo, hi = max(0, j - band), min(m, j + band + 1)
        cj[j] = 0.0
        for i in range(lo, hi):  # the terms beyond the band are exact zeros: the sum is the same
            cj[j] += pi[i, j] * mu[i]
        for i in range(lo, hi):  # w beyond the band is never read
            w[i, j] = pi[i, j] * mu[i] / cj[j]
        if d == 4 and jerks[j] > 0.0:
            _mix_trend(j, xs, ps, w, x0, p0, lo, hi)
        else:  # a random walk's x⁰, P⁰ on [θ, θ', a]; with trend modes its j is zeroed below
            for a in range(3):
                acc = 0.0
                for i in range(lo, hi):
                    acc += w[i, j] * xs[i, a]
                x0[j, a] = acc
            for a in range(3):
                for b in range(3):
                    acc = 0.0
                    for i in range(lo, hi):
                        acc += w[i, j] * (ps[i, a, b] + (xs[i, a] - x0[j, a]) * (xs[i, b] - x0[j, b]))
                    p0[j, a, b] = acc
        if d == 4 and jerks[j] == 0.0:
            x0[j, 3] = 0.0
            for a in range(4):
                p0[j, 3, a] = 0.0
                p0[j, a, 3] = 0.0


@njit(cache=True, inline="always")
def _mix_trend(
    j: int, xs: np.ndarray, ps: np.ndarray, w: np.ndarray, x0: np.ndarray, p0: np.ndarray, lo: int, hi: int
) -> None:
    """``_mix``'s x⁰_j, P⁰_j over four states: the terms with w_ij = 0 skipped (modes of the band the chain
    does not link to j: interleaved by ``with_trends``, a walk's neighbour's partner) and P⁰_j's upper
    triangle mirrored."""
    for a in range(4):
        x0[j, a] = 0.0
    for i in range(lo, hi):
        wij = w[i, j]
        if wij == 0.0:
            continue
        for a in range(4):
            x0[j, a] += wij * xs[i, a]
    for a in range(4):
        for b in range(a, 4):
            p0[j, a, b] = 0.0
    for i in range(lo, hi):
        wij = w[i, j]
        if wij == 0.0:
            continue
        for a in range(4):
            da = xs[i, a] - x0[j, a]
            for b in range(a, 4):
                p0[j, a, b] += wij * (ps[i, a, b] + da * (xs[i, b] - x0[j, b]))
    for a in range(4):
        for b in range(a):
            p0[j, a, b] = p0[j, b, a]


@njit(cache=True)
def _update_modes(logl: np.ndarray, mu: np.ndarray) -> None:
    """μ_j ∝ exp(logl_j) (logl_j = ln c_j + ln N(ν_j; 0, S_j)), floored at 1e-12."""
    m = mu.size
    top = logl.max()
    total = 0.0
    for j in range(m):
        mu[j] = math.exp(logl[j] - top)
        total += mu[j]
    for j in range(m):
        mu[j] = max(mu[j] / total, 1e-12)  # a floor keeps every mode revivable (and no 0/0 in the mixing)


@njit(cache=True)
def _combine(xs: np.ndarray, ps: np.ndarray, mu: np.ndarray, x: np.ndarray, p: np.ndarray) -> None:
    """x = Σ μ_j x_j, P = Σ μ_j (P_j + (x_j − x)(x_j − x)ᵀ), over [θ, θ', a] (a trend mode's j is its own)."""
    m = mu.size
    for a in range(3):
        x[a] = 0.0
        for j in range(m):
            x[a] += mu[j] * xs[j, a]
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for j in range(m):
                acc += mu[j] * (ps[j, a, b] + (xs[j, a] - x[a]) * (xs[j, b] - x[b]))
            p[a, b] = acc


@njit(cache=True)
def _mix_ring(
    j: int,
    xs: np.ndarray,
    x0: np.ndarray,
    w: np.ndarray,
    ra: np.ndarray,
    rv: np.ndarray,
    rc: np.ndarray,
    out_a: np.ndarray,
    out_v: np.ndarray,
    out_c: np.ndarray,
    band: int,
    jerks: np.ndarray,
) -> None:
    """IMM mixing of mode j's buffer, every slot into out_*: â⁰_j = Σ_i w_ij â_i, var⁰_j = Σ_i w_ij (var_i +
    (â_i − â⁰_j)²), c⁰_j = Σ_i w_ij (c_i + (â_i − â⁰_j)(x_i − x⁰_j)) (the a_slot rows of the mixed augmented
    covariance: all the fixed-lag update needs). The buffer is the innermost, contiguous axis, so each
    sum runs as vector arithmetic over all slots; a slot's own sums keep their order over i. With trend
    modes (four states) c's fourth entry mixes alike, and is 0 for a random-walk mode (``_mix``)."""
    m, size = ra.shape
    lo, hi = max(0, j - band), min(m, j + band + 1)  # w_ij = 0 beyond the chain's band
    for s in range(size):
        out_a[s] = 0.0
        out_v[s] = 0.0
        out_c[0, s] = 0.0
        out_c[1, s] = 0.0
        out_c[2, s] = 0.0
    for i in range(lo, hi):
        wij = w[i, j]
        row = ra[i]
        for s in range(size):
            out_a[s] += wij * row[s]
    for i in range(lo, hi):
        wij = w[i, j]
        d0, d1, d2 = xs[i, 0] - x0[j, 0], xs[i, 1] - x0[j, 1], xs[i, 2] - x0[j, 2]
        row_a, row_v, row_c = ra[i], rv[i], rc[i]
        for s in range(size):
            da = row_a[s] - out_a[s]
            out_v[s] += wij * (row_v[s] + da * da)
            out_c[0, s] += wij * (row_c[0, s] + da * d0)
            out_c[1, s] += wij * (row_c[1, s] + da * d1)
            out_c[2, s] += wij * (row_c[2, s] + da * d2)
    if xs.shape[1] == 4:
        for s in range(size):
            out_c[3, s] = 0.0
        if jerks[j] > 0.0:
            for i in range(lo, hi):
                wij = w[i, j]
                d3 = xs[i, 3] - x0[j, 3]
                row_a, row_c = ra[i], rc[i]
                for s in range(size):
                    out_c[3, s] += wij * (row_c[3, s] + (row_a[s] - out_a[s]) * d3)


@njit(cache=True)
def _imm_step_into(
    xs: np.ndarray,
    ps: np.ndarray,
    mu: np.ndarray,
    x: np.ndarray,
    p: np.ndarray,
    ra: np.ndarray,
    rv: np.ndarray,
    rc: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    jerks: np.ndarray,
    scratch: ImmScratch,
) -> bool:
    """imm_step with its work arrays given (``imm_scratch``): a recording's pass allocates them once."""
    cj, x0, p0, f, k, logl, pi, w, new_a, new_v, new_c, memo, work = scratch
    g, length, c, r = params[0], params[1], params[2], params[3]
    q_rate, reset_gap = params[4], params[6]
    m = qs.size
    size = ra.shape[1]
    trend = xs.shape[1] == 4
    if needs_restart(state, t, reset_gap):
        _imm_start(xs, ps, mu, x, p, ra, rv, rc, state, t, y, params, jerks)
        return True
    dt = t - state[0]
    count = int(state[1])
    held = min(count, size - 1)
    if dt != memo[0]:  # Π depends on Δt only: at a steady rate it is computed once
        _chain_step(rates, dt, pi)
        memo[0] = dt
    if memo[1] < 0.0:  # the chain's reach: w_ij = 0 for |i − j| > band (1 for a birth-death chain)
        band = 0
        for i in range(m):
            for j in range(m):
                if rates[i, j] != 0.0:
                    band = max(band, abs(i - j))
        memo[1] = band
    band = int(memo[1])
    _mix(xs, ps, mu, pi, cj, w, x0, p0, band, jerks)
    # Mode by mode: its buffer mixed into the work rows (from every mode's buffer as it was before this
    # sample), then predicted and updated there in one pass while the rows are in cache; the buffers and
    # the modes' states take the new values once every mode is done (the mixing reads the old ones).
    # The loops run over every slot, held or not: a slot not yet held holds nothing anyone reads (it is
    # written whole before it is read), and whole contiguous rows run as vector arithmetic.
    new = count % size
    linv = 1.0 / length
    for j in range(m):
        if held:
            _mix_ring(j, xs, x0, w, ra, rv, rc, new_a[j], new_v[j], new_c[j], band, jerks)
            row_a, row_v, row_c = new_a[j], new_v[j], new_c[j]
        else:
            row_a, row_v, row_c = ra[j], rv[j], rc[j]
        if trend and jerks[j] > 0.0:
            predict_trend(x0[j], p0[j], f, dt, g, linv, c, q_rate, qs[j], jerks[j], work)
            nu, s_nu = _trend_lag_update(x0[j], p0[j], f, k, y, r, row_a, row_v, row_c, new, held)
            logl[j] = -0.5 * (nu * nu / s_nu + math.log(s_nu)) + math.log(cj[j])
            continue
        if trend:  # a random walk beside trend modes: j ≡ 0 with no covariance (``_mix``) and its buffer's
            # fourth entry stays 0, so the three-state lines run on the leading block
            fw = f[:3, :3]
            nu, s_nu = _walk_lag_update(
                x0[j, :3],
                p0[j, :3, :3],
                fw,
                k,
                y,
                r,
                row_a,
                row_v,
                row_c,
                new,
                held,
                dt,
                g,
                linv,
                c,
                q_rate,
                qs[j],
            )
        else:
            nu, s_nu = _walk_lag_update(
                x0[j], p0[j], f, k, y, r, row_a, row_v, row_c, new, held, dt, g, linv, c, q_rate, qs[j]
            )
        logl[j] = -0.5 * (nu * nu / s_nu + math.log(s_nu)) + math.log(cj[j])
    if held:
        ra[:] = new_a
        rv[:] = new_v
        rc[:] = new_c
    if trend:
        xs[:, :] = x0
        ps[:, :, :] = p0
    else:
        for j in range(m):
            _copy3(x0[j], p0[j], xs[j], ps[j])
    _update_modes(logl, mu)
    _combine(xs, ps, mu, x, p)
    if _finite(x, p):
        state[0], state[1] = t, count + 1.0
        return False
    _imm_start(xs, ps, mu, x, p, ra, rv, rc, state, t, y, params, jerks)  # diverged: restart, never inf/NaN
    return True


@njit(cache=True, inline="always")  # inlined: a call per mode per sample costs a third of auto's step
def _walk_lag_update(
    xj: np.ndarray,
    pj: np.ndarray,
    f: np.ndarray,
    k: np.ndarray,
    y: float,
    r: float,
    row_a: np.ndarray,
    row_v: np.ndarray,
    row_c: np.ndarray,
    new: int,
    held: int,
    dt: float,
    g: float,
    linv: float,
    c: float,
    q_rate: float,
    q_accel: float,
) -> tuple[float, float]:
    """One random-walk mode's prediction, update and buffer (``_imm_step_into``): x, P ← ``predict``, the
    buffered a's c ← F c, the new slot takes the prior's a row, then the innovation moves â, var and c of
    every slot and the state (``correct``); returns (ν, S). x, P, F: three states (a view of the leading
    block beside trend modes)."""
    size = row_a.size
    predict(xj, pj, f, dt, g, linv, c, q_rate, q_accel)
    prior_a, prior_v = xj[2], pj[2, 2]
    prior_c0, prior_c1, prior_c2 = pj[2, 0], pj[2, 1], pj[2, 2]
    nu, s_nu = correct(xj, pj, k, y, r)
    k0, k1, k2 = k[0], k[1], k[2]
    if held:  # the buffered a's: c ← F c, then the update moves â, var and c by the innovation
        f00, f01, f02 = f[0, 0], f[0, 1], f[0, 2]
        f10, f11, f12 = f[1, 0], f[1, 1], f[1, 2]
        f20, f21, f22 = f[2, 0], f[2, 1], f[2, 2]
        for s in range(size):
            c0, c1, c2 = row_c[0, s], row_c[1, s], row_c[2, s]
            n0 = f00 * c0 + f01 * c1 + f02 * c2
            n1 = f10 * c0 + f11 * c1 + f12 * c2
            n2 = f20 * c0 + f21 * c1 + f22 * c2
            row_a[s] += n0 * nu / s_nu
            row_v[s] -= n0 * n0 / s_nu
            row_c[0, s] = n0 - n0 * k0
            row_c[1, s] = n1 - n0 * k1
            row_c[2, s] = n2 - n0 * k2
    # The new sample: its prior (the predicted a and its covariance row), then the same update.
    row_c[0, new], row_c[1, new], row_c[2, new] = prior_c0, prior_c1, prior_c2
    c0 = row_c[0, new]
    row_a[new] = prior_a + c0 * nu / s_nu
    row_v[new] = prior_v - c0 * c0 / s_nu
    row_c[0, new] -= c0 * k0
    row_c[1, new] -= c0 * k1
    row_c[2, new] -= c0 * k2
    return nu, s_nu


@njit(cache=True, inline="always")
def _trend_lag_update(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    k: np.ndarray,
    y: float,
    r: float,
    row_a: np.ndarray,
    row_v: np.ndarray,
    row_c: np.ndarray,
    new: int,
    held: int,
) -> tuple[float, float]:
    """One four-state mode's update and its buffer (``_walk_lag_update`` over d = 4, after the prediction):
    the buffered a's c ← F c, the new slot takes the prior's a row, then the innovation moves â, var and c
    of every slot and the state (``correct``); returns (ν, S)."""
    size = row_a.size
    if held:
        for s in range(size):
            c0, c1, c2, c3 = row_c[0, s], row_c[1, s], row_c[2, s], row_c[3, s]
            for i in range(4):
                row_c[i, s] = f[i, 0] * c0 + f[i, 1] * c1 + f[i, 2] * c2 + f[i, 3] * c3
    row_a[new], row_v[new] = x[2], p[2, 2]
    for i in range(4):
        row_c[i, new] = p[2, i]
    nu, s_nu = correct(x, p, k, y, r)
    gains = (k[0], k[1], k[2], k[3])
    last = size if held else new + 1
    for s in range(new if not held else 0, last):
        c0 = row_c[0, s]
        row_a[s] += c0 * nu / s_nu
        row_v[s] -= c0 * c0 / s_nu
        for i in range(4):
            row_c[i, s] -= c0 * gains[i]
    return nu, s_nu


@njit(cache=True)
def lag_variance_one(
    var_lag: float, var_filter: float, power: float, revision: float, weight: float
) -> float:
    """min(P_f (P_lag/P_f)^γ + κ d², P_lag) with the ratio clipped to [0, 1], d = â_lag − â_f (``revision``),
    κ = ``weight``; P_lag where P_f ≤ 0 (kalman.lag_variance)."""
    if not var_filter > 0.0 or var_lag != var_lag:  # no filter variance, or no lagged one (NaN) to map
        return var_lag
    ratio = min(max(var_lag / var_filter, 0.0), 1.0)
    return min(var_filter * ratio**power + weight * revision * revision, var_lag)


@njit(cache=True)
def lag_variance_into(
    var_lag: np.ndarray,
    var_filter: np.ndarray,
    a_lag: np.ndarray,
    a_filter: np.ndarray,
    power: float,
    weight: float,
    out: np.ndarray,
) -> None:
    """out ← lag_variance_one of each sample, d = a_lag − a_filter (one pass, no temporaries; column views
    are read in place)."""
    for i in range(out.size):
        out[i] = lag_variance_one(var_lag[i], var_filter[i], power, a_lag[i] - a_filter[i], weight)


@njit(cache=True)
def imm_lagged(mu: np.ndarray, ra: np.ndarray, rv: np.ndarray, slot: int) -> tuple[float, float]:
    """(â, var) of a buffered sample over the modes: â = Σ μ_j â_j, var = Σ μ_j (var_j + (â_j − â)²)."""
    a = 0.0
    for j in range(mu.size):
        a += mu[j] * ra[j, slot]
    v = 0.0
    for j in range(mu.size):
        d = ra[j, slot] - a
        v += mu[j] * (rv[j, slot] + d * d)
    return a, v


@njit(cache=True)
def _imm_start(
    xs: np.ndarray,
    ps: np.ndarray,
    mu: np.ndarray,
    x: np.ndarray,
    p: np.ndarray,
    ra: np.ndarray,
    rv: np.ndarray,
    rc: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
    jerks: np.ndarray,
) -> None:
    """Every mode initialised from y (``initialise``), equally likely; the buffer holds y's sample only. A
    trend mode (jerks[j] > 0) starts at j = 0 with variance INIT_JERK_STD²; a random-walk one at j ≡ 0."""
    m = mu.size
    initialise(x, p, y, params[0], params[1], params[3], params[7], params[8])
    for j in range(m):
        xs[j, :3] = x
        ps[j, :3, :3] = p
        mu[j] = 1.0 / m
        ra[j, 0], rv[j, 0] = x[2], p[2, 2]
        for b in range(3):
            rc[j, b, 0] = p[2, b]
        if xs.shape[1] == 4:
            xs[j, 3] = 0.0
            ps[j, 3, :] = 0.0
            ps[j, :, 3] = 0.0
            ps[j, 3, 3] = INIT_JERK_STD**2 if jerks[j] > 0.0 else 0.0
            rc[j, 3, 0] = 0.0
    state[0], state[1] = t, 1.0


@njit(cache=True, nogil=True)  # as run_pass
def run_imm(
    t: np.ndarray,
    y: np.ndarray,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    lags: np.ndarray,
    keep_mu: bool = True,
    jerks: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(â, var, μ) of the IMM over a recording (``imm_step`` per sample): column m of â, var holds the
    fixed-lag estimate â_{i | i + lags[m]} aligned to the sample i it describes (lag 0: the filter's x₃,
    P_aa; the last lags[m] samples of a segment use all the data there is); μ: a column per mode, or no
    rows without ``keep_mu`` (8 B a mode a sample that a caller wanting â only does not hold). ``jerks``:
    each mode's q_j, for an IMM with trend modes (imm_step); None: random-walk modes only."""
    n = t.size
    m = qs.size
    qj = np.empty(0) if jerks is None else jerks
    d = 4 if qj.size else 3
    size = int(lags.max()) + 1 if lags.size else 1
    a = np.full((n, lags.size), np.nan)
    v = np.full((n, lags.size), np.nan)
    mus = np.empty((n if keep_mu else 0, m))
    xs = np.zeros((m, d))
    ps = np.zeros((m, d, d))
    mu = np.full(m, 1.0 / m)
    x = np.zeros(3)
    p = np.zeros((3, 3))
    ra = np.zeros((m, size))
    rv = np.zeros((m, size))
    rc = np.zeros((m, d, size))
    state = np.array([np.nan, 0.0])
    scratch = imm_scratch(m, size, d)
    for i in range(n):
        if i > 0 and needs_restart(state, t[i], params[6]):
            _imm_flush(a, v, mu, ra, rv, i - 1, int(state[1]), lags)
        _imm_step_into(xs, ps, mu, x, p, ra, rv, rc, state, t[i], y[i], params, qs, rates, qj, scratch)
        count = int(state[1])
        for col in range(lags.size):
            lag = lags[col]
            if lag < count:
                a[i - lag, col], v[i - lag, col] = imm_lagged(mu, ra, rv, (count - 1 - lag) % size)
        if keep_mu:
            mus[i] = mu
    _imm_flush(a, v, mu, ra, rv, n - 1, int(state[1]), lags)
    return a, v, mus


@njit(cache=True)
def _imm_flush(
    out_a: np.ndarray,
    out_v: np.ndarray,
    mu: np.ndarray,
    ra: np.ndarray,
    rv: np.ndarray,
    last: int,
    count: int,
    lags: np.ndarray,
) -> None:
    """At a segment's end (sample ``last``): samples whose lag reaches past it get their latest â, var."""
    size = ra.shape[1]
    for j in range(min(count, size)):
        slot = (count - 1 - j) % size
        for col in range(lags.size):
            if lags[col] > j:
                out_a[last - j, col], out_v[last - j, col] = imm_lagged(mu, ra, rv, slot)


@njit(cache=True)
def smooth_modes(t: np.ndarray, mu: np.ndarray, rates: np.ndarray, reset_gap: float) -> None:
    """In place: the IMM's filtered mode probabilities μ_k (run_imm, n × modes) become the smoothed ones,
    μˢ_k(i) = μ_k(i) Σ_j Π_ij μˢ_{k+1}(j) / μ⁻_{k+1}(j), μ⁻_{k+1}(j) = Σ_l Π_lj μ_k(l), Π over t_{k+1} − t_k
    (the chain's backward recursion, exact for a hidden Markov chain; the IMM's mode likelihoods make it an
    approximation here). A segment's last sample (the next one restarts after a gap) keeps its μ."""
    n, m = mu.shape
    pi = np.empty((m, m))
    pred = np.empty(m)
    memo = math.nan
    for k in range(n - 2, -1, -1):
        dt = t[k + 1] - t[k]
        if dt > reset_gap:
            continue
        if dt != memo:
            _chain_step(rates, dt, pi)
            memo = dt
        for j in range(m):
            acc = 0.0
            for i in range(m):
                acc += mu[k, i] * pi[i, j]
            pred[j] = acc
        total = 0.0
        for i in range(m):
            acc = 0.0
            for j in range(m):
                acc += pi[i, j] * mu[k + 1, j] / pred[j]
            mu[k, i] *= acc
            total += mu[k, i]
        for i in range(m):
            mu[k, i] /= total


@njit(cache=True)
def log_likelihood(t: np.ndarray, y: np.ndarray, params: np.ndarray) -> float:
    """Σ_k −½ (ν_k²/S_k + ln S_k) of the single-model filter at params (the first 10 samples of each
    segment left out: they hold the start-up, whatever q_a)."""
    x = np.zeros(3)
    p = np.zeros((3, 3))
    f = np.eye(3)
    k = np.zeros(3)
    state = np.array([np.nan, 0.0])
    total = 0.0
    g, length, c, r = params[0], params[1], params[2], params[3]
    for i in range(t.size):
        if needs_restart(state, t[i], params[6]):
            initialise(x, p, y[i], g, length, r, params[7], params[8])
            state[0], state[1] = t[i], 1.0
            continue
        predict(x, p, f, t[i] - state[0], g, 1.0 / length, c, params[4], params[5])
        nu, s = correct(x, p, k, y[i], r)
        if state[1] >= 10.0:
            total += -0.5 * (nu * nu / s + math.log(s))
        state[0], state[1] = t[i], state[1] + 1.0
    return total


def chain_rates(modes: int, up_time: float, down_time: float | None = None) -> np.ndarray:
    """R (modes × modes, 1/s) of the mode chain. With ``down_time`` None: each mode is left at rate
    1/up_time, to every other mode evenly. With ``down_time``: a birth-death chain over modes ordered by
    q_a, R_{i,i+1} = 1/up_time and R_{i,i−1} = 1/down_time (neighbours only).

    Neighbours only, the calm mode never jumps straight into the most agile one: in a calm stretch the
    agile modes keep only the weight their likelihood earns. A short down_time lets the weight settle back
    into the calm modes within seconds after a manoeuvre (docs/estimators.md, "auto")."""
    rates = np.zeros((modes, modes))
    for i in range(modes):
        if down_time is None:
            for j in range(modes):
                if j != i:
                    rates[i, j] = 1.0 / (up_time * (modes - 1))
            continue
        if i + 1 < modes:
            rates[i, i + 1] = 1.0 / up_time
        if i > 0:
            rates[i, i - 1] = 1.0 / down_time
    return rates


def with_trends(
    qs: np.ndarray, rates: np.ndarray, trends: np.ndarray, cross_time: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q_a, q_j, R) of the IMM over both walks: each random-walk mode k (q_a = qs[k], q_j = 0), followed,
    where trends[k] > 0, by its trend partner (q_a = 0, q_j = trends[k]). The random walks keep the chain
    ``rates`` among themselves, the trend modes the same rates among themselves, and each pair swaps at
    1/cross_time both ways. Interleaved so, a birth-death chain's modes reach at most two indices away
    and the mixing's band stays 2 (``_mix``)."""
    walk, partner = [], []  # each mode's index in the IMM; -1: no trend partner
    m = 0
    for k in range(qs.size):
        walk.append(m)
        partner.append(m + 1 if trends[k] > 0.0 else -1)
        m += 2 if trends[k] > 0.0 else 1
    q_a, q_j, out = np.zeros(m), np.zeros(m), np.zeros((m, m))
    for k in range(qs.size):
        q_a[walk[k]] = qs[k]
        if partner[k] >= 0:
            q_j[partner[k]] = trends[k]
            out[walk[k], partner[k]] = out[partner[k], walk[k]] = 1.0 / cross_time
        for n in range(qs.size):
            if rates[k, n] != 0.0:
                out[walk[k], walk[n]] = rates[k, n]
                if partner[k] >= 0 and partner[n] >= 0:
                    out[partner[k], partner[n]] = rates[k, n]
    return q_a, q_j, out


def warm() -> None:
    """Compile (or load from the cache) every pass: a few samples through each."""
    t = np.arange(30) / 100.0
    y = np.zeros(30)
    params = np.array([9.80665, 1.0, 0.05, 1e-6, 0.0, 0.01, 1.0, 1.55, 0.3])
    for q_accel in (np.empty(0), np.full(30, 0.01)):
        lags = np.array([0, 5], dtype=np.int64)
        _, _, xpr, ppr, xpo, ppo, fk, starts = run_pass(t, y, params, lags, True, q_accel)
    rts(xpr, ppr, xpo, ppo, fk, starts)
    qs, rates = np.array([1e-3, 0.1]), chain_rates(2, 5.0)
    for keep_mu in (True, False):
        run_imm(t, y, params, qs, rates, np.array([0, 5], dtype=np.int64), keep_mu)
        run_imm(t, y, params, qs, rates, np.array([0, 5], dtype=np.int64), keep_mu, np.array([0.0, 1.0]))
    smooth_modes(t, run_imm(t, y, params, qs, rates, np.zeros(1, dtype=np.int64), True)[2], rates, 1.0)
    log_likelihood(t, y, params)
    # The live IMM's per-sample step (kalman.KalmanEstimator.update), with the arrays it keeps: left
    # out, the estimator compiled it at its first angle, while the simulator waited for it.
    m, size = 2, 1
    for d, jerks in ((3, np.empty(0)), (4, np.array([0.0, 1.0]))):  # random-walk modes; with trend modes
        xs, ps, mu = np.zeros((m, d)), np.zeros((m, d, d)), np.full(m, 1.0 / m)
        ra, rv, rc = np.zeros((m, size)), np.zeros((m, size)), np.zeros((m, d, size))
        x, p, state, scratch = np.zeros(3), np.zeros((3, 3)), np.array([np.nan, 0.0]), imm_scratch(m, size, d)
        for k in range(3):
            tk, yk = float(t[k]), float(y[k])
            imm_step(xs, ps, mu, x, p, ra, rv, rc, state, tk, yk, params, qs, rates, jerks, scratch)
    imm_lagged(mu, ra, rv, 0)  # the live fixed-lag output (lag > 0) and its variance map's filter column
    lag_variance_one(1.0, 2.0, 2.0, 0.5, 1.0)  # that output's variance map, a sample at a time
    # The batch map (kalman.lag_variance) on whole columns and on column views of the lag table.
    table = np.ones((2, 2))
    lag_variance_into(np.ones(2), np.full(2, 2.0), np.ones(2), np.zeros(2), 2.0, 1.0, np.empty(2))
    lag_variance_into(table[:, 1], table[:, 0], table[:, 1], table[:, 0], 2.0, 1.0, np.empty(2))


if __name__ == "__main__":
    warm()
