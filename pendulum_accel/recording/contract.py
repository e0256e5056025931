"""Is a bag the pendulum chain's? The offline commands ask the same question the estimator node asks of
each message (estimators.guard.joint_state_problem), once per shape of message in the bag.

A bag whose angles name another joint and not the pendulum's, or whose angle, truth or estimate carry
another frame (the truth's and estimate's: base_link under any frame prefix, as car1/base_link) is
refused with one line (analyze, allan, animate, export): figures computed from another robot's data
would look like figures of this one. Among a robot's joints, the pendulum's may be at any
place, the same in every message: the offline readers take ``angle_field`` (``position[k]``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag
from pendulum_accel.bag.shapes import TopicArrays
from pendulum_accel.errors import BagError
from pendulum_accel.estimators.guard import frame_problem, joint_state_problem

FRAMED_TOPICS = (bm.TOPIC_ACCEL_TRUTH, bm.TOPIC_ACCEL_ESTIMATE)
"""Topics whose header.frame_id must be the car's, under any frame prefix (the angle's is checked with its
joint). The Imu is not among them: its frame may be an ``imu_frame_id`` of the estimator's (docs/ros.md)."""


def unprefixed(frame_id: str) -> str:
    """``frame_id`` without a frame prefix: the part after its last '/' ('car1/base_link' → 'base_link').
    A namespaced chain stamps its truth and estimate in its frame_prefix + base_link, as
    robot_state_publisher's frame_prefix names a robot's frames, so a multi-robot TF tree keeps them apart."""
    return frame_id.rsplit("/", 1)[-1]


def _checks() -> list[tuple[str, str | None]]:
    """(root topic, message type) of every topic the contract checks."""
    return [(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)] + [
        (topic, bm.topic_type(topic)) for topic in FRAMED_TOPICS
    ]


def decode_chain(
    bag: Bag, requests: Mapping[str, tuple[str | None, Sequence[str] | None]]
) -> dict[str, TopicArrays]:
    """bag.decode_topics(requests) of a bag that keeps the chain contract, in one pass over the file that
    also finds the shapes check_chain_contract asks about; BagError (check_chain_contract's line first,
    when the bag breaks it, even where the decoding broke before it) otherwise."""
    try:
        decoded = bag.decode_topics(requests, shapes=[bag.chain_topic(root) for root, _ in _checks()])
    except BagError:
        check_chain_contract(bag)  # a foreign bag's refusal says more than what its data broke
        raise
    check_chain_contract(bag)  # from the shapes the pass found: no other pass
    return decoded


def require_angles(bag: Bag) -> str:
    """The bag's angle topic (its chain name for pendulum/joint_states); BagError when it has none, in one
    line that names the bag's topics and the flag that reads the angles from another."""
    topic = bag.chain_topic(bm.TOPIC_JOINT_STATES)
    if topic not in bag.topics:
        known = ", ".join(sorted(bag.topics)) or "none"
        raise BagError(
            f"bag {bag.path} has no angles: no topic {topic} (topics: {known}); "
            f"--topic {bm.TOPIC_JOINT_STATES.lstrip('/')}=NAME reads them from topic NAME"
        )
    return topic


def joint_index(names: Sequence[str], joint: str) -> int:
    """The place of ``joint`` among a JointState's ``names``; 0 for a bare angle (no names) or a message
    without it (which the contract refuses)."""
    return names.index(joint) if joint in names else 0


def angle_field(bag: Bag) -> str:
    """``position[k]``: the column the offline readers take θ from, k the chosen joint's place in the
    angles' first message (check_chain_contract refuses a bag where another message has it elsewhere)."""
    topic = bag.chain_topic(bm.TOPIC_JOINT_STATES)
    first = bag.first_payload(topic) if topic in bag.topics else None
    if first is None:
        return "position[0]"
    try:
        msg = bm.deserialize(first, bm.JOINT_STATE)
    except BagError:
        return "position[0]"  # the decoding pass says what is wrong with it
    return f"position[{joint_index([str(n) for n in getattr(msg, 'name', [])], bag.choice.joint)}]"


def check_chain_contract(bag: Bag) -> None:
    """BagError (one line) unless every pendulum/joint_states message passes joint_state_problem and every
    message of FRAMED_TOPICS passes frame_problem, each found by its role under any namespace; topics the
    bag lacks are not checked here."""
    checks = _checks()
    hint = "; --joint NAME reads another joint's angles" if bag.choice.joint == bm.PENDULUM_JOINT else ""
    frame_hint = "; --joint-frame FRAME accepts angles stamped in FRAME"
    bag.find_shapes([bag.chain_topic(root) for root, _ in checks])  # one pass for all
    places: set[int] = set()
    for root, msgtype in checks:
        topic = bag.chain_topic(root)
        if topic not in bag.topics or bag.topics[topic].count == 0:
            continue
        total = bag.topics[topic].count
        for msg, count in bag.shapes(topic, msgtype):
            header = getattr(msg, "header", None)
            frame = str(header.frame_id) if header is not None else None
            advice = ""
            if root == bm.TOPIC_JOINT_STATES:
                names = [str(n) for n in getattr(msg, "name", [])]
                joint = bag.choice.joint
                problem = joint_state_problem(names, frame, joint, bag.choice.joint_frame)
                # The flag that answers it: the rule's own phrase for the names alone, or for the frame.
                if problem is not None and problem == joint_state_problem(names, None, joint):
                    advice = hint
                elif problem is not None:
                    advice = frame_hint
                places.add(joint_index(names, joint))
                if problem is None and len(places) > 1:
                    problem = (
                        f"{joint!r} is at places {sorted(places)} among the joints of different messages: "
                        "the offline commands read it at one place"
                    )
            else:
                problem = None
                if frame is not None and frame_problem(unprefixed(frame)) is not None:
                    problem = f"frame_id {frame[:40]!r}, not {bm.FRAME_ID!r} under a frame prefix"
            if problem is not None:
                raise BagError(
                    f"bag {bag.path}: {count} of {total} {topic} messages are not the pendulum chain's "
                    f"({problem}); refused: another robot's data would pass for this pendulum's{advice}"
                )
