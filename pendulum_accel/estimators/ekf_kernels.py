"""Compiled (numba) model of the pendulum EKF on x = [θ, θ', a]: prediction, update, one-model pass, RTS.

Model (physics.rigid.theta_ddot written out in scalar form, as in physics.kernels):

    θ'' = (a cos θ − g sin θ)/l − c θ',   a' = w_a, E[w_a w_a] = q_a δ (a random walk of a),
    θ''' noise: E[w_ω w_ω] = q_ω δ on θ' (unmodelled torque),   y = θ + v, E[v²] = r.

Prediction over Δt: sub-steps h ≤ ``MAX_STEP``; per sub-step x ← one classic RK4 step with a held,
F_h = I + J h + J² h²/2 (J the Jacobian at the prior state), P ← F_h P F_hᵀ + Q_h with Q_h the
integrated random walk of a through θ'' ≈ j₁₂ a (j₁₂ = cos θ / l): q_a [h⁵j²/20, h⁴j²/8, h³j/6; ·, h³j²/3,
h²j/2; ·, ·, h] plus q_ω h on θ'θ'. The transition kept for the smoothers is the product of the F_h.

Trend modes (the IMM only): x = [θ, θ', a, j] with a' = j, j' = w_j, E[w_j w_j] = q_j δ, an integrated
walk of a that predicts a trend (``predict_trend``, ``trend_noise``).

These are the scalar, one-model forms: ``run_pass`` (the filter of one model, keeping what the RTS pass
``rts`` needs) runs them. The IMM (below) runs the same operations for all its modes at once, structure of
arrays (test_smoother and test_trend_modes hold the two equal), and its fixed-lag pass. They live in one
module on purpose: numba caches a function with the code of the kernels it calls, keyed on its own file
only, so a kernel calling another file's would keep a stale copy of it after an edit of that file alone
(as a `git pull` in an editable install makes).

The first call compiles (≈ 20 s) into numba's on-disk cache beside this file (``make setup`` warms it:
``python -m pendulum_accel.kernel_cache``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

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
    out: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
) -> bool:
    """One sample into the filter; True when it (re)started here.

    ``state`` = [last t (NaN before the first sample), samples in the current segment]; ``params`` =
    [g, l, c, r, q_ω, q_a, reset_gap, clamp, init amplitude]. out ← (â, var) of the sample: a⁻ + P⁻_aθ ν/S
    and P⁻_aa − (P⁻_aθ)²/S (as the IMM's per-mode row, ``_step``). The prior x⁻, P⁻ of the sample is left
    in prior_x, prior_p and the transition from the last in f.
    """
    g, length, c, r = params[0], params[1], params[2], params[3]
    q_rate, q_accel, reset_gap = params[4], params[5], params[6]
    last_t = state[0]
    if needs_restart(state, t, reset_gap):
        _start(x, p, f, prior_x, prior_p, out, state, t, y, params)
        return True
    predict(x, p, f, t - last_t, g, 1.0 / length, c, q_rate, q_accel)
    _copy3(x, p, prior_x, prior_p)
    nu, s = correct(x, p, k, y, r)
    c0 = prior_p[2, 0]
    out[0] = prior_x[2] + c0 * nu / s
    out[1] = prior_p[2, 2] - c0 * c0 / s
    if _finite(x, p):
        state[0], state[1] = t, state[1] + 1.0
        return False
    # A diverged filter restarts rather than publish inf/NaN.
    _start(x, p, f, prior_x, prior_p, out, state, t, y, params)
    return True


@njit(cache=True)
def needs_restart(state: np.ndarray, t: float, reset_gap: float) -> bool:
    """True before the first sample and after a gap longer than reset_gap."""
    last_t = state[0]
    result: bool = last_t != last_t or t - last_t > reset_gap
    return result


@njit(cache=True)
def _start(
    x: np.ndarray,
    p: np.ndarray,
    f: np.ndarray,
    prior_x: np.ndarray,
    prior_p: np.ndarray,
    out: np.ndarray,
    state: np.ndarray,
    t: float,
    y: float,
    params: np.ndarray,
) -> None:
    """Initialise the filter from y (``initialise``) as sample 0 of a segment; out ← its a and P_aa."""
    initialise(x, p, y, params[0], params[1], params[3], params[7], params[8])
    prior_x[:] = x
    prior_p[:, :] = p
    for i in range(3):
        for j in range(3):
            f[i, j] = 1.0 if i == j else 0.0
    out[0], out[1] = x[2], p[2, 2]
    state[0], state[1] = t, 1.0


@njit(cache=True, nogil=True)  # a long batch leaves the GIL: Ctrl-C reaches the main thread
def run_pass(
    t: np.ndarray, y: np.ndarray, params: np.ndarray, q_accel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The one-model filter over a recording (``step`` per sample), keeping what the RTS pass needs.

    Returns (â, var) of each sample (``step``'s out), the priors x⁻, P⁻, posteriors x⁺, P⁺, transitions F
    (from the previous sample) and the restart flags. ``q_accel``: q_a of the interval into each sample
    (n values), or empty for params[5] throughout.
    """
    n = t.size
    varying = q_accel.size == n
    params = params.copy()  # params[5] takes each sample's q_a when it varies
    out_a = np.empty(n)
    out_v = np.empty(n)
    xpr = np.empty((n, 3))
    ppr = np.empty((n, 3, 3))
    xpo = np.empty((n, 3))
    ppo = np.empty((n, 3, 3))
    fk = np.empty((n, 3, 3))
    starts = np.zeros(n, dtype=np.bool_)
    x = np.zeros(3)
    p = np.zeros((3, 3))
    f = np.eye(3)
    k = np.zeros(3)
    out = np.zeros(2)
    state = np.array([np.nan, 0.0])
    for i in range(n):
        if varying:
            params[5] = q_accel[i]
        starts[i] = step(x, p, f, k, xpr[i], ppr[i], out, state, t[i], y[i], params)
        _copy3(x, p, xpo[i], ppo[i])
        for r in range(3):
            for col in range(3):
                fk[i, r, col] = f[r, col]
        out_a[i], out_v[i] = out[0], out[1]
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


# ---- The IMM: every mode stepped at once, as vector arithmetic ---------------------------------------------
# The model and its discretisation above (``predict``, ``predict_trend``, ``correct``), run for all the
# IMM's modes together, with Blom & Bar-Shalom's mixing, mode probabilities and combination (``_step``).
# The state is kept structure-of-arrays: row r of ``X`` holds component r of every mode's state and row e
# of ``P`` entry e of every mode's covariance (upper triangle, ``P_ENTRY``), so each line of the algebra is
# one loop over the modes, which the compiler runs as vector arithmetic. Each mode's numbers are the ones
# ``predict`` / ``predict_trend`` and ``correct`` give it, operation for operation: the loops change the
# order in which the modes are computed, never the order of any sum.
#
# Layout of one IMM (``imm_layout``): m modes, mixing band b (Π_ij = 0 for |i − j| > b: 1 for a
# birth-death chain, 2 with trend partners), d states (3, or 4 with trend modes). Mode j sits in column
# j + b of ``X`` (d rows), ``P`` (``P_ROWS[d]`` rows) and ``MU``; the b columns either side are zero, so
# the mixing's sum over the band runs over whole rows (a term from a column outside is an exact 0).
# Everything a step needs lives in one float64 buffer (``imm_buffer``) and one int64 buffer, so the live
# estimator hands the compiled step few arrays per sample.

# Packed upper triangle of a mode's covariance: the three-state entries first, so a three-state IMM uses
# the leading P_ROWS[3] rows; P_ENTRY[e] = (row, column) of entry e.
P00, P01, P02, P11, P12, P22, P03, P13, P23, P33 = range(10)
P_ENTRY = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2), (0, 3), (1, 3), (2, 3), (3, 3))
P_ROWS = (0, 0, 0, 6, 10)  # rows of P for d states (index d)
ENTRY_OF = ((0, 1, 2, 6), (1, 3, 4, 7), (2, 4, 5, 8), (6, 7, 8, 9))  # (row, column) → packed entry
STAGE_ROWS = 18  # per-mode rows of a step: 16 temporaries (``_rk4_stages``), q_a and q_j of each lane
PI_SLOTS = 16  # Π kept for this many Δt (a recording's stamps step by a few distinct Δt, rounding apart)


