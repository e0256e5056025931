"""``--topic ROLE=NAME`` and ``--namespace NS``: which of a bag's topics the offline commands read.

A recording stores its chain's topic map (a remap or a namespace applied), and the commands follow it;
these options override it, or pick one chain of a bag that holds several.
"""

from __future__ import annotations

import argparse

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag
from pendulum_accel.errors import BagError


def add_topic_flags(parser: argparse.ArgumentParser) -> None:
    """Add --topic (repeatable) and --namespace to a command that reads a bag."""
    parser.add_argument(
        "--topic",
        dest="topic_roles",
        action="append",
        default=[],
        metavar="ROLE=NAME",
        help="read the chain role ROLE (e.g. pendulum/joint_states) from the bag's topic NAME (e.g. /angle); "
        "by default the topic map the recording stored, else the topic whose name ends with the role",
    )
    parser.add_argument(
        "--namespace",
        default="",
        metavar="NS",
        help="of a bag holding several chains (/car1/..., /car2/...), read the one in namespace NS",
    )


def topic_choice(
    topics: list[str], roles: dict[str, str], texts: list[str], namespace: str
) -> bm.TopicChoice:
    """The TopicChoice of a bag with ``topics`` and a stored map ``roles``, with the user's ``--topic``
    rules (``texts``) on top and ``namespace``; BagError (one line) for a rule that does not read
    ROLE=NAME, names no role, or names a topic the bag lacks, and for a namespace the bag has no topic in."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    # The stored map names one chain's topics: another namespace asked for sets it aside.
    chosen = {role: name for role, name in roles.items() if not ns or bm.in_namespace(name, ns)}
    for text in texts:
        role_text, sep, name = text.partition("=")
        if not sep or not name:
            raise BagError(f"--topic {text!r} must read ROLE=NAME (e.g. pendulum/joint_states=/angle)")
        try:
            role = bm.role_name(role_text)
        except ValueError as err:
            raise BagError(f"--topic {text!r}: {err}") from None
        if name not in topics:
            raise BagError(f"--topic {text!r}: the bag has no topic {name} (it has {', '.join(topics)})")
        chosen[role] = name
    if ns and not any(t.startswith(ns + "/") for t in topics):
        raise BagError(
            f"--namespace {namespace}: the bag has no topic under {ns}/ (it has {', '.join(topics)})"
        )
    return bm.TopicChoice(chosen, ns)


def namespace_topics(bag: Bag) -> list[str]:
    """The bag's topics in the chosen namespace (with the global /diagnostics); all without one."""
    ns = bag.choice.namespace
    return [t for t in bag.topics if not ns or bm.in_namespace(t, ns)]


def choose_topics(bag: Bag, args: argparse.Namespace) -> Bag:
    """``bag`` reading the topics ``args`` choose (--topic, --namespace) on top of its stored map."""
    bag.choice = topic_choice(
        list(bag.topics), bag.choice.roles, list(args.topic_roles), str(args.namespace or "")
    )
    return bag
