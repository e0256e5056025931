"""The first run after an install: numba's cache is cold (the README's pip lines leave it so), and
``pendulum-accel run`` compiles it before starting the nodes, says so, and records the whole scene.

Two install paths are taken as users take them: a fresh venv made with the README's pip lines in a clean
checkout (its cache beside the installed modules, cold after pip), whose first run compiles; and
``colcon build`` run from a workspace (its console scripts in the ``ros2 run`` layout, lib/pendulum_accel/),
whose install step warms the cache, so its script runs without compiling, while with NUMBA_CACHE_DIR
pointing numba at an empty directory (as after ``colcon build --symlink-install``) the same install reads
as cold. A cold compile is a minute or more of CPU: the suite does it once for a first run (the README's
path), and once in colcon's install step; the launcher's compile-first path is the same code whichever
script starts it.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from test.conftest import PYTHON, REPO
from test.install_paths import clean_checkout, outside_env

COMPILING = "compiling the stepping kernels and the estimators' loops into numba's cache"


def _cold(env: dict[str, str], python: str = PYTHON, cwd: Path = REPO) -> bool:
    """kernel_cache.is_cold() under ``env``, in ``python`` started in ``cwd`` (``python -c`` imports from
    its working directory first: "/" for an installed copy, so this checkout's modules do not shadow it)."""
    code = "from pendulum_accel.kernel_cache import is_cold; print(is_cold())"
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True, timeout=120, cwd=cwd)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip() == "True"


def _imported_from(env: dict[str, str], python: str) -> Path:
    """The directory ``python`` imports pendulum_accel from under ``env`` (started in "/", as _cold)."""
    code = "import pendulum_accel; print(pendulum_accel.__file__)"
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True, timeout=120, cwd="/")
    assert out.returncode == 0, out.stderr[-2000:]
    return Path(out.stdout.strip()).parent


def _story(stderr: str) -> str:
    """The launcher's lines (what started, waited, ended), every node's error line and the end of
    ``stderr``: a failure's cause."""
    marks = ("chain:", "pendulum-accel run:")
    chain = [line for line in stderr.splitlines() if line.startswith(marks) or "error" in line.lower()]
    return "\n".join(chain) + "\n...\n" + stderr[-2000:]


def _assert_recorded(bag: Path) -> None:
    """The bag holds angles and their estimates (the run summary's own check is its exit code)."""
    topics = read_bag(bag).topics
    assert topics[bm.TOPIC_JOINT_STATES].count > 0 and topics[bm.TOPIC_ACCEL_ESTIMATE].count > 0


def readme_pip_lines() -> list[str]:
    """The shell lines of the README's "Without ROS 2 (pip)" install: the first ```sh block after it."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```sh\n(.*?)```", text[text.index("**Without ROS 2 (pip).**") :], re.S)
    assert block is not None, "README.md: no ```sh block after **Without ROS 2 (pip).**"
    return [line for line in block.group(1).splitlines() if line.strip()]


def readme_first_run() -> list[str]:
    """The README's first ``pendulum-accel run`` line (its arguments, comment dropped)."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    line = re.search(r"^pendulum-accel run [^#\n]*", text, re.M)
    assert line is not None, "README.md: no `pendulum-accel run` line"
    return line.group(0).split()[1:]