class ImmArrays(NamedTuple):
    """The float buffer's slots (``imm_layout``), as arrays of their shapes (``imm_arrays``)."""

    X: np.ndarray  # d × W: each mode's state, component by row (mode j in column b + j; W = m + 2b)
    P: np.ndarray  # P_ROWS[d] × W: each mode's covariance, entry by row (P_ENTRY)
    MU: np.ndarray  # W: the mode probabilities
    X0: np.ndarray  # d × m: the mixed states x⁰ (by mode)
    P0: np.ndarray  # P_ROWS[d] × m: the mixed covariances P⁰
    Y: np.ndarray  # d × m: the state being predicted and corrected, lanes grouped (random walks first)
    Q: np.ndarray  # P_ROWS[d] × m: its covariance
    PB: np.ndarray  # (PI_SLOTS (2b + 1)) × m: Π by offset, PB[s(2b + 1) + o, j] = Π_{j−b+o, j} for DT[s]
    WT: np.ndarray  # (2b + 1) × m: the mixing weights w by offset
    CJ: np.ndarray  # m: c_j, the predicted mode probabilities
    LOGL: np.ndarray  # m: ln c_j + ln N(ν_j; 0, S_j)
    RA: np.ndarray  # m: each mode's â of the new sample (its fixed-lag row's: a⁻ + P⁻_aθ ν / S)
    RV: np.ndarray  # m: its variance, P⁻_aa − (P⁻_aθ)² / S
    T: np.ndarray  # STAGE_ROWS × m: the step's per-lane temporaries, q_a and q_j (rows 16, 17)
    PI: np.ndarray  # m × m: Π, formed
    DT: np.ndarray  # PI_SLOTS: the Δt of each PB slot (NaN: none)
    FF: np.ndarray  # 16 × m: with a lag, each lane's transition F over the interval (row-major 4 × 4)
    PR: np.ndarray  # 14 × m: with a lag, each lane's prior x⁻ (4) and P⁻ (10, P_ENTRY)
    MEMO: np.ndarray  # 3: the PB slot to fill next, the last accepted time (NaN: none), samples in segment


@njit(cache=True)
def imm_layout(m: int, band: int, d: int) -> np.ndarray:
    """Offsets into the float buffer of one IMM (m modes, band b, d states), in ImmArrays' order (its
    fields say each slot's shape and content), and the buffer's size last."""
    w = m + 2 * band
    ne = 10 if d == 4 else 6
    sizes = (
        d * w, ne * w, w, d * m, ne * m, d * m, ne * m, PI_SLOTS * (2 * band + 1) * m, (2 * band + 1) * m,
        m, m, m, m, STAGE_ROWS * m, m * m, PI_SLOTS, 16 * m, 14 * m, 3,
    )  # fmt: skip
    out = np.empty(len(sizes) + 1, dtype=np.int64)
    total = 0
    for k in range(len(sizes)):
        out[k] = total
        total += sizes[k]
    out[len(sizes)] = total
    return out


def chain_band(rates: np.ndarray) -> int:
    """b = max |i − j| over R_ij ≠ 0: the mixing's reach (1 for a birth-death chain)."""
    rows, cols = np.nonzero(rates)
    return int(np.max(np.abs(rows - cols))) if rows.size else 0


