"""benchmarks.bags at two rates on the smallest bags that hold every row: each rate gets its rows, every
estimator its analyze row with the pass and the read in µs per angle, and the page its table per rate and
plot. The figures are parsed (never compared as text) and no timing is asserted."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from benchmarks import bags
from pendulum_accel.estimators import ESTIMATORS

RATES = (20.0, 50.0)
DURATION_S = 2.0
"""Two seconds at 20 and 50 Hz: 41 and 101 angles, enough for every estimator to run on the bag."""


def test_bags_benchmark_gives_every_estimator_at_each_rate(tmp_path: Path) -> None:
    out, docs = tmp_path / "out", tmp_path / "docs"
    argv = ["--rates", *(f"{r:g}" for r in RATES), "--duration", f"{DURATION_S:g}", "--repeat", "1"]
    assert bags.main([*argv, "--out", str(out), "--docs", str(docs)]) == 0
    with (out / "bags.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {float(r["rate_hz"]) for r in rows} == set(RATES)
    for rate in RATES:
        mine = [r for r in rows if float(r["rate_hz"]) == rate]
        analyze = {r["task"].split()[2]: r for r in mine if r["task"].startswith("analyze --estimator")}
        assert set(analyze) == set(ESTIMATORS)
        # The read beside each pass is analyze --estimator instant's time over the bag's angles.
        instant = float(analyze["instant"]["seconds"])
        angles = int(DURATION_S * rate) + 1
        reads = {float(r["read_us_per_angle"]) for r in analyze.values()}
        assert len(reads) == 1
        # The cell is printed to 3 decimals (off by ≤ 5e-4 µs) and the seconds to 6 (off by ≤ 0.5e-6 s, so
        # ≤ 0.5e-6 / angles s an angle): their difference is bounded by the sum.
        assert math.isclose(
            reads.pop(), instant / angles * 1e6, rel_tol=1e-5, abs_tol=5e-4 + 0.5e-6 / angles * 1e6
        )
        for r in analyze.values():
            assert float(r["pass_us_per_angle"]) > 0.0 and float(r["x_plain_rosbags"]) > 0.0
        loop = next(r for r in mine if r["task"] == "plain rosbags read + deserialize loop")
        assert float(loop["x_plain_rosbags"]) == 1.0
    page = (docs / "benchmarks" / "bags.md").read_text()
    assert all(f"At {r:g} Hz:" in page for r in RATES)
    assert (docs / "img" / "bench_bags.png").stat().st_size > 0
