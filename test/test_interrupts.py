"""Ctrl-C during a long command: exit 130 with one line, no partial output.

What ``generate`` or ``animate`` must do after SIGINT: finish the C call it is in (one frame's Agg draw,
one MCAP chunk's compression), run its finally blocks (kill ffmpeg, drop the frames held, unlink the
partial output), print the line and os._exit, skipping the interpreter's teardown. From SIGINT to exit:
0.01-0.22 s measured with both cores busy (two spinning processes, load 5), whether the SIGINT came while
importing, simulating or drawing (after 45 s of GIF frames held). A machine shared with other suites may
give the command a small fraction of a core for seconds at a time, so their tests wait for the exit
itself: EXIT_TIMEOUT_S, 500 times the slowest stop measured, only tells a hung process (an interrupt
lost) from a slow one, and none of them asserts how quickly the stop came.

A compiled kernel run and ``allan`` hold the work in slices (kernels.SLICE_STEPS, allan.interruptible) so
that Ctrl-C is handled between two of them: those two tests bound the stop, each bound argued beside it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from pendulum_accel.scene import load_scene, scene_to_yaml
from test.conftest import PYTHON, REPO

EXIT_TIMEOUT_S = 120.0  # a stop that has not come by then never will: see the module docstring
START_BOUND_S = 300.0  # imports and the work before the watched point, on a loaded machine


def _long_scene(tmp_path: Path, duration: float) -> Path:
    """lecture_constant lengthened to ``duration`` s, as a scene file."""
    from dataclasses import replace

    path = tmp_path / "long.yaml"
    path.write_text(scene_to_yaml(replace(load_scene("lecture_constant"), name="long", duration=duration)))
    return path


# The command as the console script runs it, with one observation added: ``MARK`` is created once the
# first frame is grabbed, so a test knows the drawing has started (a GIF shows nothing on disk until the
# end). Nothing else changes: main() runs as its own process, and exits through os._exit on Ctrl-C.
_MARK_DRAWING = """
import os, sys
from pathlib import Path
from pendulum_accel.animation import SwingAnimation
from pendulum_accel.cli.main import main
draw = SwingAnimation.draw_frame
def draw_and_mark(self, k):
    if k == 1:
        Path(os.environ["MARK"]).touch()
    return draw(self, k)
SwingAnimation.draw_frame = draw_and_mark
sys.exit(main())
"""


def _interrupt_when(
    args: list[str],
    ready: Callable[[], bool],
    run: tuple[str, ...] = ("-m", "pendulum_accel.cli.main"),
    **env: str,
) -> tuple[int, str]:
    """Run ``python RUN ARGS`` (``pendulum-accel ARGS``), SIGINT once ``ready()``, wait for the exit;
    (exit code, stderr)."""
    proc = subprocess.Popen(
        [sys.executable, *run, *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, **env},
    )  # fmt: skip
    deadline = time.monotonic() + START_BOUND_S
    while not ready():
        assert proc.poll() is None, f"finished before the interrupt: {proc.communicate()}"
        assert time.monotonic() < deadline, "never reached the point to interrupt"
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"still running {EXIT_TIMEOUT_S:g} s after SIGINT: the interrupt was lost")
    return proc.returncode, err


def test_generate_interrupted_while_writing_leaves_no_bag(tmp_path: Path) -> None:
    """SIGINT as soon as the bag directory appears (the writer has started): exit 130, one line, no bag."""
    scene = _long_scene(tmp_path, 3000.0)  # 300 000 samples: seconds of writing
    out = tmp_path / "bag"
    code, err = _interrupt_when(["generate", str(scene), "--out", str(out), "-e", "instant"], out.exists)
    assert code == 130, err
    assert err.strip().splitlines() == ["pendulum-accel generate: interrupted"]
    assert not out.exists()


def test_animate_interrupted_while_encoding_leaves_no_file(tmp_path: Path) -> None:
    """SIGINT once ffmpeg has opened its (hidden, partial) output: exit 130, no MP4 and no partial file
    (ffmpeg is a requirement of the animation tests: make setup installs it)."""
    out = tmp_path / "swing.mp4"

    def encoding() -> bool:
        """The hidden partial MP4 (textfile.partial_path, which ffmpeg writes) holds encoded bytes."""
        return any(
            p.name.startswith(".") and ".partial" in p.name and p.stat().st_size > 0
            for p in tmp_path.iterdir()
            if p.suffix == ".mp4"
        )

    scene = _long_scene(tmp_path, 600.0)
    code, err = _interrupt_when(["animate", str(scene), "--out", str(out), "--duration", "600"], encoding)
    assert code == 130, err
    assert err.strip().splitlines() == ["pendulum-accel animate: interrupted"]
    assert sorted(os.listdir(tmp_path)) == ["long.yaml"]


def test_animate_gif_interrupted_leaves_no_file(tmp_path: Path) -> None:
    """GIF frames are held in memory until the end: SIGINT once the drawing has started (the scene ran,
    the first frame is grabbed) leaves no GIF, neither the asked one nor a partial one."""
    scene = _long_scene(tmp_path, 600.0)
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    mark = tmp_path / "drawing"
    args = ["animate", str(scene), "--out", str(outputs / "swing.gif"), "--duration", "600"]
    code, err = _interrupt_when(args, mark.exists, ("-c", _MARK_DRAWING), MARK=str(mark))
    assert code == 130, err
    assert err.strip().splitlines() == ["pendulum-accel animate: interrupted"]
    assert os.listdir(outputs) == []


# ``scenes`` as the console script runs it, its work replaced by code that swallows Ctrl-C as matplotlib's
# Agg converters did on CI: a KeyboardInterrupt raised inside comes out as a ValueError. With SIGNAL unset
# the same ValueError comes with no Ctrl-C at all, as a bug would.
_SWALLOWING_COMMAND = """
import os, signal, sys, time
import pendulum_accel.cli.scenes as scenes
def swallowing(args):
    try:
        if os.environ.get("SIGNAL"):
            os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    raise ValueError("Invalid bounding box")
