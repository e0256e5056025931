"""A recording in progress, as users meet it: ``pendulum-accel run … --record DIR`` while they reach for DIR.

One chain is recorded live (step_start, RUN_S s, its angles remapped to ``angles`` as an integrator's
bringup may name them). While its recorder writes, every command that reads or writes a bag runs on DIR
(in this process, through the CLI's ``main``): ``info`` says the bag is being recorded and by whom, not
that it is damaged; ``repair``, ``analyze``, ``export``, ``allan``, ``animate``, ``generate --overwrite``
and the player refuse it in one line, ``analyze --salvage`` reads what is written and says so; and
nothing in DIR is moved or replaced. The run then exits 0 with a bag holding every message it reports,
its table counting the remapped angles, and a copy of the bag whose accounting says ten more angles were
published than recorded reads INCOMPLETE. A second run has its file moved aside under its recorder, as
``repair`` once did (issue 58): it must not exit 0. The recorder's lock itself is tested without ROS at
the end: it names its holder, dies with its process, and a lock left by a dead writer is told apart.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.lock import LOCK_NAME, BagLock, holder
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.writer import BagWriter
from pendulum_accel.cli.main import main
from pendulum_accel.errors import BagError, ParameterError
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING
from test.chain_helpers import Output
from test.conftest import PYTHON, REPO, rclpy_available, stop_processes
from test.refusal import error_line

RUN_S = 12.0
"""s of step_start recorded live: the commands below take about 3 s on a idle machine, 6 s loaded; the
fixture checks that the recorder was still writing when the last of them ended."""
REMAP = "pendulum/joint_states:=angles"
ANGLES = "/angles"


@dataclass
class Outcome:
    """What a command did: exit code, stdout, stderr."""

    code: int
    out: str
    err: str


@dataclass
class Live:
    """What the commands did on the live bag, and the run once it ended."""

    bag: Path
    tmp: Path
    during: dict[str, Outcome] = field(default_factory=dict)
    files_before: list[str] = field(default_factory=list)
    files_after: list[str] = field(default_factory=list)
    player: str = ""
    run_code: int = -1
    run_text: str = ""


def _in_process(*argv: str) -> Outcome:
    """``pendulum-accel ARGV`` through main() in this process, its output captured."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return Outcome(code, out.getvalue(), err.getvalue())


