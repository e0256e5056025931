"""Write a bag straight from a scene, without DDS, with the topics a live recording of it has.

Topics (stamp = log time = sim time t, starting at 0): /clock, /pendulum/joint_states (measured θ,
and its rate from backward differences of the measured θ: no truth), /car/accel/truth,
/pendulum/string (only when the scene computes tension or stretch),
/car/accel/estimate (the default estimator, from the first sample it gives a value on),
/diagnostics (the estimator node's input-guard report, once per second of sim time), and what viewers
draw (``viewer_streams``): /imu/data_raw (one Imu per estimate, as the estimator node writes it),
/pendulum/markers (the simulator's swing and the estimator's arrow, each at ``MARKER_RATE_HZ``) and
/robot_description (the scene's URDF, once, transient local). Every fixed-layout topic is serialised in
bulk (:class:`Layout`) and written in one ``write_sorted`` call, so a 1 kHz scene goes far faster than
real time.
"""

from __future__ import annotations

import dataclasses
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pendulum_accel import __version__
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.bag.writer import (
    CUSTOM_ESTIMATOR,
    CUSTOM_PLAN,
    CUSTOM_SCENE,
    CUSTOM_VERSION,
    BagWriter,
    Stream,
)
from pendulum_accel.errors import BagError
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.estimators.guard import InputGuard
from pendulum_accel.recording import visual
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene import Scene, load_scene, stored_scene_text
from pendulum_accel.scene_run import SceneRun, run_scene

DIAGNOSTIC_NAME = "accel_estimator"
_STAMP = ("header.stamp.sec", "header.stamp.nanosec")


@dataclass(frozen=True)
class GenerateResult:
    """What generate_bag wrote: counts per topic, sim duration, and the wall time of each phase (s)."""

    path: Path
    counts: dict[str, int]
    sim_duration: float
    simulate_s: float
    estimate_s: float
    write_s: float

    @property
    def messages(self) -> int:
        """Total messages written."""
        return sum(self.counts.values())

    @property
    def wall_s(self) -> float:
        """Total wall time (simulate + estimate + write)."""
        return self.simulate_s + self.estimate_s + self.write_s


def _stamp_columns(ns: NDArray[np.int64], prefix: str = "header.stamp") -> dict[str, NDArray[np.generic]]:
    """{prefix.sec, prefix.nanosec} columns for integer-ns stamps."""
    sec, nanosec = bm.split_stamp(ns)
    return {f"{prefix}.sec": sec, f"{prefix}.nanosec": nanosec}


DEFAULT_CLOCK_RATE_HZ = 100.0
"""/clock messages per simulated second. Nodes on sim time need only a tick (rosbag2's player ticks at
40 Hz by default); every data message carries its exact stamp, so a clock per 1 kHz sample would only
cost messages: in the as-fast-as-possible chain it was a third of the work."""

StringColumns = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


def clock_mask(t: NDArray[np.float64], clock_rate_hz: float) -> NDArray[np.bool_]:
    """Samples that also publish /clock: all when clock_rate_hz ≤ 0, else the first in each 1/rate tick."""
    if clock_rate_hz <= 0.0 or t.size == 0:
        return np.ones(t.size, dtype=bool)
    ticks = np.floor((t - t[0]) * clock_rate_hz + 1e-9).astype(np.int64)
    mask = np.ones(t.size, dtype=bool)
    mask[1:] = ticks[1:] != ticks[:-1]
    return mask


