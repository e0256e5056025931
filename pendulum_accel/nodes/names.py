"""The ROS names a chain starts with (``--namespace``, ``--remap``), checked with rcl's rules before any node.

A name rcl refuses kills each node at start-up with an rcl parse error, after the others have started;
checked here, it is one line and nothing starts. The rules are ROS's own:

* namespaces, topic names and full topic names: rclpy's validators (``rclpy.validate_namespace`` ...)
  and ``rclpy.expand_topic_name`` when rclpy imports, else the pure-Python copies below, which give
  the same verdicts (test_ros_names.py runs both over the same cases and random strings);
* remap rules: rcl's grammar (rcl/src/rcl/arguments.c), ``[node:]match:=replacement`` with
  ``match = [rostopic://|rosservice://][~/|/]TOKEN(/TOKEN)*`` and ``replacement = [~/|/]TOKEN(/TOKEN)*``,
  ``TOKEN = [A-Za-z_][A-Za-z0-9_]*`` without ``__`` (rclpy has no function for it; rcl's parser itself
  logs to stderr, so the test compares this grammar with it instead);
* every name a chain node would create (its topics and its parameter services) expanded under the
  namespace and the remaps must be a valid full topic name: at most 247 characters (RMW's limit).

``__node``/``__name``/``__ns`` rules are refused: the chain's nodes find each other by name, and its
namespace is ``--namespace``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

from pendulum_accel.bag import messages as bm
from pendulum_accel.errors import ParameterError

TOPIC_MAX_LENGTH = 247
"""RMW_TOPIC_MAX_NAME_LENGTH (255 - 8: room for the DDS prefixes)."""
NAMESPACE_MAX_LENGTH = TOPIC_MAX_LENGTH - 2
"""RMW_NAMESPACE_MAX_LENGTH."""

CHAIN_NODES = ("pendulum_sim", "accel_estimator", "bag_recorder")
"""The chain's node names (each node module's NODE_NAME)."""
CHAIN_NAMES = (
    bm.JOINT_STATES,
    bm.ACCEL_TRUTH,
    bm.STRING,
    bm.ACCEL_ESTIMATE,
    bm.IMU_DATA_RAW,
    bm.MARKERS,
    bm.ROBOT_DESCRIPTION,
    "~/set_parameters_atomically",  # the longest of every node's parameter services
    "~/get_type_description",
)
"""Relative names every chain node may create: its topics, its parameter services."""

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_ALNUM = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789")
_SPECIAL_RULES = ("__node", "__name", "__ns")

Problem = Callable[[str], "str | None"]


# --- pure-Python copies of rmw/rcl's validators: None when valid, else rmw/rcl's own reason -----------


def full_topic_name_problem(name: str) -> str | None:
    """rmw_validate_full_topic_name: absolute, [A-Za-z0-9_/], no '//', no token starting with a digit,
    no trailing '/', at most TOPIC_MAX_LENGTH characters."""
    if not name:
        return "topic name must not be empty"
    if name[0] != "/":
        return "topic name must be absolute, it must lead with a '/'"
    if name[-1] == "/":
        return "topic name must not end with a '/'"
    if any(c not in _ALNUM and c not in "_/" for c in name):
        return "topic name must not contain characters other than alphanumerics, '_', or '/'"
    if "//" in name:
        return "topic name must not contain repeated '/'"
    if any(token[:1].isdigit() for token in name.split("/")):
        return "topic name must not have a token that starts with a number"
    if len(name) > TOPIC_MAX_LENGTH:
        return f"topic length should not exceed {TOPIC_MAX_LENGTH}"
    return None


def namespace_problem(namespace: str) -> str | None:
    """rmw_validate_namespace: '/' or a full topic name of at most NAMESPACE_MAX_LENGTH characters."""
    if namespace == "/":
        return None
    problem = full_topic_name_problem(namespace)
    if problem is not None and not problem.startswith("topic length"):
        if problem.endswith("end with a '/'"):
            return "namespace must not end with a '/', unless only a '/'"
        return problem.replace("topic name", "namespace")
    if len(namespace) > NAMESPACE_MAX_LENGTH:
        return f"namespace should not exceed {NAMESPACE_MAX_LENGTH}"
    return None


def topic_name_problem(name: str) -> str | None:
    """rcl_validate_topic_name: a relative, private ('~/...') or absolute name with {substitutions}."""
    if not name:
        return "topic name must not be empty string"
    if name[0] in "0123456789":
        return "topic name token must not start with a number"
    if name[-1] == "/":
        return "topic name must not end with a forward slash"
    opened: int | None = None
    for i, c in enumerate(name):
        if c in _ALNUM:
            if c.isdigit() and opened is not None and i - 1 == opened:
                return "substitution name must not start with a number"
        elif c == "_":
            continue
        elif c == "/":
            if opened is not None:
                return "substitution name must not contain characters other than alphanumerics or '_'"
        elif c == "~":
            if i != 0:
                return "topic name must not have tilde '~' unless it is the first character"
        elif c == "{":
            if opened is not None:
                return "substitution name must not contain characters other than alphanumerics or '_'"
            opened = i
        elif c == "}":
            if opened is None:
                return "topic name must not have unmatched (unbalanced) curly braces '{}'"
            opened = None
        elif opened is not None:
            return "substitution name must not contain characters other than alphanumerics or '_'"
        else:
            return "topic name must not contain characters other than alphanumerics, '_', '~', '{', or '}'"
    if opened is not None:
        return "topic name must not have unmatched (unbalanced) curly braces '{}'"
    for i in range(len(name) - 1):
        if name[i] == "/" and name[i + 1] in "0123456789":
            return "topic name token must not start with a number"
        if i == 1 and name[0] == "~" and name[1] != "/":
            return "topic name must not have a tilde '~' that is not followed by a forward slash '/'"
    return None


def expand_topic_name(name: str, node: str, namespace: str) -> str:
    """rcl_expand_topic_name: '~' -> the node's full name, {node}/{ns}/{namespace} substituted, a relative
    name prefixed by the namespace; ValueError for an unknown substitution."""
    node_fqn = f"{namespace.rstrip('/')}/{node}"
    if name.startswith("~"):
        name = node_fqn + name[1:]  # rcl replaces the '~' alone: '~x' becomes '/ns/nodex'
    values = {"node": node, "ns": namespace, "namespace": namespace}

    def substitute(match: re.Match[str]) -> str:
        """The value of one {substitution}."""
        key = match.group(1)
        if key not in values:
            raise ValueError(f"unknown substitution: {{{key}}}")
        return values[key]

    name = re.sub(r"\{([^}]*)\}", substitute, name)
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


# --- rclpy's validators when rclpy imports (same verdicts, same reasons) ------------------------------


def _rclpy_problem(validate: Callable[[str], object]) -> Problem:
    """A ``*_problem`` function from an rclpy validator: None, or the first line of its exception."""

    def problem(name: str) -> str | None:
        """None when ``validate`` accepts ``name``, else its reason (without the caret drawing)."""
        try:
            validate(name)
        except Exception as err:  # rclpy's Invalid*Exception (and ValueError for odd input)
            text = str(err).splitlines()[0].rstrip(":").strip()
            return text.split(": ", 1)[1] if text.startswith("Invalid ") and ": " in text else text
        return None

    return problem


def validators(use_rclpy: bool = True) -> tuple[Problem, Problem, Problem, Callable[[str, str, str], str]]:
    """(namespace_problem, topic_name_problem, full_topic_name_problem, expand_topic_name): rclpy's when
    ``use_rclpy`` and it imports, else this module's copies."""
    if use_rclpy:
        try:
            from rclpy.expand_topic_name import expand_topic_name as rclpy_expand
            from rclpy.validate_full_topic_name import validate_full_topic_name
            from rclpy.validate_namespace import validate_namespace
            from rclpy.validate_topic_name import validate_topic_name
        except ImportError:
            pass
        else:
            return (
                _rclpy_problem(validate_namespace),
                _rclpy_problem(validate_topic_name),
                _rclpy_problem(validate_full_topic_name),
                rclpy_expand,
            )
    return namespace_problem, topic_name_problem, full_topic_name_problem, expand_topic_name