def _start_run(bag: Path, seconds: float, *extra: str) -> Output:
    """``pendulum-accel run step_start --set duration=SECONDS --record BAG EXTRA`` in its own session."""
    proc = subprocess.Popen(
        [PYTHON, "-m", "pendulum_accel.cli.main", "run", "step_start", "--set", f"duration={seconds:g}",
         "--record", str(bag), *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(REPO), start_new_session=True,
    )  # fmt: skip
    return Output(proc)


def _wait_for_messages(bag: Path, run: Output, timeout: float = 90.0) -> None:
    """Until the live bag's file holds some angles (the recorder's first flush), its lock held."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert run.proc.poll() is None, run.text
        with contextlib.suppress(BagError, OSError):
            topic = read_bag(bag).topics.get(ANGLES)
            if topic is not None and topic.count > 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"no angle recorded in {bag} within {timeout} s:\n{run.text}")


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Live]:
    """The remapped chain recorded live, every bag command run on its bag while the recorder writes."""
    if not rclpy_available():
        pytest.fail("rclpy does not import: run the tests through `make test`", pytrace=False)
    tmp = tmp_path_factory.mktemp("in_progress")
    seen = Live(tmp / "rb", tmp)
    run = _start_run(seen.bag, RUN_S, "--remap", REMAP)
    try:
        _wait_for_messages(seen.bag, run)
        seen.files_before = sorted(p.name for p in seen.bag.iterdir())
        seen.during["info"] = _in_process("info", str(seen.bag))
        seen.during["repair"] = _in_process("repair", str(seen.bag))
        seen.during["analyze"] = _in_process("analyze", str(seen.bag))
        seen.during["export"] = _in_process("export", str(seen.bag), "--out", str(tmp / "tables"))
        seen.during["allan"] = _in_process("allan", str(seen.bag))
        seen.during["animate"] = _in_process("animate", str(seen.bag), "--out", str(tmp / "a.gif"))
        seen.during["generate"] = _in_process(
            "generate", "lecture_constant", "--out", str(seen.bag), "--overwrite", "--duration", "1"
        )
        from pendulum_accel.nodes.player_node import open_source

        try:
            open_source(str(seen.bag))
        except ParameterError as err:
            seen.player = str(err)
        seen.during["salvage"] = _in_process("analyze", str(seen.bag), "--salvage")
        seen.files_after = sorted(p.name for p in seen.bag.iterdir())
        still = holder(seen.bag)
        assert run.proc.poll() is None and still is not None and still.live, (
            f"the recording ended before the commands did: RUN_S is too short for this machine\n{run.text}"
        )
        seen.run_code = run.finish(timeout=120)
        seen.run_text = run.text
        yield seen
    finally:
        stop_processes([run.proc])


@pytest.mark.ros
@pytest.mark.slow  # the module's live run (about 20 s) is set up for it
def test_info_says_a_live_bag_is_being_recorded_not_damaged(live: Live) -> None:
    """[RECORDING: being written by bag_recorder (pid …)], no DAMAGED, no advice to repair; exit 1 (not
    complete) with one warning line."""
    info = live.during["info"]
    assert info.code == 1, info.err
    head = info.out.splitlines()[0]
    assert re.search(r"\[RECORDING: being written by bag_recorder \(pid \d+ on ", head), head
    assert "DAMAGED" not in info.out + info.err and "repair" not in info.out + info.err
    (line,) = info.err.strip().splitlines()
    assert "is being recorded by bag_recorder" in line and "written so far" in line, line


@pytest.mark.ros
@pytest.mark.parametrize("command", ["repair", "analyze", "export", "allan", "animate", "generate"])
def test_commands_refuse_a_live_bag_in_one_line_and_change_nothing(live: Live, command: str) -> None:
    """Each refuses in one line naming the recorder; the bag's files are the same names (none moved aside
    as .damaged, none replaced), and no output is written."""
    done = live.during[command]
    error_line(done.code, done.err, "is being recorded by bag_recorder")
    assert live.files_after == live.files_before == sorted([LOCK_NAME, "metadata.yaml", "rb.mcap"])
    assert not (live.tmp / "tables").exists() and not (live.tmp / "a.gif").exists()


@pytest.mark.ros
def test_the_player_refuses_a_live_bag_and_analyze_salvage_reads_it(live: Live) -> None:
    """The player: one sentence (a replay would stop short of the end). analyze --salvage: the figures of
    what is written, and a warning that it is being recorded; exit 1."""
    assert "is being recorded by bag_recorder" in live.player, live.player
    assert "once the recording has ended" in live.player, live.player
    salvage = live.during["salvage"]
    assert salvage.code == 1 and "Traceback" not in salvage.err, salvage.err
    assert "estimate vs truth" in salvage.out or "RMS" in salvage.out, salvage.out
    (line,) = salvage.err.strip().splitlines()
    assert "being recorded" in line and "written so far" in line, line


def _written(text: str) -> dict[str, int]:
    """The recorder's 'bag_recorder: TOPIC: received N, written M' lines: {topic: M}."""
    return {m[1]: int(m[2]) for m in re.finditer(r"bag_recorder: (\S+): received \d+, written (\d+)", text)}


@pytest.mark.ros
def test_the_run_ends_with_every_message_it_reports(live: Live) -> None:
    """Exit 0; the bag at DIR holds, topic by topic, every message the recorder reports written, reads
    [complete], and its lock is gone."""
    assert live.run_code == 0, live.run_text
    written = _written(live.run_text)
    assert written.get(ANGLES, 0) > 0, live.run_text
    bag = read_bag(live.bag, salvage=False)
    # A topic the recorder subscribed to and got nothing on (/pendulum/string in this scene) has no channel.
    assert {name: bag.topics[name].count if name in bag.topics else 0 for name in written} == written
    assert not (live.bag / LOCK_NAME).exists()
    info = _in_process("info", str(live.bag))
    assert info.code == 0 and "[complete]" in info.out.splitlines()[0], info.out + info.err


def _row(text: str, topic: str) -> list[int]:
    """The numbers of ``topic``'s row in the run's table (published, est. in, estimated, recorded)."""
    for line in text.splitlines():
        parts = line.split()
        if parts and parts[0] == topic and len(parts) >= 5 and parts[1].isdigit():
            return [int(p) for p in parts[1:5]]
    raise AssertionError(f"no row for {topic} in:\n{text}")


@pytest.mark.ros
def test_a_remapped_run_counts_its_angles(live: Live) -> None:
    """After --remap pendulum/joint_states:=angles the table has the /angles row: published, received by
    the estimator, estimated and recorded, each the bag's count (step_start at 100 Hz: every sample)."""
    published, received, estimated, recorded = _row(live.run_text, ANGLES)
    held = read_bag(live.bag).topics[ANGLES].count
    assert published == received == estimated == recorded == held > 0


