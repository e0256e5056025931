"""The simulator and the estimator are managed nodes: a lifecycle client drives every transition.

Each node starts with autostart false (unconfigured, publishing nothing), then the client calls
``~/change_state`` (lifecycle_msgs/ChangeState) through configure, activate, deactivate, cleanup and
shutdown, checking ``~/get_state`` after each; shutdown ends the process with exit 0.
"""

from __future__ import annotations

import itertools
import json

import pytest

from pendulum_accel.nodes.launcher import ParamValue, node_command
from test.chain_helpers import Output
from test.conftest import PYTHON, Spawn

pytestmark = [pytest.mark.ros]

CLIENT = r"""
import json, sys, time
import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from sensor_msgs.msg import JointState

node_name, topic = sys.argv[1], sys.argv[2]
rclpy.init()
node = rclpy.create_node("lifecycle_client")
heard = [0]
node.create_subscription(JointState, topic, lambda m: heard.__setitem__(0, heard[0] + 1), 100)
change = node.create_client(ChangeState, f"/{node_name}/change_state")
get = node.create_client(GetState, f"/{node_name}/get_state")
assert change.wait_for_service(timeout_sec=60) and get.wait_for_service(timeout_sec=60)

def call(client, request):
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=30)
    return future.result()

def state():
    return call(get, GetState.Request()).current_state.label

def spin(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)

steps = [("start", state(), None)]
T = Transition
for name, tid in [("configure", T.TRANSITION_CONFIGURE), ("activate", T.TRANSITION_ACTIVATE),
                  ("deactivate", T.TRANSITION_DEACTIVATE), ("cleanup", T.TRANSITION_CLEANUP)]:
    before = heard[0]
    ok = call(change, ChangeState.Request(transition=Transition(id=tid))).success
    spin(3.0)
    steps.append((name, state() if ok else "failed", heard[0] - before))
shutdown = Transition(id=T.TRANSITION_UNCONFIGURED_SHUTDOWN)
ok = call(change, ChangeState.Request(transition=shutdown)).success
steps.append(("shutdown", "ok" if ok else "failed", None))
print(json.dumps(steps), flush=True)
"""


@pytest.mark.parametrize(
    ("module", "node_name", "params"),
    [
        ("simulator_node", "pendulum_sim", {"scene": "step_start", "realtime": True, "exit_on_end": False}),
        ("estimator_node", "accel_estimator", {"scene": "step_start"}),
    ],
)
def test_lifecycle_transitions(
    spawn: Spawn, module: str, node_name: str, params: dict[str, ParamValue]
) -> None:
    node = Output(spawn(node_command(module, {**params, "autostart": False, "time_source": "wall"})))
    node.wait_for("autostart false", timeout=60)
    # The simulator's angles show whether it publishes; the estimator is checked by its state alone.
    client = Output(spawn([PYTHON, "-c", CLIENT, node_name, "pendulum/joint_states"]))
    assert client.finish(timeout=120) == 0, client.text + node.text
    steps = json.loads(client.lines[-1])
    labels = [label for _, label, _ in steps]
    assert labels == ["unconfigured", "inactive", "active", "inactive", "unconfigured", "ok"], steps
    if module == "simulator_node":
        heard = {name: count for name, _, count in steps if count is not None}
        assert heard["configure"] == 0  # configured, not active: nothing published
        assert heard["activate"] > 0  # active: the angles flow (3 s of a 100 Hz real-time scene)
        assert heard["cleanup"] == 0  # deactivated, then cleaned up: silent
    assert node.finish(timeout=30) == 0, node.text  # shutdown ends the process cleanly


REACTIVATE = r"""
import json, sys, time
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rosgraph_msgs.msg import Clock

node_name = sys.argv[1]
rclpy.init()
node = rclpy.create_node("lifecycle_client")
heard = []  # (phase, stamp s) of each /clock tick or /diagnostics message
phase = ["configured"]
if node_name == "pendulum_sim":
    node.create_subscription(
        Clock, "/clock", lambda m: heard.append((phase[0], m.clock.sec + m.clock.nanosec * 1e-9)), 1000
    )
else:
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: heard.append((phase[0], 0.0)), 100)
change = node.create_client(ChangeState, f"/{node_name}/change_state")
assert change.wait_for_service(timeout_sec=60)

def spin(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)

def go(tid, name):
    if name.startswith("active"):  # what comes from now on is the active phase's
        phase[0] = name
    future = change.call_async(ChangeState.Request(transition=Transition(id=tid)))
    rclpy.spin_until_future_complete(node, future, timeout_sec=30)
    assert future.result().success, name
    if not name.startswith("active"):
        spin(0.5)  # what was in flight at the transition arrives before the phase is renamed
        phase[0] = name

def until_heard(name, count, seconds=30.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end and sum(1 for p, _ in heard if p == name) < count:
        rclpy.spin_once(node, timeout_sec=0.05)

T = Transition
go(T.TRANSITION_CONFIGURE, "configured")
spin(1.5)
go(T.TRANSITION_ACTIVATE, "active")
until_heard("active", 5)
go(T.TRANSITION_DEACTIVATE, "inactive")
spin(2.0)
go(T.TRANSITION_ACTIVATE, "active again")
until_heard("active again", 5)
print(json.dumps(heard), flush=True)
"""


@pytest.mark.parametrize(
    ("module", "node_name", "params"),
    [
        (
            "simulator_node",
            "pendulum_sim",
            {"scene": "step_start", "realtime": True, "time_source": "sim", "publish_clock": True},
        ),
        ("estimator_node", "accel_estimator", {"scene": "step_start", "diagnostics_period": 0.2}),
    ],
)
def test_an_inactive_node_is_silent_and_a_reactivated_one_goes_on(
    spawn: Spawn, module: str, node_name: str, params: dict[str, ParamValue]
) -> None:
    """Lifecycle conventions: nothing is published while configured or inactive (the estimator's
    /diagnostics included); re-activated, the simulator goes on where it stopped: /clock never jumps back."""
    node = Output(spawn(node_command(module, {**params, "autostart": False})))
    node.wait_for("autostart false", timeout=60)
    client = Output(spawn([PYTHON, "-c", REACTIVATE, node_name]))
    assert client.finish(timeout=120) == 0, client.text + node.text
    heard = json.loads(client.lines[-1])
    phases = [phase for phase, _ in heard]
    assert "configured" not in phases and "inactive" not in phases, phases
    assert phases.count("active") > 0 and phases.count("active again") > 0, phases
    if module == "simulator_node":
        stamps = [stamp for _, stamp in heard]
        # Each tick later than the one before: a restart at t = 0 would show as a step back.
        assert all(b > a for a, b in itertools.pairwise(stamps)), stamps
        node.wait_for(r"resuming at sample \d+", timeout=10)
