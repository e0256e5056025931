"""QoS profiles shared by every node of the chain, so publishers and subscribers always match; the
``qos_overrides`` parameters every publisher and subscription accepts; one log line per incompatible peer.

Every entity is created with ``qos_options()`` (rclpy's QoSOverridingOptions): its history, depth,
reliability and durability can be set at start-up, by the parameter
``qos_overrides.<resolved topic>.<publisher|subscription>.<policy>`` (a params file or ``-p``), as in
every ROS 2 node that supports overrides. Each entity gets its own copy of its profile: rclpy writes the
overrides into the profile object it is given, so a shared one would carry one entity's overrides into
every entity made from it later. Subscriptions to data ask for ``best_available``
reliability: reliable (and lossless, as the chain needs) when every publisher is, best-effort when
one is not, as a hardware driver's SensorDataQoS publisher.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any, TypeAlias

from rclpy.event_handler import (
    PublisherEventCallbacks,
    QoSMessageLostInfo,
    QoSRequestedIncompatibleQoSInfo,
    SubscriptionEventCallbacks,
)
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_policy_name_from_kind,
)
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.subscription import Subscription

from pendulum_accel.bag.messages import ROBOT_DESCRIPTION, TOPIC_DIAGNOSTICS, role_of

# Any: the message packages ship no type information, so to mypy their classes are not rclpy's Msg and
# a publisher's or subscription's message class cannot be named (the chain's carry several).
AnyPublisher: TypeAlias = Publisher[Any]
"""A publisher of some message class."""
AnySubscription: TypeAlias = Subscription[Any]
"""A subscription to some message class."""

# KEEP_ALL on both ends makes a slow reader push back on the writer (publish blocks)
# instead of dropping samples: that is what keeps the as-fast-as-possible chain lossless.
DATA_QOS = QoSProfile(
    depth=1000,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Reliable, keep-all, volatile: every data topic of the chain (/clock included)."""

