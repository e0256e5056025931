"""The swinging bob drawn from a run: the car, the pendulum, true and estimated acceleration, θ(t) below.

Drawn in the world's (forward, up) plane: the car pitched nose-up by the road's grade β, the pivot on its
roof, the bob at pivot + R(β) (−l sin θ, −l cos θ) (θ > 0 to the rear, as everywhere in the package). The
arrows start at the pivot along the car's x axis, ARROW_M_PER_MS2 metres per m/s². Frames are taken at
``fps`` from the run's samples (linear interpolation), so a 100 Hz or 1 kHz run animates at the same cost.
"""

from __future__ import annotations

import contextlib
import logging
import math
import shutil
import signal
import subprocess
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

import matplotlib as mpl
import numpy as np
from matplotlib.animation import FFMpegWriter, PillowWriter
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon
from matplotlib.quiver import Quiver
from numpy.typing import NDArray

from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.errors import BagError, ParameterError
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.recording.stored_scene import scene_but_motion
from pendulum_accel.scene import Scene
from pendulum_accel.scene_run import run_scene
from pendulum_accel.textfile import write_through_partial

FloatArray = NDArray[np.float64]

BOB_COLOR = "#d62728"  # the bob's pure colour, which the tests look for in the rendered frame
TRUE_COLOR = "#2ca02c"
EST_COLOR = "#ff7f0e"
FIGSIZE = (6.4, 4.8)  # inches
DPI = 80  # 512 × 384 pixels: a 10 s GIF at 20 fps stays well under 1 MB
CAR_LENGTH = 2.4  # in pendulum lengths
ARROW_M_PER_MS2 = 0.25  # arrow length per m/s², in pendulum lengths
FORMATS = (".gif", ".mp4")


