"""Start-up by name: is each of the chain's own readers subscribed, and matched, on a topic?

A subscriber count can be satisfied by a stranger (``ros2 topic echo``) before the chain's own
reader is there, and the chain then starts without it. The wait here asks the ROS graph *which*
nodes subscribe (``get_subscriptions_info_by_topic``: node name and namespace) and also asks DDS
whether the publisher has matched every compatible subscriber the graph lists, so the first
sample goes to every one of them (then the first-sample acknowledgement closes the handshake).
``wait_for_readers`` is the wait itself: it says every few seconds which readers it still waits for
(a peer process can take tens of seconds to import and subscribe on a loaded machine) and gives up
after a timeout with one line naming them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from rclpy.node import Node
from rclpy.qos import QoSCompatibility, qos_check_compatible

from pendulum_accel.nodes.qos import AnyPublisher


def qualified_name(name: str, namespace: str) -> str:
    """'/ns/name' of a node name: kept as is when it starts with '/', else put in ``namespace``."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


def node_names(entries: Sequence[str], namespace: str) -> list[str]:
    """The fully qualified names of the non-empty ``entries`` (see qualified_name)."""
    return [qualified_name(entry, namespace) for entry in entries if entry]


def missing_readers(node: Node, publisher: AnyPublisher, wanted: Sequence[str]) -> list[str]:
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


READY_STEADY_S = 0.1  # s every reader must stay matched before the wait ends (a match can flicker)
WAIT_NOTE_S = 10.0  # s between the lines that say which readers a wait still waits for


def describe_missing(missing: dict[str, list[str]]) -> str:
    """'topic: reader, reader; topic: reader' of a {topic: readers still missing} map."""
    return "; ".join(f"{topic}: {', '.join(names)}" for topic, names in missing.items())


def wait_for_readers(
    missing: Callable[[], dict[str, list[str]]],
    timeout: float,
    stopped: Callable[[], bool],
    note: Callable[[str], object],
    give_up: Callable[[str], object],
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], object] = time.sleep,
) -> bool:
    """True once ``missing()`` has stayed empty for READY_STEADY_S; False when ``stopped()``, or after
    ``timeout`` s with readers still missing (then one ``give_up`` line names them).

    While readers are missing, a ``note`` line names them every WAIT_NOTE_S, so whoever watches a slow
    start-up sees what it waits for. The note is checked before the timeout, so a wait longer than
    WAIT_NOTE_S always says what it waits for before it gives up.
    """
    start = clock()
    next_note = start + WAIT_NOTE_S
    ready_since: float | None = None
    while not stopped():
        waiting_for = missing()
        now = clock()
        if not waiting_for:
            ready_since = now if ready_since is None else ready_since
            if now - ready_since >= READY_STEADY_S:
                return True
        else:
            ready_since = None
            if now >= next_note:
                note(
                    f"waiting {now - start:.0f} s so far for the chain's readers (wait_timeout "
                    f"{timeout:g} s): {describe_missing(waiting_for)}"
                )
                next_note = now + WAIT_NOTE_S
            if now - start > timeout:
                give_up(
                    f"gave up after {timeout:g} s waiting for the chain's readers (raise wait_timeout "
                    f"if they are only slow to start): {describe_missing(waiting_for)}"
                )
                return False
        sleep(0.01)
    return False
