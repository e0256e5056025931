"""``--topic ROLE=NAME``, ``--namespace NS`` and ``--joint NAME``: which of a bag's topics, and which
joint of its angles, the offline commands read (``recording.topic_rules``).
"""

from __future__ import annotations

import argparse

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag
from pendulum_accel.recording.topic_rules import TopicRules


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
    parser.add_argument(
        "--joint",
        default=bm.PENDULUM_JOINT,
        metavar="NAME",
        help="the pendulum's joint in the angles' JointState, as the estimator node's joint parameter "
        f"(default {bm.PENDULUM_JOINT})",
    )
    parser.add_argument(
        "--joint-frame",
        default=bm.FRAME_ID,
        metavar="FRAME",
        help="the frame_id the angles' JointState may carry besides none, as the estimator node's "
        f"joint_frame_id parameter (default {bm.FRAME_ID}; a real sensor's driver may stamp its own)",
    )


def namespace_topics(bag: Bag) -> list[str]:
    """The bag's topics in the chosen namespace (with the global /diagnostics); all without one."""
    ns = bag.choice.namespace
    return [t for t in bag.topics if not ns or bm.in_namespace(t, ns)]


def topic_rules(args: argparse.Namespace) -> TopicRules:
    """The TopicRules of a command's --topic, --namespace, --joint and --joint-frame."""
    return TopicRules(
        tuple(args.topic_roles),
        str(args.namespace or ""),
        str(getattr(args, "joint", bm.PENDULUM_JOINT)),
        str(getattr(args, "joint_frame", bm.FRAME_ID)),
    )


def choose_topics(bag: Bag, args: argparse.Namespace) -> Bag:
    """``bag`` reading the topics and joint ``args`` choose (--topic, --namespace, --joint) on top of its
    stored map."""
    return topic_rules(args).apply(bag)
