"""``pendulum_sim``: publishes a scene's measured angle, true acceleration, string state and /clock.

The whole scene is simulated up front by the ROS-free core (``scene_run.run_scene``) and serialised
in bulk (``bag.messages.Layout``), so publishing is a loop over ready CDR rows: the same scene and
seed always give the same bytes. ``realtime`` paces the loop by the wall clock and logs its jitter;
otherwise it runs as fast as the subscribers take the messages (reliable keep-all QoS blocks the
publisher when a reader lags, so nothing is lost) and the graph follows /clock.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence

import numpy as np
from geometry_msgs.msg import AccelStamped
from numpy.typing import NDArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from pendulum_accel.bag import messages as bm
from pendulum_accel.errors import PendulumAccelError
from pendulum_accel.nodes.parameters import SIMULATOR
from pendulum_accel.nodes.qos import DATA_QOS
from pendulum_accel.nodes.runtime import (
    ThreadedNode,
    change_result,
    declare_parameters,
    parameter_values,
    publish_blocking,
    run_node,
)
from pendulum_accel.overrides import OVERRIDES, apply_overrides
from pendulum_accel.recording.generate import Frames, serialise_run
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.scene_run import run_scene

NODE_NAME = "pendulum_sim"
_ACK_TIMEOUT = Duration(seconds=10)


def jitter_summary(lateness: NDArray[np.float64]) -> str:
    """'jitter (publish − due): median …, p99 …, max … µs over n samples' for lateness in seconds."""
    if lateness.size == 0:
        return "jitter: no samples"
    us = lateness * 1e6
    med, p99 = np.percentile(us, [50.0, 99.0])
    return (
        f"jitter (publish − due): median {med:.0f} µs, p99 {p99:.0f} µs, max {us.max():.0f} µs "
        f"over {us.size} samples"
    )


class SimulatorNode(ThreadedNode):
    """Publishes one scene: parameters pick the scene, override its physics and choose the pacing."""

    def __init__(self) -> None:
        """Declare parameters, build the scene (PendulumAccelError on a bad one) and start publishing."""
        super().__init__(NODE_NAME)
        values = declare_parameters(
            self, SIMULATOR, lambda name: {spec.name: spec.get(load_scene(name)) for spec in OVERRIDES}
        )
        self._base_scene = load_scene(str(values["scene"]))
        self.realtime = bool(values["realtime"])
        self.exit_on_end = bool(values["exit_on_end"])
        self.wait_for_subscribers = int(values["wait_for_subscribers"])
        self.wait_for_recorder = bool(values["wait_for_recorder"])
        self.wait_timeout = float(values["wait_timeout"])
        self.clock_rate_hz = float(values["clock_rate_hz"])
        self.scene = self._scene_from(self._override_values())
        self._outputs: dict[str, Publisher] = {
            bm.TOPIC_CLOCK: self.create_publisher(Clock, bm.TOPIC_CLOCK, DATA_QOS),
            bm.TOPIC_JOINT_STATES: self.create_publisher(JointState, bm.TOPIC_JOINT_STATES, DATA_QOS),
            bm.TOPIC_ACCEL_TRUTH: self.create_publisher(AccelStamped, bm.TOPIC_ACCEL_TRUTH, DATA_QOS),
        }
        self._string_publisher: Publisher | None = None
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._parameters_applied)
        self._restart = threading.Event()
        self.published = 0
        self.start_thread(self._publish_loop, "pendulum_sim_publisher")

    # -- parameters ---------------------------------------------------------------------------

    def _override_values(self, changes: Sequence[Parameter] = ()) -> dict[str, float]:
        """Current override parameter values, with ``changes`` applied on top."""
        return parameter_values(self, [spec.name for spec in OVERRIDES], changes)

    def _scene_from(self, values: dict[str, float]) -> Scene:
        """The base scene with the override values (PendulumAccelError naming a bad value)."""
        return apply_overrides(self._base_scene, values)

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Accept a change only if the scene it makes is valid; otherwise keep the old value and say why."""
        for param in params:
            if isinstance(param.value, float) and not math.isfinite(param.value):
                return SetParametersResult(
                    successful=False, reason=f"{param.name} must be finite, got {param.value}"
                )
        return change_result(lambda: self._scene_from(self._override_values(params)))

    def _parameters_applied(self, params: list[Parameter]) -> None:
        """A physics change restarts the scene at t = 0 with the new values (receivers see time jump back)."""
        if any(p.name in {spec.name for spec in OVERRIDES} for p in params):
            self.scene = self._scene_from(self._override_values())
            self.get_logger().info(
                "parameters changed ("
                + ", ".join(f"{p.name}={p.value}" for p in params)
                + "): restarting the scene"
            )
            self._restart.set()

    # -- publishing -----------------------------------------------------------------------------

    def _wait_for_subscribers(self, topics: Sequence[str]) -> bool:
        """True once the subscriber counts reach what the wait_* parameters ask; False on timeout or stop."""
        deadline = time.monotonic() + self.wait_timeout
        while not self._stop.is_set():
            counts = {topic: self._outputs[topic].get_subscription_count() for topic in topics}
            ok = counts[bm.TOPIC_JOINT_STATES] >= self.wait_for_subscribers
            if self.wait_for_recorder:
                ok = ok and all(c >= 1 for c in counts.values())
            if ok:
                return True
            if time.monotonic() > deadline:
                self.get_logger().error(
                    f"gave up after {self.wait_timeout:g} s waiting for subscribers: {counts}"
                )
                return False
            time.sleep(0.01)
        return False

    def _publish(self, topic: str, data: bytes) -> None:
        """Publish CDR bytes on ``topic``, waiting out a full keep-all history unless stopping."""
        publish_blocking(self._outputs[topic], data, self._stop.is_set)

    def _publish_loop(self) -> None:
        """Thread body: simulate, wait for subscribers, publish every sample, then exit or idle."""

        try:
            while not self._stop.is_set():
                self._restart.clear()
                scene = self.scene
                wall0 = time.perf_counter()
                frames = serialise_run(run_scene(scene), self.clock_rate_hz)
                self.get_logger().info(
                    f"scene {scene.name}: {frames.size} samples over "
                    f"{frames.t[-1] - frames.t[0]:.3f} s simulated in {time.perf_counter() - wall0:.2f} s; "
                    f"{frames.plan}"
                )
                if bm.TOPIC_STRING in frames.rows and bm.TOPIC_STRING not in self._outputs:
                    self._outputs[bm.TOPIC_STRING] = self.create_publisher(
                        JointState, bm.TOPIC_STRING, DATA_QOS
                    )
                if not self._wait_for_subscribers([*frames.rows, bm.TOPIC_CLOCK]):
                    self.finish(1)
                    return
                self.get_logger().info("subscribers matched: publishing")
                completed = self._publish_frames(frames)
                if completed:
                    for publisher in self._outputs.values():
                        publisher.wait_for_all_acked(_ACK_TIMEOUT)
                if self._restart.is_set():
                    continue
                if self.exit_on_end or self._stop.is_set():
                    self.finish(0)
                    return
                self.get_logger().info(
                    "scene ended; idle (exit_on_end is false; change a parameter to restart)"
                )
                while not (self._stop.is_set() or self._restart.wait(0.1)):
                    pass
        except PendulumAccelError as err:
            self.get_logger().error(str(err))
            self.finish(2)

    def _publish_frames(self, frames: Frames) -> bool:
        """Publish every sample in order, paced by the wall clock in real-time mode; True when all went."""
        joint = frames.rows[bm.TOPIC_JOINT_STATES]
        others = [(topic, rows) for topic, rows in frames.rows.items() if topic != bm.TOPIC_JOINT_STATES]
        clock_index = np.cumsum(frames.clock_mask) - 1
        lateness = np.empty(frames.size)
        t_rel = frames.t - frames.t[0]
        start = time.perf_counter()
        sent = 0
        for i in range(frames.size):
            if self._stop.is_set() or self._restart.is_set():
                break
            if self.realtime:
                due = start + t_rel[i]
                now = time.perf_counter()
                if due > now:
                    time.sleep(due - now)
                    now = time.perf_counter()
                lateness[i] = now - due
            if frames.clock_mask[i]:
                self._publish(bm.TOPIC_CLOCK, frames.clock_rows[clock_index[i]].tobytes())
            self._publish(bm.TOPIC_JOINT_STATES, joint[i].tobytes())
            for topic, rows in others:
                self._publish(topic, rows[i].tobytes())
            sent += 1
            if i == 0:
                # Handshake: readers acknowledge only once their side of discovery has matched this
                # writer. Until then a keep-all writer fills up and blocks, which stalled the first
                # seconds of fast runs; one acknowledged sample proves every reader is ready.
                for publisher in self._outputs.values():
                    publisher.wait_for_all_acked(_ACK_TIMEOUT)
                start = time.perf_counter() - float(t_rel[0])
        self.published += sent
        wall = time.perf_counter() - start
        span = float(t_rel[sent - 1]) if sent else 0.0
        factor = f"{span / wall:.1f}" if wall > 0 else "inf"
        mode = "real time" if self.realtime else "as fast as possible"
        line = (
            f"published {sent}/{frames.size} samples ({span:.3f} s simulated) in {wall:.3f} s wall, "
            f"{mode}: real-time factor {factor}"
        )
        if self.realtime:
            line += "; " + jitter_summary(lateness[:sent])
        self.get_logger().info(line)
        return sent == frames.size


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``pendulum_sim``: run the simulator node until the scene ends or a signal."""
    return run_node(SimulatorNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
