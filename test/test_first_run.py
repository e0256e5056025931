"""The first run after an install: numba's cache is cold (the README's pip lines leave it so), and
``pendulum-accel run`` compiles it before starting the nodes, says so, and records the whole scene.

The install path is taken as users take it: a fresh venv made with the README's pip lines in a clean
checkout (its cache beside the installed modules, cold after pip), whose first run compiles. A cold compile
is a minute or more of CPU: the suite does it once for a first run (here, the README's path) and once in
colcon's install step (test_package); the launcher's compile-first path is the same code whichever script
starts it, and test_package checks that a colcon install with an empty NUMBA_CACHE_DIR reads as cold.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from test.conftest import PYTHON, REPO
from test.install_paths import (
    COMPILING,
    assert_recorded,
    clean_checkout,
    cold,
    imported_from,
    outside_env,
    story,
)


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
    # pip's byte-compile of every installed module is half its CPU here (62 s against 34 s without), and
    # nothing this test checks depends on it: Python compiles what the run imports as it imports it.
    env = {**outside_env(), "PIP_NO_COMPILE": "1"}
    try:
        for line in lines:
            done = subprocess.run(
                ["sh", "-c", line], cwd=checkout, env=env, capture_output=True, text=True, timeout=1800
            )
            assert done.returncode == 0, f"{line}: {done.stdout[-1500:]}{done.stderr[-1500:]}"
        python = str(checkout / ".venv" / "bin" / "python")
        assert imported_from(env, python) == checkout / "pendulum_accel"  # the fresh install, not ours
        assert cold(env, python, Path("/"))  # the pip lines leave numba's cache cold
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
        assert result.returncode == 0, story(result.stderr)
        assert COMPILING in result.stderr
        assert_recorded(bag)
        assert not cold(env, python, Path("/"))
    finally:
        shutil.rmtree(tmp_path, ignore_errors=True)  # the venv is over a gigabyte


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
    assert done.returncode == 0, story(done.stderr)
    assert_recorded(bag)