def string_columns(run: SceneRun) -> StringColumns | None:
    """(stretch, stretch rate, tension) of a scene run that computed tension or stretch, else None.

    A run with only one of them gets zeros for the other, as /pendulum/string always carries all three.
    """
    if run.tension is None and run.stretch is None:
        return None
    zeros = np.zeros(np.shape(run.t))

    def column(values: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """values as float64, zeros when the run did not compute them."""
        return zeros if values is None else np.asarray(values, dtype=np.float64)

    return column(run.stretch), column(run.stretch_rate), column(run.tension)


@dataclass(frozen=True)
class SimulatorRows:
    """The simulator node's topics for one run, serialised: one CDR row per sample and topic
    (joint states, truth, string if any, in publishing order), and /clock rows on its ticks."""

    ns: NDArray[np.int64]
    rows: dict[str, NDArray[np.uint8]]
    clock_mask: NDArray[np.bool_]
    clock_rows: NDArray[np.uint8]


def simulator_rows(
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    theta_dot: NDArray[np.float64],
    accel_true: NDArray[np.float64],
    *,
    string: StringColumns | None = None,
    clock_rate_hz: float = DEFAULT_CLOCK_RATE_HZ,
    frame_id: str = bm.FRAME_ID,
    joint_frame_id: str = bm.FRAME_ID,
) -> SimulatorRows:
    """What the simulator publishes at times t (s): measured θ and its rate (joint states in
    ``joint_frame_id``), true a in ``frame_id`` (the chain's frame prefix + base_link), (r − l, ṙ, T)."""
    ns = bm.seconds_to_ns(t)
    if ns.size > 1 and np.any(np.diff(ns) <= 0):
        raise BagError("sample times must be strictly increasing after rounding to ns")
    n = ns.size
    stamp = _stamp_columns(ns)
    joint = Layout.of(
        bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0], frame_id=joint_frame_id), bm.JOINT_STATE
    )
    truth = Layout.of(bm.accel_stamped(0, 0.0, frame_id), bm.ACCEL_STAMPED)
    rows = {
        bm.TOPIC_JOINT_STATES: joint.encode(n, {**stamp, "position[0]": theta, "velocity[0]": theta_dot}),
        bm.TOPIC_ACCEL_TRUTH: truth.encode(n, {**stamp, "accel.linear.x": accel_true}),
    }
    if string is not None:
        layout = Layout.of(bm.joint_state(0, [bm.STRING_JOINT], [0.0], [0.0], [0.0]), bm.JOINT_STATE)
        stretch, rate, tension = string
        cols = {**stamp, "position[0]": stretch, "velocity[0]": rate, "effort[0]": tension}
        rows[bm.TOPIC_STRING] = layout.encode(n, cols)
    mask = clock_mask(np.asarray(t, dtype=np.float64), clock_rate_hz)
    clock = Layout.of(bm.clock(0), bm.CLOCK)
    clock_rows = clock.encode(int(mask.sum()), _stamp_columns(ns[mask], "clock"))
    return SimulatorRows(ns, rows, mask, clock_rows)


@dataclass(frozen=True)
class Frames:
    """One scene run, serialised: sample times (s) and one CDR row per sample for each topic."""

    t: NDArray[np.float64]
    rows: dict[str, NDArray[np.uint8]]
    clock_rows: NDArray[np.uint8]
    clock_mask: NDArray[np.bool_]
    plan: str

    @property
    def size(self) -> int:
        """Number of samples."""
        return int(self.t.size)


def serialise_run(
    run: SceneRun, clock_rate_hz: float, frame_id: str = bm.FRAME_ID, joint_frame_id: str = bm.FRAME_ID
) -> Frames:
    """Frames of a SceneRun: joint_states (measured θ and rate, in ``joint_frame_id``), truth (a, in
    ``frame_id``), string (r − l, ṙ, T), clock."""
    t = np.asarray(run.t, dtype=np.float64)
    sim = simulator_rows(
        t,
        np.asarray(run.theta_measured, dtype=np.float64),
        run.theta_dot_measured,
        np.asarray(run.accel_true, dtype=np.float64),
        string=string_columns(run),
        clock_rate_hz=clock_rate_hz,
        frame_id=frame_id,
        joint_frame_id=joint_frame_id,
    )
    return Frames(t, sim.rows, sim.clock_rows, sim.clock_mask, run.plan.explain())


def chain_streams(
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    theta_dot: NDArray[np.float64],
    accel_true: NDArray[np.float64],
    accel_est: NDArray[np.float64],
    variance: NDArray[np.float64],
    *,
    estimator: str,
    rate_hz: float,
    string: StringColumns | None = None,
    clock_rate_hz: float = DEFAULT_CLOCK_RATE_HZ,
    saturation_range: float = 0.0,
) -> list[Stream]:
    """Bulk-serialised streams of the chain's topics for samples at times t (s).

    ``string`` = (stretch, stretch rate, tension) adds /pendulum/string. Estimates are written where
    they are finite (the live estimator publishes nothing while it warms up).
    """
    sim = simulator_rows(t, theta, theta_dot, accel_true, string=string, clock_rate_hz=clock_rate_hz)
    ns = sim.ns
    streams = [Stream(bm.TOPIC_CLOCK, ns[sim.clock_mask], sim.clock_rows)]
    streams += [Stream(topic, ns, rows) for topic, rows in sim.rows.items()]
    est = Layout.of(bm.accel_with_covariance_stamped(0, 0.0, 0.0), bm.ACCEL_WITH_COVARIANCE_STAMPED)
    ok = np.isfinite(accel_est) & np.isfinite(variance)
    est_ns = ns[ok]
    est_cols = {
        **_stamp_columns(est_ns),
        "accel.accel.linear.x": accel_est[ok],
        "accel.covariance[0]": variance[ok],
    }
    streams.append(Stream(bm.TOPIC_ACCEL_ESTIMATE, est_ns, est.encode(est_ns.size, est_cols)))
    diag_ns, diag = diagnostics(t, theta, estimator, rate_hz, saturation_range)
    streams.append(Stream(bm.TOPIC_DIAGNOSTICS, diag_ns, diag))
    return streams


