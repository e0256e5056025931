"""``bag_player``: publishes a bag's messages (raw CDR) with their original timing.

Options: ``rate`` factor, ``loop`` (the stamps jump back at each pass, which the estimator sees as a
reset), ``start_offset`` into the bag, a ``topics`` filter, and ``clock``: publish /clock from the
bag's log time (the recorded /clock, if any, is then not replayed).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from rclpy.duration import Duration
from rclpy.publisher import Publisher

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag, salvage_note
from pendulum_accel.errors import ParameterError
from pendulum_accel.nodes.conversions import message_class
from pendulum_accel.nodes.parameters import PLAYER
from pendulum_accel.nodes.qos import qos_for
from pendulum_accel.nodes.runtime import ThreadedNode, declare_parameters, publish_blocking, run_node
from pendulum_accel.recording.generate import clock_mask

NODE_NAME = "bag_player"
_ACK_TIMEOUT = Duration(seconds=10)


class PlayerNode(ThreadedNode):
    """Replays one bag into the graph from a publishing thread."""

    def __init__(self) -> None:
        """Declare parameters, read the bag (BagError when unreadable), create publishers, start playing."""
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PLAYER)
        path = str(values["path"])
        self.rate = float(values["rate"])
        self.loop = bool(values["loop"])
        self.start_offset = float(values["start_offset"])
        topics: list[str] = list(values["topics"])
        self.clock = bool(values["clock"])
        self.clock_rate_hz = float(values["clock_rate_hz"])
        self.exit_on_end = bool(values["exit_on_end"])
        self.wait_for_subscribers = int(values["wait_for_subscribers"])
        self.wait_for_recorder = bool(values["wait_for_recorder"])
        if not path:
            raise ParameterError("parameter path (the bag to play) is required")
        bag = read_bag(path)
        note = salvage_note(bag)
        if note:
            self.get_logger().warning(note)
        available = bag.topics
        wanted = [t for t in topics if t] or list(available)
        missing = [t for t in wanted if t not in available]
        if missing:
            raise ParameterError(f"bag {path} has no topic {missing[0]} (it has {', '.join(available)})")
        if self.clock:
            wanted = [t for t in wanted if t != bm.TOPIC_CLOCK]
        self._outputs: dict[str, Publisher] = {
            topic: self.create_publisher(message_class(available[topic].msgtype), topic, qos_for(topic))
            for topic in wanted
        }
        if self.clock:
            self._outputs[bm.TOPIC_CLOCK] = self.create_publisher(
                message_class(bm.CLOCK), bm.TOPIC_CLOCK, qos_for(bm.TOPIC_CLOCK)
            )
        start = bag.start_ns + round(self.start_offset * 1e9)
        self._messages = [(topic, ns, data) for topic, ns, data in bag.iter_raw(wanted) if ns >= start]
        if not self._messages:
            raise ParameterError(f"bag {path} has no messages after start_offset {self.start_offset:g} s")
        self.passes = 0
        self.published = 0
        self.start_thread(self._play, "bag_player")
        self.get_logger().info(
            f"playing {len(self._messages)} messages of {path} ({', '.join(wanted)}) at rate {self.rate:g}"
            + (", looping" if self.loop else "")
        )

    def _wait(self) -> bool:
        """True once /pendulum/joint_states has wait_for_subscribers subscribers and, with
        wait_for_recorder, every published topic has one (False if stopped while waiting)."""
        joint = self._outputs.get(bm.TOPIC_JOINT_STATES)

        def ready() -> bool:
            """The subscriber counts asked for are there."""
            if joint is not None and joint.get_subscription_count() < self.wait_for_subscribers:
                return False
            return not self.wait_for_recorder or all(
                publisher.get_subscription_count() >= 1 for publisher in self._outputs.values()
            )

        while not ready():
            if self._stop.wait(0.01):
                return False
        return True

    def _play(self) -> None:
        """Thread body: publish every message at (log time − first)/rate after the start, pass after pass."""
        if not self._wait():
            return
        times = np.array([ns for _, ns, _ in self._messages], dtype=np.int64)
        ticks = (
            clock_mask(times.astype(np.float64) * 1e-9, self.clock_rate_hz)
            if self.clock
            else np.zeros(times.size, dtype=bool)
        )
        stopping = self._stop.is_set
        while not stopping():
            start = time.perf_counter()
            for i, (topic, ns, data) in enumerate(self._messages):
                due = start + (ns - times[0]) * 1e-9 / self.rate
                delay = due - time.perf_counter()
                if delay > 0 and self._stop.wait(delay):
                    return
                if ticks[i]:
                    publish_blocking(
                        self._outputs[bm.TOPIC_CLOCK], bm.serialize(bm.clock(int(ns)), bm.CLOCK), stopping
                    )
                if not publish_blocking(self._outputs[topic], data, stopping):
                    return
                self.published += 1
            self.passes += 1
            if not self.loop:
                break
        for publisher in self._outputs.values():
            publisher.wait_for_all_acked(_ACK_TIMEOUT)
        self.get_logger().info(f"played {self.published} messages in {self.passes} pass(es)")
        if self.exit_on_end:
            self.finish(0)


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``bag_player``: play the bag, then exit (or loop until a signal)."""
    return run_node(PlayerNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
