"""A scripted controller of bag_player for the player tests: listens, calls its services, sets parameters.

python -m test.player_control SPEC_JSON   (from the repository root)

SPEC keys:
  "node": name                    the player's node name (default bag_player)
  "listen": {topic: type, ...}    record (wall time, stamp, value) of every message on these topics
                                  (stamp None for a type without header or clock);
  "matched": [topic, ...]         listened topics whose publisher must be matched before the first step;
                                  value: accel.accel.linear.x of an estimate, position[0] of a joint state
  "steps": [step, ...]            run in order, each recording one result:
      ["call", service]           call /<node>/<service> (std_srvs/Trigger): [success, message]
      ["set", {name: value}]      SetParameters on the node: [[successful, reason], ...]
      ["get", [name, ...]]        GetParameters: {name: value}
      ["sleep", seconds]          keep listening
      ["count", topic]            messages of topic so far
      ["wait_count", topic, n]    until n messages of topic arrived (30 s at most): the count
      ["wait_stamp", topic, t]    until a message of topic stamped ≥ t arrived (30 s at most): its stamp
  "linger": seconds               keep listening after the steps
Prints one JSON object: {"messages": {topic: [[wall, stamp, value], ...]}, "results": [...]}.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import rclpy
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from pendulum_accel.nodes.conversions import message_class, time_to_seconds
from pendulum_accel.nodes.qos import qos_for
from test.node_probe import call, spin_for

_WAIT_LIMIT = 30.0  # s


def stamp_of(msg: Any) -> float | None:
    """header.stamp (or clock) of a message, in seconds; None for a type with neither (String, markers)."""
    if hasattr(msg, "clock"):
        return time_to_seconds(msg.clock)
    return time_to_seconds(msg.header.stamp) if hasattr(msg, "header") else None


def value_of(msg: Any) -> float | None:
    """accel.accel.linear.x of an estimate, position[0] of a joint state, None for other types."""
    if hasattr(msg, "accel") and hasattr(msg.accel, "accel"):
        return float(msg.accel.accel.linear.x)
    if hasattr(msg, "position") and len(msg.position):
        return float(msg.position[0])
    return None


def main() -> None:
    """Run the spec from argv[1] and print the JSON result."""
    spec = json.loads(sys.argv[1])
    target = spec.get("node", "bag_player")
    rclpy.init()
    node = Node("player_control")
    messages: dict[str, list[list[Any]]] = {topic: [] for topic in spec.get("listen", {})}
    subscriptions = {}
    for topic, msgtype in spec.get("listen", {}).items():
        subscription = node.create_subscription(
            message_class(msgtype),
            topic,
            lambda msg, topic=topic: messages[topic].append([time.time(), stamp_of(msg), value_of(msg)]),
            qos_for(topic),
        )
        subscriptions[topic] = subscription
    setter: Any = node.create_client(SetParameters, f"/{target}/set_parameters")
    getter: Any = node.create_client(GetParameters, f"/{target}/get_parameters")
    triggers: dict[str, Any] = {}
    results: list[Any] = []

    def wait_until(done: Any) -> None:
        """Spin until done() or the wait limit."""
        end = time.monotonic() + _WAIT_LIMIT
        while not done() and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.01)

    # Nothing sent on a "matched" topic may be missed: its publisher is matched before step one.
    matched = [subscriptions[topic] for topic in spec.get("matched", [])]
    wait_until(lambda: all(sub.get_publisher_count() > 0 for sub in matched))
    for step in spec.get("steps", []):
        kind = step[0]
        if kind == "call":
            if step[1] not in triggers:
                triggers[step[1]] = node.create_client(Trigger, f"/{target}/{step[1]}")
            reply = call(node, triggers[step[1]], Trigger.Request())
            results.append([reply.success, reply.message])
        elif kind == "set":
            request = SetParameters.Request()
            for name, value in step[1].items():
                request.parameters.append(Parameter(name, value=value).to_parameter_msg())
            reply = call(node, setter, request)
            results.append([[r.successful, r.reason] for r in reply.results])
        elif kind == "get":
            reply = call(node, getter, GetParameters.Request(names=list(step[1])))
            results.append(
                {
                    name: Parameter.from_parameter_msg(ParameterMsg(name=name, value=value)).value
                    for name, value in zip(step[1], reply.values, strict=True)
                }
            )
        elif kind == "sleep":
            spin_for(node, float(step[1]))
            results.append(None)
        elif kind == "count":
            results.append(len(messages[step[1]]))
        elif kind == "wait_count":
            topic, count = step[1], int(step[2])
            wait_until(lambda topic=topic, count=count: len(messages[topic]) >= count)
            results.append(len(messages[topic]))
        elif kind == "wait_stamp":
            topic, t = step[1], float(step[2])
            wait_until(lambda topic=topic, t=t: any(m[1] >= t for m in messages[topic]))
            results.append(max((m[1] for m in messages[topic]), default=None))
        else:
            raise ValueError(f"unknown step {step!r}")
    spin_for(node, float(spec.get("linger", 0.0)))
    print(json.dumps({"messages": messages, "results": results}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
