"""animate: frames have the promised size, the bob is drawn where θ puts it, and a GIF is written."""

from __future__ import annotations

import errno
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from PIL import Image

from pendulum_accel.animation import (
    BOB_COLOR,
    DPI,
    FIGSIZE,
    SwingAnimation,
    SwingData,
    bob_position,
    swing_from_scene,
)
from pendulum_accel.errors import ParameterError
from pendulum_accel.scene import load_scene

WIDTH, HEIGHT = round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI)


def swing(grade: float = 0.0) -> SwingData:
    """A made-up swing: θ = 0.3 sin(2π t/2) + 0.2 over 3 s at 100 Hz, a = 2, â = 1.9."""
    t = np.linspace(0.0, 3.0, 301)
    theta = 0.2 + 0.3 * np.sin(np.pi * t)
    return SwingData(t, theta, np.full_like(t, 2.0), np.full_like(t, 1.9), length=0.8, grade=grade)


def bob_pixel_centre(rgba: np.ndarray) -> tuple[float, float]:
    """Centroid (x, y from the top) of the pixels in the bob's exact colour."""
    target = np.array(to_rgb(BOB_COLOR)) * 255.0
    mask = np.all(np.abs(rgba[:, :, :3].astype(float) - target) < 2.0, axis=2)
    # the strip chart's trace shares the colour: keep only the upper (car) panel
    mask[int(0.6 * rgba.shape[0]) :, :] = False
    ys, xs = np.nonzero(mask)
    assert xs.size > 50, "the bob is not visible in the frame"
    return float(xs.mean()), float(ys.mean())


@pytest.mark.parametrize("grade", [0.0, 0.15])
def test_frames_have_the_size_and_the_bob_is_where_theta_puts_it(grade: float) -> None:
    """For a few frames: the bob artist sits at R(β)(−l sin θ, −l cos θ), and so does its drawn colour."""
    anim = SwingAnimation(swing(grade), fps=10)
    assert anim.times.size == 31  # 0, 0.1, …, 3.0 s
    for k in (0, 7, 15, 26):
        anim.draw_frame(k)
        theta = 0.2 + 0.3 * math.sin(math.pi * anim.times[k])
        x, z = bob_position(0.8, theta, grade)
        bx, bz = anim.bob.get_data()
        assert float(np.asarray(bx)[0]) == pytest.approx(float(x), abs=1e-6)
        assert float(np.asarray(bz)[0]) == pytest.approx(float(z), abs=1e-6)
        # no grade: θ > 0 puts the bob to the rear, left of the pivot on the screen (forward is right)
        if grade == 0.0:
            assert np.sign(float(x)) == -np.sign(theta)
        canvas = anim.figure.canvas
        assert isinstance(canvas, FigureCanvasAgg)
        canvas.draw()
        rgba = np.asarray(canvas.buffer_rgba())
        assert rgba.shape == (HEIGHT, WIDTH, 4)
        px, py = anim.scene_axes.transData.transform((float(x), float(z)))
        cx, cy = bob_pixel_centre(rgba)
        assert cx == pytest.approx(px, abs=2.0)
        assert cy == pytest.approx(HEIGHT - py, abs=2.0)


def test_gif_is_written_with_the_requested_frames(tmp_path: Path) -> None:
    """A 0.5 s animation at 10 fps of a bundled scene: 6 frames of the figure's size, under 1 MB."""
    data = swing_from_scene(load_scene("lecture_constant"))
    assert np.all(np.isfinite(data.accel_est))
    anim = SwingAnimation(data, fps=10, duration=0.5)
    out = anim.save(tmp_path / "swing.gif")
    with Image.open(out) as img:
        assert img.size == (WIDTH, HEIGHT)
        assert getattr(img, "n_frames", 1) == 6
    assert out.stat().st_size < 1_000_000