# pip installs from its cache (~/.cache/pip, warm after `make setup`) in a few minutes, then the first run
# compiles every kernel (1-2 min on 2 idle cores, several times that on a loaded machine): limits longer
# than the suite's 600 s, not speed thresholds.
@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_the_readme_pip_lines_in_a_fresh_venv_give_a_first_run_that_works(tmp_path: Path) -> None:
    """From a clean checkout, the README's pip lines exactly (python3 -m venv, pip install -r …, pip install
    -e .), then the README's first run: it compiles numba's cache first, says so, and records the scene."""
    lines = readme_pip_lines()
    assert lines[0].startswith("python3 -m venv .venv")
    assert all(line.startswith(".venv/bin/pip install") for line in lines[1:])
    # Not named pendulum_accel: the run starts in tmp_path, and `python -m` (every node) would import a
    # directory of that name there as a namespace package (as it would from a cwd holding such a clone).
    checkout = clean_checkout(tmp_path / "checkout")
    env = outside_env()
    try:
        for line in lines:
            done = subprocess.run(
                ["sh", "-c", line], cwd=checkout, env=env, capture_output=True, text=True, timeout=1800
            )
            assert done.returncode == 0, f"{line}: {done.stdout[-1500:]}{done.stderr[-1500:]}"
        python = str(checkout / ".venv" / "bin" / "python")
        assert _imported_from(env, python) == checkout / "pendulum_accel"  # the fresh install, not ours
        assert _cold(env, python, Path("/"))  # the pip lines leave numba's cache cold
        args = readme_first_run()
        bag = tmp_path / "bag"
        args[args.index("--record") + 1] = str(bag)
        result = subprocess.run(
            [str(checkout / ".venv" / "bin" / "pendulum-accel"), *args],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=2300,
        )
        assert result.returncode == 0, _story(result.stderr)
        assert COMPILING in result.stderr
        _assert_recorded(bag)
        assert not _cold(env, python, Path("/"))
    finally:
        shutil.rmtree(tmp_path, ignore_errors=True)  # the venv is over a gigabyte


# The shared build (conftest's colcon_workspace, with the compile of its install step): a limit longer than
# the suite's 600 s (a loaded machine takes several times the 1-2 min of 2 idle cores), not a speed threshold.
@pytest.mark.slow
@pytest.mark.timeout(2400)
def test_colcon_build_warms_the_cache_and_the_ros2_run_layout_runs_first_time(
    colcon_workspace: Path, tmp_path: Path
) -> None:
    """colcon build (from this venv, as the README's colcon lines do) warms numba's cache in its install
    step, and the console script it installs in lib/pendulum_accel (what `ros2 run` starts) runs the
    chain on that warm cache without compiling; with NUMBA_CACHE_DIR empty (as after `colcon build
    --symlink-install`, which installs nothing) the same install reads as cold, so that script's first run
    would compile first, as the README's does (test_the_readme_pip_lines_…)."""
    env = outside_env()
    prefix = colcon_workspace / "install" / "pendulum_accel"
    (site,) = prefix.glob("lib/python3*/site-packages")
    # What colcon's local_setup puts on the paths for this package (no ROS install here: the ROS wheels
    # are in the venv the console scripts' shebang names).
    env["PYTHONPATH"] = str(site)
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["PATH"] = f"{prefix / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    assert _imported_from(env, PYTHON) == site / "pendulum_accel"
    assert not _cold(env, PYTHON, Path("/"))  # the install step compiled it beside the installed modules
    script = prefix / "lib" / "pendulum_accel" / "pendulum-accel"
    command = ["run", "step_start", "--fast", "--set", "duration=2", "--record"]
    warm = subprocess.run(
        [str(script), *command, str(tmp_path / "warm")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert warm.returncode == 0, _story(warm.stderr)
    assert COMPILING not in warm.stderr
    _assert_recorded(tmp_path / "warm")
    assert _cold({**env, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}, PYTHON, Path("/"))


@pytest.mark.slow
def test_a_folder_named_like_the_package_in_the_working_directory_does_not_shadow_it(tmp_path: Path) -> None:
    """``run`` from a directory holding a ``pendulum_accel`` folder (a colcon workspace's src/ after the
    README's clone): the nodes, started with ``python -m``, still import the installed package (without
    PYTHONSAFEPATH they imported the folder as a namespace package and the recorder exited 1)."""
    (tmp_path / "pendulum_accel").mkdir()  # the clone, seen from src/: no __init__.py at its top
    command = Path(PYTHON).with_name("pendulum-accel")
    assert command.exists(), "the venv's pendulum-accel script is missing (make setup installs it)"
    bag = tmp_path / "bag"
    done = subprocess.run(
        [str(command), "run", "step_start", "--fast", "--set", "duration=1", "--record", str(bag)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, _story(done.stderr)
    _assert_recorded(bag)
