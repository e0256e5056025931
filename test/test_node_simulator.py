"""pendulum_sim over real DDS: parameters validated with reasons (old value kept), bad values refused."""

from __future__ import annotations

import signal

import pytest

from pendulum_accel.nodes.launcher import node_command
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
