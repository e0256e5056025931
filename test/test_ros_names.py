"""Names of a live chain: ``run --namespace`` and ``run --remap`` checked by ROS's own rules before any node
starts (nodes/names.py): rclpy's validators and rcl's remap grammar, and the pure-Python copies of both used
without rclpy, which must give the same verdicts on the same edge cases and random strings."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendulum_accel.errors import ParameterError
from test.conftest import cli
from test.refusal import one_line_error

_A300 = "a" * 300
BAD_NAMESPACES = [
    "..",
    ".",
    "~",
    "a//b",
    "car one",
    "car-1",
    "1car",
    "car🚗",
    "voiture_é",
    "{node}",
    "$HOME",
    _A300,
    "x --ros-args",
    "a" * 220,  # a valid namespace the chain's longest name (260 characters) overflows
]
BAD_REMAPS = [
    "..:=x",
    "pendulum/joint_states:=..",
    "a:=b:=c",
    "pendulum/joint_states:=an gles",
    "pendulum/joint_states:=anglés",
    "pendulum/joint_states:=" + _A300,
    "a:=" + _A300,
    "__node:=same",
    "__ns:=/car",
    "noassign",
    ":=b",
    "*:=b",
]


@pytest.mark.parametrize(
    "args",
    [("--namespace", ns) for ns in BAD_NAMESPACES] + [("--remap", rule) for rule in BAD_REMAPS],
    ids=[f"namespace-{ns[:12]}" for ns in BAD_NAMESPACES] + [f"remap-{rule[:30]}" for rule in BAD_REMAPS],
)
def test_a_name_ros_refuses_is_one_line_before_anything_starts(tmp_path: Path, args: tuple[str, str]) -> None:
    result = cli("run", "at_rest", *args, "--record", str(tmp_path / "bag"), timeout=60)
    line = one_line_error(result, "nothing started")
    assert len(line) < 400  # a 300-character name is elided, the line stays one readable line
    assert "started" not in result.stderr.replace("nothing started", "")  # no node was started
    assert not (tmp_path / "bag").exists()


# Names both validators see: the battery above, rcl's edge cases, and lengths around RMW's limits
# (namespace 245, full topic name 247 characters).
_EDGE_NAMES = [
    *BAD_NAMESPACES,
    "",
    "/",
    "//",
    "a",
    "/a",
    "/a/",
    "a/",
    "~/a",
    "~a",
    "~",
    "/~",
    "a~",
    "{ns}/a",
    "{node}",
    "{1a}",
    "{a/b}",
    "{a",
    "a}",
    "{{a}}",
    "_",
    "__",
    "/_1",
    "/1",
    "a/1b",
    "a__b",
    "A_Z09",
    "é",
    "a\tb",
    *("/" + "a" * (n - 1) for n in (244, 245, 246, 247, 248)),
]


def test_the_pure_validators_agree_with_rclpys() -> None:
    from pendulum_accel.nodes import names

    ros, pure = names.validators(use_rclpy=True), names.validators(use_rclpy=False)
    assert ros[0] is not names.namespace_problem  # rclpy imported: the comparison is real
    for name in _EDGE_NAMES + ["/" + n for n in _EDGE_NAMES]:
        for ros_check, pure_check in zip(ros[:3], pure[:3], strict=True):  # namespace, topic, full topic
            assert (ros_check(name) is None) == (pure_check(name) is None), (name, ros_check(name))
        if ros[1](name) is None:
            for ns in ("/", "/car1", "/car1/sub"):
                assert _expanded(ros[3], name, ns) == _expanded(pure[3], name, ns), (name, ns)


def _expanded(expand: Callable[[str, str, str], str], name: str, ns: str) -> str:
    """``expand(name, 'node', ns)``, or 'refused' for a ValueError (an unknown substitution)."""
    try:
        return expand(name, "node", ns)
    except ValueError:
        return "refused"


_NAME_PIECES = ["a", "b", "_", "1", "/", "~", "{", "}", "{node}", "{ns}", ".", " ", "é", "-", "a" * 60]


@settings(max_examples=1500, deadline=None)
@given(st.lists(st.sampled_from(_NAME_PIECES), max_size=8).map("".join))
def test_the_pure_validators_agree_with_rclpys_on_random_names(name: str) -> None:
    from pendulum_accel.nodes import names

    ros, pure = names.validators(use_rclpy=True), names.validators(use_rclpy=False)
    for candidate in (name, "/" + name):
        for ros_check, pure_check in zip(ros[:3], pure[:3], strict=True):
            assert (ros_check(candidate) is None) == (pure_check(candidate) is None), candidate
        if ros[1](candidate) is None:
            assert _expanded(ros[3], candidate, "/car1") == _expanded(pure[3], candidate, "/car1")


def _rcl_parses(rule: str) -> bool:
    """True when rcl itself parses ``-r rule`` (rclpy's Context.init: rcl_parse_arguments; no node)."""
    from rclpy.context import Context

    context = Context()
    try:
        context.init(["prog", "--ros-args", "-r", rule])
    except Exception:  # rclpy's RCLError ("Couldn't parse remap rule")
        return False
    finally:
        with contextlib.suppress(Exception):
            context.try_shutdown()
    return True


_RULE_PIECES = [
    "a",
    "b",
    "_",
    "1",
    "/",
    ":",
    "=",
    ":=",
    "~",
    "~/",
    "{",
    "}",
    ".",
    " ",
    "é",
    "__",
    "*",
    "__ns",
    "__node",
    "__name",
    "n:",
    "rostopic://",
    "rosservice://",
]
_EDGE_RULES = [
    *BAD_REMAPS,
    "a:=b",
    "n:a:=b",
    "/a:=/b",
    "~/a:=b",
    "a:=~/b",
    "rostopic://a:=b",
    "rostopic:///a:=b",
    "a:=rostopic://b",
    "__ns:=/",
    "__ns:=/a/",
    "__ns:=a",
    "__ns:=//",
    "__node:=x",
    "__name:=1x",
    "x:__node:=y",
    "n:n:a:=b",
    "a__b:=c",
    "_a:=b_",
    "a:={node}",
]


@settings(max_examples=1500, deadline=None)
@given(st.lists(st.sampled_from(_RULE_PIECES), min_size=1, max_size=8).map("".join))
def test_the_remap_grammar_is_rcls(rule: str) -> None:
    from pendulum_accel.nodes.names import remap_syntax_ok

    assert remap_syntax_ok(rule) == _rcl_parses(rule), rule


@pytest.mark.parametrize("rule", _EDGE_RULES)
def test_the_remap_grammar_is_rcls_on_the_edge_cases(rule: str) -> None:
    from pendulum_accel.nodes.names import remap_syntax_ok

    assert remap_syntax_ok(rule) == _rcl_parses(rule), rule


@pytest.mark.parametrize(
    ("namespace", "remaps"),
    [(ns, []) for ns in BAD_NAMESPACES] + [("", [rule]) for rule in BAD_REMAPS] + [("car1", ["a:=b"])],
)
def test_the_chain_check_is_the_same_without_rclpy(namespace: str, remaps: list[str]) -> None:
    from pendulum_accel.nodes.names import check_chain_names

    messages = []
    for use_rclpy in (True, False):
        try:
            check_chain_names(namespace, remaps, use_rclpy=use_rclpy)
            messages.append("accepted")
        except ParameterError as err:
            messages.append(str(err))
    assert messages[0] == messages[1]
    assert (messages[0] == "accepted") == (namespace == "car1")


def test_the_longest_accepted_namespace_is_the_limit_of_the_longest_chain_name() -> None:
    from pendulum_accel.nodes import names

    # '/' + NS + '/' + node + '/' + name: the longest node and name leave 247 - 3 - 15 - 25 characters.
    longest = max(
        len(f"/{node}/{name[2:]}") if name.startswith("~/") else len("/" + name)
        for node in names.CHAIN_NODES
        for name in names.CHAIN_NAMES
    )
    room = names.TOPIC_MAX_LENGTH - longest - 1
    names.check_chain_names("a" * room, [])
    with pytest.raises(ParameterError, match="longer than 247 characters"):
        names.check_chain_names("a" * (room + 1), [])


def test_the_chain_node_names_are_the_nodes_own() -> None:
    from pendulum_accel.nodes import estimator_node, recorder_node, simulator_node
    from pendulum_accel.nodes.names import CHAIN_NODES

    assert CHAIN_NODES == (simulator_node.NODE_NAME, estimator_node.NODE_NAME, recorder_node.NODE_NAME)