@njit(cache=True)
def imm_buffer(qs: np.ndarray, band: int, jerks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(float buffer, int buffer) of a fresh IMM: nothing seen yet (``imm_state``'s state row NaN).

    The int buffer: [m, band, d, walks, trends, then the grouped order: perm[k] = the mode of lane k,
    random walks first]."""
    m = qs.size
    d = 4 if jerks.size else 3
    lay = imm_layout(m, band, d)
    buf = np.zeros(lay[-1])
    buf[lay[15] : lay[16]] = math.nan  # DT: no Π formed yet
    buf[lay[18] + 1] = math.nan  # MEMO: no sample yet
    ibuf = np.zeros(5 + m, dtype=np.int64)
    walks = 0
    for j in range(m):
        if not (d == 4 and jerks[j] > 0.0):
            ibuf[5 + walks] = j
            walks += 1
    k = walks
    for j in range(m):
        if d == 4 and jerks[j] > 0.0:
            ibuf[5 + k] = j
            k += 1
    ibuf[0], ibuf[1], ibuf[2], ibuf[3], ibuf[4] = m, band, d, walks, m - walks
    T = buf[lay[13] : lay[14]].reshape(STAGE_ROWS, m)  # q_a and q_j of each lane, rows 16 and 17
    for k in range(m):
        T[16, k] = qs[ibuf[5 + k]]
        T[17, k] = jerks[ibuf[5 + k]] if d == 4 else 0.0
    return buf, ibuf


@njit(cache=True, inline="always")
def imm_arrays(buf: np.ndarray, m: int, band: int, d: int) -> ImmArrays:
    """The buffer's slots (ImmArrays, offsets as imm_layout's) as arrays of their shapes."""
    w = m + 2 * band
    ne = 10 if d == 4 else 6
    nb = 2 * band + 1
    o1 = d * w
    o2 = o1 + ne * w
    o3 = o2 + w
    o4 = o3 + d * m
    o5 = o4 + ne * m
    o6 = o5 + d * m
    o7 = o6 + ne * m
    o8 = o7 + PI_SLOTS * nb * m
    o9 = o8 + nb * m
    o13 = o9 + 4 * m
    o14 = o13 + STAGE_ROWS * m
    o15 = o14 + m * m
    o16 = o15 + PI_SLOTS
    o17 = o16 + 16 * m
    o18 = o17 + 14 * m
    return ImmArrays(
        buf[0:o1].reshape(d, w),
        buf[o1:o2].reshape(ne, w),
        buf[o2:o3],
        buf[o3:o4].reshape(d, m),
        buf[o4:o5].reshape(ne, m),
        buf[o5:o6].reshape(d, m),
        buf[o6:o7].reshape(ne, m),
        buf[o7:o8].reshape(PI_SLOTS * nb, m),
        buf[o8:o9].reshape(nb, m),
        buf[o9 : o9 + m],
        buf[o9 + m : o9 + 2 * m],
        buf[o9 + 2 * m : o9 + 3 * m],
        buf[o9 + 3 * m : o13],
        buf[o13:o14].reshape(STAGE_ROWS, m),
        buf[o14:o15].reshape(m, m),
        buf[o15:o16],
        buf[o16:o17].reshape(16, m),
        buf[o17:o18].reshape(14, m),
        buf[o18 : o18 + 3],
    )


@njit(cache=True, inline="always")
def _mix(
    X: np.ndarray, P: np.ndarray, MU: np.ndarray, X0: np.ndarray, P0: np.ndarray, PB: np.ndarray,
    WT: np.ndarray, CJ: np.ndarray, m: int, band: int, d: int, row: int,
) -> None:  # fmt: skip
    """IMM mixing of every mode at once: c_j = Σ_i Π_ij μ_i, w_ij = Π_ij μ_i / c_j, x⁰_j = Σ_i w_ij x_i,
    P⁰_j = Σ_i w_ij (P_i + (x_i − x⁰_j)(x_i − x⁰_j)ᵀ), each sum over i = j − b … j + b in increasing i
    (PB[row + o, j] = Π_{j−b+o, j}, 0 beyond the modes; the terms it zeroes are exact zeros). Arrays are
    indexed, never sliced, in the loops: a view costs a reference count each."""
    nb = 2 * band + 1
    for j in range(m):
        cj = 0.0
        for o in range(nb):
            cj += PB[row + o, j] * MU[o + j]
        CJ[j] = cj
        for o in range(nb):
            WT[o, j] = PB[row + o, j] * MU[o + j] / cj
    trend = d == 4
    for j in range(m):
        x0 = 0.0
        x1 = 0.0
        x2 = 0.0
        x3 = 0.0
        for o in range(nb):
            w = WT[o, j]
            if w != 0.0:  # an exact zero term (a mode the chain does not link to j) adds nothing
                x0 += w * X[0, o + j]
                x1 += w * X[1, o + j]
                x2 += w * X[2, o + j]
                if trend:
                    x3 += w * X[3, o + j]
        X0[0, j], X0[1, j], X0[2, j] = x0, x1, x2
        c00 = c01 = c02 = c11 = c12 = c22 = c03 = c13 = c23 = c33 = 0.0
        for o in range(nb):
            w = WT[o, j]
            if w != 0.0:
                i = o + j
                d0, d1, d2 = X[0, i] - x0, X[1, i] - x1, X[2, i] - x2
                c00 += w * (P[P00, i] + d0 * d0)
                c01 += w * (P[P01, i] + d0 * d1)
                c02 += w * (P[P02, i] + d0 * d2)
                c11 += w * (P[P11, i] + d1 * d1)
                c12 += w * (P[P12, i] + d1 * d2)
                c22 += w * (P[P22, i] + d2 * d2)
                if trend:
                    d3 = X[3, i] - x3
                    c03 += w * (P[P03, i] + d0 * d3)
                    c13 += w * (P[P13, i] + d1 * d3)
                    c23 += w * (P[P23, i] + d2 * d3)
                    c33 += w * (P[P33, i] + d3 * d3)
        P0[P00, j], P0[P01, j], P0[P02, j], P0[P11, j], P0[P12, j], P0[P22, j] = c00, c01, c02, c11, c12, c22
        if trend:
            X0[3, j] = x3
            P0[P03, j], P0[P13, j], P0[P23, j], P0[P33, j] = c03, c13, c23, c33


@njit(cache=True, inline="always")
def _rk4_stages(
    Y: np.ndarray, T: np.ndarray, m: int, d: int, h: float, g: float, linv: float, c: float
) -> None:
    """One RK4 sub-step h of every mode (ekf_kernels._rk4, a(s) = a + j s: a trend mode's; a random walk's
    j ≡ 0 makes it a held a, to the bit), Y's θ, θ' (and a) advanced in place; T[13], T[14] ← j₁₀, j₁₂ of
    the Jacobian at the prior (ekf_kernels.predict). libm's sin and cos run in their own loops, the
    arithmetic between them over all modes at once. T's rows: 0, 1 cos and sin at θ, 2 w₁, 3, 4 θ₂, θ'₂,
    5, 6 cos and sin at the stage's θ, 7 w₂, 8, 9 θ₃, θ'₃, 10 w₃, 11, 12 θ₄, θ'₄, 15 a mid-step, then at
    the end."""
    half = 0.5 * h
    sixth = h / 6.0
    for k in range(m):
        T[0, k] = math.cos(Y[0, k])
        T[1, k] = math.sin(Y[0, k])
    for k in range(m):
        T[13, k] = -(g * T[0, k] + Y[2, k] * T[1, k]) * linv
        T[14, k] = T[0, k] * linv
        T[2, k] = (Y[2, k] * T[0, k] - g * T[1, k]) * linv - c * Y[1, k]
        T[3, k] = Y[0, k] + half * Y[1, k]
        T[4, k] = Y[1, k] + half * T[2, k]
    if d == 4:
        for k in range(m):
            T[15, k] = Y[2, k] + 0.5 * h * Y[3, k]
    else:
        for k in range(m):
            T[15, k] = Y[2, k]
    for k in range(m):
        T[5, k] = math.cos(T[3, k])
        T[6, k] = math.sin(T[3, k])
    for k in range(m):
        T[7, k] = (T[15, k] * T[5, k] - g * T[6, k]) * linv - c * T[4, k]
        T[8, k] = Y[0, k] + half * T[4, k]
        T[9, k] = Y[1, k] + half * T[7, k]
    for k in range(m):
        T[5, k] = math.cos(T[8, k])
        T[6, k] = math.sin(T[8, k])
    for k in range(m):
        T[10, k] = (T[15, k] * T[5, k] - g * T[6, k]) * linv - c * T[9, k]
        T[11, k] = Y[0, k] + h * T[9, k]
        T[12, k] = Y[1, k] + h * T[10, k]
    for k in range(m):
        T[5, k] = math.cos(T[11, k])
        T[6, k] = math.sin(T[11, k])
    if d == 4:
        for k in range(m):
            T[15, k] = Y[2, k] + h * Y[3, k]  # a at the step's end (a trend's; a random walk's: a itself)
    for k in range(m):
        w4 = (T[15, k] * T[5, k] - g * T[6, k]) * linv - c * T[12, k]
        Y[0, k] = Y[0, k] + sixth * (Y[1, k] + 2.0 * T[4, k] + 2.0 * T[9, k] + T[12, k])
        Y[1, k] = Y[1, k] + sixth * (T[2, k] + 2.0 * T[7, k] + 2.0 * T[10, k] + w4)
    if d == 4:
        for k in range(m):
            Y[2, k] = T[15, k]


@njit(cache=True, inline="always")
def _walk_covariance(
    Q: np.ndarray, T: np.ndarray, lo: int, hi: int, h: float, c: float, q_rate: float
) -> None:
    """P ← F_h P F_hᵀ + Q_h of the random-walk lanes lo … hi − 1 (ekf_kernels.predict, operation for
    operation), F_h's rows from the Jacobian in T[13], T[14], q_a in T[16]."""
    h3 = h * h * h
    for k in range(lo, hi):
        f00, f01, f02, f10, f11, f12 = _flow_rows(T[13, k], T[14, k], c, h)
        p00, p01, p02, p11, p12, p22 = Q[P00, k], Q[P01, k], Q[P02, k], Q[P11, k], Q[P12, k], Q[P22, k]
        a00 = f00 * p00 + f01 * p01 + f02 * p02
        a01 = f00 * p01 + f01 * p11 + f02 * p12
        a02 = f00 * p02 + f01 * p12 + f02 * p22
        a10 = f10 * p00 + f11 * p01 + f12 * p02
        a11 = f10 * p01 + f11 * p11 + f12 * p12
        a12 = f10 * p02 + f11 * p12 + f12 * p22
        n00 = a00 * f00 + a01 * f01 + a02 * f02
        n01 = a00 * f10 + a01 * f11 + a02 * f12
        n11 = a10 * f10 + a11 * f11 + a12 * f12
        n20 = p02 * f00 + p12 * f01 + p22 * f02
        n21 = p02 * f10 + p12 * f11 + p22 * f12
        q, jj = T[16, k], T[14, k]
        Q[P00, k] = n00 + q * jj * jj * h3 * h * h / 20.0
        Q[P01, k] = n01 + q * jj * jj * h3 * h / 8.0
        Q[P02, k] = n20 + q * jj * h3 / 6.0
        Q[P11, k] = n11 + q * jj * jj * h3 / 3.0 + q_rate * h
        Q[P12, k] = n21 + q * jj * h * h / 2.0
        Q[P22, k] = p22 + q * h


@njit(cache=True, inline="always")
def _trend_covariance(
    Q: np.ndarray, T: np.ndarray, lo: int, hi: int, h: float, c: float, q_rate: float
) -> None:
    """P ← F_h P F_hᵀ + Q_h of the trend lanes lo … hi − 1 (ekf_kernels.predict_trend and trend_noise,
    operation for operation; F_h's rows 2 and 3 are (0, 0, 1, h) and e₄, whose zero terms that loop adds
    are left out: each is an exact 0), q_a and q_j in T[16], T[17]."""
    h3 = h * h * h
    h4, h5 = h3 * h, h3 * h * h
    for k in range(lo, hi):
        f00, f01, f02, f10, f11, f12 = _flow_rows(T[13, k], T[14, k], c, h)
        jj = T[14, k]
        f13 = jj * (0.5 * h * h)
        qa, qj = T[16, k], T[17, k]
        q00 = qa * jj * jj * h5 / 20.0 + qj * jj * jj * h5 * h * h / 252.0
        q01 = qa * jj * jj * h4 / 8.0 + qj * jj * jj * h3 * h3 / 72.0
        q02 = qa * jj * h3 / 6.0 + qj * jj * h5 / 30.0
        q03 = qj * jj * h4 / 24.0
        q11 = qa * jj * jj * h3 / 3.0 + qj * jj * jj * h5 / 20.0 + q_rate * h
        q12 = qa * jj * h * h / 2.0 + qj * jj * h4 / 8.0
        q13 = qj * jj * h3 / 6.0
        q22 = qa * h + qj * h3 / 3.0
        q23 = qj * h * h / 2.0
        q33 = qj * h
        b00, b01, b02, b03 = Q[P00, k], Q[P01, k], Q[P02, k], Q[P03, k]
        b11, b12, b13, b22, b23, b33 = Q[P11, k], Q[P12, k], Q[P13, k], Q[P22, k], Q[P23, k], Q[P33, k]
        t00 = f00 * b00 + f01 * b01 + f02 * b02
        t01 = f00 * b01 + f01 * b11 + f02 * b12
        t02 = f00 * b02 + f01 * b12 + f02 * b22
        t03 = f00 * b03 + f01 * b13 + f02 * b23
        t10 = f10 * b00 + f11 * b01 + f12 * b02 + f13 * b03
        t11 = f10 * b01 + f11 * b11 + f12 * b12 + f13 * b13
        t12 = f10 * b02 + f11 * b12 + f12 * b22 + f13 * b23
        t13 = f10 * b03 + f11 * b13 + f12 * b23 + f13 * b33
        t22 = b22 + h * b23
        t23 = b23 + h * b33
        Q[P00, k] = q00 + t00 * f00 + t01 * f01 + t02 * f02
        Q[P01, k] = q01 + t00 * f10 + t01 * f11 + t02 * f12 + t03 * f13
        Q[P02, k] = q02 + t02 + t03 * h
        Q[P03, k] = q03 + t03
        Q[P11, k] = q11 + t10 * f10 + t11 * f11 + t12 * f12 + t13 * f13
        Q[P12, k] = q12 + t12 + t13 * h
        Q[P13, k] = q13 + t13
        Q[P22, k] = q22 + t22 + t23 * h
        Q[P23, k] = q23 + t23
        Q[P33, k] = q33 + b33


@njit(cache=True, inline="always")
def _transition(
    FF: np.ndarray, T: np.ndarray, m: int, d: int, walks: int, h: float, c: float, first: bool
) -> None:
    """F ← F_h F of every lane over a sub-step (the first: F ← F_h), F_h = I + J h + J² h²/2 at the prior
    (ekf_kernels.predict's f): rows 0 and 1 from ``_flow_rows`` and the Jacobian in T[13], T[14]; row 2 e₃
    (a held), or on a trend lane (0, 0, 1, h) with f₁₃ = j₁₂ h²/2 and row 3 e₄. Row-major 4 × 4 per lane
    (a random-walk lane's fourth row and column 0)."""
    for k in range(m):
        f00, f01, f02, f10, f11, f12 = _flow_rows(T[13, k], T[14, k], c, h)
        trend = d == 4 and k >= walks
        f13 = T[14, k] * (0.5 * h * h) if trend else 0.0
        f23 = h if trend else 0.0
        f33 = 1.0 if trend else 0.0
        if first:
            FF[0, k], FF[1, k], FF[2, k], FF[3, k] = f00, f01, f02, 0.0
            FF[4, k], FF[5, k], FF[6, k], FF[7, k] = f10, f11, f12, f13
            FF[8, k], FF[9, k], FF[10, k], FF[11, k] = 0.0, 0.0, 1.0, f23
            FF[12, k], FF[13, k], FF[14, k], FF[15, k] = 0.0, 0.0, 0.0, f33
            continue
        for col in range(4):
            r0, r1, r2, r3 = FF[col, k], FF[4 + col, k], FF[8 + col, k], FF[12 + col, k]
            FF[col, k] = f00 * r0 + f01 * r1 + f02 * r2
            FF[4 + col, k] = f10 * r0 + f11 * r1 + f12 * r2 + f13 * r3
            FF[8 + col, k] = r2 + f23 * r3
            FF[12 + col, k] = f33 * r3


@njit(cache=True, inline="always")
def _correct(Y: np.ndarray, Q: np.ndarray, T: np.ndarray, m: int, d: int, y: float, r: float) -> None:
    """The scalar Kalman update of every lane over d states (ekf_kernels.correct: S = P₀₀ + r, K = P e₁/S,
    x ← x + K ν, P ← P − K Kᵀ S; a random-walk lane's j and P₃ₓ are 0 and stay exactly 0); T[0], T[1] ←
    ν, S and T[2], T[3], T[4] ← the prior's a, P_aa, P_aθ, for the mode's fixed-lag row and likelihood."""
    for k in range(m):
        T[2, k], T[3, k], T[4, k] = Y[2, k], Q[P22, k], Q[P02, k]
        s = Q[P00, k] + r
        nu = y - Y[0, k]
        k0, k1, k2 = Q[P00, k] / s, Q[P01, k] / s, Q[P02, k] / s
        Y[0, k] += k0 * nu
        Y[1, k] += k1 * nu
        Y[2, k] += k2 * nu
        Q[P00, k] -= k0 * k0 * s
        Q[P01, k] -= k0 * k1 * s
        Q[P02, k] -= k0 * k2 * s
        Q[P11, k] -= k1 * k1 * s
        Q[P12, k] -= k1 * k2 * s
        Q[P22, k] -= k2 * k2 * s
        if d == 4:
            k3 = Q[P03, k] / s
            Y[3, k] += k3 * nu
            Q[P03, k] -= k0 * k3 * s
            Q[P13, k] -= k1 * k3 * s
            Q[P23, k] -= k2 * k3 * s
            Q[P33, k] -= k3 * k3 * s
        T[0, k], T[1, k] = nu, s


@njit(cache=True)
def _restart(
    st: ImmArrays, m: int, band: int, d: int, t: float, y: float, params: np.ndarray, jerks: np.ndarray
) -> None:
    """Every mode initialised from y (ekf_kernels.initialise), equally likely; a trend mode at j = 0 with
    variance INIT_JERK_STD², a random walk's j ≡ 0; its (â, var) row the initial a, P_aa."""
    X, P, MU, RA, RV, MEMO = st.X, st.P, st.MU, st.RA, st.RV, st.MEMO
    x, p = np.empty(3), np.empty((3, 3))
    initialise(x, p, y, params[0], params[1], params[3], params[7], params[8])
    for j in range(m):
        col = band + j
        for a in range(3):
            X[a, col] = x[a]
        for e in range(P_ROWS[3]):
            P[e, col] = p[P_ENTRY[e][0], P_ENTRY[e][1]]
        if d == 4:
            X[3, col] = 0.0
            P[P03, col] = P[P13, col] = P[P23, col] = 0.0
            P[P33, col] = INIT_JERK_STD**2 if jerks[j] > 0.0 else 0.0
        MU[col] = 1.0 / m
        RA[j], RV[j] = x[2], p[2, 2]
    MEMO[1], MEMO[2] = t, 1.0


@njit(cache=True)
def _step(
    st: ImmArrays, perm: np.ndarray, m: int, band: int, d: int, walks: int, t: float, y: float,
    params: np.ndarray, rates: np.ndarray, jerks: np.ndarray,
) -> bool:  # fmt: skip
    """One sample into the IMM (Blom & Bar-Shalom); True when it (re)started here.

    Mode j is the EKF of ekf_kernels with q_a = qs[j] (and with ``jerks``, q_j = jerks[j]: a trend mode on
    [θ, θ', a, j]; q_j = 0, a random walk whose j and its covariance are zeroed after the mixing). The mode
    follows a continuous-time Markov chain with jump rates R_ij (ekf_kernels.chain_rates): over Δt it stays
    with Π_ii = e^{−r_i Δt}, r_i = Σ_j R_ij, and moves to j with Π_ij = (1 − e^{−r_i Δt}) R_ij / r_i
    (ekf_kernels._chain_step). Per sample: mix (``_mix``), predict and correct every mode
    (``_rk4_stages``, ``_walk_covariance``, ``_trend_covariance``, ``_correct``), μ_j ∝ c_j N(ν_j; 0, S_j),
    floored at 1e-12 (``_update_modes``). Each mode's estimate of a and its variance, RA and RV, are the
    fixed-lag row of the new sample: â_j = a⁻_j + P⁻_aθ,j ν_j / S_j, var_j = P⁻_aa,j − (P⁻_aθ,j)² / S_j.
    A sample after a gap longer than params[6], or where the combination is not finite (a filter driven
    out of its model), restarts every mode from it (``_restart``). The fixed-lag pass (``_lagged_step``) runs
    its buffer's update between ``_predict_correct`` and ``_finish``."""
    if _predict_correct(st, perm, m, band, d, walks, t, y, params, rates, jerks, False):
        return True
    result: bool = _finish(st, perm, m, band, d, t, y, params, jerks)
    return result


@njit(cache=True, inline="always")
def _predict_correct(
    st: ImmArrays, perm: np.ndarray, m: int, band: int, d: int, walks: int, t: float, y: float,
    params: np.ndarray, rates: np.ndarray, jerks: np.ndarray, lagging: bool,
) -> bool:  # fmt: skip
    """``_step`` up to the update: True when it restarted instead (then nothing is left to do); else the
    modes' corrected states are in Y, Q (lanes grouped), their ν, S, a⁻, P⁻_aa and P⁻_aθ in T[0 … 4], and
    X, P still hold the last posteriors. ``lagging``: also keep each lane's transition F and prior x⁻, P⁻
    (FF, PR) for the fixed-lag pass."""
    X, P, MU, X0, P0, Y, Q, PB, WT = st.X, st.P, st.MU, st.X0, st.P0, st.Y, st.Q, st.PB, st.WT
    CJ, T, PI, DT, MEMO = st.CJ, st.T, st.PI, st.DT, st.MEMO
    last = MEMO[1]
    if last != last or t - last > params[6]:  # NaN: no sample yet
        _restart(st, m, band, d, t, y, params, jerks)
        return True
    dt = t - last
    nb = 2 * band + 1
    slot = -1
    for k in range(PI_SLOTS):  # Π depends on Δt only: formed once for each Δt a recording steps by
        if DT[k] == dt:
            slot = k
            break
    if slot < 0:
        slot = int(MEMO[0])
        MEMO[0] = (slot + 1) % PI_SLOTS
        DT[slot] = dt
        _chain_step(rates, dt, PI)
        for o in range(nb):
            for j in range(m):
                i = j - band + o
                PB[slot * nb + o, j] = PI[i, j] if 0 <= i < m else 0.0
    _mix(X, P, MU, X0, P0, PB, WT, CJ, m, band, d, slot * nb)
    ne = P_ROWS[d]
    for k in range(m):  # grouped: the random walks, then the trend modes (their covariance differs)
        j = perm[k]
        for a in range(d):
            Y[a, k] = X0[a, j]
        for e in range(ne):
            Q[e, k] = P0[e, j]
    if d == 4:
        for k in range(walks):  # a random walk carries no trend
            Y[3, k] = 0.0
            Q[P03, k] = Q[P13, k] = Q[P23, k] = Q[P33, k] = 0.0
    g, length, c, r, q_rate = params[0], params[1], params[2], params[3], params[4]
    linv = 1.0 / length
    steps = max(1, math.ceil(dt / MAX_STEP))
    h = dt / steps
    for sub in range(steps):
        _rk4_stages(Y, T, m, d, h, g, linv, c)
        if lagging:
            _transition(st.FF, T, m, d, walks, h, c, sub == 0)
        _walk_covariance(Q, T, 0, walks, h, c, q_rate)
        if d == 4:
            _trend_covariance(Q, T, walks, m, h, c, q_rate)
    if lagging:
        for k in range(m):
            for a in range(d):
                st.PR[a, k] = Y[a, k]
            for e in range(ne):
                st.PR[4 + e, k] = Q[e, k]
    _correct(Y, Q, T, m, d, y, r)
    return False


@njit(cache=True, inline="always")
def _finish(
    st: ImmArrays, perm: np.ndarray, m: int, band: int, d: int, t: float, y: float, params: np.ndarray,
    jerks: np.ndarray,
) -> bool:  # fmt: skip
    """``_step`` after the update: each mode's row RA, RV and likelihood, the posteriors into X, P, the mode
    probabilities; True when the combination was not finite and every mode restarted."""
    X, P, MU, RA, RV, T, LOGL, CJ, MEMO = st.X, st.P, st.MU, st.RA, st.RV, st.T, st.LOGL, st.CJ, st.MEMO
    ne = P_ROWS[d]
    for k in range(m):
        j = perm[k]
        nu, s, c0 = T[0, k], T[1, k], T[4, k]
        RA[j] = T[2, k] + c0 * nu / s
        RV[j] = T[3, k] - c0 * c0 / s
        LOGL[j] = -0.5 * (nu * nu / s + math.log(s)) + math.log(CJ[j])
        for a in range(d):
            X[a, band + j] = st.Y[a, k]
        for e in range(ne):
            P[e, band + j] = st.Q[e, k]
    _update_modes(LOGL, MU, m, band)
    if _bounded(X, P, MU, m, band):
        MEMO[1], MEMO[2] = t, MEMO[2] + 1.0
        return False
    _restart(st, m, band, d, t, y, params, jerks)  # never an inf or NaN published
    return True


@njit(cache=True, inline="always")
def _update_modes(logl: np.ndarray, MU: np.ndarray, m: int, band: int) -> None:
    """μ_j ∝ exp(logl_j) (logl_j = ln c_j + ln N(ν_j; 0, S_j)), floored at 1e-12 (ekf_kernels._update_modes;
    μ_j in MU's column b + j)."""
    top = logl[0]
    for j in range(1, m):
        top = max(top, logl[j]) if logl[j] == logl[j] else math.nan  # numpy's max: a NaN wins
    total = 0.0
    for j in range(m):
        MU[band + j] = math.exp(logl[j] - top)
        total += MU[band + j]
    for j in range(m):
        MU[band + j] = max(MU[band + j] / total, 1e-12)  # a floor keeps every mode revivable


@njit(cache=True, inline="always")
def _bounded(X: np.ndarray, P: np.ndarray, MU: np.ndarray, m: int, band: int) -> bool:
    """True when the combination x = Σ μ_j x_j, P = Σ μ_j (P_j + (x_j − x)(x_j − x)ᵀ) on [θ, θ', a] is
    finite (ekf_kernels._finite of it). With every μ_j in [0, 1], Σ_j (|x_j| + |P_j|) < 1e150 bounds every
    entry of it by 1e150 + 4·1e300, so the combination is formed only past that bound or with a μ out of
    [0, 1] or NaN (a filter far out of its model), and the answer is the same."""
    bound = 0.0
    for j in range(band, band + m):
        if not 0.0 <= MU[j] <= 1.0:  # NaN too
            bound = math.inf
    for e in range(P_ROWS[3]):
        for j in range(band, band + m):
            bound += abs(P[e, j])
    for a in range(3):
        for j in range(band, band + m):
            bound += abs(X[a, j])
    if bound < 1e150:
        return True
    x = np.zeros(3)
    for a in range(3):
        for j in range(m):
            x[a] += MU[band + j] * X[a, band + j]
    total = 0.0
    for a in range(3):
        total += x[a]
        for b in range(3):
            e = ENTRY_OF[a][b]
            acc = 0.0
            for j in range(m):
                col = band + j
                acc += MU[col] * (P[e, col] + (X[a, col] - x[a]) * (X[b, col] - x[b]))
            total += acc
    return math.isfinite(total)


@njit(cache=True, inline="always")
def _combined(MU: np.ndarray, RA: np.ndarray, RV: np.ndarray, m: int, band: int) -> tuple[float, float]:
    """(â, var) over the modes in their order: â = Σ μ_j â_j, var = Σ μ_j (var_j + (â_j − â)²) (the
    filter's output: ``_step``'s rows RA, RV)."""
    a = 0.0
    for j in range(m):
        a += MU[band + j] * RA[j]
    v = 0.0
    for j in range(m):
        dev = RA[j] - a
        v += MU[band + j] * (RV[j] + dev * dev)
    return a, v


@njit(cache=True)
def smooth_modes(t: np.ndarray, mu: np.ndarray, rates: np.ndarray, reset_gap: float, band: int) -> None:
    """In place: the IMM's filtered mode probabilities μ_k (n × modes) become the smoothed ones,
    μˢ_k(i) = μ_k(i) Σ_j Π_ij μˢ_{k+1}(j) / μ⁻_{k+1}(j), μ⁻_{k+1}(j) = Σ_l Π_lj μ_k(l), Π over t_{k+1} − t_k
    (the chain's backward recursion, exact for a hidden Markov chain; the IMM's mode likelihoods make it an
    approximation here). The sums run over the chain's band (Π_ij = 0 beyond it: the terms left out are
    exact zeros). A segment's last sample (the next one restarts after a gap) keeps its μ."""
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
            for i in range(max(0, j - band), min(m, j + band + 1)):
                acc += mu[k, i] * pi[i, j]
            pred[j] = acc
        total = 0.0
        for i in range(m):
            acc = 0.0
            for j in range(max(0, i - band), min(m, i + band + 1)):
                acc += pi[i, j] * mu[k + 1, j] / pred[j]
            mu[k, i] *= acc
            total += mu[k, i]
        for i in range(m):
            mu[k, i] /= total


# ---- The IMM's fixed-lag pass, its drivers (batch and live) and the lag's variance map -------------------
# Fixed-lag smoothing (Anderson & Moore's augmented state, for a only): for every buffered sample i ≤ k
# each mode keeps â_{i|k}, its variance and the cross-covariance row c_i = Cov(a_i, x_k | y_{..k}). A
# measurement with innovation ν, S = P⁻₀₀ + r, gain K moves â_i by c_i[0] ν/S and its variance by
# −c_i[0]²/S, then c_i ← c_i − c_i[0] K; a prediction maps c_i ← F c_i. The IMM's mixing mixes each
# buffered sample's â, var and c like the state (``_mix_ring``: the augmented state's IMM mixing,
# restricted to the blocks the update reads), and ``_combined_slot`` combines a sample over the modes,
# â = Σ μ_j â_j, var = Σ μ_j (var_j + (â_j − â)²). A trend mode's rows carry a fourth entry, the
# cross-covariance with its j. One pass gives every lag at once; it costs O(m N) per sample for m modes
# and a lag of N samples (docs/estimators.md, "The lag knob", says why it is not an RTS pass).
#
# The buffer holds N + 1 samples, sample i of a segment at slot i mod (N + 1), the buffer the innermost
# axis, so each of its loops runs as vector arithmetic over the slots.


@njit(cache=True)
def lag_variance_one(
    var_lag: float, var_filter: float, power: float, revision: float, weight: float
) -> float:
    """min(P_f (P_lag/P_f)^γ + κ d², P_lag) with the ratio clipped to [0, 1], d = â_lag − â_f (``revision``),
    κ = ``weight``; P_lag where P_f ≤ 0 (kalman.lag_variance)."""
    if not var_filter > 0.0 or var_lag != var_lag:  # no filter variance, or no lagged one (NaN) to map
        return var_lag
    ratio = min(max(var_lag / var_filter, 0.0), 1.0)
    result: float = min(var_filter * ratio**power + weight * revision * revision, var_lag)
    return result


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


class Ring(NamedTuple):
    """The fixed-lag buffer of every mode (ring_buffer, ``ring``), mode j's rows in row j. The buffer holds
    two sets of rows; a step mixes the current set into the other, which then becomes the current one (a
    flag, the buffer's last float: no copy)."""

    A: np.ndarray  # m × (N + 1): â of each buffered sample
    V: np.ndarray  # m × (N + 1): its variance
    C: (
        np.ndarray
    )  # m × 4 × (N + 1): its cross-covariance with the mode's state (three entries without trends)
    NA: np.ndarray  # as A: a step's mixed rows, before they replace A
    NV: np.ndarray
    NC: np.ndarray


def ring_buffer(size: int, m: int) -> np.ndarray:
    """The float buffer of a ring of ``size`` = N + 1 slots over m modes (Ring), and its flag."""
    return np.zeros(2 * (6 * m * size) + 1)


@njit(cache=True, inline="always")
def ring(rbuf: np.ndarray, size: int, m: int) -> Ring:
    """The ring buffer's parts (Ring): the current set of rows first, as its flag says."""
    o = m * size
    cur = 6 * o if rbuf[12 * o] != 0.0 else 0
    new = 6 * o - cur
    return Ring(
        rbuf[cur : cur + o].reshape(m, size),
        rbuf[cur + o : cur + 2 * o].reshape(m, size),
        rbuf[cur + 2 * o : cur + 6 * o].reshape(m, 4, size),
        rbuf[new : new + o].reshape(m, size),
        rbuf[new + o : new + 2 * o].reshape(m, size),
        rbuf[new + 2 * o : new + 6 * o].reshape(m, 4, size),
    )


@njit(cache=True, inline="always")
def _ring_start(st: ImmArrays, rg: Ring, m: int, band: int, d: int) -> None:
    """After a restart: each mode's buffer holds the new sample only, its â, var and row of P_a·."""
    for j in range(m):
        col = band + j
        rg.A[j, 0], rg.V[j, 0] = st.RA[j], st.RV[j]
        rg.C[j, 0, 0], rg.C[j, 1, 0], rg.C[j, 2, 0] = st.P[P02, col], st.P[P12, col], st.P[P22, col]
        rg.C[j, 3, 0] = 0.0


@njit(cache=True, inline="always")
def _mix_ring(
    st: ImmArrays, rg: Ring, j: int, m: int, band: int, d: int, size: int, trend: bool
) -> None:  # fmt: skip
    """IMM mixing of mode j's buffer into its new rows: â⁰_j = Σ_i w_ij â_i, var⁰_j = Σ_i w_ij (var_i +
    (â_i − â⁰_j)²), c⁰_j = Σ_i w_ij (c_i + (â_i − â⁰_j)(x_i − x⁰_j)), over the band in increasing i (w_ij
    the step's mixing weights, x_i the last posteriors, x⁰_j the mixed state). A trend mode's fourth entry
    mixes alike; a random walk's is 0."""
    lo, hi = max(0, j - band), min(m, j + band + 1)
    for s in range(size):
        rg.NA[j, s] = 0.0
        rg.NV[j, s] = 0.0
        rg.NC[j, 0, s] = 0.0
        rg.NC[j, 1, s] = 0.0
        rg.NC[j, 2, s] = 0.0
    for i in range(lo, hi):
        wij = st.WT[i - j + band, j]
        for s in range(size):
            rg.NA[j, s] += wij * rg.A[i, s]
    for i in range(lo, hi):
        wij = st.WT[i - j + band, j]
        col = band + i
        d0, d1, d2 = st.X[0, col] - st.X0[0, j], st.X[1, col] - st.X0[1, j], st.X[2, col] - st.X0[2, j]
        for s in range(size):
            da = rg.A[i, s] - rg.NA[j, s]
            rg.NV[j, s] += wij * (rg.V[i, s] + da * da)
            rg.NC[j, 0, s] += wij * (rg.C[i, 0, s] + da * d0)
            rg.NC[j, 1, s] += wij * (rg.C[i, 1, s] + da * d1)
            rg.NC[j, 2, s] += wij * (rg.C[i, 2, s] + da * d2)
    if d == 4:
        for s in range(size):
            rg.NC[j, 3, s] = 0.0
        if trend:
            for i in range(lo, hi):
                wij = st.WT[i - j + band, j]
                d3 = st.X[3, band + i] - st.X0[3, j]
                for s in range(size):
                    rg.NC[j, 3, s] += wij * (rg.C[i, 3, s] + (rg.A[i, s] - rg.NA[j, s]) * d3)


@njit(cache=True, inline="always")
def _ring_update(
    st: ImmArrays, rg: Ring, perm: np.ndarray, m: int, band: int, d: int, walks: int, held: int, new: int
) -> None:
    """Every mode's buffer through the step (module doc), after ``_predict_correct``: mixed (``_mix_ring``,
    when it holds earlier samples), c ← F c, the new slot takes the prior's a row, then the innovation
    moves â, var and c of every slot. Each mode's own rows, in the operations of the pass it replaced
    (ekf_kernels' step and the IMM's, to the bit)."""
    size = rg.A.shape[1]
    T, FF, PR = st.T, st.FF, st.PR
    for k in range(m):
        j = perm[k]
        trend = d == 4 and k >= walks
        if held:
            _mix_ring(st, rg, j, m, band, d, size, trend)
            A, V, C = rg.NA, rg.NV, rg.NC
        else:
            A, V, C = rg.A, rg.V, rg.C
        nu, s_nu = T[0, k], T[1, k]
        p00, p01, p02 = PR[4 + P00, k], PR[4 + P01, k], PR[4 + P02, k]
        k0, k1, k2 = p00 / s_nu, p01 / s_nu, p02 / s_nu
        prior_a, prior_v = PR[2, k], PR[4 + P22, k]
        if not trend:
            f00, f01, f02, f10, f11, f12 = FF[0, k], FF[1, k], FF[2, k], FF[4, k], FF[5, k], FF[6, k]
            f20, f21, f22 = FF[8, k], FF[9, k], FF[10, k]
            if held:  # c ← F c, then the update moves â, var and c by the innovation
                for s in range(size):
                    c0, c1, c2 = C[j, 0, s], C[j, 1, s], C[j, 2, s]
                    n0 = f00 * c0 + f01 * c1 + f02 * c2
                    n1 = f10 * c0 + f11 * c1 + f12 * c2
                    n2 = f20 * c0 + f21 * c1 + f22 * c2
                    A[j, s] += n0 * nu / s_nu
                    V[j, s] -= n0 * n0 / s_nu
                    C[j, 0, s] = n0 - n0 * k0
                    C[j, 1, s] = n1 - n0 * k1
                    C[j, 2, s] = n2 - n0 * k2
            C[j, 0, new], C[j, 1, new], C[j, 2, new] = p02, PR[4 + P12, k], prior_v
            c0 = C[j, 0, new]
            A[j, new] = prior_a + c0 * nu / s_nu
            V[j, new] = prior_v - c0 * c0 / s_nu
            C[j, 0, new] -= c0 * k0
            C[j, 1, new] -= c0 * k1
            C[j, 2, new] -= c0 * k2
            continue
        k3 = PR[4 + P03, k] / s_nu
        if held:
            for s in range(size):
                c0, c1, c2, c3 = C[j, 0, s], C[j, 1, s], C[j, 2, s], C[j, 3, s]
                for row in range(4):
                    C[j, row, s] = (
                        FF[4 * row, k] * c0
                        + FF[4 * row + 1, k] * c1
                        + FF[4 * row + 2, k] * c2
                        + (FF[4 * row + 3, k] * c3)
                    )
        A[j, new], V[j, new] = prior_a, prior_v
        C[j, 0, new], C[j, 1, new], C[j, 2, new], C[j, 3, new] = p02, PR[4 + P12, k], prior_v, PR[4 + P23, k]
        for s in range(0 if held else new, size if held else new + 1):
            c0 = C[j, 0, s]
            A[j, s] += c0 * nu / s_nu
            V[j, s] -= c0 * c0 / s_nu
            C[j, 0, s] -= c0 * k0
            C[j, 1, s] -= c0 * k1
            C[j, 2, s] -= c0 * k2
            C[j, 3, s] -= c0 * k3


@njit(cache=True, inline="always")
def _lagged_step(
    st: ImmArrays, rbuf: np.ndarray, perm: np.ndarray, m: int, band: int, d: int, walks: int, t: float,
    y: float, params: np.ndarray, rates: np.ndarray, jerks: np.ndarray,
) -> bool:  # fmt: skip
    """One sample into the IMM and its fixed-lag buffer ``rbuf`` (ring_buffer: ``_step`` with ``_ring_update``
    between the update and the rest); True when the IMM (re)started here, its buffer then holding the new
    sample only."""
    size = (rbuf.size - 1) // (12 * m)
    count = int(st.MEMO[2])
    if _predict_correct(st, perm, m, band, d, walks, t, y, params, rates, jerks, True):
        _ring_start(st, ring(rbuf, size, m), m, band, d)
        return True
    held = min(count, size - 1)
    _ring_update(st, ring(rbuf, size, m), perm, m, band, d, walks, held, count % size)
    if held:  # the mixed rows are the current ones now
        rbuf[rbuf.size - 1] = 0.0 if rbuf[rbuf.size - 1] != 0.0 else 1.0
    if _finish(st, perm, m, band, d, t, y, params, jerks):
        _ring_start(st, ring(rbuf, size, m), m, band, d)
        return True
    return False


@njit(cache=True, inline="always")
def _combined_slot(MU: np.ndarray, rg: Ring, m: int, band: int, slot: int) -> tuple[float, float]:
    """(â, var) of a buffered sample over the modes: â = Σ μ_j â_j, var = Σ μ_j (var_j + (â_j − â)²)."""
    a = 0.0
    for j in range(m):
        a += MU[band + j] * rg.A[j, slot]
    v = 0.0
    for j in range(m):
        dev = rg.A[j, slot] - a
        v += MU[band + j] * (rg.V[j, slot] + dev * dev)
    return a, v


@njit(cache=True)
def _flush(
    out_a: np.ndarray, out_v: np.ndarray, MU: np.ndarray, rg: Ring, m: int, band: int, last: int, count: int,
    lags: np.ndarray,
) -> None:  # fmt: skip
    """At a segment's end (sample ``last``): samples whose lag reaches past it get their latest â, var."""
    size = rg.A.shape[1]
    for j in range(min(count, size)):
        slot = (count - 1 - j) % size
        for col in range(lags.size):
            if lags[col] > j:
                out_a[last - j, col], out_v[last - j, col] = _combined_slot(MU, rg, m, band, slot)


@njit(cache=True, nogil=True)  # a long batch leaves the GIL: Ctrl-C reaches the main thread
def run_imm(
    t: np.ndarray, y: np.ndarray, params: np.ndarray, qs: np.ndarray, rates: np.ndarray, jerks: np.ndarray,
    band: int, lags: np.ndarray, keep_mu: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(â, var, μ) of the IMM over a recording (``_step`` per sample, with a lag ``_lagged_step``):
    column c of â, var holds the fixed-lag estimate â_{i | i + lags[c]} aligned to the sample i it
    describes (lag 0: the filter's, ``_combined``; its variance unmapped; the last lags[c] samples of a
    segment use all the data there is, and where a divergence restart lost them they are NaN); μ: a
    column per mode, or no rows without ``keep_mu``. ``jerks``: each mode's q_j (empty: random walks
    only); ``band``: chain_band(rates)."""
    n, m, nl = t.size, qs.size, lags.size
    buf, ibuf = imm_buffer(qs, band, jerks)
    d, walks = ibuf[2], ibuf[3]
    perm = ibuf[5 : 5 + m]
    st = imm_arrays(buf, m, band, d)
    size = int(lags.max()) + 1 if nl else 1
    rbuf = np.zeros(12 * m * size + 1)  # ring_buffer(size, m)
    a = np.full((n, nl), np.nan)
    v = np.full((n, nl), np.nan)
    mus = np.empty((n if keep_mu else 0, m))
    for i in range(n):
        if size == 1:
            _step(st, perm, m, band, d, walks, t[i], y[i], params, rates, jerks)
            fa, fv = _combined(st.MU, st.RA, st.RV, m, band)
            for c in range(nl):
                a[i, c], v[i, c] = fa, fv
        else:
            if i > 0 and t[i] - st.MEMO[1] > params[6]:  # a gap ends the segment
                _flush(a, v, st.MU, ring(rbuf, size, m), m, band, i - 1, int(st.MEMO[2]), lags)
            _lagged_step(st, rbuf, perm, m, band, d, walks, t[i], y[i], params, rates, jerks)
            rg = ring(rbuf, size, m)
            count = int(st.MEMO[2])
            for c in range(nl):
                lag = lags[c]
                if lag < count:
                    a[i - lag, c], v[i - lag, c] = _combined_slot(
                        st.MU, rg, m, band, (count - 1 - lag) % size
                    )
        if keep_mu:
            for j in range(m):
                mus[i, j] = st.MU[band + j]
    if size > 1 and n:
        _flush(a, v, st.MU, ring(rbuf, size, m), m, band, n - 1, int(st.MEMO[2]), lags)
    return a, v, mus


@njit(cache=True)
def live_step(
    buf: np.ndarray, ibuf: np.ndarray, rbuf: np.ndarray, hist: np.ndarray, lag: int, t: float, y: float,
    params: np.ndarray, rates: np.ndarray, jerks: np.ndarray, mapped: bool, power: float, weight: float,
    out: np.ndarray,
) -> bool:  # fmt: skip
    """One sample of the live estimator (kalman.KalmanEstimator.update): the IMM's step and, with a lag of
    N samples, its fixed-lag buffer; out ← (â, var, t) of the sample it now describes, var (when ``mapped``)
    mapped by ``lag_variance_one`` (γ = ``power``, κ = ``weight``) against the filter's own â, var of that
    sample (``hist``: (N + 1) × 3, each buffered sample's stamp and filter â, var); False while the lag
    fills (a segment's first N samples). The same compiled steps as ``run_imm``: equal to its columns (and
    kalman.lag_variance of them) to the last bit."""
    m, band, d, walks = ibuf[0], ibuf[1], ibuf[2], ibuf[3]
    perm = ibuf[5 : 5 + m]
    st = imm_arrays(buf, m, band, d)
    if lag == 0:
        _step(st, perm, m, band, d, walks, t, y, params, rates, jerks)
        out[0], out[1] = _combined(st.MU, st.RA, st.RV, m, band)
        out[2] = t
        return True
    size = lag + 1
    _lagged_step(st, rbuf, perm, m, band, d, walks, t, y, params, rates, jerks)
    rg = ring(rbuf, size, m)
    count = int(st.MEMO[2])
    newest = (count - 1) % size
    hist[newest, 0] = t
    hist[newest, 1], hist[newest, 2] = _combined_slot(st.MU, rg, m, band, newest)
    if count <= lag:
        return False
    slot = (count - 1 - lag) % size
    a, var = _combined_slot(st.MU, rg, m, band, slot)
    if mapped:
        var = lag_variance_one(var, hist[slot, 2], power, a - hist[slot, 1], weight)
    out[0], out[1], out[2] = a, var, hist[slot, 0]
    return True


def warm_live() -> None:
    """Compile (or load from the cache) the live step (kalman.KalmanEstimator.update): a few samples through
    ``live_step`` without and with a lag."""
    t = np.arange(3) / 100.0
    params = np.array([9.80665, 1.0, 0.05, 1e-6, 0.0, 0.01, 1.0, 1.55, 0.3])
    qs = np.array([1e-3, 0.1])
    rates = np.array([[0.0, 0.2], [0.2, 0.0]])
    jerks = np.empty(0)  # random walks only: trend modes run the same compiled step
    for lag in (0, 5):
        buf, ibuf = imm_buffer(qs, 1, jerks)
        rbuf, hist, out = ring_buffer(lag + 1, qs.size), np.zeros((lag + 1, 3)), np.empty(3)
        for k in range(3):
            live_step(buf, ibuf, rbuf, hist, lag, float(t[k]), 0.0, params, rates, jerks, True, 2.0, 1.0, out)


def _warm_imm() -> None:
    """Compile (or load from the cache) the IMM's batch passes, a few samples through each: with random
    walks only, with trend modes, filter and fixed lag (the live step: ``warm_live``)."""
    t = np.arange(30) / 100.0
    y = np.zeros(30)
    params = np.array([9.80665, 1.0, 0.05, 1e-6, 0.0, 0.01, 1.0, 1.55, 0.3])
    qs = np.array([1e-3, 0.1])
    rates = np.array([[0.0, 0.2], [0.2, 0.0]])
    for jerks in (np.empty(0), np.array([0.0, 1.0])):
        for lags in (np.zeros(1, dtype=np.int64), np.array([0, 5], dtype=np.int64)):
            for keep_mu in (True, False):
                mu = run_imm(t, y, params, qs, rates, jerks, 1, lags, keep_mu)[2]
    smooth_modes(t, mu, rates, 1.0, 1)
    lag_variance_into(np.ones(2), np.full(2, 2.0), np.ones(2), np.zeros(2), 2.0, 1.0, np.empty(2))
    table = np.ones((2, 2))
    lag_variance_into(table[:, 1], table[:, 0], table[:, 1], table[:, 0], 2.0, 1.0, np.empty(2))


def imm_pass(
    t: np.ndarray,
    y: np.ndarray,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    lags: np.ndarray,
    keep_mu: bool = False,
    jerks: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``run_imm`` with the chain's band worked out (``chain_band``); ``jerks`` None: random-walk
    modes only."""
    trend = np.empty(0) if jerks is None else np.asarray(jerks, dtype=float)
    lag_arr = np.asarray(lags, dtype=np.int64)
    result: tuple[np.ndarray, np.ndarray, np.ndarray] = run_imm(
        t, y, params, np.asarray(qs, dtype=float), rates, trend, chain_band(rates), lag_arr, keep_mu
    )
    return result


def warm_single() -> None:
    """Compile (or load from the cache) the single model's passes (filter, RTS, likelihood) and the four-state
    prediction: a few samples through each."""
    t = np.arange(30) / 100.0
    y = np.zeros(30)
    params = np.array([9.80665, 1.0, 0.05, 1e-6, 0.0, 0.01, 1.0, 1.55, 0.3])
    for q_accel in (np.empty(0), np.full(30, 0.01)):
        _, _, xpr, ppr, xpo, ppo, fk, starts = run_pass(t, y, params, q_accel)
    rts(xpr, ppr, xpo, ppo, fk, starts)
    log_likelihood(t, y, params)
    work = np.empty((3, 4, 4))  # the four-state prediction (kalman.steady_state, the tests' references)
    predict_trend(np.zeros(4), np.eye(4), np.empty((4, 4)), 0.01, 9.8, 1.0, 0.0, 0.0, 0.0, 1.0, work)
    trend_noise(work[0], 1.0, 0.01, 0.0, 1.0, 0.0)


def warm_batch() -> None:
    """Compile (or load) every offline pass: the single model's (``warm_single``) and the IMM's
    (``_warm_imm`` without its live step)."""
    warm_single()
    _warm_imm()


def warm() -> None:
    """Compile (or load) every pass, a few samples through each: ``warm_batch``, ``warm_live``."""
    warm_batch()
    warm_live()


if __name__ == "__main__":
    warm()
