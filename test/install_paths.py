"""The install paths users take, for the tests that take them: a clean checkout, a user's shell after an
install, and one ``colcon build`` of the package shared by every test that needs it (``colcon_workspace``
in conftest: the build, with its numba compile in the install step, is the costliest thing the suite does
twice otherwise)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from test.conftest import PYTHON, REPO


def clean_checkout(destination: Path) -> Path:
    """The repository's tracked files, as the working tree has them, copied to ``destination`` (what a
    fresh clone holds, with this tree's changes): no .venv, no caches, no build output."""
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.split("\0")
    for name in filter(None, files):
        source = REPO / name
        if source.is_file():  # a deleted, not yet committed file is listed but absent
            (destination / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, destination / name)
    return destination


def outside_env() -> dict[str, str]:
    """The test's environment (its ROS domain, localhost discovery) without what points Python at this
    checkout or this venv, or numba at another cache: as a user's shell after an install."""
    drop = ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "NUMBA_CACHE_DIR")
    return {k: v for k, v in os.environ.items() if k not in drop}


def build_colcon_workspace(workspace: Path) -> None:
    """``colcon build --base-paths src`` (this venv's colcon, as the README's colcon lines run it) of a clean
    checkout in ``workspace/src/pendulum_accel``; AssertionError with colcon's output when it fails."""
    colcon = str(Path(PYTHON).with_name("colcon"))
    if not Path(colcon).exists():
        colcon = shutil.which("colcon") or "colcon"
    (workspace / "src").mkdir(parents=True)
    clean_checkout(workspace / "src" / "pendulum_accel")
    built = subprocess.run(
        [colcon, "build", "--base-paths", "src"],
        cwd=workspace,
        env=outside_env(),
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]


COMPILING = "compiling the stepping kernels and the estimators' loops into numba's cache"


def cold(env: dict[str, str], python: str = PYTHON, cwd: Path = REPO) -> bool:
    """kernel_cache.is_cold() under ``env``, in ``python`` started in ``cwd`` (``python -c`` imports from
    its working directory first: "/" for an installed copy, so this checkout's modules do not shadow it)."""
    code = "from pendulum_accel.kernel_cache import is_cold; print(is_cold())"
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True, timeout=120, cwd=cwd)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip() == "True"


def imported_from(env: dict[str, str], python: str) -> Path:
    """The directory ``python`` imports pendulum_accel from under ``env`` (started in "/", as _cold)."""
    code = "import pendulum_accel; print(pendulum_accel.__file__)"
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True, timeout=120, cwd="/")
    assert out.returncode == 0, out.stderr[-2000:]
    return Path(out.stdout.strip()).parent


def story(stderr: str) -> str:
    """The launcher's lines (what started, waited, ended), every node's error line and the end of
    ``stderr``: a failure's cause."""
    marks = ("chain:", "pendulum-accel run:")
    chain = [line for line in stderr.splitlines() if line.startswith(marks) or "error" in line.lower()]
    return "\n".join(chain) + "\n...\n" + stderr[-2000:]


def assert_recorded(bag: Path) -> None:
    """The bag holds angles and their estimates (the run summary's own check is its exit code)."""
    topics = read_bag(bag).topics
    assert topics[bm.TOPIC_JOINT_STATES].count > 0 and topics[bm.TOPIC_ACCEL_ESTIMATE].count > 0
