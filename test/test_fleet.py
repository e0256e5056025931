"""``analyze`` over many bags: the table, its error rows, and the same table from every engine.

The engines are the serial path (one process), an embedded Dask LocalCluster with 2 worker processes,
and a real cluster started as separate processes (``dask scheduler`` in one network namespace and two
``dask worker`` in another, joined by veth, as the multi-host chain test builds them). Every process a
test starts is stopped at its end.
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.errors import BagError
from pendulum_accel.recording import coverage
from pendulum_accel.recording.fleet import (
    COLUMN_NAMES,
    FleetRow,
    Job,
    analyze_many,
    bag_rows,
    find_bags,
    write_csv,
)
from test.conftest import REPO, Spawn, cli, strict_json
from test.fleet_rows import (
    SHARE_CELLS,
    _no_leftover_workers,  # noqa: F401 (the autouse fixture)
    cells,
)
from test.split_recording import split_recording
from test.test_network import TwoHosts, two_hosts  # noqa: F401 (the fixture)

SCENES = ("step_start", "braking")
AT_REST = REPO / "bags" / "at_rest"
DURATION = "3"  # s: enough for every figure (delay, calibration) and quick to re-run


@pytest.fixture(scope="module")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tree: two generated bags in subdirectories, a damaged copy (cut in half), a foreign .mcap and
    an empty bag directory."""
    root = tmp_path_factory.mktemp("fleet")
    (root / "site_a").mkdir()
    (root / "site_b").mkdir()
    for scene, site in zip(SCENES, ("site_a", "site_b"), strict=True):
        done = cli("generate", scene, "--duration", DURATION, "--out", str(root / site / scene))
        assert done.returncode == 0, done.stderr
    damaged = root / "site_b" / "damaged"
    shutil.copytree(root / "site_a" / "step_start", damaged)
    mcap = next(damaged.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    (root / "site_b" / "foreign.mcap").write_bytes(b"not a bag at all\n")
    (root / "empty").mkdir()
    return root


def test_the_row_type_has_every_column() -> None:
    """FleetRow (the TypedDict) and COLUMNS (the table's schema, docs/fleet.md) name the same columns."""
    assert set(FleetRow.__annotations__) == set(COLUMN_NAMES)
    assert FleetRow.__required_keys__ | FleetRow.__optional_keys__ == set(COLUMN_NAMES)


def _by_key(rows: list[dict[str, object]]) -> dict[tuple[str, str], dict[str, object]]:
    """Rows keyed by (bag, estimator)."""
    return {(str(r["bag"]), str(r["estimator"])): r for r in rows}


def test_find_bags_walks_trees_and_globs_and_refuses_a_typo(corpus: Path) -> None:
    """A tree gives every bag below it (bag directories are not entered, loose .mcap files count), a
    glob the same, each once; a path that names nothing is one BagError."""
    found = {p.relative_to(corpus).as_posix() for p in find_bags([str(corpus)])}
    assert found == {"site_a/step_start", "site_b/braking", "site_b/damaged", "site_b/foreign.mcap"}
    globbed = find_bags([str(corpus / "site_*" / "*"), str(corpus / "site_a" / "step_start")])
    assert len(globbed) == len(set(globbed)) == 4
    with pytest.raises(BagError, match="does not exist"):
        find_bags([str(corpus / "no_such_bag")])
    with pytest.raises(BagError, match="matches no"):
        find_bags([str(corpus / "nothing_*")])


def test_serial_table_has_a_row_per_bag_and_estimator_and_error_rows(corpus: Path) -> None:
    """Good bags give a row per estimator with finite figures; the damaged and the foreign bag give one
    row each with an error and no figures; every row has every column."""
    found = analyze_many(find_bags([str(corpus)]), Job(estimators=("kalman", "instant")), distributed=False)
    rows = [cells(r) for r in found]
    assert all(tuple(r) == COLUMN_NAMES for r in rows)
    good = [r for r in rows if not r["error"]]
    bad = [r for r in rows if r["error"]]
    assert {(Path(str(r["bag"])).name, r["estimator"]) for r in good} == {
        (s, e) for s in SCENES for e in ("kalman", "instant")
    }
    assert {Path(str(r["bag"])).name for r in bad} == {"damaged", "foreign.mcap"}
    for r in bad:
        assert r["rms"] is None and r["complete"] is False
        assert "\n" not in str(r["error"])
    for r in good:
        assert r["complete"] is True
        for key in ("rms", "bias", "max_error", "delay", "duration"):
            assert isinstance(r[key], float) and math.isfinite(r[key]), (key, r)
        assert r["duration"] == pytest.approx(float(DURATION), abs=0.02)  # one 100 Hz sample either way
    kalman = {Path(str(r["bag"])).name: r for r in good if r["estimator"] == "kalman"}
    assert all(r["motion_model"] for r in kalman.values()), "the table names kalman's motion model"
    for r in good:
        for window in ("steady", "after_change"):
            share, trials = r[f"share_2sigma_{window}"], r[f"trials_{window}"]
            low, high = r[f"share_2sigma_{window}_low"], r[f"share_2sigma_{window}_high"]
            assert isinstance(share, float) and isinstance(trials, float), (window, r)
            assert trials >= 1.0 and low <= share <= high, (window, r)
            assert (low, high) == coverage.wilson(share, trials)  # the same function at the same arguments
    for r in bad:
        assert all(r[k] is None for k in SHARE_CELLS), r


def test_share_cells_are_the_single_bag_reports_and_null_without_samples(
    corpus: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each share's trials and interval, and the share beyond 3σ, in a row are those ``analyze BAG --json``
    reports for the bag (one computation, two outputs: exact); a bag at rest has no after-change window,
    and its cells are null in the rows and empty fields in the CSV, never NaN."""
    bag = corpus / "site_b" / "braking"
    (row,) = map(cells, bag_rows(str(bag), Job(estimators=("kalman",))))
    assert main(["analyze", str(bag), "-e", "kalman", "--json"]) == 0
    single = strict_json(capsys.readouterr().out)
    for window in ("steady", "after_change"):
        assert row[f"share_2sigma_{window}"] == single[f"nees_{window}_share_2sigma"]
        assert row[f"trials_{window}"] == single[f"nees_{window}_trials"]
        assert row[f"share_2sigma_{window}_low"] == single[f"nees_{window}_share_2sigma_low"]
        assert row[f"share_2sigma_{window}_high"] == single[f"nees_{window}_share_2sigma_high"]
        assert row[f"share_3sigma_{window}"] == single[f"nees_{window}_share_3sigma"]
    (rest,) = map(cells, bag_rows(str(AT_REST), Job()))
    assert not rest["error"] and isinstance(rest["trials_steady"], float)
    assert all(rest[k] is None for k in SHARE_CELLS if "after_change" in k)
    text = io.StringIO()
    write_csv([rest], text)
    fields = dict(zip(*csv.reader(io.StringIO(text.getvalue())), strict=True))
    assert all(fields[k] == "" for k in SHARE_CELLS if "after_change" in k)
    assert all(math.isfinite(float(fields[k])) for k in SHARE_CELLS if "steady" in k)


def test_a_bag_without_truth_is_a_row_of_its_own_figures(corpus: Path, tmp_path: Path) -> None:
    """A recording without its truth topic (as a real sensor's, with its scene kept) is a row, not an
    error: truth false, the error, delay and calibration cells null, and the estimate's mean and median σ
    those of the same angles beside their truth (the same floats through the same code: equal)."""
    whole = corpus / "site_a" / "step_start"
    bare = tmp_path / "no_truth"
    split_recording(whole, bare, 1, drop=("/car/accel/truth",))
    (with_truth,) = map(cells, bag_rows(str(whole), Job()))
    (row,) = map(cells, bag_rows(str(bare), Job()))
    assert row["error"] == "" and row["truth"] is False and with_truth["truth"] is True
    for key in ("rms", "bias", "max_error", "delay", "nees_mean", *SHARE_CELLS):
        assert row[key] is None, key
    for key in ("estimate_mean", "sigma_median", "angles", "duration", "estimator", "motion_model"):
        assert row[key] == with_truth[key], key
    assert isinstance(row["estimate_mean"], float) and row["sigma_median"] > 0.0


@pytest.mark.slow
def test_one_sensors_recordings_without_a_scene_take_its_length(tmp_path: Path) -> None:
    """Two recordings of one real sensor (no truth, no scene): without --length each row says what to
    give; with it, every bag is re-run with that length, and its row is the single-bag report's."""
    from test.sensor_bag import LENGTH, write_step_bag

    for name in ("a", "b"):
        write_step_bag(tmp_path / "sensor" / name, truth=False)
    out = tmp_path / "t.csv"
    bare = cli("analyze", str(tmp_path / "sensor"), "--out", str(out))
    assert bare.returncode == 1
    with out.open() as table:
        rows = list(csv.DictReader(table))
    assert len(rows) == 2 and all("give the pendulum length (--length)" in r["error"] for r in rows)
    told = cli("analyze", str(tmp_path / "sensor"), "--out", str(out), "--length", str(LENGTH))
    assert told.returncode == 0, told.stderr
    with out.open() as table:
        rows = list(csv.DictReader(table))
    single = strict_json(
        cli("analyze", str(tmp_path / "sensor" / "a"), "--length", str(LENGTH), "--json").stdout
    )
    assert [r["error"] for r in rows] == ["", ""] and {r["truth"] for r in rows} == {"False"}
    # The CSV writes each float's shortest repr: the same float as the single report's.
    assert [float(r["estimate_mean"]) for r in rows] == [single["offline"]["estimate_mean"]] * 2


def test_local_cluster_gives_the_serial_table(corpus: Path) -> None:
    """Two worker processes of a LocalCluster give exactly the serial rows. Exact: each task runs the
    same compiled code on the same inputs on the same machine, only in another process, so no rounding
    can differ (a difference would mean the tasks were given different work)."""
    paths = find_bags([str(corpus)])
    job = Job(estimators=("kalman", "smoother"))
    serial = analyze_many(paths, job, distributed=False)
    local = analyze_many(paths, job, workers=2, distributed=True)
    assert local == serial


@pytest.mark.slow
def test_cli_writes_parquet_and_csv_and_refuses_single_bag_options(corpus: Path, tmp_path: Path) -> None:
    """--out TABLE.parquet / .csv hold the same rows; exit 1 says some bags gave error rows; --plot is
    refused for a fleet in one line, before any work."""
    parquet, csv_out = tmp_path / "r.parquet", tmp_path / "r.csv"
    done = cli("analyze", str(corpus), "--out", str(parquet), "--workers", "2", timeout=300)
    assert done.returncode == 1, done.stderr
    assert "2 bag(s) gave an error row" in done.stderr
    table = pq.read_table(parquet).to_pylist()
    assert [tuple(r) for r in table] == [COLUMN_NAMES] * len(table) and len(table) == 4
    done = cli("analyze", str(corpus / "site_a"), str(corpus / "site_b" / "braking"), "--out", str(csv_out))
    assert done.returncode == 0, done.stderr
    lines = csv_out.read_text().splitlines()
    assert lines[0].split(",") == list(COLUMN_NAMES) and len(lines) == 3
    refused = cli("analyze", str(corpus), "--plot", str(tmp_path / "p.png"))
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1
    assert "--plot" in refused.stderr and not (tmp_path / "p.png").exists()


def test_bag_rows_never_raises_for_a_bad_bag(tmp_path: Path) -> None:
    """A directory that is no bag, a file that is no MCAP, an unknown estimator: rows with errors."""
    (tmp_path / "x.mcap").write_bytes(b"")
    assert bag_rows(str(tmp_path / "x.mcap"), Job())[0]["error"]
    assert bag_rows(str(tmp_path / "missing"), Job())[0]["error"]


@pytest.fixture
def dask_bin() -> Path:
    """The ``dask`` command beside this Python (the fleet extra installs it)."""
    path = Path(sys.executable).with_name("dask")
    assert path.exists(), "the dask command is missing: pip install '.[fleet]' (make setup does)"
    return path


def test_scheduler_and_workers_on_two_hosts_give_the_serial_table(
    corpus: Path,
    tmp_path: Path,
    spawn: Spawn,
    two_hosts: TwoHosts,  # noqa: F811 (the fixture imported above)
    dask_bin: Path,
) -> None:
    """``dask scheduler`` in namespace a, two ``dask worker`` processes in namespace b, reaching it over
    the veth link; ``analyze --scheduler tcp://A:PORT`` from namespace a gives exactly the serial
    table (exact, as with the LocalCluster), and every process started here is stopped."""
    host_a = two_hosts.addr["a"]
    port = 8786
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    logs = [open(tmp_path / f"{n}.log", "w") for n in ("scheduler", "w1", "w2")]  # noqa: SIM115
    try:
        scheduler = [str(dask_bin), "scheduler", "--host", host_a, "--port", str(port), "--no-dashboard"]
        spawn(two_hosts.command("a", scheduler), env=env, stdout=logs[0], stderr=logs[0])
        address = f"tcp://{host_a}:{port}"
        for log in logs[1:]:
            worker = [str(dask_bin), "worker", address, "--nthreads", "1", "--no-dashboard", "--no-nanny"]
            spawn(two_hosts.command("b", worker), env=env, stdout=log, stderr=log)
        ready = _wait_for_workers(two_hosts, address, env, 2, timeout=90.0)
        assert ready, (tmp_path / "scheduler.log").read_text()[-2000:]
        out = tmp_path / "remote.csv"
        done = subprocess.run(
            two_hosts.command("a", [sys.executable, "-m", "pendulum_accel.cli.main", "analyze", str(corpus),
                                    "-e", "kalman", "--scheduler", address, "--out", str(out)]),
            cwd=REPO, env=env, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert done.returncode == 1, done.stderr  # the damaged and foreign bags' rows
        serial = io.StringIO()
        write_csv(
            analyze_many(find_bags([str(corpus)]), Job(estimators=("kalman",)), distributed=False), serial
        )
        assert out.read_text() == serial.getvalue()
    finally:
        for log in logs:
            log.close()


def _wait_for_workers(hosts: TwoHosts, address: str, env: dict[str, str], n: int, timeout: float) -> bool:
    """True once the scheduler at ``address`` (reached from namespace a) reports ``n`` workers."""
    probe = (
        "import sys; from distributed import Client; c = Client(sys.argv[1], timeout=5); "
        "c.wait_for_workers(int(sys.argv[2]), timeout=5); "
        "print(len(c.scheduler_info()['workers'])); c.close()"
    )
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        done = subprocess.run(
            hosts.command("a", [sys.executable, "-c", probe, address, str(n)]),
            env=env, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        if done.returncode == 0 and done.stdout.strip() == str(n):
            return True
        time.sleep(1.0)
    return False


def test_progress_bar_on_a_terminal_and_not_in_a_pipe(corpus: Path, tmp_path: Path) -> None:
    """With standard error on a terminal (a pseudo-terminal here) the run draws tqdm's bar, counting
    bags; into a pipe (the other tests) it prints only its closing line."""
    import fcntl
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    # A fresh pseudo-terminal is 0 columns wide, and tqdm draws nothing in 0 columns; a user's is not.
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "pendulum_accel.cli.main", "analyze", str(corpus / "site_a"),
             str(corpus / "site_b" / "braking"), "--out", str(tmp_path / "t.csv"), "--workers", "1"],
            cwd=REPO, stdout=subprocess.DEVNULL, stderr=slave, start_new_session=True,
        )  # fmt: skip
        os.close(slave)
        chunks = []
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:  # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        proc.wait(timeout=300)
    finally:
        os.close(master)
    text = b"".join(chunks).decode("utf-8", "replace")
    assert proc.returncode == 0, text
    assert "/2 [" in text and "bag" in text, text  # tqdm's "n/2 [elapsed<remaining, rate bag/s]"
    assert "analyzed 2 bag(s)" in text


@pytest.mark.parametrize(
    ("failure", "says"),
    [
        (ModuleNotFoundError("No module named 'distributed'", name="distributed"), "which is not installed"),
        (ImportError("cannot import name 'Client' from partially initialized module"), "failed to import"),
    ],
)
def test_a_dask_that_will_not_import_is_named_for_what_it_is(
    monkeypatch: pytest.MonkeyPatch, failure: ImportError, says: str
) -> None:
    """dask_client's one line: 'not installed' (and the pip command) only when the package is missing; an
    installed distributed that fails to import gives its own reason, so nobody reinstalls what is there."""
    import builtins

    from pendulum_accel.cluster import dask_client
    from pendulum_accel.errors import PendulumAccelError

    real_import = builtins.__import__

    def refuse(name: str, *args: object, **kwargs: object) -> object:
        if name.split(".")[0] == "distributed":
            raise failure
        return real_import(name, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(builtins, "__import__", refuse)
    with pytest.raises(PendulumAccelError) as caught, dask_client(None, 1):
        pass
    line = str(caught.value)
    assert says in line and "\n" not in line
    assert ("pip install" in line) == (says == "which is not installed")
    if says == "failed to import":
        assert "partially initialized" in line
