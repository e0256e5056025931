"""Real-time priority: parsed from one variable, taken or refused with a sentence, set only for paced runs."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pendulum_accel.cli.run import add_chain_arguments
from pendulum_accel.nodes.launcher import Chain, ChainConfig
from pendulum_accel.nodes.scheduling import RT_PRIORITY_ENV, apply_rt_priority


@pytest.mark.parametrize("value", ["", "0", " 0 "])
def test_unset_or_zero_changes_nothing(monkeypatch: pytest.MonkeyPatch, value: str) -> None:
    """No variable, empty or 0: no policy change and nothing to report."""
    monkeypatch.setenv(RT_PRIORITY_ENV, value)
    before = os.sched_getscheduler(0)
    assert apply_rt_priority() is None
    assert os.sched_getscheduler(0) == before


@pytest.mark.parametrize("value", ["high", "100", "-3", "2.5"])
def test_a_bad_value_is_reported_not_raised(monkeypatch: pytest.MonkeyPatch, value: str) -> None:
    """Anything but an integer 1-99 gives one sentence naming the variable and the value."""
    monkeypatch.setenv(RT_PRIORITY_ENV, value)
    message = apply_rt_priority()
    assert message is not None and RT_PRIORITY_ENV in message and repr(value) in message


def test_a_valid_priority_is_taken_or_refused_with_a_reason() -> None:
    """In a child process: SCHED_FIFO at the asked priority, or normal scheduling and the reason why."""
    probe = (
        "import os; from pendulum_accel.nodes.scheduling import apply_rt_priority as a; m = a(); "
        "print(os.sched_getscheduler(0) == os.SCHED_FIFO, os.sched_getparam(0).sched_priority, m)"
    )
    env = {**os.environ, RT_PRIORITY_ENV: "7"}
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True)
    fifo, priority, message = out.stdout.strip().split(" ", 2)
    if fifo == "True":
        assert (priority, message) == ("7", "None")
    else:
        assert message.startswith("cannot take real-time priority 7") and "normal priority" in message


@pytest.mark.parametrize(("realtime", "expected"), [(True, "20"), (False, "None")])
def test_the_launcher_passes_the_priority_to_paced_runs_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, realtime: bool, expected: str
) -> None:
    """A real-time chain's nodes see the variable; a fast one's never, not even an inherited one."""
    monkeypatch.setenv(RT_PRIORITY_ENV, "33")  # inherited from the caller: must not leak into a fast run
    log = tmp_path / "nodes.log"
    chain = Chain(ChainConfig(scene="at_rest", realtime=realtime, rt_priority=20), log=False, output=log)
    chain._start("probe", [sys.executable, "-c", f"import os; print(os.environ.get({RT_PRIORITY_ENV!r}))"])
    assert chain.children[0].process.wait(timeout=30) == 0
    assert log.read_text().strip() == expected


def test_the_cli_refuses_an_out_of_range_priority(capsys: pytest.CaptureFixture[str]) -> None:
    """`run --rt-priority 120`: argparse's one-line error (exit 2), naming the range."""
    parser = argparse.ArgumentParser(prog="pendulum-accel run")
    add_chain_arguments(parser)
    assert parser.parse_args(["--rt-priority", "20"]).rt_priority == 20
    with pytest.raises(SystemExit) as info:
        parser.parse_args(["--rt-priority", "120"])
    assert info.value.code == 2
    assert "from 0 to 99" in capsys.readouterr().err
