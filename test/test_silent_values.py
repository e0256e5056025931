"""Values the command line once took silently, each now refused in one line or taken as meant: a seed that
is not whole, a real-time priority for a run that is not real time, a step longer than the sample interval,
a skip past the end of the recording, and the negative accelerations of a braking sweep."""

from __future__ import annotations

from pathlib import Path

from test.conftest import cli
from test.refusal import one_line_error
from test.test_bag_io import _write_chain_bag


def test_silently_accepted_values_are_refused_or_taken_as_meant(tmp_path: Path) -> None:
    one_line_error(cli("simulate", "lecture_constant", "--set", "seed=1.5"), "integer")
    one_line_error(cli("run", "--fast", "--rt-priority", "5"), "real-time runs only")
    one_line_error(cli("simulate", "--dt", "5"), "sample interval", "at most")
    _write_chain_bag(tmp_path / "bag", n=500)
    one_line_error(cli("analyze", str(tmp_path / "bag"), "--skip", "1e9"), "no samples")
    braking = cli("sweep", "at_rest", "--accel", "-2,0,2", "--duration", "2", "--no-progress")
    assert braking.returncode == 0, braking.stderr
    rows = braking.stdout.strip().splitlines()[1:]
    assert [float(r.split(",")[2]) for r in rows] == [-2.0, 0.0, 2.0]