# --- rcl's remap grammar ----------------------------------------------------------------------------


def _token(text: str) -> bool:
    """rcl's TOKEN lexeme: [A-Za-z_][A-Za-z0-9_]* with no '__' (that starts another lexeme)."""
    return bool(_TOKEN.match(text)) and "__" not in text


def _name(text: str, *, match_side: bool) -> bool:
    """rcl's match (``[rostopic://|rosservice://][~/|/]TOKEN(/TOKEN)*``) or replacement (no URL) name."""
    if match_side:
        for url in ("rostopic://", "rosservice://"):
            if text.startswith(url):
                text = text[len(url) :]
                break
    if text.startswith("~/"):
        text = text[2:]
    elif text.startswith("/"):
        text = text[1:]
    return all(_token(part) for part in text.split("/"))


def split_rule(rule: str) -> tuple[str, str, str] | None:
    """(node prefix or '', match, replacement) of ``[node:]match:=replacement``, None without ':='.

    The first ':=' splits the rule (as rcl's lexer reads it); a ``rostopic://``/``rosservice://`` URL is
    part of the match, not a node prefix."""
    head, sep, replacement = rule.partition(":=")
    if not sep:
        return None
    node = ""
    if not head.startswith(("rostopic://", "rosservice://")) and ":" in head:
        node, _, head = head.partition(":")
    return node, head, replacement