@dataclass(frozen=True)
class SwingData:
    """What is drawn: times t (s), bob angle θ (rad), true and estimated a (m/s², NaN: none yet), l, β."""

    t: FloatArray
    theta: FloatArray
    accel_true: FloatArray
    accel_est: FloatArray
    length: float
    grade: float = 0.0
    label: str = ""

    def frame_times(self, fps: float, duration: float | None = None) -> FloatArray:
        """t₀ + k/fps for k = 0, 1, … up to the end of the run (or t₀ + duration, whichever is first)."""
        if not (math.isfinite(fps) and fps > 0.0):
            raise ParameterError(f"fps must be a number > 0, got {fps!r}")
        end = float(self.t[-1])
        if duration is not None:
            if not (math.isfinite(duration) and duration > 0.0):
                raise ParameterError(f"duration must be a number of seconds > 0, got {duration!r}")
            end = min(end, float(self.t[0]) + duration)
        return float(self.t[0]) + np.arange(math.floor((end - float(self.t[0])) * fps + 1e-9) + 1) / fps

    def at(self, times: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(θ, a_true, a_est) interpolated linearly at ``times``."""
        return (
            np.interp(times, self.t, self.theta),
            np.interp(times, self.t, self.accel_true),
            np.interp(times, self.t, self.accel_est),
        )


def _rotate(x: FloatArray, z: FloatArray, beta: float) -> tuple[FloatArray, FloatArray]:
    """Car-frame (x, z) to world (forward, up) for a car pitched nose-up by β: R(β) (x, z)."""
    c, s = math.cos(beta), math.sin(beta)
    return c * x - s * z, s * x + c * z


def bob_position(length: float, theta: float | FloatArray, grade: float) -> tuple[FloatArray, FloatArray]:
    """World position of the bob relative to the pivot: R(β) (−l sin θ, −l cos θ)."""
    th = np.asarray(theta, dtype=float)
    return _rotate(-length * np.sin(th), -length * np.cos(th), grade)


class SwingAnimation:
    """A figure with the car and bob on top and the θ(t) strip chart below; ``draw_frame(k)`` sets frame k.

    Frames go straight to matplotlib's animation writers (PillowWriter, FFMpegWriter), one draw each.
    """

    def __init__(self, data: SwingData, fps: int = 20, duration: float | None = None) -> None:
        """Lay out the figure for ``data`` and precompute the frames at ``fps`` (up to ``duration`` s)."""
        self.data = data
        self.fps = fps
        self.times = data.frame_times(fps, duration)
        self.theta, self.a_true, self.a_est = data.at(self.times)
        self.has_truth = bool(np.isfinite(data.accel_true).any())  # a real sensor's bag has none
        self.figure = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
        FigureCanvasAgg(self.figure)
        top, bottom = self.figure.subplots(2, 1, height_ratios=(2.2, 1.0))
        self.scene_axes: Axes = top
        self.chart_axes: Axes = bottom
        self._draw_car(top)
        self.rod = Line2D([0.0, 0.0], [0.0, -data.length], color="0.2", lw=2)
        self.bob = Line2D([0.0], [-data.length], marker="o", ms=14, color=BOB_COLOR, mec=BOB_COLOR, ls="")
        top.add_line(self.rod)
        top.add_line(self.bob)
        self.arrows: Quiver = top.quiver(
            [0.0, 0.0],
            [0.08 * data.length, 0.22 * data.length],
            [0.0, 0.0],
            [0.0, 0.0],
            color=[TRUE_COLOR, EST_COLOR],
            angles="xy",
            scale_units="xy",
            scale=1.0,
            width=0.012,
        )
        # Readout on the figure's left and legend on its right, both outside the car's axes (which the
        # equal aspect keeps narrow), so neither covers the other nor the car.
        self.text = self.figure.text(0.02, 0.90, "", va="top", ha="left", fontsize=9, family="monospace")
        self.figure.legend(
            handles=[
                *([Line2D([], [], color=TRUE_COLOR, lw=3, label="true a")] if self.has_truth else []),
                Line2D([], [], color=EST_COLOR, lw=3, label="estimated â"),
            ],
            loc="upper right",
            bbox_to_anchor=(0.99, 0.91),
            fontsize=8,
        )
        self._draw_chart(bottom)
        self.figure.canvas.draw()  # lay out once; frames then keep these positions
        self.figure.set_layout_engine("none")

    def _draw_car(self, ax: Axes) -> None:
        """The road and the car body (pivot at the origin on its roof), pitched by the grade."""
        length, beta = self.data.length, self.data.grade
        half = 0.5 * CAR_LENGTH * length
        body_x = np.array([-half, half, half, -half])
        body_z = np.array([-1.5 * length, -1.5 * length, 0.05 * length, 0.05 * length])
        bx, bz = _rotate(body_x, body_z, beta)
        ax.add_patch(Polygon(np.column_stack((bx, bz)), closed=True, fc="#dde6f0", ec="#5a6b7d", lw=1.5))
        road_x, road_z = _rotate(np.array([-2 * half, 2 * half]), np.array([-1.7, -1.7]) * length, beta)
        ax.plot(road_x, road_z, color="0.35", lw=3)
        ax.plot([0.0], [0.0], "ko", ms=4)
        reach = half + 0.2 * length
        ax.set(xlim=(-reach, reach), ylim=(-1.9 * length - half * abs(math.sin(beta)), 1.0 * length))
        ax.set_aspect("equal")
        ax.set_axis_off()
        title = f"{self.data.label}: " if self.data.label else ""
        grade = f", grade β = {beta:.4f} rad" if beta else ""
        ax.set_title(f"{title}l = {length:g} m{grade}   → forward", fontsize=10)

    def _draw_chart(self, ax: Axes) -> None:
        """θ(t) in degrees over the animated span, with a cursor that follows the frame."""
        span = (self.data.t >= self.times[0]) & (self.data.t <= self.times[-1])
        ax.plot(self.data.t[span], np.degrees(self.data.theta[span]), color="0.6", lw=1)
        (self.trace,) = ax.plot([], [], color=BOB_COLOR, lw=1.5)
        self.cursor = ax.axvline(float(self.times[0]), color="k", lw=1)
        ax.set(
            xlabel="time t [s]", ylabel="θ [deg]", xlim=(float(self.times[0]), float(self.times[-1]) + 1e-9)
        )
        ax.grid(True, alpha=0.3)

    def draw_frame(self, k: int) -> list[Artist]:
        """Move the bob, rod, arrows, cursor and readout to frame ``k``; returns the changed artists."""
        length, beta = self.data.length, self.data.grade
        bx, bz = bob_position(length, float(self.theta[k]), beta)
        self.rod.set_data([0.0, float(bx)], [0.0, float(bz)])
        self.bob.set_data([float(bx)], [float(bz)])
        a_est = float(self.a_est[k]) if math.isfinite(self.a_est[k]) else 0.0
        scale = ARROW_M_PER_MS2 * length
        a_true = float(self.a_true[k]) if math.isfinite(self.a_true[k]) else 0.0  # no truth: no arrow
        u, v = _rotate(np.array([a_true, a_est]) * scale, np.zeros(2), beta)
        self.arrows.set_UVC(u, v)
        t = float(self.times[k])
        self.cursor.set_xdata([t, t])
        shown = self.data.t <= t
        self.trace.set_data(self.data.t[shown], np.degrees(self.data.theta[shown]))
        truth = f"a = {a_true:+6.3f} m/s²\n" if self.has_truth else ""
        self.text.set_text(
            f"t = {t:6.2f} s\nθ = {math.degrees(self.theta[k]):+6.2f}°\n{truth}â = {a_est:+6.3f} m/s²"
        )
        return [self.rod, self.bob, self.arrows, self.cursor, self.trace, self.text]

    def save(self, path: Path, on_frame: Callable[[], object] | None = None) -> Path:
        """Write the animation to ``path``: GIF with Pillow, MP4 with ffmpeg (ParameterError when it is not
        installed). ``on_frame`` is called after each frame is written (a progress bar).

        The file is written under the hidden partial name of ``path`` (textfile.write_through_partial; the
        name adds a leading dot, so it never is ``path``, whatever ``path`` is called) and renamed over
        ``path`` only once complete: on an error or an interrupt the encoder is stopped and the partial file
        removed, so a file already at ``path`` stays as it was. A device or FIFO is written directly.
        """
        return write_through_partial(check_output_path(path), lambda target: self.encode(target, on_frame))

    def encode(self, target: Path, on_frame: Callable[[], object] | None = None) -> Path:
        """Write the animation into ``target`` itself, in the format its suffix names, with no rename: for
        a caller that owns the naming (cli.output.write_output passes its partial name). On an error or
        an interrupt the encoder is stopped (ffmpeg killed, Pillow's frames dropped, nothing encoded);
        removing what ``target`` holds by then is the caller's part."""
        out = check_output_path(target)
        writer: PillowWriter | FFMpegWriter
        if out.suffix.lower() == ".gif":
            writer = PillowWriter(fps=self.fps)
        else:
            # -xerror: ffmpeg 5 exits 0 after "Error writing trailer ...: No space left on device"
            # without it, leaving an MP4 with no moov atom; with it, the exit status tells.
            writer = FFMpegWriter(fps=self.fps, codec="h264", extra_args=["-pix_fmt", "yuv420p", "-xerror"])
        # Not writer.saving(): its finally encodes every frame grabbed so far even on Ctrl-C (seconds of
        # Pillow or ffmpeg work, and a partial file). Each frame is drawn once, by the writer's savefig.
        done = False
        writer.setup(self.figure, str(out), DPI)
        try:
            # matplotlib logs a failed encoder's whole stderr as a warning; the one line below says it.
            with mpl.rc_context({"savefig.bbox": None}), _quiet_logger("matplotlib.animation"):
                try:
                    with _interrupts_between_frames() as interrupted:
                        for k in range(self.times.size):
                            self.draw_frame(k)
                            writer.grab_frame()
                            if on_frame is not None:
                                on_frame()
                            interrupted()
                    writer.finish()
                except (BrokenPipeError, subprocess.CalledProcessError) as err:
                    # ffmpeg stopped (its pipe closed) or exited non-zero: say why, in its words.
                    raise _encoder_failure(writer, err) from None
            done = True
        finally:
            if not done:
                _abandon(writer)
        return out


@contextlib.contextmanager
def _interrupts_between_frames() -> Iterator[Callable[[], None]]:
    """While the body runs, a SIGINT is held until the body calls the yielded check, which hands it to the
    handler that was in place (Python's own raises KeyboardInterrupt): frames stop between two draws,
    never inside one.

    Why: a KeyboardInterrupt raised inside matplotlib's Agg renderer (its C++ converters check for
    signals) can come out as ``ValueError: Invalid bounding box``, where a notebook or the command expects
    the interrupt. A frame draws in milliseconds, so the stop comes as soon. Outside the main thread, or
    when SIGINT is ignored or left to the system, nothing is changed."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield lambda: None
        return
    caught: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        """Remember the SIGINT; the check hands it on."""
        caught.append(signum)

    def check() -> None:
        """Hand a SIGINT that came since the last check to the handler that was in place."""
        if caught:
            caught.clear()
            previous(signal.SIGINT, None)

    signal.signal(signal.SIGINT, hold)
    try:
        yield check
    finally:
        signal.signal(signal.SIGINT, previous)
    check()  # a SIGINT that came during the body's last moment, after its last check


@contextlib.contextmanager
def _quiet_logger(name: str) -> Iterator[None]:
    """Logger ``name`` shows errors only while the body runs."""
    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _encoder_failure(writer: PillowWriter | FFMpegWriter, err: Exception) -> OSError:
    """OSError('ffmpeg exited with status N: REASON'), REASON the end of ffmpeg's last stderr line (e.g.
    'No space left on device'), for an encoder that closed its pipe or exited non-zero."""
    stderr = getattr(err, "stderr", None)
    proc = getattr(writer, "_proc", None)
    if stderr is None and proc is not None:
        try:
            _, stderr = proc.communicate(timeout=10)
        except (subprocess.TimeoutExpired, ValueError, OSError):
            stderr = b""
    if isinstance(stderr, bytes):
        stderr = stderr.decode("utf-8", "replace")
    lines = [line.strip() for line in (stderr or "").splitlines() if line.strip()]
    reason = lines[-1].rsplit(": ", 1)[-1] if lines else "no message"
    code = proc.returncode if proc is not None else getattr(err, "returncode", None)
    return OSError(f"ffmpeg exited with status {code}: {reason}")


def _abandon(writer: PillowWriter | FFMpegWriter) -> None:
    """Drop an unfinished writer without encoding: kill its ffmpeg (if any), forget Pillow's frames."""
    proc = getattr(writer, "_proc", None)
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()
    if hasattr(writer, "_frames"):
        writer._frames = []


def check_output_path(path: Path | str) -> Path:
    """``path`` as a Path when it ends in .gif or .mp4 (with ffmpeg on PATH) in an existing directory."""
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ParameterError(f"animation output must end in .gif or .mp4, got {str(out)!r}")
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise ParameterError("writing .mp4 needs ffmpeg on PATH (apt-get install ffmpeg); use a .gif instead")
    if not out.parent.is_dir():
        raise ParameterError(f"output directory does not exist: {str(out.parent)!r}")
    return out


def swing_from_scene(scene: Scene, estimator: str | None = None) -> SwingData:
    """SwingData of a simulated scene: its true θ and a, and ``estimator`` (default: the package's) on the
    measured θ with the scene's estimator settings."""
    run = run_scene(scene)
    name = estimator or DEFAULT_ESTIMATOR
    a_est, _ = estimate_batch(name, run.t, run.theta_measured, **estimator_options(scene, name))
    return SwingData(
        t=run.t,
        theta=run.theta_true,
        accel_true=run.accel_true,
        accel_est=np.asarray(a_est, dtype=np.float64),
        length=scene.pendulum.length,
        grade=scene.grade,
        label=f"{scene.name} ({name})",
    )


def swing_from_bag(
    path: Path | str | Bag, estimator: str | None = None, config: dict[str, float] | None = None
) -> SwingData:
    """SwingData of a bag (read here, refused when damaged, or already read): its recorded θ and truth
    (NaN in a bag without one), ``estimator`` re-run offline (recording.analyze, ``config`` overriding
    the stored scene's length and noise: needed for a bag that stores no scene)."""
    bag = path if isinstance(path, Bag) else read_bag(path, salvage=False)
    path = bag.path
    result = analyze_bag(bag, estimator=estimator, config=config)
    text = bag.custom_data.get("pendulum_accel.scene")
    grade = 0.0
    if text:
        try:
            grade = scene_but_motion(text).grade
        except BagError:
            grade = 0.0  # an older or foreign scene text: draw the car level
    return SwingData(
        t=result.t,
        theta=result.theta,
        accel_true=result.accel_true,
        accel_est=result.accel_est,
        length=float(result.config["length"]),
        grade=grade,
        label=f"{result.scene or Path(path).name} ({result.estimator})",
    )
