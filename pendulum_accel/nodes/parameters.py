"""Every node's ROS parameters as data: name, type, default, range, description, read-only (no rclpy).

``nodes.runtime.declare_parameters`` declares one of these tables on a node. The tables import
nothing from ROS, so a node's parameters (say, for ``--help``) can be listed without rclpy.
Scene fields a node overrides come from the one override table, ``pendulum_accel.overrides``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

from pendulum_accel.bag import messages as bm
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, LIVE_ESTIMATORS, TEACHING_ESTIMATORS
from pendulum_accel.estimators.motion import MOTIONS
from pendulum_accel.overrides import OVERRIDE_BY_NAME, OVERRIDES, Override
from pendulum_accel.recording.generate import DEFAULT_CLOCK_RATE_HZ
from pendulum_accel.scene import DEFAULT_SCENE

SCENE_PRESET = "scene"
"""The ``preset`` parameter's value that takes kalman's preset from the scene (estimators.motion)."""

ParamType = Literal["bool", "integer", "double", "string", "string_array"]
ParamValue = bool | int | float | str | tuple[str, ...]

FROM_SCENE = None
"""A default of None: the value the node's scene has (known only once the scene is loaded)."""

LOG_TIMES: tuple[str, ...] = ("stamp", "receive")
"""The recorder's log_time choices: the message stamp (sim time) or its receive time."""

TIME_SOURCES: tuple[str, ...] = ("sim", "wall")
"""One time base per run. sim: stamps from the scene's t = 0, /clock published (publish_clock), use_sim_time
on every node (Gazebo's convention). wall: stamps are the ROS (system) clock at each sample's due time, no
/clock, use_sim_time off (what a hardware driver does). The rule: time_source sets use_sim_time unless
use_sim_time is given explicitly (-p use_sim_time:=false, a params file): the explicit value wins."""

IMU_TOPIC = "imu/data_raw"
"""The estimator's sensor_msgs/Imu output: a relative name, so a namespace or a remap applies."""

UNMEASURED_ACCEL_VARIANCE = bm.UNMEASURED_VARIANCE
"""(m/s²)² on the Imu's y and z acceleration: a pendulum does not measure them. The same figure as the
estimate's unmeasured covariance entries, far above any real signal's variance, so a consumer that
forgets to mask them learns nothing from them."""