def remap_syntax_ok(rule: str) -> bool:
    """True when rcl parses ``rule`` as a remap rule: ``[node:]__ns:=/ns/``, ``[node:]__node:=TOKEN``
    (or ``__name``), or ``[node:]match:=replacement`` (see the module docstring)."""
    parts = split_rule(rule)
    if parts is None:
        return False
    node, match, replacement = parts
    if (node and not _token(node)) or (node == "" and rule.startswith(":")):
        return False
    if match == "__ns":
        body = replacement[1:]
        if body.endswith("/") and len(body) > 1:
            body = body[:-1]
        return replacement.startswith("/") and (body == "" or all(_token(p) for p in body.split("/")))
    if match in ("__node", "__name"):
        return _token(replacement)
    return _name(match, match_side=True) and _name(replacement, match_side=False)


# --- the chain's check ------------------------------------------------------------------------------


def fully_qualified_namespace(namespace: str) -> str:
    """The node namespace ``--namespace NS`` means: '/' + NS without leading or trailing '/' ('' for none)."""
    return "/" + namespace.strip("/") if namespace.strip("/") else ""


def check_chain_names(namespace: str, remaps: Sequence[str], *, use_rclpy: bool = True) -> None:
    """ParameterError (one line) unless every node of the chain can start with ``namespace`` and ``remaps``:
    the namespace is a ROS namespace, each rule a remap rule rcl parses (and not __node/__name/__ns),
    and every name a chain node creates, expanded and remapped, is a valid full topic name."""
    ns_problem, topic_problem, full_problem, expand = validators(use_rclpy)
    node_ns = fully_qualified_namespace(namespace) or "/"
    problem = ns_problem(node_ns)
    if problem is not None:
        if "exceed" in problem:  # rclpy's text names a C macro; say the number
            problem = f"longer than {NAMESPACE_MAX_LENGTH} characters"
        raise ParameterError(
            f"--namespace {_shown(namespace)} is not a ROS namespace: {problem}; nothing started"
        )
    rules: list[tuple[str, str, str]] = []
    for rule in remaps:
        if not remap_syntax_ok(rule):
            match, sep, replacement = rule.partition(":=")
            why = "it must read FROM:=TO"
            for side, text in (("FROM", match), ("TO", replacement)):
                side_problem = topic_problem(text) if sep else None
                if side_problem is not None:
                    why = f"{side} {_shown(text)}: {side_problem}"
                    break
            else:
                if sep:
                    why = (
                        "FROM and TO must be ROS names: tokens [A-Za-z_][A-Za-z0-9_]* (no '__') joined by '/'"
                    )
            raise ParameterError(f"--remap {_shown(rule)} is not a ROS remap rule: {why}; nothing started")
        node, match, replacement = split_rule(rule) or ("", "", "")
        if match in _SPECIAL_RULES:
            raise ParameterError(
                f"--remap {_shown(rule)}: the chain's node names and namespace are its own "
                "(use --namespace); nothing started"
            )
        rules.append((node, match.split("://")[-1], replacement))
    # Every chain name as each node resolves it, and every rule's target even where it matches nothing
    # yet (a node of a later version, or a typo in FROM, would meet it at run time).
    targets = [
        (node, _resolved(name, node, node_ns, rules, expand)) for name in CHAIN_NAMES for node in CHAIN_NODES
    ]
    targets += [(node, expand(to, node, node_ns)) for _, _, to in rules for node in CHAIN_NODES]
    for node, full in targets:
        problem = full_problem(full)
        if problem is None:
            continue
        if "exceed" in problem:
            problem = f"longer than {TOPIC_MAX_LENGTH} characters"
        given = f"--namespace {_shown(namespace)}" if namespace else ""
        given += "".join(f" --remap {_shown(rule)}" for rule in remaps)
        raise ParameterError(
            f"node {node} would use the name {_shown(full)}, which ROS refuses: {problem} "
            f"(from {given.strip()}); nothing started"
        )


