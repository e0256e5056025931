"""Start-up by name: is each of the chain's own readers subscribed, and matched, on a topic?

A subscriber count can be satisfied by a stranger (``ros2 topic echo``) before the chain's own
reader is there, and the chain then starts without it. The wait here asks the ROS graph *which*
nodes subscribe (``get_subscriptions_info_by_topic``: node name and namespace) and also asks DDS
whether the publisher has matched every compatible subscriber the graph lists, so the first
sample goes to every one of them (then the first-sample acknowledgement closes the handshake).
"""

from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSCompatibility, qos_check_compatible


def qualified_name(name: str, namespace: str) -> str:
    """'/ns/name' of a node name: kept as is when it starts with '/', else put in ``namespace``."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


def node_names(entries: Sequence[str], namespace: str) -> list[str]:
    """The fully qualified names of the non-empty ``entries`` (see qualified_name)."""
    return [qualified_name(entry, namespace) for entry in entries if entry]


def missing_readers(node: Node, publisher: Publisher, wanted: Sequence[str]) -> list[str]:
    """The names in ``wanted`` not yet subscribed to the publisher's topic (its resolved name: namespace
    and remaps applied) and matched by ``publisher``.

    A wanted node listed in the graph counts as matched only once the publisher's matched count
    reaches the number of QoS-compatible subscribers the graph lists (ours and anyone else's).
    """
    infos = node.get_subscriptions_info_by_topic(publisher.topic_name)
    present = {qualified_name(info.node_name, info.node_namespace) for info in infos}
    missing = [name for name in wanted if name not in present]
    if missing:
        return missing
    compatible = sum(
        1
        for info in infos
        if qos_check_compatible(publisher.qos_profile, info.qos_profile)[0] != QoSCompatibility.ERROR
    )
    if publisher.get_subscription_count() < compatible:
        return [f"{name} (not matched yet)" for name in wanted]
    return []
