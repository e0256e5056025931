"""pendulum_sim over real DDS: parameters validated with reasons (old value kept), bad values refused."""

from __future__ import annotations

import re
import signal

import pytest

from pendulum_accel.nodes.graph import READY_STEADY_S, WAIT_NOTE_S, wait_for_readers
from pendulum_accel.nodes.launcher import ParamValue, node_command
from test.chain_helpers import Output, run_probe, start_node
from test.conftest import Spawn

pytestmark = [
    pytest.mark.ros,
]


def test_invalid_parameters_are_rejected_and_a_valid_change_restarts(spawn: Spawn) -> None:
    sim = start_node(
        spawn, "simulator_node", {"scene": "lecture_constant", "duration": 0.5, "exit_on_end": False}
    )
    sim.wait_for(r"scene ended; idle", timeout=60)
    # SetParameters applies them one by one, in this order.
    params = {
        "length": -1.0,  # outside the declared range
        "theta0": 120.0,  # outside the ±16 turns (±32π ≈ ±100.5 rad) a start angle is wrapped from
        "rate_hz": 1000.0,  # valid: accepted, the scene restarts
        "duration": 80000.0,  # in range, but 8e7 samples at the new 1 kHz: the core refuses the scene
        "realtime": False,  # read-only
        "noise_std": 0.002,  # valid
    }
    result = run_probe(spawn, {"set": {"node": "pendulum_sim", "params": params}})
    outcome = dict(zip(params, result["set"], strict=True))
    for name in ("length", "theta0", "realtime"):
        ok, reason = outcome[name]
        assert not ok and reason, name
    ok, reason = outcome["duration"]
    assert not ok and "samples" in reason, reason
    assert outcome["rate_hz"][0], outcome["rate_hz"]
    assert outcome["noise_std"][0]
    assert result["get"] == {
        "length": 1.0,
        "theta0": 0.0,
        "duration": 0.5,
        "rate_hz": 1000.0,
        "realtime": True,
        "noise_std": 0.002,
    }
    sim.wait_for(r"restarting the scene", timeout=30)
    sim.wait_for(r"501 samples over 0\.500 s", timeout=30)  # the restarted scene runs at the new rate
    sim.proc.send_signal(signal.SIGINT)
    assert sim.finish(timeout=20) == 0


def test_bad_startup_value_is_one_line_error(spawn: Spawn) -> None:
    sim = Output(spawn(node_command("simulator_node", {"scene": "lecture_constant", "length": -2.0})))
    assert sim.finish(timeout=60) == 2
    assert "pendulum_sim: error:" in sim.text and "length" in sim.text
    assert "Traceback" not in sim.text
    missing = Output(spawn(node_command("simulator_node", {"scene": "no_such_scene"})))
    assert missing.finish(timeout=60) == 2
    assert "pendulum_sim: error:" in missing.text and "no_such_scene" in missing.text
    assert "Traceback" not in missing.text


class _FakeClock:
    """A monotonic clock that only the wait's own sleeps advance: the test is independent of load."""

    def __init__(self) -> None:
        """Start at t = 0."""
        self.t = 0.0

    def now(self) -> float:
        """The fake time (s)."""
        return self.t

    def sleep(self, seconds: float) -> None:
        """Advance the fake time by ``seconds``."""
        self.t += seconds


def _wait(
    missing_until: float, timeout: float, stop_at: float = float("inf")
) -> tuple[bool, list[str], list[str], float]:
    """Run wait_for_readers on a fake clock with /accel_estimator missing until ``missing_until``:
    (result, notes, give-up lines, fake time at return)."""
    clock = _FakeClock()
    notes: list[str] = []
    errors: list[str] = []

    def missing() -> dict[str, list[str]]:
        """The estimator is missing on the angles until ``missing_until``."""
        return {"pendulum/joint_states": ["/accel_estimator"]} if clock.t < missing_until else {}

    ok = wait_for_readers(
        missing, timeout, lambda: clock.t >= stop_at, notes.append, errors.append, clock.now, clock.sleep
    )
    return ok, notes, errors, clock.t


def test_reader_wait_says_what_it_waits_for_and_gives_up_with_one_line() -> None:
    """Readers that never come: a note every WAIT_NOTE_S names them, then one line after the timeout.
    Readers that come late: the notes until then, no give-up, ready once steady. A stop: silent."""
    ok, notes, errors, t = _wait(missing_until=float("inf"), timeout=2.5 * WAIT_NOTE_S)
    assert not ok and t >= 2.5 * WAIT_NOTE_S
    assert len(notes) == 2 and len(errors) == 1  # notes at 1 and 2 WAIT_NOTE_S, then the timeout
    for line in [*notes, *errors]:
        assert "pendulum/joint_states: /accel_estimator" in line and "wait_timeout" in line, line
    gave_up = re.search(r"gave up after ([0-9.e+]+) s", errors[0])
    assert gave_up and float(gave_up.group(1)) == 2.5 * WAIT_NOTE_S, errors[0]
    waited = [float(m.group(1)) for line in notes if (m := re.search(r"waiting ([0-9]+) s so far", line))]
    # Each note states the whole seconds waited: within 0.5 s (rounding) plus one 0.01 s poll step.
    assert len(waited) == 2 and all(
        abs(w - k * WAIT_NOTE_S) <= 0.51 for k, w in zip((1, 2), waited, strict=True)
    )

    ok, notes, errors, t = _wait(missing_until=3.5 * WAIT_NOTE_S, timeout=120.0)
    assert ok and not errors and len(notes) == 3
    assert t >= 3.5 * WAIT_NOTE_S + READY_STEADY_S  # ready only once the readers stayed matched

    ok, notes, errors, _ = _wait(missing_until=float("inf"), timeout=120.0, stop_at=0.5 * WAIT_NOTE_S)
    assert not ok and not notes and not errors


def test_simulator_without_its_reader_names_it_then_gives_up(spawn: Spawn) -> None:
    """A reader that never comes: INFO lines name it while the simulator waits, then the one-line error
    and exit 1 (a chain whose estimator never comes still ends). The timeout just above WAIT_NOTE_S
    gives one note whatever the load: the note is checked before the timeout on every poll."""
    timeout = WAIT_NOTE_S + 0.5
    params: dict[str, ParamValue] = {
        "scene": "at_rest",
        "duration": 0.5,
        "reader_nodes": ["never_there"],
        "wait_timeout": timeout,
    }
    sim = start_node(spawn, "simulator_node", params)
    assert sim.finish(timeout=timeout + 90) == 1, sim.text
    notes = [line for line in sim.lines if "so far for the chain's readers" in line]
    errors = [line for line in sim.lines if "gave up after" in line]
    assert len(notes) == 1 and "[INFO]" in notes[0], sim.text
    assert len(errors) == 1 and "[ERROR]" in errors[0], sim.text
    for line in [*notes, *errors]:
        assert "pendulum/joint_states: /never_there" in line, line
    assert "subscribers matched" not in sim.text and "Traceback" not in sim.text
