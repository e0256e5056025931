"""Every sample accounted for: the launcher's losses and ``info``'s check of a bag's estimate stream."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from pendulum_accel.cli.main import main
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting
from pendulum_accel.nodes.names import publisher_topic_map
from pendulum_accel.recording.generate import chain_streams, write_chain_bag

N = 200


def _bag(path: Path, estimated: np.ndarray, accounting: Mapping[str, object] | None) -> Path:
    """A chain bag of N angles at 100 Hz with estimates only where ``estimated``."""
    t = np.arange(N) / 100.0
    theta = np.full(N, 0.1)
    a = np.where(estimated, 1.0, np.nan)
    streams = chain_streams(
        t, theta, np.zeros(N), np.ones(N), a, np.full(N, 0.01), estimator="kalman", rate_hz=100.0
    )
    custom = {} if accounting is None else {CUSTOM_ACCOUNTING: json.dumps(accounting)}
    write_chain_bag(path, streams, custom_data=custom)
    return path


def _estimator(inputs: int, estimates: int, warmup: int, nonfinite: int = 0) -> dict[str, int]:
    """The estimator's counters."""
    return {
        "inputs": inputs,
        "estimates": estimates,
        "warmup": warmup,
        "dropped_nonfinite": nonfinite,
        "dropped_out_of_order": 0,
        "unpublished": 0,
    }


def test_info_reports_a_hole_without_accounting(tmp_path: Path, capsys: object) -> None:
    estimated = np.ones(N, dtype=bool)
    estimated[50:60] = False
    assert main(["info", str(_bag(tmp_path / "b", estimated, None))]) == 1
    out = capsys.readouterr()  # type: ignore[attr-defined]
    assert "[INCOMPLETE: 10 angles without an estimate]" in out.out
    assert "[complete]" not in out.out


def test_info_tells_a_late_start_from_warm_up_with_the_accounting(tmp_path: Path, capsys: object) -> None:
    estimated = np.ones(N, dtype=bool)
    estimated[:30] = False  # the first 30 angles have no estimate
    # The estimator warmed up on 5 of them; it never received the other 25 (it subscribed late).
    late = {"estimator": _estimator(N - 25, N - 30, 5)}
    assert main(["info", str(_bag(tmp_path / "late", estimated, late))]) == 1
    assert "[INCOMPLETE: 25 angles without an estimate]" in capsys.readouterr().out  # type: ignore[attr-defined]
    # The same bag where the estimator received all and says 30 were warm-up: complete.
    warm = {"estimator": _estimator(N, N - 30, 30)}
    assert main(["info", str(_bag(tmp_path / "warm", estimated, warm))]) == 0
    assert "[complete]" in capsys.readouterr().out  # type: ignore[attr-defined]


def test_losses_name_each_missing_sample() -> None:
    published = {"/pendulum/joint_states": 100, "/car/accel/truth": 100, "/clock": 100}
    recorded = {**published, "/car/accel/estimate": 97, "/imu/data_raw": 97}
    whole = Accounting({"published": published}, _estimator(100, 97, 2, 1), {"written": recorded})
    assert whole.losses(recording=True) == []
    assert "estimator warm-up 2, dropped non-finite 1" in "\n".join(whole.table())
    late = Accounting({"published": published}, _estimator(80, 78, 2), {"written": recorded})
    assert "the estimator missed 20 of 100 angles" in late.losses(recording=True)
    lost = Accounting(
        {"published": published}, _estimator(100, 97, 3), {"written": {**recorded, "/car/accel/truth": 90}}
    )
    assert lost.losses(recording=True) == ["/car/accel/truth: 10 of 100 not recorded"]
    assert lost.losses(recording=False) == []


