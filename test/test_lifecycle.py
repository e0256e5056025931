"""The simulator and the estimator are managed nodes: a lifecycle client drives every transition.

Each node starts with autostart false (unconfigured, publishing nothing), then the client calls
``~/change_state`` (lifecycle_msgs/ChangeState) through configure, activate, deactivate, cleanup and
shutdown, checking ``~/get_state`` after each; shutdown ends the process with exit 0.
"""

from __future__ import annotations

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
