"""``pendulum-accel export``: a golden bag round-trips through CSV and Parquet to the values the reader
decodes, under PlotJuggler's column names; the merged table sits on the angle's stamps."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.export import (
    BULK_TYPES,
    VISUAL_ROLES,
    ExportError,
    column_name,
    export_bag,
    file_stem,
)
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import main
from test.conftest import REPO

GOLDEN = REPO / "bags" / "step_start"
JOINT_NAMES = {"position[0]": "pendulum_joint/position", "velocity[0]": "pendulum_joint/velocity"}
"""PlotJuggler's JointState series: <joint name>/<field>, not <field>[i]."""


def _read(path: Path) -> pd.DataFrame:
    """A table written by export, read back with pandas."""
    return pd.read_csv(path) if path.suffix == ".csv" else pd.read_parquet(path)


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_every_topic_round_trips_to_the_reader_values(tmp_path: Path, fmt: str) -> None:
    bag = read_bag(GOLDEN)
    paths = export_bag(bag, tmp_path, fmt=fmt)
    # Every topic but what RViz and Foxglove draw (markers, the URDF), which export leaves out by default.
    tables = {t: info for t, info in bag.topics.items() if bm.role_of(t) not in VISUAL_ROLES}
    assert sorted(p.name for p in paths) == sorted(f"{file_stem(t)}.{fmt}" for t in tables)
    assert bm.TOPIC_IMU in tables
    for topic, info in tables.items():
        table = _read(tmp_path / f"{file_stem(topic)}.{fmt}")
        assert len(table) == info.count
        if info.msgtype in BULK_TYPES:
            arrays = bag.decode(topic)
            np.testing.assert_array_equal(table["t"], arrays.stamp)
            np.testing.assert_array_equal(table["log_time"], arrays.log_time_ns * 1e-9)
            for path, column in arrays.fields.items():
                name = column_name(
                    topic, JOINT_NAMES.get(path, path) if topic == bm.TOPIC_JOINT_STATES else path
                )
                np.testing.assert_array_equal(table[name], column)
        else:  # /diagnostics, named as PlotJuggler names it: <hardware_id>/<name>/<key>
            _, payloads = bag.raw(topic)
            messages: list[Any] = [bm.deserialize(p, info.msgtype) for p in payloads]
            prefix = f"{topic}/pendulum_accel/accel_estimator"
            assert table[f"{prefix}/message"].tolist() == [m.status[0].message for m in messages]
            assert table[f"{prefix}/level"].tolist() == [int(m.status[0].level) for m in messages]
            pairs = [{kv.key: kv.value for kv in m.status[0].values} for m in messages]
            for key in ("method", "state", "accepted", "resets"):
                expected = [p[key] if key in ("method", "state") else float(p[key]) for p in pairs]
                assert table[f"{prefix}/{key}"].tolist() == expected
    estimate = _read(tmp_path / f"car__accel__estimate.{fmt}")
    assert "/car/accel/estimate/accel/accel/linear/x" in estimate.columns  # PlotJuggler's name


def test_merged_table_sits_on_the_angle_stamps(tmp_path: Path) -> None:
    bag = read_bag(GOLDEN)
    (path,) = export_bag(bag, tmp_path, fmt="parquet", merged=True)
    table = _read(path)
    angles = bag.decode(bm.TOPIC_JOINT_STATES)
    np.testing.assert_array_equal(table["t"], angles.stamp)
    estimate = bag.decode(bm.TOPIC_ACCEL_ESTIMATE)
    at = np.searchsorted(angles.stamp, estimate.stamp)
    x = table["/car/accel/estimate/accel/accel/linear/x"].to_numpy()
    np.testing.assert_array_equal(x[at], estimate["accel.accel.linear.x"])
    np.testing.assert_array_equal(
        table["/car/accel/truth/accel/linear/x"], bag.decode("/car/accel/truth")["accel.linear.x"]
    )
    # /diagnostics (1 Hz): the latest report at or before each angle.
    message = table["/diagnostics/pendulum_accel/accel_estimator/message"]
    assert message.notna().all() and message.iloc[150] == message.iloc[100] != message.iloc[99]


def test_missing_extra_and_bad_input_are_one_line_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(GOLDEN), "--out", str(tmp_path), "--topics", "/nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pendulum-accel export: error: bag") and "/nope" in err and "\n" not in err
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ExportError, match=r"pip install 'pendulum_accel\[export\]'"):
        export_bag(read_bag(GOLDEN), tmp_path)
    assert main(["export", str(GOLDEN), "--out", str(tmp_path)]) == 2
    assert "needs pandas" in capsys.readouterr().err