DIAGNOSTICS_QOS = QoSProfile(
    depth=100,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Reliable, keep-last 100: /diagnostics is low-rate status, a backlog is never useful."""


DESCRIPTION_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""robot_description, as robot_state_publisher offers it: reliable, keep last 1, transient local (a late
subscriber still gets the URDF; a volatile subscriber would match but get nothing published before it)."""

TF_STATIC_QOS = QoSProfile(
    depth=100,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""/tf_static as tf2_ros's static listener asks for it (StaticListenerQoS: reliable, transient local, keep
last 100): the transforms every static broadcaster sent before the subscription was made."""
TOPIC_TF_STATIC = "/tf_static"


def qos_for(topic: str) -> QoSProfile:
    """QoS of ``topic`` by its role under any namespace: DIAGNOSTICS_QOS for /diagnostics,
    DESCRIPTION_QOS for robot_description, TF_STATIC_QOS for /tf_static, DATA_QOS for everything else."""
    if topic == TOPIC_TF_STATIC:
        return TF_STATIC_QOS
    role = role_of(topic)
    if role == TOPIC_DIAGNOSTICS:
        return DIAGNOSTICS_QOS
    if role == ROBOT_DESCRIPTION:
        return DESCRIPTION_QOS
    return DATA_QOS


OVERRIDABLE = (
    QoSPolicyKind.HISTORY,
    QoSPolicyKind.DEPTH,
    QoSPolicyKind.RELIABILITY,
    QoSPolicyKind.DURABILITY,
)
"""The policies each publisher and subscription exposes as qos_overrides parameters."""


def qos_options() -> QoSOverridingOptions:
    """QoSOverridingOptions declaring a ``qos_overrides`` parameter for each OVERRIDABLE policy."""
    return QoSOverridingOptions(OVERRIDABLE)


def own_profile(qos: QoSProfile) -> QoSProfile:
    """A copy of ``qos`` for one entity: rclpy's create_publisher and create_subscription write the entity's
    qos_overrides into the profile they are given (rclpy.qos_overriding_options._declare_qos_parameters)."""
    return copy.copy(qos)


def subscription_qos(profile: QoSProfile) -> QoSProfile:
    """A copy of ``profile`` (``own_profile``) with best_available reliability: a subscription that matches
    reliable and best-effort publishers alike (reliable when every publisher on the graph at its creation
    is)."""
    out = own_profile(profile)
    out.reliability = ReliabilityPolicy.BEST_AVAILABLE
    return out


def override_parameter(topic: str, entity: str, policy: str) -> str:
    """'qos_overrides.<topic>.<entity>.<policy>': the parameter that sets ``policy`` of an entity
    (publisher or subscription) on the resolved ``topic``."""
    return f"qos_overrides.{topic}.{entity}.{policy}"


def left_best_available(node: Node, topic: str) -> bool:
    """True when the subscription to ``topic`` (resolved) is left at best_available reliability: its
    qos_overrides parameter says so (declared at the subscription's first creation)."""
    parameter = override_parameter(topic, "subscription", "reliability")
    return bool(node.has_parameter(parameter) and node.get_parameter(parameter).value == "best_available")


def offered_best_effort(node: Node, topic: str) -> bool:
    """True when a publisher of ``topic`` (resolved) known to ``node``'s graph is best-effort."""
    offered = {info.qos_profile.reliability for info in node.get_publishers_info_by_topic(topic)}
    return ReliabilityPolicy.BEST_EFFORT in offered


def incompatible_line(topic: str, entity: str, policy_kind: int) -> str:
    """The one line a node logs when a peer's QoS is incompatible with its ``entity`` on ``topic``: which
    policy, and the parameter that changes it (or, for a policy not exposed, that the peer must)."""
    policy = qos_policy_name_from_kind(policy_kind).lower()
    peer = "subscription" if entity == "publisher" else "publisher"
    exposed = policy in {kind.name.lower() for kind in OVERRIDABLE}
    fix = (
        f"set the parameter {override_parameter(topic, entity, policy)} to match it (e.g. in a params file)"
        if exposed
        else f"this node does not expose {policy}: the {peer}'s must change"
    )
    return f"{topic}: a {peer} with incompatible QoS ({policy}) gets no messages from this {entity}; {fix}"


def _once(node: Node, topic: str, entity: str) -> Callable[[QoSRequestedIncompatibleQoSInfo], None]:
    """An incompatible-QoS callback logging ``incompatible_line`` once per policy (discovery repeats it)."""
    said: set[int] = set()

    def callback(event: QoSRequestedIncompatibleQoSInfo) -> None:
        kind = int(event.last_policy_kind)
        if kind not in said:
            said.add(kind)
            node.get_logger().warning(incompatible_line(topic, entity, kind))

    return callback


def publisher_events(node: Node, topic: str) -> PublisherEventCallbacks:
    """Event callbacks of a publisher on ``topic``: one line per incompatible subscription's policy."""
    return PublisherEventCallbacks(incompatible_qos=_once(node, node.resolve_topic_name(topic), "publisher"))


def subscription_events(
    node: Node,
    topic: str,
    incompatible: Callable[[QoSRequestedIncompatibleQoSInfo], None] | None = None,
    message_lost: Callable[[QoSMessageLostInfo], None] | None = None,
) -> SubscriptionEventCallbacks:
    """Event callbacks of a subscription on ``topic``: one line per incompatible publisher's policy (or
    ``incompatible(event)`` instead, when given), and ``message_lost(event)`` when the middleware reports
    losses."""
    on_incompatible = incompatible or _once(node, node.resolve_topic_name(topic), "subscription")
    return SubscriptionEventCallbacks(incompatible_qos=on_incompatible, message_lost=message_lost)


# Any (msg_type): a message package's class; the packages ship no types (see AnyPublisher).
def make_publisher(node: Node, msg_type: Any, topic: str, qos: QoSProfile) -> AnyPublisher:
    """node.create_publisher with its own copy of ``qos``, the qos_overrides parameters and the one-line
    incompatible-QoS report."""
    return node.create_publisher(
        msg_type,
        topic,
        own_profile(qos),
        event_callbacks=publisher_events(node, topic),
        qos_overriding_options=qos_options(),
    )


def make_subscription(
    node: Node,
    # Any: a message package's class (untyped, see AnyPublisher); the callback gets raw CDR bytes, which
    # rclpy's types (callback of the message class) cannot say.
    msg_type: Any,
    topic: str,
    callback: Callable[[Any], None],
    qos: QoSProfile,
    *,
    incompatible: Callable[[QoSRequestedIncompatibleQoSInfo], None] | None = None,
    message_lost: Callable[[QoSMessageLostInfo], None] | None = None,
    best_effort: bool = False,
) -> AnySubscription:
    """node.create_subscription (raw CDR) with ``subscription_qos(qos)``, the qos_overrides parameters and
    the event callbacks of ``subscription_events``; ``best_effort``: best-effort reliability instead,
    which no parameter overrides (the switch a best-effort publisher asked for, see the estimator)."""
    profile = subscription_qos(qos)
    if best_effort:
        profile.reliability = ReliabilityPolicy.BEST_EFFORT
    return node.create_subscription(
        msg_type,
        topic,
        callback,
        profile,
        raw=True,
        event_callbacks=subscription_events(node, topic, incompatible, message_lost),
        qos_overriding_options=None if best_effort else qos_options(),
    )