@pytest.mark.ros
def test_a_bag_whose_accounting_disagrees_is_incomplete(live: Live, tmp_path: Path) -> None:
    """The live bag copied with its accounting saying 10 more angles were published than recorded: info
    says INCOMPLETE and its warning names the remapped topic's loss, exit 1 (it read [complete])."""
    bag = read_bag(live.bag, salvage=False)
    accounting = json.loads(bag.custom_data[CUSTOM_ACCOUNTING])
    accounting["simulator"]["published"][ANGLES] += 10
    copy = tmp_path / "told"
    told = {**bag.custom_data, CUSTOM_ACCOUNTING: json.dumps(accounting)}
    with BagWriter(copy, custom_data=told) as writer:
        for name, topic in bag.topics.items():
            writer.add_topic(name, topic.msgtype)
        for name, ns, data in bag.iter_raw():
            writer.write(name, ns, data)
    n = bag.topics[ANGLES].count
    info = _in_process("info", str(copy))
    assert info.code == 1, info.out
    # The first loss named may be the estimator's (it received 10 fewer angles than were published): the
    # warning line lists every loss, the recorder's on the remapped name among them.
    assert "[INCOMPLETE: " in info.out.splitlines()[0], info.out
    assert f"{ANGLES}: 10 of {n + 10} published not recorded" in info.err, info.err


@pytest.mark.ros
@pytest.mark.slow
def test_a_run_whose_file_is_moved_under_its_recorder_does_not_exit_0(tmp_path: Path) -> None:
    """The live file moved aside and a cut copy put in its place (what repair did to a live bag): the
    recorder keeps writing into the moved file, the bag at DIR ends short, and run exits 1 with a WARNING
    naming it (it exited 0)."""
    bag = tmp_path / "moved"
    run = _start_run(bag, 4.0)
    try:
        _wait_for_messages_root(bag, run)
        live = bag / "moved.mcap"
        aside = bag / "moved.mcap.damaged"
        os.rename(live, aside)
        shutil.copyfile(aside, live)
        code = run.finish(timeout=120)
    finally:
        stop_processes([run.proc])
    assert code == 1, run.text
    assert "WARNING: the recorded bag" in run.text and "is not complete" in run.text, run.text
    assert read_bag(aside).topics[bm.TOPIC_JOINT_STATES].count == _written(run.text)[bm.TOPIC_JOINT_STATES]


def _wait_for_messages_root(bag: Path, run: Output, timeout: float = 90.0) -> None:
    """Until the live bag holds angles under their own name (the run is not remapped)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert run.proc.poll() is None, run.text
        with contextlib.suppress(BagError, OSError):
            topics = read_bag(bag).topics
            if bm.TOPIC_JOINT_STATES in topics and topics[bm.TOPIC_JOINT_STATES].count > 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"no angle recorded in {bag} within {timeout} s:\n{run.text}")


# --- the lock itself, without ROS ------------------------------------------------------------------------

_HOLD = """
import sys, time
from pathlib import Path
from pendulum_accel.bag.writer import BagWriter
writer = BagWriter(Path(sys.argv[1]), program="holder_test")
print("open", flush=True)
sys.stdin.readline()
writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
writer.write("/clock", 1, bytes([0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]))
writer.flush()
print("flushed", flush=True)
time.sleep(600)
"""


def _start_holder(bag: Path) -> subprocess.Popen[str]:
    """A process running _HOLD on ``bag`` (its lock taken, its file open), once it has said 'open'."""
    proc = subprocess.Popen(
        [PYTHON, "-c", _HOLD, str(bag)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=str(REPO),
    )
    if proc.stdout is None or proc.stdout.readline().strip() != "open":
        proc.kill()
        proc.wait()
        raise AssertionError("the holder did not open its bag")
    return proc


def test_the_lock_names_its_holder_and_dies_with_its_process(tmp_path: Path) -> None:
    """A writer killed with SIGKILL leaves its lock file, but not its lock: while it runs, holder() says
    live and names it, a second writer and a replace are refused; once it is dead, the file is a dead
    writer's (info: DAMAGED, naming it), and repair takes the bag, then removes the file."""
    bag = tmp_path / "b"
    proc = _start_holder(bag)
    try:
        assert proc.stdin is not None and proc.stdout is not None
        # Before its first flush the file is empty: info says it is being recorded, not that it is empty.
        empty = _in_process("info", str(bag))
        error_line(empty.code, empty.err, "being recorded by holder_test", "nothing is written yet")
        proc.stdin.write("go\n")
        proc.stdin.flush()
        assert proc.stdout.readline().strip() == "flushed"
        found = holder(bag)
        assert found is not None and found.live and found.pid == proc.pid and found.program == "holder_test"
        with pytest.raises(BagError, match=r"being written by holder_test \(pid"):
            BagLock(bag)
        with pytest.raises(BagError, match="being recorded by holder_test"):
            BagWriter(bag, overwrite=True)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    dead = holder(bag)
    assert dead is not None and not dead.live and dead.verified and dead.pid == proc.pid
    info = _in_process("info", str(bag))
    assert "DAMAGED" in info.out and f"its writer holder_test (pid {proc.pid}" in info.out, info.out
    assert _in_process("repair", str(bag)).code == 0
    assert not (bag / LOCK_NAME).exists() and holder(bag) is None