def test_bad_outputs_are_one_line_errors(tmp_path: Path) -> None:
    """A wrong suffix, a missing directory or a bad fps is a ParameterError before any work."""
    anim_data = swing()
    with pytest.raises(ParameterError, match="fps"):
        anim_data.frame_times(0.0)
    cli = [sys.executable, "-m", "pendulum_accel.cli.main", "animate", "at_rest"]
    for out, message in (("x.png", "must end in .gif or .mp4"), ("nodir/x.gif", "does not exist")):
        done = subprocess.run(
            [*cli, "--out", str(tmp_path / out)], capture_output=True, text=True, check=False
        )
        assert done.returncode == 2
        assert message in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_a_bag_animates_from_its_recorded_angles(tmp_path: Path) -> None:
    """animate BAG: frames follow the bag's own θ and its stored scene's length and grade; a GIF comes out."""
    from pendulum_accel.animation import swing_from_bag
    from pendulum_accel.bag.messages import JOINT_STATE, TOPIC_JOINT_STATES
    from pendulum_accel.bag.reader import read_bag
    from test.conftest import REPO

    bag_dir = REPO / "bags" / "hill"
    data = swing_from_bag(bag_dir)
    recorded = read_bag(bag_dir).decode(TOPIC_JOINT_STATES, JOINT_STATE, fields=["position[0]"])
    assert np.array_equal(np.sort(data.theta), np.sort(recorded["position[0]"]))
    scene = load_scene("hill")
    assert data.grade == scene.grade != 0.0
    assert data.length == scene.pendulum.length
    assert np.all(np.isfinite(data.accel_est))
    out = tmp_path / "hill.gif"
    done = subprocess.run(
        [sys.executable, "-m", "pendulum_accel.cli.main", "animate", str(bag_dir), "--out", str(out),
         "--duration", "0.5", "--fps", "4"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    with Image.open(out) as img:
        assert img.size == (WIDTH, HEIGHT) and getattr(img, "n_frames", 1) == 3


@pytest.mark.slow
def test_a_bag_without_truth_or_scene_animates_with_its_length_given(tmp_path: Path) -> None:
    """A real sensor's bag (no truth, no scene): refused in one line naming --length without it; with it,
    the GIF comes out, the readout has no true a, and the frames carry the estimate only. --length with a
    scene is refused: a scene's pendulum is its own."""
    from test.sensor_bag import LENGTH, write_step_bag

    bag = write_step_bag(tmp_path / "sensor", truth=False)

    def animate(*args: str) -> subprocess.CompletedProcess[str]:
        """pendulum-accel animate ARGS --duration 0.5 --fps 4, captured."""
        command = [sys.executable, "-m", "pendulum_accel.cli.main", "animate", *args]
        return subprocess.run([*command, "--duration", "0.5", "--fps", "4"], capture_output=True, text=True)

    refused = animate(str(bag), "--out", str(tmp_path / "no.gif"))
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and "--length" in refused.stderr
    out = tmp_path / "sensor.gif"
    done = animate(str(bag), "--out", str(out), "--length", str(LENGTH))
    assert done.returncode == 0, done.stderr
    with Image.open(out) as img:
        assert img.size == (WIDTH, HEIGHT) and getattr(img, "n_frames", 1) == 3
    from pendulum_accel.animation import swing_from_bag

    anim = SwingAnimation(swing_from_bag(bag, config={"length": LENGTH}), fps=4, duration=0.5)
    anim.draw_frame(1)
    readout = anim.text.get_text()
    assert "â =" in readout and "a =" not in readout.replace("â =", "") and "nan" not in readout
    scene = animate("step_start", "--out", str(tmp_path / "s.gif"), "--length", "1")
    assert scene.returncode == 2 and "a scene's pendulum is its own" in scene.stderr


def test_animate_writes_through_one_partial_name(tmp_path: Path) -> None:
    """animate writes under one hidden partial name, ``.NAME.partial.gif`` (textfile.partial_path),
    renamed to NAME.gif: an output whose partial name is exactly the file system's longest name is
    written, and nothing else is left beside it. A partial name made twice (``..NAME.partial.partial``,
    9 characters longer) would not fit, and the write would fail with 'File name too long'."""
    from pendulum_accel.textfile import partial_path

    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("s" * (name_max - len("..partial.gif")) + ".gif")
    assert len(partial_path(out).name) == name_max
    done = subprocess.run(
        [sys.executable, "-m", "pendulum_accel.cli.main", "animate", "at_rest", "--out", str(out),
         "--duration", "0.5", "--fps", "4"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert sorted(tmp_path.iterdir()) == [out]
    with Image.open(out) as img:
        assert img.size == (WIDTH, HEIGHT) and getattr(img, "n_frames", 1) == 3


def test_mp4_is_written_through_ffmpeg(tmp_path: Path) -> None:
    """.mp4 goes through ffmpeg (make setup installs it): a real H.264 file ffprobe reads back."""
    import shutil

    assert shutil.which("ffmpeg") and shutil.which("ffprobe"), "ffmpeg is missing: run `make setup`"
    anim = SwingAnimation(swing(), fps=10, duration=1.0)
    out = anim.save(tmp_path / "swing.mp4")
    probe = subprocess.run(
        ["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_frames",
         "-show_entries", "stream=width,height,nb_read_frames", "-of", "csv=p=0", str(out)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    width, height, frames = (int(v) for v in probe.stdout.strip().split(","))
    assert (width, height) == (WIDTH, HEIGHT) and frames == 11


# A user's file may be named like a partial name (.NAME.partial.SUFFIX): it is the asked file all the same.
@pytest.mark.parametrize("stem", ["swing", ".swing.partial"])
@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_a_direct_save_over_a_file_keeps_it_until_the_new_one_is_complete(
    tmp_path: Path, suffix: str, stem: str
) -> None:
    """SwingAnimation.save called directly (a notebook) on an existing file: Ctrl-C mid-way (after the first
    frame, once ffmpeg has opened its output: it truncates the file it writes at once) leaves the old
    bytes as they were and no partial file; a save that completes replaces them."""
    out = tmp_path / f"{stem}{suffix}"
    old = b"the animation of last week's lab\n"
    out.write_bytes(old)
    anim = SwingAnimation(swing(), fps=10, duration=1.0)

    def opened() -> bool:
        """The encoder has touched the file system: the asked file changed or another file appeared."""
        return out.read_bytes() != old or any(p != out for p in tmp_path.iterdir())

    def interrupt() -> None:
        """Ctrl-C after the first frame; for MP4 once ffmpeg's output exists (Pillow writes only at the
        end), or after 30 s without it (the assertions below then still tell)."""
        deadline = time.monotonic() + 30.0
        while suffix == ".mp4" and not opened() and time.monotonic() < deadline:
            time.sleep(0.02)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        anim.save(out, on_frame=interrupt)
    assert out.read_bytes() == old
    assert sorted(tmp_path.iterdir()) == [out]
    assert anim.save(out) == out
    assert sorted(tmp_path.iterdir()) == [out]
    if suffix == ".gif":
        with Image.open(out) as img:
            frames = getattr(img, "n_frames", 1)
    else:
        probe = subprocess.run(
            ["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_frames",
             "-show_entries", "stream=nb_read_frames", "-of", "csv=p=0", str(out)],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
        frames = int(probe.stdout.strip())
    assert frames == 11  # 0, 0.1, …, 1.0 s: the whole new animation


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_a_sigint_inside_a_draw_stops_between_frames(
    tmp_path: Path, suffix: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A real SIGINT arriving while a frame is drawn: KeyboardInterrupt after that frame, no file left, and
    SIGINT's default handler back. The draw here turns a KeyboardInterrupt raised inside it into
    ``ValueError('Invalid bounding box')``, as matplotlib's Agg converters did on CI (a traceback and
    exit 1 where Ctrl-C must give 130); the SIGINT must reach no code inside a draw."""
    draw = SwingAnimation.draw_frame
    drawn: list[int] = []

    def draw_with_sigint(self: SwingAnimation, k: int) -> object:
        """Frame 2 gets a SIGINT half way, which a KeyboardInterrupt there would turn into a ValueError."""
        if k == 2:
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)  # the handler runs here, between bytecodes
            except KeyboardInterrupt:
                raise ValueError("Invalid bounding box") from None
        drawn.append(k)
        return draw(self, k)

    monkeypatch.setattr(SwingAnimation, "draw_frame", draw_with_sigint)
    anim = SwingAnimation(swing(), fps=10, duration=1.0)
    with pytest.raises(KeyboardInterrupt):
        anim.save(tmp_path / f"swing{suffix}")
    assert drawn == [0, 1, 2]
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_sigint_held_between_frames_reaches_the_callers_own_handler(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A caller that handles SIGINT its own way (a flag, as the launcher does) gets the SIGINT that came
    inside a draw once, after that frame, and the animation, which its handler did not stop, is whole."""
    calls: list[int] = []

    def flag(signum: int, frame: object) -> None:
        """The caller's handler: note how many frames were drawn by then."""
        calls.append(len(drawn))

    previous = signal.signal(signal.SIGINT, flag)
    draw = SwingAnimation.draw_frame
    drawn: list[int] = []

    def draw_with_sigint(self: SwingAnimation, k: int) -> object:
        """Frame 2 gets a SIGINT half way."""
        if k == 2:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
        drawn.append(k)
        return draw(self, k)

    monkeypatch.setattr(SwingAnimation, "draw_frame", draw_with_sigint)
    try:
        anim = SwingAnimation(swing(), fps=10, duration=1.0)
        out = anim.save(tmp_path / "swing.gif")
        with Image.open(out) as img:
            assert getattr(img, "n_frames", 1) == anim.times.size
        assert calls == [3]  # after frame 2 (the third) was written, not inside its draw
        assert signal.getsignal(signal.SIGINT) is flag
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("name", ["swing.gif", ".swing.partial.gif"])
def test_a_direct_save_on_a_full_disk_keeps_the_old_file(tmp_path: Path, name: str) -> None:
    """SwingAnimation.save over an existing file on a disk with no room for the new one (a 62 KiB GIF, a
    16 KiB file system): OSError 'No space left on device', the old bytes as they were and nothing left
    beside them, whatever the file is called (written in place, it would have been truncated first)."""
    from test.tiny_filesystem import tiny_filesystem

    old = b"the animation of last week's lab\n"
    anim = SwingAnimation(swing(), fps=10, duration=1.0)
    with tiny_filesystem(tmp_path / "fs", "16k") as fs:
        out = fs / name
        out.write_bytes(old)
        with pytest.raises(OSError) as failed:
            anim.save(out)
        assert failed.value.errno == errno.ENOSPC
        assert out.read_bytes() == old
        assert sorted(fs.iterdir()) == [out]