def test_info_says_complete_only_where_the_publishers_counts_agree(tmp_path: Path, capsys: object) -> None:
    """A recorder-only accounting (nodes started on their own) cannot vouch for what never reached the
    recorder: no '[complete]'; publishers' counts above the recorded ones: INCOMPLETE, exit 1."""
    every = np.ones(N, dtype=bool)
    written = {"written": {"/pendulum/joint_states": N, "/car/accel/estimate": N}}
    assert main(["info", str(_bag(tmp_path / "alone", every, {"recorder": written}))]) == 0
    out = capsys.readouterr().out  # type: ignore[attr-defined]
    assert "[recorded intact; the publishers left no counts to check it against]" in out
    assert "[complete]" not in out
    # The estimator says it published N + 11 estimates; the recorder wrote N.
    short = {"estimator": _estimator(N, N + 11, 0), "recorder": written}
    assert main(["info", str(_bag(tmp_path / "short", every, short))]) == 1
    captured = capsys.readouterr()  # type: ignore[attr-defined]
    assert "[INCOMPLETE: /car/accel/estimate: 11 of 211 published not recorded]" in captured.out
    assert "11 of 211 published not recorded" in captured.err


def test_the_table_keeps_its_columns_under_long_namespaced_names() -> None:
    """Each count ends where its column's header ends, and each name stays in the topic column, for names
    longer than the column's 24 characters (a deep namespace): parsed by position, not compared as text."""
    ns = "/fleet/depot_north/car_0001"
    published = {f"{ns}/pendulum/joint_states": 100, f"{ns}/car/accel/truth": 100, f"{ns}/clock": 100}
    recorded = {**published, f"{ns}/car/accel/estimate": 97, f"{ns}/imu/data_raw": 97}
    accounting = Accounting({"published": published}, _estimator(100, 97, 3), {"written": recorded})
    header, *rows = accounting.table()
    columns = ("published", "est. in", "estimated", "recorded")
    ends = [header.index(word) + len(word) for word in columns]
    first_count = header.index("published") + len("published") - 9  # the 9-wide column's left edge
    assert rows and all(len(name) > 24 for name in (*published, *recorded))
    for row in rows:
        name = row.split()[0]
        assert name.startswith(ns) and row.index(name) + len(name) < first_count, row
        # The four count fields, right-aligned: each ends at its header's end.
        fields = row.split()[1:5]
        at = len(row.split()[0]) + row.index(name)
        for field, end in zip(fields, ends, strict=True):
            start = row.index(field, at)
            assert start + len(field) == end, (row, field, end)
            at = start + len(field)
        counts = [int(f) for f in fields if f != "-"]  # the figures themselves, parsed
        assert counts and all(c in (97, 100) for c in counts), row


def test_a_namespaced_chain_is_accounted_under_its_own_names() -> None:
    """The table and the losses name the topics as the run resolved them (/car1/...), not the root names."""
    published = {"/car1/pendulum/joint_states": 100, "/car1/car/accel/truth": 100, "/clock": 100}
    recorded = {**published, "/car1/car/accel/truth": 90, "/car1/car/accel/estimate": 97}
    ns = Accounting({"published": published}, _estimator(100, 97, 3), {"written": recorded})
    table = "\n".join(ns.table())
    assert "/car1/pendulum/joint_states" in table and "/car1/car/accel/estimate" in table
    assert " /pendulum/joint_states" not in table
    assert "/car1/car/accel/truth: 10 of 100 not recorded" in ns.losses(recording=True)


def test_a_remapped_chain_is_accounted_through_its_topic_map() -> None:
    """After ``--remap pendulum/joint_states:=angles`` in namespace car1 the launcher's map finds the
    angles under /car1/angles: the table has their row and a loss there is counted (the suffix match
    found no angle row, and no loss). A name no role of the map covers is still compared under its own
    name, so no loss goes unseen."""
    roles = publisher_topic_map("car1", ["pendulum/joint_states:=angles"])
    assert roles["pendulum/joint_states"] == "/car1/angles"
    assert roles["car/accel/estimate"] == "/car1/car/accel/estimate"
    published = {"/car1/angles": 100, "/car1/car/accel/truth": 100, "/car1/extra": 50}
    recorded = {**published, "/car1/angles": 90, "/car1/extra": 40, "/car1/car/accel/estimate": 97}
    remapped = Accounting(
        {"published": published}, _estimator(100, 97, 3), {"written": recorded}, roles=roles
    )
    rows = {line.split()[0]: line.split()[1:5] for line in remapped.table()[1:]}
    assert rows["/car1/angles"] == ["100", "100", "97", "90"]
    losses = remapped.losses(recording=True)
    assert "/car1/angles: 10 of 100 not recorded" in losses
    assert "/car1/extra: 10 of 50 not recorded" in losses