def diagnostics(
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    estimator: str,
    rate_hz: float,
    saturation_range: float = 0.0,
) -> tuple[NDArray[np.int64], list[bytes]]:
    """(stamps, CDR) of the estimator node's /diagnostics: its InputGuard fed every sample, one report
    per second of sim time (at the first sample at or after each whole second), same fields as live."""
    guard = InputGuard(rate_hz=rate_hz, saturation_range=saturation_range)
    stamps: list[int] = []
    out: list[bytes] = []
    next_report = 0.0
    for ti, yi in zip(t.tolist(), theta.tolist(), strict=True):
        guard.check(ti, yi)
        if ti >= next_report:
            report = guard.report()
            ns = int(bm.seconds_to_ns(ti))
            values = {"method": estimator, "state": report.state.value, **dict(report.values)}
            msg = bm.diagnostic_array(
                ns, report.level, DIAGNOSTIC_NAME, f"{report.state.value}: {report.message}", values
            )
            stamps.append(ns)
            out.append(bm.serialize(msg, bm.DIAGNOSTIC_ARRAY))
            next_report = float(np.floor(ti)) + 1.0
    return np.array(stamps, dtype=np.int64), out


def viewer_streams(
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    accel_true: NDArray[np.float64],
    accel_est: NDArray[np.float64],
    variance: NDArray[np.float64],
    *,
    length: float,
    mass: float,
    gravity: float,
) -> list[Stream]:
    """The streams a live chain adds for viewers at sample times t (s): the estimator node's Imu for each
    finite estimate (specific force (â, 0, g), var(â) on x), the markers (the simulator's swing at
    MARKER_RATE_HZ of sim time, the estimator's arrow on the first estimate of each 1/MARKER_RATE_HZ tick
    of stamp time) and the URDF once at the first sample."""
    ns = bm.seconds_to_ns(t)
    ok = np.isfinite(accel_est) & np.isfinite(variance)
    est_ns, est_t = ns[ok], t[ok]
    template = bm.imu(0, 0.0, gravity, 0.0, bm.UNMEASURED_VARIANCE, bm.FRAME_ID)
    imu_cols = {
        **_stamp_columns(est_ns),
        "linear_acceleration.x": accel_est[ok],
        "linear_acceleration_covariance[0]": variance[ok],
    }
    imu_rows = Layout.of(template, bm.IMU).encode(est_ns.size, imu_cols)
    swing = visual.marker_mask(t)
    swing_rows = visual.swing_marker_rows(ns[swing], theta[swing], accel_true[swing], length)
    tick = np.floor(est_t * visual.MARKER_RATE_HZ).astype(np.int64)
    first = np.ones(tick.size, dtype=bool)
    first[1:] = tick[1:] != tick[:-1]
    arrow = visual.estimate_marker_writer(length)
    sec, nanosec = bm.split_stamp(est_ns[first])
    arrows = [
        arrow(s, n, a)
        for s, n, a in zip(sec.tolist(), nanosec.tolist(), accel_est[ok][first].tolist(), strict=True)
    ]
    # One topic, two publishers: at equal stamps the simulator's swing goes out before the estimate's arrow.
    marker_ns = np.concatenate([ns[swing], est_ns[first]])
    order = np.argsort(marker_ns, kind="stable")
    markers = [row.tobytes() for row in swing_rows] + arrows
    description = bm.serialize(
        bm.TYPESTORE.types[bm.STRING_MSG](data=visual.urdf(length, mass=mass)), bm.STRING_MSG
    )
    return [
        Stream(bm.TOPIC_IMU, est_ns, imu_rows),
        Stream(bm.TOPIC_MARKERS, marker_ns[order], [markers[i] for i in order]),
        Stream(bm.TOPIC_ROBOT_DESCRIPTION, ns[:1], [description]),
    ]