def test_a_lock_file_of_another_host_is_unverified(tmp_path: Path) -> None:
    """An unlocked lock file naming another host (a recorder there, on a mount without shared locks) is
    not taken for a dead writer's: holder() marks it unverified, and repair leaves the bag as it is."""
    bag = tmp_path / "b"
    BagWriter(bag).close()
    mcap = bag / "b.mcap"
    mcap.write_bytes(mcap.read_bytes()[:-40])  # cut off, as a live file is
    other = {"pid": 1, "host": "robot7", "program": "bag_recorder", "since": "x"}
    (bag / LOCK_NAME).write_text(json.dumps(other))
    found = holder(bag)
    assert found is not None and not found.live and not found.verified and found.host == "robot7"
    before = {p.name: p.read_bytes() for p in bag.iterdir()}
    repair = _in_process("repair", str(bag))
    error_line(repair.code, repair.err, "bag_recorder (pid 1 on robot7", "cannot be checked from this host")
    assert {p.name: p.read_bytes() for p in bag.iterdir()} == before


def test_closing_a_bag_removes_its_lock(tmp_path: Path) -> None:
    """A closed bag has no lock file; a bag in a directory of its own is the writer's until then."""
    with BagWriter(tmp_path / "c") as writer:
        writer.add_topic(bm.TOPIC_CLOCK, bm.CLOCK)
        mine = holder(tmp_path / "c")
        assert mine is not None and mine.live and mine.ours and mine.pid == os.getpid()
        assert mine.program == Path(sys.argv[0]).name
    assert holder(tmp_path / "c") is None and sorted(p.name for p in (tmp_path / "c").iterdir()) == [
        "c.mcap",
        "metadata.yaml",
    ]


def test_repair_never_moves_a_file_another_process_has_open(tmp_path: Path) -> None:
    """A cut-off bag without our lock whose .mcap another process holds open (``ros2 bag record`` takes
    no lock of ours): repair refuses in one line naming that process, and every file is as it was."""
    bag = tmp_path / "b"
    with BagWriter(bag) as writer:
        writer.add_topic(bm.TOPIC_CLOCK, bm.CLOCK)
    mcap = bag / "b.mcap"
    mcap.write_bytes(mcap.read_bytes()[:-40])  # cut off, as a live file is
    before = {p.name: p.read_bytes() for p in bag.iterdir()}
    with mcap.open("rb") as held:
        other = subprocess.Popen(["sleep", "600"], stdin=held, text=True, start_new_session=True)
    try:
        repair = _in_process("repair", str(bag))
    finally:
        stop_processes([other])
    error_line(repair.code, repair.err, f"open in process {other.pid} (sleep)", "nothing changed")
    assert {p.name: p.read_bytes() for p in bag.iterdir()} == before