scenes.run = swallowing
from pendulum_accel.cli.main import main
sys.exit(main())
"""


@pytest.mark.parametrize("sigint", [True, False])
def test_an_error_raised_by_a_swallowed_ctrl_c_is_the_interrupt(sigint: bool) -> None:
    """Any command: an error that escapes after a Ctrl-C (code that turned the KeyboardInterrupt into an
    error of its own) ends as the interrupt, one line and exit 130. The same error with no Ctrl-C is a bug
    and keeps its traceback and exit 1."""
    env = {**os.environ, "SIGNAL": "1" if sigint else ""}
    proc = subprocess.run(
        [sys.executable, "-c", _SWALLOWING_COMMAND, "scenes"],
        capture_output=True, text=True, env=env, timeout=EXIT_TIMEOUT_S,
    )  # fmt: skip
    if sigint:
        assert (proc.returncode, proc.stderr.strip().splitlines()) == (
            130,
            ["pendulum-accel scenes: interrupted"],
        )
    else:
        assert proc.returncode == 1
        assert proc.stderr.strip().splitlines()[-1] == "ValueError: Invalid bounding box"


_LONG_KERNEL = """
import numpy as np
from pendulum_accel.physics import kernels
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Sinusoid
kernel = kernels.Kernel.rigid(Pendulum(1.0), Sinusoid(amplitude=1.0, frequency_hz=0.5))
kernels.run_kernel(kernel, np.zeros(2), np.array([0.0, 0.001]), "rk4", 1e-9)  # compiled, cached
print("stepping", flush=True)
kernels.run_kernel(kernel, np.zeros(2), np.linspace(0.0, 100.0, 10001), "rk4", 1e-7)  # 1e9 steps
"""


def test_ctrl_c_stops_a_compiled_run_within_a_second() -> None:
    """1e9 RK4 steps (minutes) in the compiled kernel: SIGINT ends it after at most one slice."""
    proc = subprocess.Popen(
        [PYTHON, "-c", _LONG_KERNEL], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "stepping"
        time.sleep(1.0)
        assert proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
        waited = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode != 0 and "KeyboardInterrupt" in (proc.stderr.read() if proc.stderr else "")
    # One slice is ~0.1-0.2 s of work; on a loaded 2-core machine allow a few times that, far below the run.
    assert waited < 3.0, f"took {waited:.1f} s to stop"


@pytest.mark.parametrize("after", [12.0, 45.0])  # simulating the static run; estimating on it
@pytest.mark.slow
def test_ctrl_c_stops_a_long_allan_within_a_second(tmp_path: Path, after: float) -> None:
    """allan on 4e7 samples (400000 s at 100 Hz): minutes of numpy and compiled work. The main thread
    waits for the work in 50 ms slices (allan.interruptible) and the compiled batch kernels leave the
    GIL, so SIGINT is handled within a slice and the process exits at once (cli.main's os._exit):
    1 s is 20 slices, a bound that holds on a loaded machine because nothing but the GIL hand-off
    (5 ms switch interval) stands between the signal and the exit. Without the slices it was 1-1.6 s
    on an idle machine and up to the whole estimator pass (minutes) inside it."""
    plot = tmp_path / "allan.png"
    proc = subprocess.Popen(
        [
            PYTHON,
            "-m",
            "pendulum_accel.cli.main",
            "allan",
            "lecture_constant",
            "--duration",
            "400000",
            "--plot",
            str(plot),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        # A background job's SIGINT may be ignored by inheritance; the command must see it as a user would.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        time.sleep(after)
        assert proc.poll() is None, proc.communicate()
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        waited = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1] == "pendulum-accel allan: interrupted", err
    assert list(tmp_path.iterdir()) == []  # nothing partial: the plot is written only at the end
    assert waited < 1.0, f"took {waited:.2f} s to stop"