TOPIC_QOS = {bm.TOPIC_ROBOT_DESCRIPTION: bm.qos_profile(depth=1, transient_local=True)}
"""Offered QoS that differs from the writer's default (reliable, keep last 1000): the URDF's, latched as
robot_state_publisher offers it, so that a player's late subscriber still gets it."""


def write_chain_bag(
    out: Path | str,
    streams: list[Stream],
    *,
    custom_data: dict[str, str],
    overwrite: bool = False,
    compression: str | None = None,
) -> dict[str, int]:
    """Create bag ``out`` with the streams' topics (contract types, reliable QoS); returns counts."""
    with BagWriter(out, overwrite=overwrite, custom_data=custom_data, compression=compression) as writer:
        for stream in streams:
            msgtype = {**bm.TOPIC_TYPES, **bm.VIEWER_TOPIC_TYPES}[stream.topic]
            writer.add_topic(stream.topic, msgtype, TOPIC_QOS.get(stream.topic))
        writer.write_sorted(streams)
        return writer.counts


def generate_bag(
    scene: Scene | str | Path,
    out: Path | str,
    *,
    overwrite: bool = False,
    estimator: str | None = None,
    duration: float | None = None,
    compression: str | None = None,
) -> GenerateResult:
    """Simulate ``scene`` (a Scene or a scene name/path) and write its bag to ``out``."""
    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    if duration is not None:
        # It shortens the scene: a longer one would silently give a bag of the scene's length.
        if not 0.0 < duration <= scene.duration:
            raise BagError(
                f"duration must be in (0, {scene.duration:g}] s (scene {scene.name} lasts "
                f"{scene.duration:g} s; --duration only shortens it), got {duration!r}"
            )
        scene = dataclasses.replace(scene, duration=float(duration))
    out = Path(out)
    if out.exists() and not overwrite:
        raise BagError(f"{out} exists already; pass --overwrite to replace it")
    method = estimator or DEFAULT_ESTIMATOR
    t0 = time.perf_counter()
    run = run_scene(scene)
    t1 = time.perf_counter()
    # The estimator sees the stamps as a subscriber does: rounded to ns, t = sec + nanosec·1e-9.
    t = bm.stamp_seconds(*bm.split_stamp(bm.seconds_to_ns(run.t)))
    theta = np.asarray(run.theta_measured, dtype=np.float64)
    a_est, variance = estimate_batch(method, t, theta, **estimator_options(scene, method))
    t2 = time.perf_counter()
    streams = chain_streams(
        t,
        theta,
        run.theta_dot_measured,
        np.asarray(run.accel_true, dtype=np.float64),
        np.asarray(a_est, dtype=np.float64),
        np.asarray(variance, dtype=np.float64),
        estimator=method,
        rate_hz=float(scene.sensor.rate_hz),
        string=string_columns(run),
        saturation_range=float(scene.sensor.range),
    )
    streams += viewer_streams(
        t,
        theta,
        np.asarray(run.accel_true, dtype=np.float64),
        np.asarray(a_est, dtype=np.float64),
        np.asarray(variance, dtype=np.float64),
        length=float(scene.pendulum.length),
        mass=float(scene.pendulum.mass),
        gravity=float(scene.pendulum.gravity),
    )
    custom = {
        CUSTOM_SCENE: stored_scene_text(scene),
        CUSTOM_PLAN: run.plan.explain(),
        CUSTOM_VERSION: __version__,
        CUSTOM_ESTIMATOR: method,
    }
    try:
        counts = write_chain_bag(
            out, streams, custom_data=custom, overwrite=overwrite, compression=compression
        )
    except KeyboardInterrupt:
        # The writer closes what it holds into a readable bag of the first k seconds, which `info` would
        # call complete: an interrupted generate leaves no bag instead (the directory then holds only it:
        # prepare_output replaces nothing but a bag).
        shutil.rmtree(out, ignore_errors=True)
        raise
    t3 = time.perf_counter()
    sim_duration = float(t[-1] - t[0]) if t.size > 1 else 0.0
    return GenerateResult(out, counts, sim_duration, t1 - t0, t2 - t1, t3 - t2)