def _shown(text: str) -> str:
    """``text`` quoted, its middle elided past 60 characters (a 300-character name in one line)."""
    return repr(text) if len(text) <= 60 else f"{text[:40]!r}…({len(text)} characters)"


def _resolved(
    name: str,
    node: str,
    namespace: str,
    rules: Sequence[tuple[str, str, str]],
    expand: Callable[[str, str, str], str],
) -> str:
    """The full name ``node`` uses for ``name``: expanded, then replaced by the first rule that matches
    it (rcl_remap_topic_name: the match and the replacement are expanded for the node too)."""
    full = expand(name, node, namespace)
    for rule_node, match, replacement in rules:
        if rule_node and rule_node != node:
            continue
        if expand(match, node, namespace) == full:
            return expand(replacement, node, namespace)
    return full


PUBLISHERS: dict[str, str] = {
    **dict.fromkeys(
        (bm.JOINT_STATES, bm.ACCEL_TRUTH, bm.STRING, bm.MARKERS, bm.ROBOT_DESCRIPTION, bm.TOPIC_CLOCK),
        "pendulum_sim",
    ),
    bm.ACCEL_ESTIMATE: "accel_estimator",
    bm.IMU_DATA_RAW: "accel_estimator",
}
"""The node that publishes each chain role (the global /diagnostics has one from every node)."""


def publisher_topic_map(namespace: str, remaps: Sequence[str]) -> dict[str, str]:
    """{role: full name} of each chain role as the node that publishes it resolves it under ``namespace``
    and ``remaps`` (rcl's rules, as check_chain_names applies them; rules already checked): the names
    the nodes' counters carry, so that a remapped or namespaced run's accounting finds its roles."""
    expand = validators(use_rclpy=False)[3]
    node_ns = fully_qualified_namespace(namespace) or "/"
    rules = []
    for rule in remaps:
        node, match, replacement = split_rule(rule) or ("", "", "")
        rules.append((node, match.split("://")[-1], replacement))
    return {role: _resolved(role, node, node_ns, rules, expand) for role, node in PUBLISHERS.items()}
