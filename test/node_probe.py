"""A scripted DDS peer for the node tests: feeds joint states, listens, sets parameters; prints JSON.

python test/node_probe.py SPEC_JSON

SPEC keys (all optional):
  "listen": [topic, ...]          record /car/accel/estimate and /diagnostics messages
  "listen_transient_local": topic subscribe to this AccelWithCovarianceStamped topic asking transient-local
                                  durability (an incompatible subscriber for a volatile publisher)
  "wait_subscribers": n           before feeding, wait until /pendulum/joint_states has n subscribers
  "feed": [[t, theta] | ["pause", seconds] | ["until", state, seconds], ...]  joint states at 100 Hz
                                  wall pace, theta null = NaN; "until" waits (at most seconds) for a
                                  /diagnostics status whose state is ``state`` (needs "listen")
  "joints": [name, ...]           publish these joints (θ on the last, 0.5 on the others), no velocity
  "others": value                 with "joints": the other joints' value (null = NaN; default 0.5)
  "frame_id": name                stamp the fed joint states in this frame (default: the chain's base_link)
  "burst": [n, t0, theta]         after "feed": n angles stamped t0 + i/1000 s, as fast as publish goes
  "package_profile": true         use the package's Fast DDS profile (nodes.dds_profile), as the nodes do:
                                  its 10 ms writer heartbeat repairs a lost sample (a service request
                                  dropped by a flooded port) at once, where Fast DDS's default takes 3 s
  "say_feeding": true             print "feeding" to stderr as the feed begins (the publisher is up)
  "sensor_data": true             publish with rclpy's SensorDataQoS (best-effort, keep last 5)
  "endpoints": [topic, ...]       at the end, each topic's subscriptions and publishers as the graph
                                  lists them: {topic: {"subscriptions"|"publishers": [[node, reliability,
                                  durability]]}} (discovery carries no history or depth)
  "set": {"node": name, "params": {name: value}}  call SetParameters, then GetParameters
  "get": {"node": name, "names": [name, ...]}     call GetParameters only
  "endpoints_of": [node, seconds]  before listing "endpoints", wait (spinning, at most seconds) until node
                                  has an endpoint on each of them: discovery under load can take longer
                                  than a fixed linger
  "until_estimates": [n, seconds]  after feeding, keep listening until n estimates arrived (at most seconds):
                                  a loaded machine can hold the estimator back past any fixed linger
  "until_values": [{key: value}, seconds]  then until a /diagnostics status holds every key at its value
                                  (at most seconds), e.g. a drop counter at the count fed
  "linger": seconds               after those, keep listening (late or extra messages, a last status)
  "linger_until": [state, seconds] then keep listening until a /diagnostics status whose state is
                                  ``state`` arrives after the feed and burst and after every angle
                                  published was acknowledged (at most seconds)
  "qos_graph": [[topic, ...], n, seconds, [node, ...]]  at the end, the endpoints on these topics of the
                                  named nodes (full names) as the graph lists them, once there are n of
                                  them (spinning, at most seconds): [[node's full name, topic,
                                  "publisher"|"subscription", reliability, durability]], sorted. Only the
                                  named nodes count: a stopped test's nodes linger in the graph until
                                  their lease ends, and their endpoints would fill the count early
Prints one JSON object: {"estimates": [[t, a, var], ...], "diagnostics": [[level, message, values]],
"set": [[successful, reason], ...], "get": {name: value}, "set_seconds": s (from the request, sent as the
feed and burst end, to the answer; the service is discovered before the feed), "diagnostics_after":
[[s, state, values]], "qos_graph": [...]} (diagnostics_after: each /diagnostics status's arrival, seconds
after the feed and burst ended, with its state and key/values).
"""

from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelWithCovarianceStamped
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState

from pendulum_accel.nodes.conversions import joint_state, time_from_ns, time_to_seconds
from pendulum_accel.nodes.dds_profile import use_package_profile
from pendulum_accel.nodes.qos import DATA_QOS, DIAGNOSTICS_QOS
from pendulum_accel.nodes.runtime import publish_blocking


