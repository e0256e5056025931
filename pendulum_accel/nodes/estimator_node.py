"""``accel_estimator``: joint states in, acceleration estimates and input health (/diagnostics) out.

Each angle goes through ``estimators.guard.GuardedEstimator`` (drops NaN/inf, resets on a time jump
back, flags |θ| near 90°), then the chosen method; the estimate carries the input's stamp and its
variance in covariance[0]. Nothing non-finite is ever published.

The executor only takes each angle into a backlog (with its arrival time); a worker thread estimates
them in order and publishes /diagnostics every ``diagnostics_period``, so the parameter services and
the health report are served while a burst is worked off (also while a full backlog holds the executor:
it answers parameter requests as it waits, runtime.serve_parameter_requests), and a silent input goes STALE
``stale_after`` after its last arrival. The angles are taken by name (the ``joint`` parameter,
``pendulum_joint`` by default, among any other joints), from a reliable or a best-effort publisher
(``nodes.qos``).

Beside it, a ``sensor_msgs/Imu`` on ``imu/data_raw`` (REP-145): linear_acceleration is the specific
force in the car frame (REP-103), as an accelerometer at rest on a level road reads it: x = â (on
a level road the specific force along x is the car's acceleration), y = 0, z = +g (the pendulum
senses the specific force's direction in the x-z plane; its z component there is g). Covariance:
var(â) on x, ``unmeasured_accel_variance`` on y and z (not measured); orientation and angular
velocity are not measured: zeros, with covariance[0] = -1 as sensor_msgs/Imu asks.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from collections import deque
from collections.abc import Sequence
from typing import Any

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelWithCovarianceStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock
from rclpy.clock_type import ClockType
from rclpy.duration import Duration
from rclpy.event_handler import QoSMessageLostInfo, QoSRequestedIncompatibleQoSInfo
from rclpy.qos import QoSPolicyKind
from rclpy.serialization import deserialize_message
from rclpy.timer import Timer
from sensor_msgs.msg import Imu, JointState
from visualization_msgs.msg import MarkerArray

from pendulum_accel.bag import messages as bm
from pendulum_accel.errors import ParameterError, PendulumAccelError
from pendulum_accel.estimators import Estimator, make_estimator
from pendulum_accel.estimators.guard import GuardedEstimator, GuardReport, GuardState, InputGuard
from pendulum_accel.estimators.kalman import DEFAULT_PRESET
from pendulum_accel.estimators.motion import MotionChoice, stated_motion
from pendulum_accel.nodes.conversions import pendulum_angle, stamp_seconds
from pendulum_accel.nodes.diagnostics import diagnostic_array, hardware_id_of, status_name
from pendulum_accel.nodes.estimator_messages import angle_readers, output_writers
from pendulum_accel.nodes.graph import missing_readers, node_names
from pendulum_accel.nodes.parameters import ESTIMATOR, ESTIMATOR_CONFIG, IMU_TOPIC, SCENE_PRESET
from pendulum_accel.nodes.qos import (
    DATA_QOS,
    DIAGNOSTICS_QOS,
    AnyPublisher,
    AnySubscription,
    incompatible_line,
    left_best_available,
    make_publisher,
    make_subscription,
    offered_best_effort,
    override_parameter,
)
from pendulum_accel.nodes.runtime import (
    AnyParameter,
    ManagedNode,
    change_result,
    declare_parameters,
    parameter_values,
    publish_blocking,
    run_node,
    serve_parameter_requests,
    write_summary,
)
from pendulum_accel.nodes.static_tf import publish_static_transform
from pendulum_accel.recording import visual
from pendulum_accel.recording.settings import (
    estimator_settings,
    motion_choice,
    sensor_bias_settings,
    uses_preset,
)
from pendulum_accel.scene import Scene, load_scene

NODE_NAME = "accel_estimator"
ESTIMATOR_PARAMETERS = ("method", "lag", "preset", *(spec.name for spec in ESTIMATOR_CONFIG))
"""The parameters the estimator is built from: a change of one of them rebuilds it."""
_DRAIN_IDLE = 0.3  # s without input after a stop request: the queue is empty
_DRAIN_LIMIT = 10.0  # s: stop even if input keeps coming
# s after start-up the node waits for a publisher of the angles to be discovered before it subscribes (see
# _discovering): a Fast DDS participant missed in its start-up announcements is heard at its next periodic
# one (leaseDuration_announcementperiod, 3 s by default).
DISCOVERY_GRACE = 3.0
_DESCRIBE_WAIT = 10.0  # s close() waits for a rebuilt estimator's description (a steady-state solve)
# s: while the executor waits for room in a full backlog (backlog_limit), how often it answers parameter
# requests itself: they would otherwise wait behind every angle the middleware announced before them.
_SERVICE_POLL = 0.05


class EstimatorNode(ManagedNode):
    """Streams the chosen estimator over pendulum/joint_states; publishes estimates and diagnostics."""

    def __init__(self) -> None:
        """Declare parameters, then configure and activate when ``autostart`` (subscribing to the angles
        once the named readers of the outputs are there)."""
        super().__init__(NODE_NAME)
        self._born = time.monotonic()
        # The parameters' defaults and configure's sensor figures come from one read of the scene (a
        # recorded log's table takes seconds to read); the scene parameter is read-only.
        # Everything but a(t), which the estimator never reads (a long log's file is not read again here).
        self._scene_once = functools.cache(functools.partial(load_scene, motion=False))
        values = declare_parameters(self, ESTIMATOR, lambda name: estimator_settings(self._scene_once(name)))
        self.method = str(values["method"])
        self.warn_angle_deg = float(values["warn_angle_deg"])
        self.stale_after = float(values["stale_after"])
        self.diagnostics_period = float(values["diagnostics_period"])
        self.backlog_limit = int(values["backlog_limit"])
        self.time_source = str(values["time_source"])
        self.joint = str(values["joint"])
        if not self.joint.strip():
            raise ParameterError("joint must name the pendulum's joint in the input JointState, got ''")
        self.joint_frame_id = str(values["joint_frame_id"])
        self.frame_id = str(values["frame_id"])
        self.imu_frame_id = str(values["imu_frame_id"]) or self.frame_id
        self.frame_prefix = str(values["frame_prefix"])  # every frame it publishes: estimate, Imu, TF
        self.imu_offset = tuple(float(values[f"imu_offset_{axis}"]) for axis in "xyz")
        self.unmeasured_accel_variance = float(values["unmeasured_accel_variance"])
        namespace = self.get_namespace()
        self.reader_nodes = node_names(values["reader_nodes"], namespace)
        self.recorder_node = node_names([str(values["recorder_node"])], namespace)
        self.summary_file = str(values["summary_file"])
        self.hardware_id = hardware_id_of(str(values["hardware_id"]), namespace)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._parameters_applied)
        self.inputs = 0
        self.estimates = 0
        self.unpublished = 0  # estimates computed but not sent (a second stop request while blocked)
        self._last_stamp: tuple[int, int] | None = None  # (sec, nanosec) of the latest input
        # (t, sec, nanosec) of the inputs a lagged estimate may describe: its stamp is the described sample's.
        self._stamps: deque[tuple[float, int, int]] = deque()
        self._readers = angle_readers(self.joint, self.joint_frame_id, self.frame_prefix)
        self._read_input = self._readers[0]
        self._last_input = time.monotonic()
        # (arrival, CDR) of the angles taken by the executor, estimated in order by the worker thread.
        self._backlog: deque[tuple[float, bytes]] = deque()
        self._queue_changed = threading.Condition()
        self._worker_waits = False  # the worker waits for an angle: the next one notifies it
        self._producer_waits = False  # the executor waits for room in the backlog: the worker notifies it
        self._work_lock = threading.Lock()  # one estimator update, or its rebuild, at a time
        self._behind_said = False  # the backlog filled once: said (once per node)
        self._describer: threading.Thread | None = None  # the latest rebuild's _describe_rebuilt
        self._rebuilt_lines: tuple[str, ...] | None = None  # a rebuilt estimator's lines, the worker logs
        self._diagnostics_due = 0.0  # monotonic time of the next /diagnostics (0: at once)
        self._stopping_since: float | None = None
        self._subscription: AnySubscription | None = None
        self._publishers: list[AnyPublisher] = []
        self._timers: list[Timer] = []
        self._active = False
        self._marker_tick = -1
        self._best_effort = False  # the angles come best-effort (a best-effort publisher was seen)
        self._resubscribe = False  # subscribe again, best-effort, at the next tick
        self._incompatible_said: set[int] = set()
        self.lost = 0  # angles the middleware reports lost (best-effort input)
        self.start(bool(values["autostart"]))

    # -- lifecycle --------------------------------------------------------------------------------

    def configure(self) -> None:
        """Build the guarded estimator, the publishers and the timers (PendulumAccelError when bad)."""
        if any(self.imu_offset) and self.imu_frame_id == self.frame_id:
            raise ParameterError(
                "an Imu offset (imu_offset_x/y/z) needs imu_frame_id naming its own frame (e.g. imu_link), "
                f"not {self.frame_id}"
            )
        # The scene parameter is read-only: load it once for the sensor's bias and range.
        self._scene = self._own_scene()
        self.guarded = GuardedEstimator(self._build(self._config_values()), self._new_guard())
        self.estimate_publisher = make_publisher(
            self, AccelWithCovarianceStamped, bm.ACCEL_ESTIMATE, DATA_QOS
        )
        self.diagnostics_publisher = make_publisher(
            self, DiagnosticArray, bm.TOPIC_DIAGNOSTICS, DIAGNOSTICS_QOS
        )
        self.imu_publisher = make_publisher(self, Imu, IMU_TOPIC, DATA_QOS)
        self.marker_publisher = make_publisher(self, MarkerArray, bm.MARKERS, DATA_QOS)
        self._publishers = [
            self.estimate_publisher,
            self.diagnostics_publisher,
            self.imu_publisher,
            self.marker_publisher,
        ]
        self._build_writers()
        if self.imu_frame_id != self.frame_id:
            parent, child = self.frame_prefix + self.frame_id, self.frame_prefix + self.imu_frame_id
            x, y, z = self.imu_offset
            tf_static = publish_static_transform(self, parent, child, (x, y, z))
            self._publishers += [tf_static] if tf_static is not None else []
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timers = [self.create_timer(0.05, self._tick, clock=steady)]

    def activate(self) -> None:
        """Start the worker (estimates and /diagnostics); subscribe to the angles as soon as the named
        readers of the outputs are there."""
        self._active = True
        self._diagnostics_due = 0.0
        self.start_thread(self._work, "accel_estimator_worker")
        self._subscribe_when_ready()

    def deactivate(self) -> None:
        """Unsubscribe from the angles and stop the worker: no more estimates, and no /diagnostics (an
        inactive lifecycle node publishes nothing), until activated again."""
        self._active = False
        if self._subscription is not None:
            self.destroy_subscription(self._subscription)
            self._subscription = None
        self._halt_worker()

    def _halt_worker(self) -> None:
        """Stop the worker thread now (it may be waiting for work) and wait for it."""
        self._stop.set()
        with self._queue_changed:
            self._queue_changed.notify_all()
        self.stop_thread()

    def cleanup(self) -> None:
        """Destroy the publishers and timers configure made."""
        for timer in self._timers:
            self.destroy_timer(timer)
        for publisher in self._publishers:
            self.destroy_publisher(publisher)
        self._timers, self._publishers = [], []

    # -- configuration --------------------------------------------------------------------------

    # Any: each value has its own parameter's type (runtime.parameter_values).
    def _config_values(self, changes: Sequence[AnyParameter] = ()) -> dict[str, Any]:
        """method, lag, preset and the ESTIMATOR_CONFIG values, with ``changes`` applied on top."""
        return parameter_values(self, ESTIMATOR_PARAMETERS, changes)

    def _build(self, values: dict[str, Any]) -> Estimator:  # Any: as _config_values'
        """make_estimator(method, l, g, noise_std, rate_hz, damping[, lag, preset]); ParameterError if bad."""
        cfg = {k: float(v) for k, v in values.items() if k not in ("method", "lag", "preset")}
        if not all(math.isfinite(v) for v in cfg.values()):
            raise PendulumAccelError("estimator parameters must be finite")
        lag = float(values["lag"])
        method = str(values["method"])
        opts: dict[str, object] = {"lag": lag} if lag > 0.0 else {}  # lag = 0: every method's own estimate
        if uses_preset(method):
            opts["preset"] = self.motion(str(values["preset"])).preset
        # The options are checked by make_estimator at run time; their types are the parameters', by name.
        estimator = make_estimator(method, **cfg, **opts, **self._sensor_bias())  # type: ignore[arg-type]
        estimator.warm()  # its compiled step loads now, not behind the first angles
        return estimator

    def motion(self, preset: str) -> MotionChoice:
        """kalman's preset: the ``preset`` parameter, or with 'scene' the scene's (recording.settings)."""
        if preset != SCENE_PRESET:
            return stated_motion(preset, by="the preset parameter")
        scene = getattr(self, "_scene", None)
        if scene is None:
            return MotionChoice(DEFAULT_PRESET, "the scene does not load: the default preset")
        return motion_choice(scene)

    def latency(self) -> float:
        """Seconds between a sample and the estimate that describes it: the method's fixed lag (0: none)."""
        est = self.guarded.estimator
        return getattr(est, "lag_n", 0) / est.config.rate_hz

    def _own_scene(self) -> Scene | None:
        """The scene the ``scene`` parameter names, None when it does not load (no sensor figures then)."""
        try:
            return self._scene_once(str(self.get_parameter("scene").value))
        except PendulumAccelError:
            return None

    def _sensor_bias(self) -> dict[str, float]:
        """The scene's sensor bias fields, which widen the published variance (none without a scene)."""
        return {} if self._scene is None else sensor_bias_settings(self._scene)

    def _new_guard(self) -> InputGuard:
        """InputGuard at the configured rate, warn angle, stale limit and angle noise."""
        return InputGuard(
            rate_hz=float(self.get_parameter("rate_hz").value),
            warn_angle=math.radians(self.warn_angle_deg),
            stale_after=self.stale_after if self.stale_after > 0.0 else None,
            saturation_range=self._sensor_range(),
            joint=self.joint,
            noise_std=float(self.get_parameter("noise_std").value),
            joint_frame=self.joint_frame_id,
        )

    def _build_writers(self) -> None:
        """The estimate's, Imu's and marker's writers. Every frame carries frame_prefix (car1/base_link in
        /car1), so a multi-robot TF tree resolves each."""
        self._writers = output_writers(
            self.frame_prefix + self.frame_id,
            self.frame_prefix + self.imu_frame_id,
            float(self.get_parameter("gravity").value),
            self.unmeasured_accel_variance,
            float(self.get_parameter("length").value),
        )

    def _sensor_range(self) -> float:
        """The scene's sensor range R (rad; 0 = none), so readings clipped at ±R are flagged saturated."""
        return 0.0 if self._scene is None else float(self._scene.sensor.range)

    def _validate_parameters(self, params: list[AnyParameter]) -> SetParametersResult:
        """Accept a change only if the estimator it makes is valid; else keep the old value and say why.
        Other parameters (the qos_overrides each publisher declares) are not the estimator's: accepted."""
        if not any(p.name in ESTIMATOR_PARAMETERS for p in params):
            return SetParametersResult(successful=True)
        return change_result(lambda: self._build(self._config_values(params)))

    def _parameters_applied(self, params: list[AnyParameter]) -> None:
        """Rebuild the estimator from the new values; it starts over from the next sample. Only a change
        of what it is built from rebuilds it: each qos_overrides parameter a publisher declares at start
        up had rebuilt it once (20 times, the scene's motion read again each time)."""
        if not any(p.name in ESTIMATOR_PARAMETERS for p in params):
            return
        values = self._config_values()
        self.method = str(values["method"])
        if not hasattr(self, "guarded"):  # not configured yet: configure builds it from these values
            return
        # Built before the lock: only the swap waits for the update in progress.
        estimator = self._build(values)
        with self._work_lock:
            self.guarded.estimator = estimator
            self._build_writers()
            # The guard checks the input against these two (its counters go on).
            self.guarded.guard.rate_hz = float(values["rate_hz"])
            self.guarded.guard.noise_std = float(values["noise_std"])
        # A description may solve the filter's steady state (scipy): made beside the worker, so that neither
        # the parameter service's answer nor the estimates and /diagnostics wait for it.
        described = threading.Thread(
            target=self._describe_rebuilt, args=(estimator,), name="describe_rebuilt", daemon=True
        )
        self._describer = described
        described.start()
        if self._worker_stopped():  # nobody else will say it
            described.join()
            self._say_rebuilt()

    def _worker_stopped(self) -> bool:
        """True when no worker thread runs (not active)."""
        return self._thread is None or not self._thread.is_alive()

    def _describe_rebuilt(self, estimator: Estimator) -> None:
        """The log lines of a rebuilt estimator (its description and latency), for the worker to say; a
        description that comes after a newer rebuild's is dropped."""
        lines = (f"estimator rebuilt: {estimator.describe()}", f"latency {self.latency():.3f} s")
        if self.guarded.estimator is estimator:
            self._rebuilt_lines = lines
            with self._queue_changed:  # a waiting worker says them now, not at its next angle or status
                self._queue_changed.notify_all()

    def _say_rebuilt(self) -> None:
        """Log the lines _describe_rebuilt left, once."""
        lines, self._rebuilt_lines = self._rebuilt_lines, None
        for line in lines or ():
            self.get_logger().info(line)

    # -- data flow ------------------------------------------------------------------------------

    def _missing_readers(self) -> list[str]:
        """Named readers not yet on the outputs: reader_nodes on the estimate, the recorder on all three."""
        outputs = (
            (self.estimate_publisher, [*self.recorder_node, *self.reader_nodes]),
            (self.diagnostics_publisher, self.recorder_node),
            (self.imu_publisher, self.recorder_node),
        )
        missing: list[str] = []
        for publisher, wanted in outputs:
            if wanted:
                missing += missing_readers(self, publisher, wanted)
        return missing

    def _subscribe_when_ready(self) -> None:
        """Subscribe to the angles once every named reader of the outputs is subscribed and matched."""
        if self._subscription is not None or not self._active:
            return
        if not self._missing_readers() and not self._discovering():
            self._take_best_effort_if_offered()
            # The description may solve the filter's steady state (scipy): before subscribing, so the
            # first angles do not queue behind it.
            description = self.guarded.estimator.describe()
            self.holds_input()
            self._subscription = make_subscription(
                self,
                JointState,
                bm.JOINT_STATES,
                self._on_joint_state,
                DATA_QOS,
                incompatible=self._on_incompatible_angles,
                message_lost=self._on_lost,
                best_effort=self._best_effort,
            )
            self.get_logger().info(f"estimating with {description}")
            if uses_preset(self.method):
                self.get_logger().info(self.motion(str(self.get_parameter("preset").value)).line())
            self.get_logger().info(
                f"latency {self.latency():.3f} s: each estimate is stamped with the sample it describes"
            )
            # Status from the start, not one diagnostics period later: a short or fast run still
            # records how its estimator was doing.
            with self._queue_changed:
                self._diagnostics_due = 0.0
                self._queue_changed.notify_all()

    def _discovering(self) -> bool:
        """True while no publisher of the angles is known yet and the node is younger than
        DISCOVERY_GRACE: best_available reliability is settled by the publishers known as the subscription
        is made, so one made before a best-effort driver already on the graph is discovered asks reliable,
        and the driver and this node then each warn of the mismatch before the switch."""
        if self.count_publishers(self.resolve_topic_name(bm.JOINT_STATES)) > 0:
            return False
        return time.monotonic() - self._born < DISCOVERY_GRACE

    def _take_best_effort_if_offered(self) -> None:
        """Subscribe best-effort from the start when a known publisher of the angles is best-effort (a
        driver's SensorDataQoS) and reliability is left at best_available: what best_available asks, settled
        here from the graph, so that neither side meets a reliable subscription first and warns."""
        topic = self.resolve_topic_name(bm.JOINT_STATES)
        if not self._best_effort and left_best_available(self, topic) and offered_best_effort(self, topic):
            self._best_effort = True
            self.get_logger().info(
                f"{topic}: a best-effort publisher: taking its angles best-effort (losses are counted: "
                "'lost' on /diagnostics)"
            )

    def _on_incompatible_angles(self, event: QoSRequestedIncompatibleQoSInfo) -> None:
        """A publisher of the angles whose QoS this subscription refuses. A best-effort one (a hardware
        driver's SensorDataQoS) while reliability is left at best_available: subscribe again best-effort
        (the next tick), counting what is lost. Anything else: one line naming the parameter to set."""
        topic = self.resolve_topic_name(bm.JOINT_STATES)
        kind = int(event.last_policy_kind)
        parameter = override_parameter(topic, "subscription", "reliability")
        best_available = left_best_available(self, topic)
        if kind == int(QoSPolicyKind.RELIABILITY) and best_available and not self._best_effort:
            self._best_effort = True
            self._resubscribe = True
            self.get_logger().warning(
                f"{topic}: a best-effort publisher: taking its angles best-effort from now on (losses are "
                f"counted: 'lost' on /diagnostics); {parameter}:=reliable refuses it instead"
            )
        elif kind not in self._incompatible_said:
            self._incompatible_said.add(kind)
            self.get_logger().warning(incompatible_line(topic, "subscription", kind))

    def _on_lost(self, event: QoSMessageLostInfo) -> None:
        """Angles the middleware reports lost (a best-effort stream): counted, shown on /diagnostics."""
        self.lost += int(event.total_count_change)

    def _stopping(self) -> bool:
        """True once a second stop request made the node finish."""
        return self.finished.done()

    def _halted(self) -> bool:
        """True once the node finished or the worker is asked to stop (a deactivate)."""
        return self._stop.is_set() or self.finished.done()

    def _on_joint_state(self, data: bytes) -> None:
        """Take one angle sample (CDR) into the backlog, with its arrival time; wait while the backlog is
        full (back-pressure), unless the node is stopping, answering parameter requests while it waits. The
        lock is taken only to wait or to wake a waiting worker: this runs for every angle, and a lock round
        per angle cost as much as its estimate."""
        now = time.monotonic()
        self._last_input = now
        self.inputs += 1
        backlog = self._backlog
        if len(backlog) >= self.backlog_limit:  # one comparison per angle while there is room
            self._wait_for_room()
        backlog.append((now, data))  # deque.append and popleft are atomic: no lock for the hand-over
        if self._worker_waits:
            with self._queue_changed:
                self._queue_changed.notify_all()

    def _wait_for_room(self) -> None:
        """Wait while the backlog is full (back-pressure) and the node is not stopping, answering parameter
        requests meanwhile; say once that the estimator is slower than its input."""
        backlog = self._backlog
        if not self._behind_said:
            self._behind_said = True
            self.get_logger().warning(
                f"the estimator is slower than its input: {len(backlog)} angles wait (backlog_limit); the "
                "input is held back until it catches up (a best-effort publisher loses angles meanwhile)"
            )
        while len(backlog) >= self.backlog_limit and not (self._stop.is_set() or self._stopping()):
            with self._queue_changed:
                self._producer_waits = True
                if len(backlog) >= self.backlog_limit:
                    self._queue_changed.wait(_SERVICE_POLL)
                self._producer_waits = False
            # The executor is held here: the parameter requests it would run after the queued angles are
            # answered now (outside the lock: a parameter change takes the worker's _work_lock).
            serve_parameter_requests(self)

    def _work(self) -> None:
        """Worker thread: estimate the backlog in order and publish /diagnostics every diagnostics_period
        once subscribed to the angles (also while a backlog is worked off, and while the input is silent),
        until the node deactivates."""
        backlog = self._backlog
        while not self._stop.is_set():
            subscribed = self._subscription is not None
            if not backlog:
                with self._queue_changed:
                    # The flag first, then the look: an angle appended after the look sees the flag and
                    # wakes this wait (the GIL orders the two threads' steps).
                    self._worker_waits = True
                    # Until subscribed nothing is due: wait for the subscription's notify (or a stop).
                    due = self._diagnostics_due - time.monotonic() if subscribed else self.diagnostics_period
                    if not backlog:
                        self._queue_changed.wait(max(0.0, due))
                    self._worker_waits = False
            if self._rebuilt_lines is not None:
                self._say_rebuilt()
            item = backlog.popleft() if backlog else None
            if item is not None:
                if self._producer_waits:
                    with self._queue_changed:
                        self._queue_changed.notify_all()
                # Only the update holds the lock: publishing may wait for a slow reader (keep-all), and a
                # parameter change waiting for the lock behind it took seconds (issue 58).
                with self._work_lock:
                    outputs = self._estimate(*item)
                if outputs is not None:
                    self._publish_estimate(*outputs)
            # From the subscription on: before it, the node waits for its own readers, not for input.
            if subscribed and time.monotonic() >= self._diagnostics_due:
                self._diagnostics_due = time.monotonic() + self.diagnostics_period
                with self._work_lock:
                    self._publish_diagnostics()

    def _estimate(self, now: float, data: bytes) -> tuple[int, int, bytes, bytes, float] | None:
        """â for one angle sample (CDR) that arrived at ``now``, stamped like it: (sec, nanosec, estimate
        CDR, Imu CDR, â) to publish; None when the guard drops it or it warms up."""
        fields = self._read_input(data)
        if fields is None and len(self._readers) > 1:
            fields = self._readers[1](data)
        # The fast path's shape names ``joint`` in joint_frame_id already; any other shape (no velocity,
        # more joints, another frame) goes through rclpy and the guard's joint_state_problem.
        names: list[str] | None = None
        frame_id: str | None = None
        if fields is None:
            msg = deserialize_message(data, JointState)
            sec, nanosec, theta = (
                msg.header.stamp.sec,
                msg.header.stamp.nanosec,
                pendulum_angle(msg, self.joint),
            )
            names, frame_id = list(msg.name), str(msg.header.frame_id)
        else:
            sec, nanosec, theta = fields
        self._last_stamp = (sec, nanosec)
        t = stamp_seconds(sec, nanosec)
        self._stamps.append((t, sec, nanosec))
        estimate = self.guarded.update(t, theta, now, names, frame_id)
        if estimate is None:
            self._trim_stamps()
            return None
        if estimate.time is not None and estimate.time != t:  # a lagged estimate: the sample it describes
            while self._stamps and self._stamps[0][0] < estimate.time:
                self._stamps.popleft()
            if self._stamps and self._stamps[0][0] == estimate.time:
                sec, nanosec = self._stamps[0][1], self._stamps[0][2]
        self._trim_stamps()
        out = self._writers.estimate(sec, nanosec, estimate.a, estimate.variance)
        imu = self._writers.imu(sec, nanosec, estimate.a, estimate.variance)
        return sec, nanosec, out, imu, estimate.a

    def _publish_estimate(self, sec: int, nanosec: int, out: bytes, imu: bytes, accel: float) -> None:
        """Publish one estimate and its Imu (waiting while a keep-all reader pushes back), and the marker
        arrow at MARKER_RATE_HZ of stamp time."""
        if publish_blocking(self.estimate_publisher, out, self._halted) and publish_blocking(
            self.imu_publisher, imu, self._halted
        ):
            self.estimates += 1
        else:
            self.unpublished += 1
            return
        tick = math.floor(stamp_seconds(sec, nanosec) * visual.MARKER_RATE_HZ)
        if tick != self._marker_tick:  # the estimate's arrow at MARKER_RATE_HZ of stamp time
            self._marker_tick = tick
            marker = self._writers.marker(sec, nanosec, accel)
            publish_blocking(self.marker_publisher, marker, self._halted)

    def _trim_stamps(self) -> None:
        """Keep only the stamps a lagged estimate can still describe (the lag plus a margin)."""
        keep = getattr(self.guarded.estimator, "lag_n", 0) + 2
        while len(self._stamps) > keep:
            self._stamps.popleft()

    def _publish_diagnostics(self) -> None:
        """One DiagnosticArray with the worst input state since the previous one (STALE checked first)."""
        guard = self.guarded.guard
        if self._last_stamp is None:
            # Before the first sample: STALE, stamped by this node's clock (sim or wall, as the run's).
            report = GuardReport(GuardState.STALE, "waiting for input", guard.values())
            stamp = self.get_clock().now().to_msg()
        else:
            # The input's silence since its latest arrival, even while a backlog is being worked off.
            guard.check_stale(time.monotonic(), self._last_input)
            report = guard.report()
            stamp = Time(sec=self._last_stamp[0], nanosec=self._last_stamp[1])
        self.diagnostics_publisher.publish(
            diagnostic_array(
                report,
                self.method,
                stamp,
                self.latency(),
                status_name(self.get_fully_qualified_name()),
                self.hardware_id,
                self.lost,
            )
        )

    def _tick(self) -> None:
        """Subscribe when ready (again, best-effort, after a best-effort publisher showed up); during a stop,
        finish once the input has been idle (queue drained)."""
        if self._resubscribe and self._subscription is not None:
            self._resubscribe = False
            self.destroy_subscription(self._subscription)
            self._subscription = None
        self._subscribe_when_ready()
        if self._stopping_since is None:
            return
        now = time.monotonic()
        idle = now - self._last_input > _DRAIN_IDLE and not self._backlog
        if idle or now - self._stopping_since > _DRAIN_LIMIT:
            self.finish(0)

    def request_stop(self) -> None:
        """Drain: keep estimating until the input has been idle for _DRAIN_IDLE since the later of its last
        angle and this request, then finish (at once when not configured: nothing to drain). Counted from
        the request too: one deferred while the node was built comes before its first angle is taken."""
        self._stopping_since = time.monotonic()
        self._last_input = max(self._last_input, self._stopping_since)
        if not self._timers:
            self.finish(0)

    def counters(self) -> dict[str, int]:
        """inputs, estimates and every reason an input got none: warm-up, dropped, unpublished."""
        guard = self.guarded.guard
        dropped = guard.dropped_nonfinite + guard.dropped_out_of_order + guard.dropped_wrong_joint
        return {
            "inputs": self.inputs,
            "estimates": self.estimates,
            "warmup": self.inputs - self.estimates - dropped - self.unpublished,
            "dropped_nonfinite": guard.dropped_nonfinite,
            "dropped_out_of_order": guard.dropped_out_of_order,
            "dropped_wrong_joint": guard.dropped_wrong_joint,
            "ignored_joints": guard.ignored_joints,
            "lost": self.lost,
            "unpublished": self.unpublished,
            "resets": guard.resets,
        }

    def close(self) -> None:
        """Stop the worker (angles it did not reach count as unpublished), deliver what was published, then
        log the counts and write them to summary_file."""
        self._halt_worker()
        self.unpublished += len(self._backlog)
        self._backlog.clear()
        if not hasattr(self, "guarded"):  # never configured: nothing was estimated
            return
        if self._describer is not None:  # a rebuild's lines still being made: said before the counts
            self._describer.join(timeout=_DESCRIBE_WAIT)
            self._say_rebuilt()
        if self._publishers:  # configured (cleanup destroys them)
            for publisher in (self.estimate_publisher, self.imu_publisher):
                publisher.wait_for_all_acked(Duration(seconds=2))
        guard = self.guarded.guard
        self.get_logger().info(
            f"{self.inputs} inputs, {self.estimates} estimates published; dropped {guard.dropped_nonfinite} "
            f"non-finite and {guard.dropped_out_of_order} out-of-order, {guard.resets} resets"
        )
        write_summary(self.summary_file, {**self.counters(), "time_source": self.time_source})


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``accel_estimator``: run the estimator node until a signal."""
    return run_node(EstimatorNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
