"""``pendulum_sim``: publishes a scene's measured angle, true acceleration, string state and /clock.

The whole scene is simulated up front by the ROS-free core (``scene_run.run_scene``) and serialised
in bulk (``bag.cdr_layout.Layout``), so publishing is a loop over ready CDR rows: the same scene and
seed always give the same bytes. ``realtime`` paces the loop by the wall clock and logs its jitter;
otherwise it runs as fast as the subscribers take the messages (reliable keep-all QoS blocks the
publisher when a reader lags, so nothing is lost) and the graph follows /clock.

Topic names are relative (``pendulum/joint_states``, ``car/accel/truth``, ``pendulum/string``,
``pendulum/markers``, ``robot_description``), so a namespace or a remap applies; /clock is global.
The URDF of the scene's pendulum goes out once on ``robot_description`` (std_msgs/String, reliable,
transient local, depth 1: what robot_state_publisher offers, so late subscribers get it), and a
MarkerArray in base_link (string, bob, true-acceleration arrow) at 30 Hz of simulated time.

A managed node (rclpy.lifecycle): configure builds the scene and the publishers, activate starts
publishing, deactivate stops it; ``autostart`` (default true) runs both at start-up.

``time_source``: ``sim`` stamps from the scene's t = 0 and, with ``publish_clock`` (which ``run`` and the
launch file set, as ``ros2 bag play --clock``), publishes /clock; ``wall`` (real time only) stamps each
sample with the ROS clock at its due time and publishes no /clock. Publishing
starts once the nodes named in ``reader_nodes`` and ``recorder_node`` subscribe (by name: other
subscribers change nothing), and the first sample is acknowledged by every matched reader.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from collections.abc import Sequence

import numpy as np
from geometry_msgs.msg import AccelStamped
from numpy.typing import NDArray
from rcl_interfaces.msg import SetParametersResult
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.errors import ParameterError, PendulumAccelError
from pendulum_accel.nodes.conversions import restamp, stamp_offset
from pendulum_accel.nodes.graph import missing_readers, node_names, wait_for_readers
from pendulum_accel.nodes.parameters import SIMULATOR
from pendulum_accel.nodes.qos import DATA_QOS, DESCRIPTION_QOS, AnyPublisher, make_publisher
from pendulum_accel.nodes.runtime import (
    AnyParameter,
    ManagedNode,
    acked_within,
    change_result,
    declare_parameters,
    parameter_values,
    publish_blocking,
    run_node,
    write_summary,
)
from pendulum_accel.overrides import OVERRIDES, apply_overrides
from pendulum_accel.recording import visual
from pendulum_accel.recording.generate import Frames, serialise_run
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.scene_run import run_scene

NODE_NAME = "pendulum_sim"
OVERRIDE_NAMES = tuple(spec.name for spec in OVERRIDES)
"""The parameters the scene is built from (overrides.OVERRIDES): a change of one restarts it."""
_ACK_WARN_S = 10.0  # s between warnings about a reader that does not acknowledge


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


class SimulatorNode(ManagedNode):
    """Publishes one scene: parameters pick the scene, override its physics and choose the pacing."""

    def __init__(self) -> None:
        """Declare parameters (PendulumAccelError on a bad scene), then configure and activate when
        ``autostart``."""
        super().__init__(NODE_NAME)
        # The parameters' defaults and the base scene come from one read of the scene (a recorded log's
        # table takes seconds to read).
        scene_once = functools.cache(load_scene)
        values = declare_parameters(
            self, SIMULATOR, lambda name: {spec.name: spec.get(scene_once(name)) for spec in OVERRIDES}
        )
        self._base_scene = scene_once(str(values["scene"]))
        self.realtime = bool(values["realtime"])
        self.exit_on_end = bool(values["exit_on_end"])
        self.time_source = str(values["time_source"])
        self.publish_clock = bool(values["publish_clock"])
        namespace = self.get_namespace()
        self.reader_nodes = node_names(values["reader_nodes"], namespace)
        self.recorder_node = node_names([str(values["recorder_node"])], namespace)
        self.wait_timeout = float(values["wait_timeout"])
        self.clock_rate_hz = float(values["clock_rate_hz"])
        self._frame = str(values["frame_prefix"]) + bm.FRAME_ID  # the truth's and the markers' frame
        # The joint states' frame: base_link as ever, and none with a prefix (as robots' joint_states), where
        # an unprefixed base_link would name another robot's frame and no prefixed one measures the joint.
        self._joint_frame = "" if values["frame_prefix"] else bm.FRAME_ID
        self.summary_file = str(values["summary_file"])
        self._outputs: dict[str, AnyPublisher] = {}
        self.counts: dict[str, int] = {}
        self.unacknowledged: list[str] = []
        self._extra: list[AnyPublisher] = []
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._parameters_applied)
        self._restart = threading.Event()
        self._frames: Frames | None = None  # the scene's samples, built once per scene (not per activation)
        self._next_sample = 0
        self.published = 0
        self.start(bool(values["autostart"]))

    # -- lifecycle --------------------------------------------------------------------------------

    def configure(self) -> None:
        """Build the scene, its samples and the publishers; publish the URDF on robot_description."""
        if self.time_source == "wall" and not self.realtime:
            raise ParameterError(
                "time_source wall needs realtime true: a sample's wall stamp is its due time on the "
                "wall clock, which only a paced run has"
            )
        self.scene = self._scene_from(self._override_values())
        self._outputs = {
            bm.JOINT_STATES: make_publisher(self, JointState, bm.JOINT_STATES, DATA_QOS),
            bm.ACCEL_TRUTH: make_publisher(self, AccelStamped, bm.ACCEL_TRUTH, DATA_QOS),
        }
        if self.time_source == "sim" and self.publish_clock:
            self._outputs[bm.TOPIC_CLOCK] = make_publisher(self, Clock, bm.TOPIC_CLOCK, DATA_QOS)
        self._markers = make_publisher(self, MarkerArray, bm.MARKERS, DATA_QOS)
        self._description = make_publisher(self, String, bm.ROBOT_DESCRIPTION, DESCRIPTION_QOS)
        self._extra = [self._markers, self._description]
        self._publish_description()
        # The heavy work belongs to configure: activate then only publishes.
        self._frames, self._next_sample = self._simulate(), 0

    def _publish_description(self) -> None:
        """The URDF of the current scene's pendulum, once (transient local keeps it for late joiners)."""
        pendulum = self.scene.pendulum
        self._description.publish(String(data=visual.urdf(pendulum.length, mass=pendulum.mass)))

    def activate(self) -> None:
        """Start the publishing thread."""
        self.start_thread(self._publish_loop, "pendulum_sim_publisher")

    def deactivate(self) -> None:
        """Stop the publishing thread; a later activate goes on from the next sample (time never jumps
        back: /clock and the stamps continue)."""
        self.stop_thread()

    def cleanup(self) -> None:
        """Destroy the publishers configure made, and forget the scene's samples (configure starts over)."""
        self._frames, self._next_sample = None, 0
        for publisher in [*self._outputs.values(), *self._extra]:
            self.destroy_publisher(publisher)
        self._outputs, self._extra = {}, []

    # -- parameters ---------------------------------------------------------------------------

    def _override_values(self, changes: Sequence[AnyParameter] = ()) -> dict[str, float]:
        """Current override parameter values, with ``changes`` applied on top."""
        return parameter_values(self, OVERRIDE_NAMES, changes)

    def _scene_from(self, values: dict[str, float]) -> Scene:
        """The base scene with the override values (PendulumAccelError naming a bad value)."""
        return apply_overrides(self._base_scene, values)

    def _validate_parameters(self, params: list[AnyParameter]) -> SetParametersResult:
        """Accept a change only if the scene it makes is valid; otherwise keep the old value and say why.
        Other parameters (the qos_overrides each publisher declares at start up) leave the scene alone."""
        for param in params:
            if isinstance(param.value, float) and not math.isfinite(param.value):
                return SetParametersResult(
                    successful=False, reason=f"{param.name} must be finite, got {param.value}"
                )
        if not any(p.name in OVERRIDE_NAMES for p in params):
            return SetParametersResult(successful=True)
        return change_result(lambda: self._scene_from(self._override_values(params)))

    def _parameters_applied(self, params: list[AnyParameter]) -> None:
        """A physics change restarts the scene at t = 0 with the new values (receivers see time jump back)."""
        if any(p.name in OVERRIDE_NAMES for p in params):
            self.scene = self._scene_from(self._override_values())
            if self._extra:
                self._publish_description()
            self.get_logger().info(
                "parameters changed ("
                + ", ".join(f"{p.name}={p.value}" for p in params)
                + "): restarting the scene"
            )
            self._restart.set()

    # -- publishing -----------------------------------------------------------------------------

    def _missing(self) -> dict[str, list[str]]:
        """{topic: named readers not yet matched}: reader_nodes on the angles, the recorder on every topic."""
        missing: dict[str, list[str]] = {}
        for topic, publisher in self._outputs.items():
            wanted = list(self.recorder_node)
            if topic == bm.JOINT_STATES:
                wanted += self.reader_nodes
            names = missing_readers(self, publisher, wanted) if wanted else []
            if names:
                missing[topic] = names
        return missing

    def _wait_for_subscribers(self) -> bool:
        """True once every named reader is matched; False on timeout or stop (see wait_for_readers)."""
        logger = self.get_logger()
        return wait_for_readers(
            self._missing, self.wait_timeout, self._stop.is_set, logger.info, logger.error
        )

    def _acknowledged(self) -> bool:
        """Wait until every matched reader acknowledged all published (warn every 10 s); False if stopped."""
        for topic, publisher in self._outputs.items():
            started = time.monotonic()
            while not acked_within(publisher, _ACK_WARN_S, self._stop.is_set):
                if self._stop.is_set():
                    return False
                self.get_logger().warning(
                    f"{topic}: a reader has not acknowledged for {time.monotonic() - started:.0f} s "
                    "(a subscriber that does not take its messages holds a keep-all writer back); waiting"
                )
                if topic not in self.unacknowledged:
                    self.unacknowledged.append(topic)
        return True

    def _count(self, role: str, n: int) -> None:
        """Add n to the published count of ``role``, kept under its resolved name (what the bag holds)."""
        name = self._outputs[role].topic_name
        self.counts[name] = self.counts.get(name, 0) + n

    def _publish(self, topic: str, data: bytes) -> None:
        """Publish CDR bytes on ``topic``, waiting out a full keep-all history unless stopping."""
        publish_blocking(self._outputs[topic], data, self._stop.is_set)

    def _publish_loop(self) -> None:
        """Thread body: simulate, wait for subscribers, publish every sample, then exit or idle."""

        try:
            while not self._stop.is_set():
                if self._restart.is_set() or self._frames is None:
                    self._restart.clear()
                    self._frames = self._simulate()
                    self._next_sample = 0
                elif self._next_sample:  # re-activated: go on where the deactivation stopped it
                    self.get_logger().info(
                        f"resuming at sample {self._next_sample} of {self._frames.size} "
                        f"(t = {self._frames.t[min(self._next_sample, self._frames.size - 1)]:.3f} s)"
                    )
                frames = self._frames
                if bm.TOPIC_STRING in frames.rows and bm.STRING not in self._outputs:
                    self._outputs[bm.STRING] = make_publisher(self, JointState, bm.STRING, DATA_QOS)
                if not self._wait_for_subscribers():
                    if not self._stop.is_set():  # timed out (a stop is a deactivate or a signal)
                        self.finish(1)
                    return
                self.get_logger().info(f"subscribers matched: publishing ({self.time_source} time)")
                completed = self._publish_frames(frames, self._next_sample)
                if completed:
                    self._acknowledged()
                if self._restart.is_set():
                    continue
                if self._stop.is_set():
                    return
                if self.exit_on_end:
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

    def _simulate(self) -> Frames:
        """The scene's samples, serialised (logged with the time they took)."""
        scene = self.scene
        wall0 = time.perf_counter()
        frames = serialise_run(run_scene(scene), self.clock_rate_hz, self._frame, self._joint_frame)
        self.get_logger().info(
            f"scene {scene.name}: {frames.size} samples over {frames.t[-1] - frames.t[0]:.3f} s simulated "
            f"in {time.perf_counter() - wall0:.2f} s; {frames.plan}"
        )
        return frames

    def _stamp_wall(self, frames: Frames, start: float, first: int) -> None:
        """Stamp samples first.. with the ROS clock at their due time start + t − t0 (perf_counter)."""
        wall0_ns = self.get_clock().now().nanoseconds - round((time.perf_counter() - start) * 1e9)
        due_ns = wall0_ns + bm.seconds_to_ns(frames.t[first:] - frames.t[0])
        for topic, rows in frames.rows.items():
            offset = stamp_offset(bm.TOPIC_TYPES[topic])
            assert offset is not None  # every topic of the frames is stamped
            restamp(rows[first:], offset, due_ns)
        mask = self._marker_mask[first:]
        self._marker_rows[int(self._marker_mask[:first].sum()) :] = visual.swing_marker_rows(
            due_ns[mask],
            self._theta[first:][mask],
            self._accel[first:][mask],
            self._length,
            self._frame,
        )

    def _prepare_markers(self, frames: Frames) -> None:
        """The MarkerArray rows of this run (MARKER_RATE_HZ of simulated time), from the published θ and a."""
        # Read back with the layouts they were written in: a frame's length moves every field after it.
        joint_state = bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0], frame_id=self._joint_frame)
        joint = Layout.of(joint_state, bm.JOINT_STATE)
        truth = Layout.of(bm.accel_stamped(0, 0.0, self._frame), bm.ACCEL_STAMPED)
        self._theta = joint.decode(frames.rows[bm.TOPIC_JOINT_STATES], ["position[0]"])["position[0]"]
        self._accel = truth.decode(frames.rows[bm.TOPIC_ACCEL_TRUTH], ["accel.linear.x"])["accel.linear.x"]
        self._length = float(self.scene.pendulum.length)
        self._marker_mask = visual.marker_mask(frames.t)
        ns = bm.seconds_to_ns(frames.t)[self._marker_mask]
        self._marker_rows = visual.swing_marker_rows(
            ns,
            self._theta[self._marker_mask],
            self._accel[self._marker_mask],
            self._length,
            self._frame,
        )

    def _publish_frames(self, frames: Frames, first: int = 0) -> bool:
        """Publish the samples from ``first`` on in order, paced by the wall clock in real-time mode; True
        when all went. ``_next_sample`` follows, so a re-activation goes on from there."""
        joint = frames.rows[bm.TOPIC_JOINT_STATES]
        # frames hold the root-namespace names; the publishers are keyed by role (relative names).
        others = [
            (str(bm.role_of(topic)), rows)
            for topic, rows in frames.rows.items()
            if topic != bm.TOPIC_JOINT_STATES
        ]
        self._prepare_markers(frames)
        # Everything the loop reads per sample, looked up once: it runs for every sample, and its own
        # Python (numpy scalar indexing, attribute and dict lookups) was a tenth of the node's CPU.
        marker_due = self._marker_mask.tolist()  # a list of bools: 8 bytes a sample
        clock_due = frames.clock_mask.tolist()
        marker_next = int(self._marker_mask[:first].sum())  # the next marker's and clock's rows
        clock_next = int(frames.clock_mask[:first].sum())
        clock_out = self._outputs.get(bm.TOPIC_CLOCK)
        joint_out = self._outputs[bm.JOINT_STATES]
        other_outs = [(self._outputs[topic], rows) for topic, rows in others]
        stopping, restarting = self._stop.is_set, self._restart.is_set
        clocks = 0
        lateness = np.empty(frames.size)
        t_rel = frames.t - frames.t[0]
        start = time.perf_counter() - float(t_rel[first])  # sample ``first`` is due now
        if self.time_source == "wall":
            self._stamp_wall(frames, start, first)
        sent = 0
        for i in range(first, frames.size):
            if stopping() or restarting():
                break
            if self.realtime:
                due = start + t_rel[i]
                now = time.perf_counter()
                if due > now:
                    time.sleep(due - now)
                    now = time.perf_counter()
                lateness[i] = now - due
            if clock_out is not None and clock_due[i]:
                publish_blocking(clock_out, frames.clock_rows[clock_next].tobytes(), stopping)
                clock_next += 1
                clocks += 1
            publish_blocking(joint_out, joint[i].tobytes(), stopping)
            for out, rows in other_outs:
                publish_blocking(out, rows[i].tobytes(), stopping)
            if marker_due[i]:
                # Visual only: not waited for, not in the accounting.
                publish_blocking(self._markers, self._marker_rows[marker_next].tobytes(), stopping)
                marker_next += 1
            sent += 1
            self._next_sample = i + 1
            if i == first:
                # Handshake: readers acknowledge only once their side of discovery has matched this
                # writer. Until then a keep-all writer fills up and blocks, which stalled the first
                # seconds of fast runs; one acknowledged sample proves every reader is ready.
                if not self._acknowledged():
                    break
                self.get_logger().info(
                    f"first sample acknowledged by every reader after {time.perf_counter() - start:.2f} s"
                )
                if self.time_source != "wall":
                    start = time.perf_counter() - float(t_rel[first])
                # On wall time the schedule keeps the first sample's due time: every stamp is t0 + k·dt,
                # as a sensor's, and the samples due during the handshake go out late (in the jitter).
        for topic in frames.rows:
            self._count(str(bm.role_of(topic)), sent)
        if clocks:
            self._count(bm.TOPIC_CLOCK, clocks)
        self.published += sent
        wall = time.perf_counter() - start
        span = float(t_rel[first + sent - 1] - t_rel[first]) if sent else 0.0
        factor = f"{span / wall:.1f}" if wall > 0 else "inf"
        mode = "real time" if self.realtime else "as fast as possible"
        line = (
            f"published {sent}/{frames.size} samples ({span:.3f} s simulated) in {wall:.3f} s wall, "
            f"{mode}: real-time factor {factor}"
        )
        if self.realtime:
            line += "; " + jitter_summary(lateness[first : first + sent])
        self.get_logger().info(line)
        return self._next_sample == frames.size

    def close(self) -> None:
        """Stop publishing, then write the counters (published per topic) to summary_file."""
        super().close()
        write_summary(
            self.summary_file,
            {
                "published": self.counts,
                "time_source": self.time_source,
                "unacknowledged": self.unacknowledged,
            },
        )


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``pendulum_sim``: run the simulator node until the scene ends or a signal."""
    return run_node(SimulatorNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