def spin_for(node: Node, seconds: float) -> None:
    """Process callbacks for ``seconds``."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.01)


def call(node: Node, client: Any, request: Any) -> Any:
    """Call a service and wait (10 s) for the answer."""
    if not client.wait_for_service(timeout_sec=20.0):
        raise RuntimeError(f"service {client.srv_name} not available")
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    return future.result()


def qos_graph(node: Node, topics: list[str]) -> list[list[str]]:
    """[full node name, topic, kind, reliability, durability] of every endpoint on ``topics`` but this
    node's own, sorted (discovery carries no history or depth)."""
    rows: list[list[str]] = []
    for topic in topics:
        for kind, infos in (
            ("publisher", node.get_publishers_info_by_topic(topic)),
            ("subscription", node.get_subscriptions_info_by_topic(topic)),
        ):
            for info in infos:
                if info.node_name == node.get_name() and info.node_namespace == node.get_namespace():
                    continue
                name = info.node_namespace.rstrip("/") + "/" + info.node_name
                qos = info.qos_profile
                rows.append([name, topic, kind, qos.reliability.name.lower(), qos.durability.name.lower()])
    return sorted(rows)


def main() -> None:
    """Run the spec from argv[1] and print the JSON result."""
    spec = json.loads(sys.argv[1])
    if spec.get("package_profile"):
        use_package_profile()
    rclpy.init()
    node = Node("node_probe")
    out: dict[str, Any] = {"estimates": [], "diagnostics": [], "set": [], "get": {}, "diagnostics_after": []}
    fed_at: list[float] = []  # when the feed and burst ended (monotonic)

    def on_estimate(msg: AccelWithCovarianceStamped) -> None:
        """Keep (t, â, var)."""
        out["estimates"].append(
            [time_to_seconds(msg.header.stamp), msg.accel.accel.linear.x, msg.accel.covariance[0]]
        )

    def on_diagnostics(msg: DiagnosticArray) -> None:
        """Keep (level, message, values) of each status."""
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            out["diagnostics"].append([int.from_bytes(status.level, "little"), status.message, values])
            if fed_at:
                out["diagnostics_after"].append([time.monotonic() - fed_at[0], values.get("state"), values])

    listen = spec.get("listen", [])
    if "/car/accel/estimate" in listen:
        node.create_subscription(AccelWithCovarianceStamped, "/car/accel/estimate", on_estimate, DATA_QOS)
    if "listen_transient_local" in spec:
        asking = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(
            AccelWithCovarianceStamped, spec["listen_transient_local"], on_estimate, asking
        )
    if "/diagnostics" in listen:
        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, DIAGNOSTICS_QOS)
    qos = qos_profile_sensor_data if spec.get("sensor_data") else DATA_QOS
    publisher = node.create_publisher(JointState, "/pendulum/joint_states", qos)
    deadline = time.monotonic() + 30.0
    while (
        publisher.get_subscription_count() < spec.get("wait_subscribers", 0) and time.monotonic() < deadline
    ):
        spin_for(node, 0.05)
    spin_for(node, 0.3)  # let the listeners match too
    if "set" in spec:
        target = spec["set"]["node"]
        params = spec["set"]["params"]
        setter: Any = node.create_client(SetParameters, f"/{target}/set_parameters")
        getter: Any = node.create_client(GetParameters, f"/{target}/get_parameters")
        request = SetParameters.Request()
        for name, value in params.items():
            request.parameters.append(Parameter(name, value=value).to_parameter_msg())
        # Discovered before the feed: the request then goes out as the feed ends, and discovery under load
        # is not part of the node's answer.
        if not setter.wait_for_service(timeout_sec=30.0):
            raise RuntimeError(f"service {setter.srv_name} not available")
    if spec.get("say_feeding"):
        print("feeding", file=sys.stderr, flush=True)
    for item in spec.get("feed", []):
        if item[0] == "pause":
            spin_for(node, float(item[1]))
            continue
        if item[0] == "until":
            seen, end = len(out["diagnostics"]), time.monotonic() + float(item[2])
            while time.monotonic() < end and not any(
                values.get("state") == item[1] for _, _, values in out["diagnostics"][seen:]
            ):
                spin_for(node, 0.01)
            continue
        t, theta = float(item[0]), math.nan if item[1] is None else float(item[1])
        msg = joint_state(time_from_ns(round(t * 1e9)), theta, 0.0)
        if "joints" in spec:  # another publisher's shape: several joints, ours among them
            msg.name = list(spec["joints"])
            other = math.nan if spec.get("others", 0.5) is None else float(spec.get("others", 0.5))
            msg.position = [theta if name == msg.name[-1] else other for name in msg.name]
            msg.velocity = []
        if "frame_id" in spec:
            msg.header.frame_id = str(spec["frame_id"])
        publisher.publish(msg)
        spin_for(node, 0.01)
    if "burst" in spec:
        count, t0, theta = int(spec["burst"][0]), float(spec["burst"][1]), float(spec["burst"][2])
        for i in range(count):
            msg = joint_state(time_from_ns(round((t0 + i / 1000.0) * 1e9)), theta, 0.0)
            # A keep-all writer whose reader pushes back refuses a sample: wait, as the chain's nodes do.
            publish_blocking(publisher, msg, lambda: False)
            if i % 200 == 0:
                rclpy.spin_once(node, timeout_sec=0.0)
    fed_at.append(time.monotonic())
    if "set" in spec:
        asked = time.monotonic()
        response = call(node, setter, request)
        out["set_seconds"] = time.monotonic() - asked
        out["set"] = [[r.successful, r.reason] for r in response.results]
        reply = call(node, getter, GetParameters.Request(names=list(params)))
        for name, value in zip(params, reply.values, strict=True):
            out["get"][name] = Parameter.from_parameter_msg(ParameterMsg(name=name, value=value)).value
    if "get" in spec:
        getter = node.create_client(GetParameters, f"/{spec['get']['node']}/get_parameters")
        names = list(spec["get"]["names"])
        reply = call(node, getter, GetParameters.Request(names=names))
        for name, value in zip(names, reply.values, strict=True):
            out["get"][name] = Parameter.from_parameter_msg(ParameterMsg(name=name, value=value)).value
    if "until_estimates" in spec:
        count, end = int(spec["until_estimates"][0]), time.monotonic() + float(spec["until_estimates"][1])
        while time.monotonic() < end and len(out["estimates"]) < count:
            spin_for(node, 0.01)
    if "until_values" in spec:
        wanted, end = dict(spec["until_values"][0]), time.monotonic() + float(spec["until_values"][1])
        while time.monotonic() < end and not any(
            all(values.get(k) == str(v) for k, v in wanted.items()) for _, _, values in out["diagnostics"]
        ):
            spin_for(node, 0.01)
    spin_for(node, float(spec.get("linger", 0.0)))
    if "linger_until" in spec:
        state, end = spec["linger_until"][0], time.monotonic() + float(spec["linger_until"][1])
        # A reliable writer repairs lost samples only after a heartbeat (Fast DDS: every 3 s), so under load
        # the node may see a silence, and say STALE, with the burst's tail still undelivered. Exiting then
        # would destroy the writer with that tail: wait (spinning, so statuses keep their arrival times)
        # until every angle is acknowledged, then for a status in ``state`` that came after it.
        while time.monotonic() < end and not publisher.wait_for_all_acked(Duration(seconds=0)):
            spin_for(node, 0.01)
        acked = time.monotonic() - fed_at[0]
        while time.monotonic() < end and not any(
            s == state and at >= acked for at, s, _ in out["diagnostics_after"]
        ):
            spin_for(node, 0.01)
    if "endpoints_of" in spec:
        owner, end = str(spec["endpoints_of"][0]), time.monotonic() + float(spec["endpoints_of"][1])

        def listed(topic: str) -> bool:
            """True when ``owner`` has a subscription or publisher on ``topic`` in this probe's graph."""
            infos = [*node.get_subscriptions_info_by_topic(topic), *node.get_publishers_info_by_topic(topic)]
            return any(info.node_name == owner for info in infos)

        while time.monotonic() < end and not all(listed(t) for t in spec.get("endpoints", [])):
            spin_for(node, 0.05)
    out["endpoints"] = {
        topic: {
            kind: [
                [
                    info.node_name,
                    info.qos_profile.reliability.name.lower(),
                    info.qos_profile.durability.name.lower(),
                ]
                for info in infos(topic)
            ]
            for kind, infos in (
                ("subscriptions", node.get_subscriptions_info_by_topic),
                ("publishers", node.get_publishers_info_by_topic),
            )
        }
        for topic in spec.get("endpoints", [])
    }
    if "qos_graph" in spec:
        topics, count = list(spec["qos_graph"][0]), int(spec["qos_graph"][1])
        end = time.monotonic() + float(spec["qos_graph"][2])
        named = set(spec["qos_graph"][3])
        while True:
            out["qos_graph"] = [row for row in qos_graph(node, topics) if row[0] in named]
            if len(out["qos_graph"]) >= count or time.monotonic() >= end:
                break
            spin_for(node, 0.1)
    print(json.dumps(out), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
