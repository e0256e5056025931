"""The IMM smoother's backward pass (estimators.imm_smoother): the RTS smoother on one mode, the filter with
no future, blocks that cost nothing in accuracy, segments smoothed apart, and stable on a damped design."""

from __future__ import annotations

import numpy as np

from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators import imm_smoother, make_estimator
from pendulum_accel.estimators.kalman import KalmanEstimator
from test.test_smoother import CFG, RATE, drive, rms


def _auto() -> KalmanEstimator:
    """The default kalman (IMM over the auto modes) on the short damped design of test_smoother."""
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    return est


def test_one_mode_is_the_rts_smoother() -> None:
    """With a single mode the backward pass (the adjoint form, through Fᵀ) is the RTS smoother (through
    (P⁻)⁻¹) of the same filter: the same linear-Gaussian algebra, so they differ in rounding only.

    Tolerance: the RTS gain's (P⁻)⁻¹ has condition ≈ 3e5 here, so a backward step loses
    ≈ 3e5 · 2.2e-16 ≈ 7e-11 relative, and the steps' errors decay as the smoother forgets (memory ≈ 0.2 s,
    40 steps): ~3e-9 relative at most (6e-10 seen). 1e-6 (relative for var, m/s² for â) is far above that
    and far below any modelling difference (the smoother gains ~1e-2 m/s² on the filter)."""
    t, theta, _ = drive()
    est = _auto()
    params = est._params.copy()
    params[5] = est.q_accel
    a_s, v_s, a_f, _ = imm_smoother.run_imm_smoother(
        t, theta, params, np.array([est.q_accel]), np.zeros((1, 1)), t.size, 0
    )
    _, _, xpr, ppr, xpo, ppo, fk, starts = kern.run_pass(t, theta, params, np.zeros(1, np.int64), True)
    a_r, v_r = kern.rts(xpr, ppr, xpo, ppo, fk, starts)
    np.testing.assert_allclose(a_f, xpo[:, 2], rtol=0.0, atol=1e-6)  # the same filter forward
    np.testing.assert_allclose(a_s, a_r, rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(v_s, v_r, rtol=1e-6, atol=0.0)


def test_no_future_gives_the_filter() -> None:
    """Blocks of one sample and no overlap: each backward pass starts and ends at its sample (λ̃ = 0), so the
    output is the IMM filter's combination Σ μ_j x⁺_j, the same sums as the forward's (equal to rounding:
    1e-12 m/s² and relative of headroom over a few ulp)."""
    t, theta, _ = drive()
    est = _auto()
    a_s, v_s, a_f, v_f = imm_smoother.run_imm_smoother(t, theta, est._params, est._qs, est._rates, 1, 0)
    np.testing.assert_allclose(a_s, a_f, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(v_s, v_f, rtol=1e-12, atol=0.0)
    a_lag0, _ = est.lagged(t, theta, (0,))
    np.testing.assert_allclose(a_f, a_lag0[:, 0], rtol=0.0, atol=1e-12)  # and the kalman estimator's filter


def test_blocks_with_a_second_of_overlap_match_the_whole_recording() -> None:
    """Backward passes over blocks (each sample with ≥ 1 s of later data) against one pass over the whole
    30 s: RMS within 1 %. The later data's weight decays with the smoother's memory (≈ 0.2 s at these
    q_a): past 1 s, five memories, it moves the estimate by e⁻⁵ < 1 % of its correction (0.06 % seen).
    Without overlap a block's last samples lose their future: the RMS is then clearly worse (the check
    that the overlap is what buys it)."""
    t, theta, truth = drive()
    est = _auto()
    args = (t, theta, est._params, est._qs, est._rates)
    whole = rms(imm_smoother.run_imm_smoother(*args, t.size, 0)[0], truth, t)
    second = round(RATE)
    for block in (256, 4 * second):
        blocked = rms(imm_smoother.run_imm_smoother(*args, block, second)[0], truth, t)
        assert abs(blocked / whole - 1.0) < 0.01
    cut = rms(imm_smoother.run_imm_smoother(*args, 20, 0)[0], truth, t)
    assert cut > 1.1 * whole


def test_a_gap_splits_the_recording_into_segments_smoothed_apart() -> None:
    """A gap longer than reset_gap restarts the filter; the backward pass never crosses it: the two halves
    give what each gives alone (the same arithmetic on the same numbers: equal to the last bit)."""
    t, theta, _ = drive()
    est = _auto()
    half = t.size // 2
    t2 = np.concatenate([t[:half], t[half:] + 5.0])  # a 5 s gap > reset_gap (1 s)
    joined = imm_smoother.run_imm_smoother(t2, theta, est._params, est._qs, est._rates, t.size, 0)
    first = imm_smoother.run_imm_smoother(
        t2[:half], theta[:half], est._params, est._qs, est._rates, t.size, 0
    )
    second = imm_smoother.run_imm_smoother(
        t2[half:], theta[half:], est._params, est._qs, est._rates, t.size, 0
    )
    for k in range(4):
        np.testing.assert_array_equal(joined[k], np.concatenate([first[k], second[k]]))


def test_stable_over_a_long_window_on_a_damped_design() -> None:
    """The short damped design (c = 19.8 /s: F shrinks θ' by e^{−cΔt} a step) over one 30 s backward pass:
    in the RTS form the gain runs through F⁻¹ and any difference between the modes grows by e^{cΔt} ≈ 1.1 a
    step (1e41 over 1000 steps); the adjoint form damps it. Every estimate finite, every variance positive,
    and the smoother better than the filter."""
    t, theta, truth = drive()
    est = _auto()
    a_s, v_s, a_f, _ = imm_smoother.run_imm_smoother(t, theta, est._params, est._qs, est._rates, t.size, 0)
    assert np.all(np.isfinite(a_s)) and np.all(v_s > 0.0)
    assert rms(a_s, truth, t) < rms(a_f, truth, t)
