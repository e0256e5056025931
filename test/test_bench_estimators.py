"""Estimator benchmark on a tiny configuration: table structure and sensible, finite values (no timing)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from benchmarks.estimators import BenchConfig, Row, main, run_benchmark
from pendulum_accel.estimators import LIVE_ESTIMATORS


@pytest.fixture(scope="module")
def tiny() -> tuple[list[Row], dict]:
    """10 s scenes at 100 Hz, one seed, two methods."""
    cfg = BenchConfig(duration=10.0, rate_hz=100.0, seeds=1, methods=("instant", "kalman"), variants=())
    return run_benchmark(cfg)


def test_rows_cover_every_scene_and_method(tiny: tuple[list[Row], dict]) -> None:
    rows, traces = tiny
    assert [(r.scene, r.method) for r in rows] == [
        (s, m) for s in ("step", "ramp", "stop_and_go") for m in ("instant", "kalman")
    ]
    assert set(traces) == {"step", "ramp", "stop_and_go"}
    assert set(traces["step"]) == {"t", "truth", "instant", "kalman"}


def test_values_are_finite_and_consistent(tiny: tuple[list[Row], dict]) -> None:
    rows, _ = tiny
    for r in rows:
        for name in Row.COLUMNS[2:]:
            v = getattr(r, name)
            assert v is None or math.isfinite(v), (r.scene, r.method, name)
        assert abs(r.bias) <= r.rms <= r.max_err
        # n_eff < 1 is possible: a fast Kalman filter reads θ'' too, whose noise exceeds one sample's.
        assert r.crb > 0.0 and r.n_eff > 0.0 and 0.0 <= r.lag_s <= 3.0
    by = {(r.scene, r.method): r for r in rows}
    step_k, step_i = by[("step", "kalman")], by[("step", "instant")]
    # The swing after the step never leaves g tan θ, while the EKF separates it from the tilt.
    assert step_i.settle_s is None and step_i.ss_rms is not None and step_i.ss_rms > 0.5
    # The IMM settles within the run and its steady error is a small fraction of the swing g tan θ keeps
    # (the quiet mode's noise plus the few % of probability the manoeuvre mode keeps: ≈ 0.01 m/s² at
    # σ = 1 mrad, 100 Hz, against g tan θ's swing ≈ 1 m/s²): 1/10 leaves a wide margin on both.
    assert step_k.settle_s is not None and step_k.settle_s < 8.0
    assert step_k.ss_rms is not None and step_k.ss_rms < 0.1 * step_i.ss_rms
    assert step_k.t50_s is not None and 0.0 < step_k.t50_s < 1.0
    assert by[("stop_and_go", "kalman")].ss_rms is None  # 10 s is too short for its steady window


def test_command_line_prints_the_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    docs = tmp_path / "docs"
    argv = ["--out", str(tmp_path), "--duration", "4", "--rate", "50", "--seeds", "1", "--docs", str(docs)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "default method: kalman" in out and "| step | period_mean |" in out
    assert "| ramp | kalman_fixed_q |" in out and "| ramp | kalman_car |" in out
    rows = len(LIVE_ESTIMATORS) + len(BenchConfig().variants)  # the live methods and the variants
    with (tmp_path / "estimators.csv").open() as fh:
        table = list(csv.reader(fh))
    assert table[0] == list(Row.COLUMNS) and len(table) == 1 + 3 * rows
    md = (tmp_path / "estimators.md").read_text().splitlines()
    assert md[0].startswith("| scene | method | bias |") and len(md) == 2 + 3 * rows
    assert (tmp_path / "estimators.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The docs page: written by the script itself, with the command, the machine, the table and the plot.
    page = (docs / "benchmarks" / "estimators.md").read_text(encoding="utf-8")
    assert "`python -m benchmarks.estimators --out" in page and "Machine: " in page and " cores" in page
    assert "| step | period_mean |" in page and "](../img/bench_estimators.png)" in page
    assert (docs / "img" / "bench_estimators.png").read_bytes() == (tmp_path / "estimators.png").read_bytes()
