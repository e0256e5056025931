"""Which of a bag's topics, and which joint of its angles, the offline commands read.

A recording stores its chain's topic map (a remap or a namespace applied), and the commands follow it.
The user's rules (``--topic ROLE=NAME``, ``--namespace NS``, ``--joint NAME``, ``--joint-frame FRAME``) go
on top: they override the map, pick one chain of a bag that holds several, or name the pendulum's joint
and the frame its angles carry as the estimator node's ``joint`` and ``joint_frame_id`` parameters do.
One value, so that a fleet's every bag (on any worker) reads by the same rules.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag
from pendulum_accel.errors import ParameterError


@dataclass(frozen=True)
class TopicRules:
    """The user's ``--topic`` rules (``roles``, each 'ROLE=NAME'), ``--namespace``, ``--joint`` and
    ``--joint-frame``."""

    roles: tuple[str, ...] = ()
    namespace: str = ""
    joint: str = bm.PENDULUM_JOINT
    joint_frame: str = bm.FRAME_ID

    def apply(self, bag: Bag) -> Bag:
        """``bag`` reading by these rules on top of its stored map; ParameterError (one line) for a rule that
        does not read ROLE=NAME, names no role, a topic the bag lacks or one of another type than the role's,
        a namespace the bag has no topic in, or an empty joint name."""
        if not self.joint.strip():
            raise ParameterError("--joint must name the pendulum's joint, got ''")
        bag.choice = topic_choice(
            list(bag.topics),
            bag.choice.roles,
            list(self.roles),
            self.namespace,
            self.joint,
            self.joint_frame,
            types={name: topic.msgtype for name, topic in bag.topics.items()},
        )
        return bag


def topic_choice(
    topics: list[str],
    roles: dict[str, str],
    texts: list[str],
    namespace: str,
    joint: str = bm.PENDULUM_JOINT,
    joint_frame: str = bm.FRAME_ID,
    types: Mapping[str, str] | None = None,
) -> bm.TopicChoice:
    """The TopicChoice of a bag with ``topics`` and a stored map ``roles``, with the user's ``--topic``
    rules (``texts``) on top, ``namespace``, the pendulum's ``joint`` and its angles' ``joint_frame``;
    ParameterError (one line) for a rule that does not read ROLE=NAME, names no role, names a topic the bag
    lacks or (with the bag's ``types``, name -> message type) one whose type is not the role's
    (messages.ROLE_TYPES), and for a namespace the bag has no topic in: every command refuses it as
    it parses its options, info too, which reads no message of it."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    # The stored map names one chain's topics: another namespace asked for sets it aside.
    chosen = {role: name for role, name in roles.items() if not ns or bm.in_namespace(name, ns)}
    for text in texts:
        role_text, sep, name = text.partition("=")
        if not sep or not name:
            raise ParameterError(f"--topic {text!r} must read ROLE=NAME (e.g. pendulum/joint_states=/angle)")
        try:
            role = bm.role_name(role_text)
        except ValueError as err:
            raise ParameterError(f"--topic {text!r}: {err}") from None
        if name not in topics:
            raise ParameterError(
                f"--topic {text!r}: the bag has no topic {name} (it has {', '.join(topics)})"
            )
        expected = bm.ROLE_TYPES[role]
        if types is not None and types.get(name, expected) != expected:
            raise ParameterError(
                f"--topic {text!r}: topic {name} has type {types[name]}, expected {expected}"
            )
        chosen[role] = name
    if ns and not any(t.startswith(ns + "/") for t in topics):
        raise ParameterError(
            f"--namespace {namespace}: the bag has no topic under {ns}/ (it has {', '.join(topics)})"
        )
    return bm.TopicChoice(chosen, ns, joint, joint_frame)