ESTIMATOR_CONFIG: tuple[Override, ...] = tuple(
    OVERRIDE_BY_NAME[name] for name in ("length", "gravity", "damping", "noise_std", "rate_hz")
)
"""The scene fields an estimator is configured with; a change rebuilds the estimator."""


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: ROS type, default (FROM_SCENE: the scene's), closed range, choices, text."""

    name: str
    type: ParamType
    default: ParamValue | None
    description: str
    low: float | None = None
    high: float | None = None
    read_only: bool = False
    choices: tuple[str, ...] = ()

    def help_line(self) -> str:
        """'name (type[, low..high][, read-only]; default D): description[; one of a | b]'."""
        facts: list[str] = [self.type]
        if self.low is not None and self.high is not None:
            shown = (f"{int(v)}" if self.type == "integer" else f"{v:g}" for v in (self.low, self.high))
            facts.append("..".join(shown))  # an integer's bounds whole: 2147483647, not 2.14748e+09
        if self.read_only:
            facts.append("read-only")
        default = "the scene's" if self.default is FROM_SCENE else repr(self.default)
        choices = f"; one of {' | '.join(self.choices)}" if self.choices else ""
        return f"{self.name} ({', '.join(facts)}; default {default}): {self.description}{choices}"


def override_param(spec: Override, note: str) -> ParamSpec:
    """The node parameter of one scene override: its type and range, default the scene's, text + note."""
    unit = f", {spec.unit}" if spec.unit else ""
    return ParamSpec(
        spec.name,
        "integer" if spec.kind is int else "double",
        FROM_SCENE,
        f"{spec.description}{unit} ({note})",
        low=spec.low,
        high=spec.high,
    )


def _fixed(
    name: str,
    type_: ParamType,
    default: ParamValue,
    description: str,
    low: float | None = None,
    high: float | None = None,
) -> ParamSpec:
    """A read-only ParamSpec (fixed for the node's life), with optional low/high."""
    return ParamSpec(name, type_, default, description, low=low, high=high, read_only=True)


_WAIT_FOR_RECORDER = "start only once every published topic has a subscriber"


def time_source_param(default: str = "sim") -> ParamSpec:
    """The ``time_source`` parameter every node declares (it also sets use_sim_time: true for sim)."""
    return ParamSpec(
        "time_source",
        "string",
        default,
        "time base of every stamp: sim (scene time from 0, on /clock, use_sim_time true) or wall "
        "(the ROS system clock, use_sim_time false); an explicit use_sim_time wins over it",
        read_only=True,
        choices=TIME_SOURCES,
    )


def autostart_param() -> ParamSpec:
    """The ``autostart`` parameter of a managed node: configure and activate at start-up."""
    return _fixed(
        "autostart",
        "bool",
        True,
        "configure and activate at start-up (false: stay unconfigured until a lifecycle manager or "
        "`ros2 lifecycle set` drives the transitions)",
    )


def summary_file_param() -> ParamSpec:
    """The ``summary_file`` parameter: where the node writes its counters (JSON) at exit."""
    return _fixed(
        "summary_file", "string", "", "write this node's counters here as JSON at exit (empty: none)"
    )


def _readers(topics: str) -> ParamSpec:
    """``reader_nodes``: nodes (by name) that must subscribe to ``topics`` before data flows."""
    return _fixed(
        "reader_nodes",
        "string_array",
        ("",),
        f"wait until these nodes (name, or /namespace/name; a bare name is in this node's namespace) "
        f"subscribe to {topics}: by name, so other subscribers neither satisfy nor delay the wait",
    )


def _recorder(topics: str) -> ParamSpec:
    """``recorder_node``: the recorder (by name) that must subscribe to ``topics`` before data flows."""
    return _fixed(
        "recorder_node",
        "string",
        "",
        f"wait until this recorder node (name, or /namespace/name) subscribes to {topics} (empty: none)",
    )


def frame_prefix_param(what: str) -> ParamSpec:
    """``frame_prefix``: prepended to the frames of the ``what`` viewers draw (robot_state_publisher's)."""
    return _fixed(
        "frame_prefix",
        "string",
        "",
        f"prepended to the frame_id of the {what} (e.g. car1/, as robot_state_publisher's frame_prefix), so "
        "that a multi-robot TF tree resolves each chain's messages to its own robot; with a prefix the "
        "simulator's joint states name no frame, as robots' joint_states do",
    )


SIMULATOR: tuple[ParamSpec, ...] = (
    _fixed("scene", "string", DEFAULT_SCENE,
           "bundled scene name or path of a scene YAML (fixed for the node's life)"),
    *(override_param(spec, "overrides the scene's") for spec in OVERRIDES),
    _fixed("realtime", "bool", True, "pace by the wall clock (else as fast as possible)"),
    time_source_param(),
    _fixed("publish_clock", "bool", False,
           "publish /clock from the scene's time (time_source sim only), as `ros2 bag play --clock` does; "
           "pendulum-accel run and chain.launch.py set it for a sim-time chain, so a standalone simulator "
           "leaves the graph's clock alone unless asked"),
    ParamSpec("exit_on_end", "bool", True, "exit when the scene ends (else stay idle)"),
    _readers("pendulum/joint_states"),
    _recorder("every topic this node publishes"),
    autostart_param(),
    _fixed("wait_timeout", "double", 120.0,
           "give up waiting for the named readers (reader_nodes, recorder_node) after this many seconds "
           "(s); while it waits, INFO lines name those not there yet",
           low=0.0, high=3600.0),
    _fixed("clock_rate_hz", "double", DEFAULT_CLOCK_RATE_HZ,
           "/clock messages per simulated second (0: one per sample)", low=0.0, high=100_000.0),
    frame_prefix_param("truth and markers"),
    summary_file_param(),
)  # fmt: skip

ESTIMATOR: tuple[ParamSpec, ...] = (
    _fixed("scene", "string", DEFAULT_SCENE, "scene whose pendulum and sensor configure the method"),
    ParamSpec("method", "string", DEFAULT_ESTIMATOR,
              f"estimation method; {', '.join(TEACHING_ESTIMATORS)} are teaching methods whose σ counts "
              "sensor noise and bias only", choices=LIVE_ESTIMATORS),
    ParamSpec("lag", "double", 0.0,
              "latency (s) of a fixed-lag smoother: each estimate describes, and is stamped with, the sample "
              "this long ago, using the data since (0: the filter; kalman only)", low=0.0, high=10.0),
    ParamSpec("preset", "string", SCENE_PRESET,
              "kalman's process model of a(t), fitted on real motion: auto (learned from the angles), or a "
              "prior: car, robot or lab_steps; 'scene' takes the scene's motion key, else auto",
              choices=(SCENE_PRESET, *MOTIONS)),
    *(override_param(spec, "default: the scene's") for spec in ESTIMATOR_CONFIG),
    _fixed("joint", "string", bm.PENDULUM_JOINT,
           "the pendulum's joint in the input JointState: its position is θ, other joints are ignored, and "
           "a message without it is dropped (ERROR); a message naming no joint is a bare angle"),
    _fixed("joint_frame_id", "string", bm.FRAME_ID,
           "the frame_id the input JointState may carry besides none: a real sensor's driver may stamp its "
           "own (e.g. pan_link); a message in another frame is dropped (ERROR)"),
    _fixed("warn_angle_deg", "double", 80.0,
           "|θ| from which the input is flagged ill-conditioned (WARN), degrees", low=1.0, high=89.9),
    _fixed("stale_after", "double", 0.0,
           "STALE after this long without input, s (0: 20 periods, at least 0.5 s)", low=0.0, high=3600.0),
    _fixed("diagnostics_period", "double", 1.0, "seconds between /diagnostics messages (wall clock)",
           low=0.01, high=60.0),
    _fixed("backlog_limit", "integer", 5000,
           "angles taken but not yet estimated before taking waits for the estimator: the back-pressure, "
           "through a reliable keep-all input, that keeps a chain faster than the estimator lossless "
           "(parameter requests are answered while it waits)", low=10, high=10_000_000),
    _fixed("hardware_id", "string", "",
           "hardware_id of the /diagnostics status, whose name is the node's full name (empty: "
           "pendulum_accel followed by the node's namespace, e.g. pendulum_accel/car1)"),
    time_source_param(),
    _fixed("frame_id", "string", bm.FRAME_ID, "frame_id of the estimate and the Imu (the car, REP-103)"),
    _fixed("imu_frame_id", "string", "",
           "frame_id of the Imu (empty: frame_id); give its own frame (imu_link) with an imu offset"),
    *(_fixed(f"imu_offset_{axis}", "double", 0.0,
             f"{axis} of the Imu frame's origin in frame_id, m (the transform is stated at start-up for a "
             "static_transform_publisher; a rigid, non-rotating car reads the same specific force there)",
             low=-100.0, high=100.0) for axis in "xyz"),
    frame_prefix_param("estimate, Imu, markers and /tf_static"),
    _fixed("unmeasured_accel_variance", "double", UNMEASURED_ACCEL_VARIANCE,
           "Imu linear_acceleration_covariance of y and z, (m/s²)²: not measured by a pendulum",
           low=1e-6, high=1e12),
    _readers("car/accel/estimate (before subscribing to the input)"),
    _recorder(f"car/accel/estimate, /diagnostics and {IMU_TOPIC} (before subscribing to the input)"),
    autostart_param(),
    summary_file_param(),
)  # fmt: skip

PLAYER_CLOCK_RATE_HZ = 40.0
"""The player's default /clock rate, rosbag2's (``ros2 bag play --clock`` without a value: 40 Hz)."""

PLAYER: tuple[ParamSpec, ...] = (
    _fixed("path", "string", "", "bag to play (~: the home directory)"),
    ParamSpec("rate", "double", 1.0, "speed factor (2: twice as fast); settable while playing (~/set_rate)",
              low=1e-3, high=1e3),
    _fixed("start_paused", "bool", False, "start paused (~/resume, ~/play_next, space key to go on)"),
    _fixed("loop", "bool", False, "start over at the end"),
    _fixed("start_offset", "double", 0.0, "skip this many seconds of the bag", low=0.0, high=1e6),
    _fixed("playback_duration", "double", -1.0,
           "play only this many bag seconds from the start offset, s (negative: no limit)",
           low=-1.0, high=1e9),
    _fixed("playback_until", "double", -1.0,
           "play only messages up to this bag time (log time), s (negative: no limit)",
           low=-1.0, high=1e12),
    _fixed("delay", "double", 0.0, "wait this many seconds before each pass (s)", low=0.0, high=3600.0),
    # [""], not []: ROS infers a parameter's type from its default, and an empty list has none.
    _fixed("topics", "string_array", ("",), "topics to play (empty: all)"),
    _fixed("topics_regex", "string", "", "play only topics matching this regular expression (empty: all)"),
    _fixed("exclude_topics", "string_array", ("",), "topics not to play"),
    _fixed("exclude_regex", "string", "", "do not play topics matching this regular expression"),
    _fixed("clock", "bool", False, "publish /clock from the bag time"),
    _fixed("clock_rate_hz", "double", PLAYER_CLOCK_RATE_HZ,
           "/clock messages per bag second (0: one per message)", low=0.0, high=1e5),
    ParamSpec("burst_size", "integer", 0, "messages ~/burst plays (0: the rest of the bag)",
              low=0, high=10**9),
    ParamSpec("seek_time", "double", 0.0, "bag time (log time, s) ~/seek goes to", low=-1e12, high=1e12),
    _fixed("keyboard", "bool", True,
           "keyboard control when stdin is a terminal: space pause/resume, → play next, ↑/↓ rate ±0.1"),
    _fixed("progress_period", "double", 0.5, "seconds between progress lines on stderr (0: none)",
           low=0.0, high=3600.0),
    _fixed("exit_on_end", "bool", True, "exit after the last message"),
    _fixed("wait_for_subscribers", "integer", 0,
           "start once pendulum/joint_states has this many subscribers", low=0, high=64),
    _fixed("wait_for_recorder", "bool", False, _WAIT_FOR_RECORDER),
    _readers("the played pendulum/joint_states (by name: strangers neither satisfy nor delay it)"),
    _recorder("every played topic and /clock"),
    time_source_param(),
)  # fmt: skip

RECORDER: tuple[ParamSpec, ...] = (
    _fixed("path", "string", "", "bag directory to create (~: the home directory)"),
    _fixed("overwrite", "bool", False, "replace an existing bag"),
    _fixed("topics", "string_array", bm.CHAIN_ROLES,
           "topics to record (relative names resolve in this node's namespace and follow its remaps; a "
           "name outside the chain's roles takes its type from the graph)"),
    _fixed("scene", "string", "", "scene stored in the bag's custom_data"),
    ParamSpec("log_time", "string", "stamp",
              "log time: the message stamp (on the run's time base) or its receive time (node clock)",
              read_only=True, choices=LOG_TIMES),
    time_source_param(),
    _fixed("chain_summaries", "string_array", ("",),
           "the other nodes' summary files: read at close and stored in the bag as the chain's accounting"),
    summary_file_param(),
)  # fmt: skip

NODE_PARAMETERS: Mapping[str, Sequence[ParamSpec]] = {
    "pendulum_sim": SIMULATOR,
    "accel_estimator": ESTIMATOR,
    "bag_player": PLAYER,
    "bag_recorder": RECORDER,
}
"""Each node's parameter table, by node name (the name its node module declares)."""
