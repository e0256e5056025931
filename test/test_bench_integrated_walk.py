"""benchmarks.integrated_walk: its four-state EKF against the exact discretisation and on a ramp it models
exactly, and the page it writes."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from benchmarks import integrated_walk as iw
from benchmarks import motion_designs as md
from benchmarks import motion_scores as ms
from pendulum_accel.physics.profiles import Ramp

G = 9.80665


def test_one_prediction_matches_van_loans_exact_discretisation() -> None:
    """F and Q of one sub-step against expm of the linearised system (Van Loan's block exponential), with
    both a random walk's q_a and an integrated walk's q_j.

    Error argument: at l = 0.1 m, ω₀ = √(g/l) ≈ 9.9 /s and h = 5 ms, so ω₀h ≈ 0.05. F is e^{Jh} to third
    order: its relative error is about (ω₀h)⁴/24 ≈ 3e-7. Q integrates Φ(s) Q_c Φ(s)ᵀ with Φ cut after s³;
    in the columns Q_c feeds (e₃, e₄) the first dropped term is (ω₀ s)²/12 ≈ 2e-4 of the term kept in
    the θ and ω rows; the quadrature is exact for the kept polynomial. So rtol 2e-3 is 10× the largest
    truncation, and every entry compared is far above the float noise (atol 1e-14 of P's entries ≥ 1e-9)."""
    length, c, q_a, q_j, h = 0.1, 0.5, 0.2, 3.0, 0.005
    th, om, a, j = 0.05, 0.2, 0.4, -0.3
    x = np.array([th, om, a, j])
    p0 = np.diag([1e-6, 1e-3, 1e-2, 1.0])
    p = p0.copy()
    iw._predict(x, p, h, G, length, c, q_a, q_j)
    jac = np.zeros((4, 4))
    jac[0, 1] = 1.0
    jac[1, 0] = -(G * math.cos(th) + a * math.sin(th)) / length
    jac[1, 1] = -c
    jac[1, 2] = math.cos(th) / length
    jac[2, 3] = 1.0
    qc = np.zeros((4, 4))
    qc[2, 2], qc[3, 3] = q_a, q_j
    block = np.zeros((8, 8))
    block[:4, :4] = -jac
    block[:4, 4:] = qc
    block[4:, 4:] = jac.T
    e = expm(block * h)
    f = e[4:, 4:].T
    q = f @ e[:4, 4:]
    expected = f @ p0 @ f.T + q
    np.testing.assert_allclose(p, expected, rtol=2e-3, atol=1e-14)
    assert x[2] == pytest.approx(a + j * h, rel=1e-15)  # a moves by the jerk held over the sub-step


def test_a_ramp_is_tracked_without_the_lag_a_random_walk_has() -> None:
    """a(t) from 0 rising 0.3 m/s³ for 20 s: the integrated walk holds a ramp (j constant), so once it
    settles its error is the angle noise's alone, while the random-walk EKF at every q of its grid lags
    the ramp by a'·τ (or, at a q large enough to keep up, lets the noise through).

    Error argument: σ = 1e-6 rad maps to about g σ = 1e-5 m/s² of a per sample; the bound 1e-3 m/s²
    on the integrated walk's RMS over 5–20 s is 100× that (it comes to 1.7e-5). The random walk's best
    RMS over the grid is its lag, 3.4e-3 here: asserted above 30× the integrated walk's, a 6× margin."""
    design = md.Design("ramp", 0.1, 0.5, 1e-6, 200.0)
    runs = md.simulate_runs(Ramp(0.0, 20.0, 0.0, 6.0), design, 1, 20.0)
    run = runs[0]
    g, length, c, r = ms.kalman_q(design, 1.0)._params[:4]
    a = iw.iw_pass(run.t, run.theta, g, length, c, r, 1e-6)
    late = run.t >= 5.0
    rms_iw = float(np.sqrt(np.mean((a - run.accel)[late] ** 2)))
    assert rms_iw < 1e-3
    rms_rw = min(
        float(np.sqrt(np.mean((ms.kalman_q(design, q).batch(run.t, run.theta)[0] - run.accel)[late] ** 2)))
        for q in ms.Q_GRID
    )
    assert rms_rw > 30.0 * rms_iw


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The benchmark run on one validation profile through one design, its page under a temporary docs."""
    docs = tmp_path_factory.mktemp("docs")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(iw, "PROFILES", tuple(p for p in md.PROFILES if p.name == "udds_p2"))
        patch.setattr(iw, "REPORTED_HELDOUT", ())
        patch.setattr(iw, "designs", lambda: md.designs()[1:])
        assert iw.main(["--out", str(docs / "out"), "--docs", str(docs)]) == 0
    return docs / "benchmarks" / "integrated_walk.md"


def test_page_has_a_row_per_cell_and_its_ratios_follow_its_figures(page: Path) -> None:
    """One row per table (udds_p2 × short_damped); every figure finite and positive; each printed ratio is
    the ratio of the row's printed RMS figures (to their 3 significant digits: a relative rounding of 5e-3
    each); the live table's shares are percentages with their trials."""
    rows = [line for line in page.read_text().splitlines() if line.startswith("| short_damped | udds_p2 |")]
    assert len(rows) == 2  # the bounds' table and the live one
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    kalman, instant = float(cells[2]), float(cells[3])
    ekf = float(re.match(r"([0-9.e+-]+) \(", cells[4]).group(1))  # type: ignore[union-attr]
    bound = float(re.match(r"([0-9.e+-]+) \(", cells[5]).group(1))  # type: ignore[union-attr]
    ratios = [float(x) for x in cells[6:9]]
    for value in (kalman, instant, ekf, bound, *ratios):
        assert math.isfinite(value) and value > 0.0
    for printed, exact in zip(ratios, (kalman / bound, ekf / bound, kalman / instant), strict=True):
        assert printed == pytest.approx(exact, rel=0.015, abs=0.006)  # 2 × 5e-3 rounding + 2 decimals
    assert (page.parent.parent / "img" / "bench_integrated_walk.png").stat().st_size > 0
    cells = [c.strip() for c in rows[1].strip("|").split("|")]
    assert float(cells[2]) == kalman  # the same figure, printed by the same format in both tables
    both = float(cells[3])
    assert float(cells[4]) == pytest.approx(both / kalman, rel=0.015, abs=0.006)
    assert float(cells[5]) == pytest.approx(both / instant, rel=0.015, abs=0.006)
    for share in cells[6:10]:
        percent, trials = re.fullmatch(r"([0-9.]+) % \(([0-9]+)\)", share).groups()  # type: ignore[union-attr]
        assert 0.0 <= float(percent) <= 100.0 and int(trials) >= 1