def test_a_bag_another_recorder_writes_is_being_recorded(tmp_path: Path) -> None:
    """A cut-off bag without our lock whose .mcap another process holds open for writing (``ros2 bag
    record`` takes no lock of ours; here a sleep with the file as its stdout): info says it is being
    recorded by that process, not damaged; analyze, repair and generate --overwrite (which deleted it)
    refuse it in one line; nothing changes. An empty file so held is 'nothing written yet', not 'empty'."""
    bag = tmp_path / "b"
    with BagWriter(bag) as writer:
        writer.add_topic(bm.TOPIC_CLOCK, bm.CLOCK)
        writer.write(bm.TOPIC_CLOCK, 1, bytes([0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]))
    mcap = bag / "b.mcap"
    mcap.write_bytes(mcap.read_bytes()[:-40])  # cut off, as a live file is
    before = {p.name: p.read_bytes() for p in bag.iterdir()}
    with mcap.open("ab") as held:
        other = subprocess.Popen(["sleep", "600"], stdout=held, text=True, start_new_session=True)
    try:
        info = _in_process("info", str(bag))
        analyze = _in_process("analyze", str(bag))
        repair = _in_process("repair", str(bag))
        generate = _in_process(
            "generate", "lecture_constant", "--out", str(bag), "--overwrite", "--duration", "1"
        )
        mcap.write_bytes(b"")
        empty = _in_process("info", str(bag))
        mcap.write_bytes(before["b.mcap"])
    finally:
        stop_processes([other])
    recorder = f"sleep (pid {other.pid} on "
    assert info.code == 1 and f"[RECORDING: being written by {recorder}" in info.out, info.out + info.err
    assert "DAMAGED" not in info.out + info.err
    error_line(analyze.code, analyze.err, f"is being recorded by {recorder}")
    error_line(repair.code, repair.err, f"is being recorded by {recorder}", "nothing changed")
    error_line(generate.code, generate.err, f"is being recorded by {recorder}", "refusing to replace it")
    error_line(empty.code, empty.err, f"is being recorded by {recorder}", "nothing is written yet")
    assert {p.name: p.read_bytes() for p in bag.iterdir()} == before


@pytest.mark.ros
def test_a_run_told_to_overwrite_a_live_bag_leaves_it_alone(tmp_path: Path) -> None:
    """``run --record DIR --overwrite`` while another writer holds DIR's lock: its recorder refuses in one
    line naming that writer, the run exits 1 without summarising the other's bag as its own (it printed
    that bag's topics and 'bag: DIR'), and DIR's files are byte for byte as they were."""
    bag = tmp_path / "held"
    proc = _start_holder(bag)
    try:
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write("go\n")
        proc.stdin.flush()
        assert proc.stdout.readline().strip() == "flushed"
        before = {p.name: p.read_bytes() for p in bag.iterdir()}
        run = _start_run(bag, 1.0, "--overwrite")
        try:
            code = run.finish(timeout=120)
        finally:
            stop_processes([run.proc])
        after = {p.name: p.read_bytes() for p in bag.iterdir()}
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert code == 1, run.text
    assert f"bag_recorder: error: bag {bag} is being recorded by holder_test (pid {proc.pid}" in run.text
    assert f"bag: {bag}" not in run.text and "messages:" not in run.text, run.text
    assert after == before


def test_a_run_whose_bag_is_too_short_to_summarise_warns_and_exits_1(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """What CI met once: the cut copy left in DIR held 1 angle, so the summary's analysis refused it (exit 2,
    "at least 2 are needed") before the run said the bag was not complete. Without ROS: the chain is
    replaced by one that leaves a 1-angle bag whose metadata.yaml lists 5; the run says why it has no
    summary, gives the WARNING, and exits 1."""
    import yaml

    from pendulum_accel.nodes import launcher
    from pendulum_accel.recording.generate import generate_bag

    def leave_a_cut_bag(config: launcher.ChainConfig, *, log: bool = True) -> int:
        """A bag at config.record with one angle, its metadata.yaml claiming four more."""
        assert config.record is not None
        generate_bag("at_rest", config.record, duration=0.005)  # 100 Hz: the sample at t = 0 only
        meta_path = config.record / "metadata.yaml"
        meta = yaml.safe_load(meta_path.read_text())
        info = meta["rosbag2_bagfile_information"]
        for entry in info["topics_with_message_count"]:
            if entry["topic_metadata"]["name"] == bm.TOPIC_JOINT_STATES:
                assert entry["message_count"] == 1, entry
                entry["message_count"] += 4
        info["message_count"] += 4
        meta_path.write_text(yaml.safe_dump(meta))
        return 0

    monkeypatch.setattr(launcher, "require_rclpy", lambda: None)
    monkeypatch.setattr(launcher, "run_chain", leave_a_cut_bag)
    monkeypatch.setattr("pendulum_accel.kernel_cache.warm_if_cold", lambda say: None)
    bag = tmp_path / "cut"
    code = main(["run", "at_rest", "--fast", "--record", str(bag)])
    err = capsys.readouterr().err
    assert code == 1, err
    assert "no summary: " in err and "at least 2 are needed" in err, err
    assert f"WARNING: the recorded bag {bag} is not complete: " in err, err
