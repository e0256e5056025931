"""One ``qos_overrides`` parameter changes one entity: each publisher and subscription of each node, in turn.

rclpy writes an entity's overrides into the QoSProfile object it is given (``_declare_qos_parameters``), so
entities created from one shared profile took each other's overrides: an Imu publisher set transient-local
made the angle subscription transient-local too (a volatile angle publisher then got no estimate), and
the log blamed the subscription's parameter. Here every node runs once per entity, in its own namespace,
with that entity's reliability and durability both flipped; the graph must show that entity flipped and
every other endpoint of the node at its default.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.nodes.launcher import ParamValue, node_command
from pendulum_accel.nodes.parameters import IMU_TOPIC
from pendulum_accel.nodes.qos import qos_for
from test.chain_helpers import Output, run_probe
from test.conftest import REPO, Spawn

pytestmark = [pytest.mark.ros]

GOLDEN = REPO / "bags" / "lecture_constant"
FLIPPED = {"reliable": "best_effort", "best_effort": "reliable", "volatile": "transient_local"}
FLIPPED["transient_local"] = "volatile"
TIME_SOURCE = [bm.TOPIC_CLOCK, "subscription", "best_effort", "volatile"]
"""rclpy's own /clock subscription (TimeSource, use_sim_time: every node here is on sim time), not one of
the node's entities: no qos_overrides parameter sets it."""
NODE_NAMES = {
    "simulator_node": "pendulum_sim",
    "estimator_node": "accel_estimator",
    "recorder_node": "bag_recorder",
    "player_node": "bag_player",
}


def _default(topic: str, kind: str) -> tuple[str, str]:
    """(reliability, durability) the graph shows for an entity left alone: its role's profile; a
    subscription's best_available reads reliable (no best-effort publisher is on the graph)."""
    return "reliable", qos_for(topic).durability.name.lower()


def _entities(module: str, namespace: str) -> list[tuple[str, str]]:
    """(resolved topic, kind) of every entity the node ``module`` makes in ``namespace``."""

    def resolved(name: str) -> str:
        """``name`` resolved in ``namespace``."""
        return name if name.startswith("/") else f"{namespace}/{name}"

    if module == "simulator_node":
        names = [bm.JOINT_STATES, bm.ACCEL_TRUTH, bm.STRING, bm.MARKERS, bm.ROBOT_DESCRIPTION, bm.TOPIC_CLOCK]
        return [(resolved(n), "publisher") for n in names]
    if module == "estimator_node":
        names = [bm.ACCEL_ESTIMATE, bm.TOPIC_DIAGNOSTICS, IMU_TOPIC, bm.MARKERS]
        return [(resolved(n), "publisher") for n in names] + [(resolved(bm.JOINT_STATES), "subscription")]
    if module == "recorder_node":
        return [(resolved(n), "subscription") for n in bm.CHAIN_ROLES]
    return [(topic, "publisher") for topic in read_bag(GOLDEN).topics]  # the player: the bag's names


def _params(module: str, tmp_path: Path, k: int) -> dict[str, ParamValue]:
    """Parameters that make ``module`` create every entity and then wait (no reader, no data flow)."""
    if module == "simulator_node":
        # Waits for its (absent) reader, every publisher made; lecture_constant has a string topic.
        return {"scene": "lecture_constant", "publish_clock": True, "wait_timeout": 600.0}
    if module == "estimator_node":
        return {"scene": "lecture_constant"}
    if module == "recorder_node":
        return {"path": str(tmp_path / f"bag{k}")}
    return {"path": str(GOLDEN), "start_paused": True}


def _flip(topic: str, kind: str) -> dict[str, ParamValue]:
    """The two qos_overrides that flip the entity's reliability and durability."""
    reliability, durability = _default(topic, kind)
    return {
        f"qos_overrides.{topic}.{kind}.reliability": FLIPPED[reliability],
        f"qos_overrides.{topic}.{kind}.durability": FLIPPED[durability],
    }


@pytest.mark.parametrize("module", ["simulator_node", "estimator_node", "recorder_node", "player_node"])
def test_an_override_changes_its_own_entity_and_no_other(spawn: Spawn, tmp_path: Path, module: str) -> None:
    """One instance per entity (namespace /qK), all at once; each with its entity's overrides. The graph
    lists every endpoint of every instance: the overridden one flipped, the others at their defaults."""
    entities = _entities(module, "/q0")
    nodes: list[Output] = []
    expected: dict[str, list[list[str]]] = {}
    topics: set[str] = {bm.TOPIC_CLOCK}
    for k, (_, kind) in enumerate(entities):
        namespace = f"/q{k}"
        own = _entities(module, namespace)
        topic = own[k][0]
        params: Mapping[str, Any] = {**_params(module, tmp_path, k), **_flip(topic, kind)}
        nodes.append(Output(spawn(node_command(module, params, namespace=namespace))))
        name = f"{namespace}/{NODE_NAMES[module]}"
        rows = []
        for i, (entity_topic, entity_kind) in enumerate(own):
            reliability, durability = _default(entity_topic, entity_kind)
            if i == k:
                reliability, durability = FLIPPED[reliability], FLIPPED[durability]
            rows.append([entity_topic, entity_kind, reliability, durability])
            topics.add(entity_topic)
        expected[name] = sorted([*rows, TIME_SOURCE])
    count = sum(len(rows) for rows in expected.values())
    # Counted over these nodes only: the previous parametrisation's nodes, stopped, may linger in the graph
    # until their lease ends, and filled the count before /q7's last endpoint was discovered (CI, once).
    result = run_probe(spawn, {"qos_graph": [sorted(topics), count, 240.0, sorted(expected)]}, timeout=300)
    seen: dict[str, list[list[str]]] = {}
    for node, *row in result["qos_graph"]:
        seen.setdefault(node, []).append(row)
    for node, rows in expected.items():
        assert sorted(seen.get(node, [])) == rows, (node, [n.text for n in nodes])
