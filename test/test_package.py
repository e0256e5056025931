"""Package metadata is consistent for colcon (ament_python) and for pip, and a colcon build installs the
``ros2 run`` layout, whose scripts run the chain on the cache its install step compiled."""

from __future__ import annotations

import ast
import importlib
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import pytest

import pendulum_accel
from pendulum_accel.scene import BUNDLED_SCENE_NAMES
from test.conftest import PYTHON, REPO
from test.install_paths import COMPILING, assert_recorded, cold, imported_from, outside_env, story

NODES = ("pendulum_sim", "accel_estimator", "bag_recorder", "bag_player")


def _package_xml() -> ET.Element:
    return ET.parse(REPO / "package.xml").getroot()


def _console_scripts() -> dict[str, str]:
    """console_scripts from setup.py, read without running it."""
    tree = ast.parse((REPO / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values, strict=True):
                if isinstance(key, ast.Constant) and key.value == "console_scripts":
                    entries = ast.literal_eval(value)
                    return dict(tuple(part.strip() for part in e.split("=", 1)) for e in entries)
    raise AssertionError("setup.py has no console_scripts")


def test_package_xml_is_format_3_ament_python() -> None:
    root = _package_xml()
    assert root.get("format") == "3"
    assert root.findtext("name") == "pendulum_accel"
    assert root.findtext("license") == "Apache-2.0"
    assert root.findtext("export/build_type") == "ament_python"
    exec_deps = {e.text for e in root.findall("exec_depend")}
    expected = {"rclpy", "std_msgs", "sensor_msgs", "geometry_msgs", "diagnostic_msgs", "rosgraph_msgs"}
    assert expected | {"python3-numpy", "python3-scipy", "python3-yaml"} <= exec_deps
    assert {"python3-matplotlib", "python3-tqdm"} <= exec_deps
    assert {"python3-pytest", "python3-hypothesis"} <= {  # mpmath has no rosdep key: requirements-dev.txt
        e.text for e in root.findall("test_depend")
    }


def duplicate_dependencies(root: ET.Element) -> list[tuple[str, str]]:
    """(tag, key) of every dependency listed more than once under one tag of a package.xml."""
    listed = Counter((e.tag, e.text or "") for e in root if e.tag.endswith("depend"))
    return sorted(key for key, count in listed.items() if count > 1)


def test_package_xml_lists_each_dependency_once() -> None:
    """No key twice under one tag (rcl_interfaces and builtin_interfaces once were), which catkin_pkg
    does not check; and catkin_pkg's own validation (a depend or test_depend redundant with another
    tag) passes. The check finds a doubled key."""
    from catkin_pkg.package import parse_package

    root = _package_xml()
    assert duplicate_dependencies(root) == []
    parse_package(str(REPO / "package.xml")).validate()
    doubled = ET.fromstring(ET.tostring(root))
    doubled.append(ET.fromstring("<exec_depend>rcl_interfaces</exec_depend>"))
    assert duplicate_dependencies(doubled) == [("exec_depend", "rcl_interfaces")]


# Every run-time import against setup.py, package.xml and the README: test/test_dependencies.py.


def test_one_version_everywhere() -> None:
    xml_version = _package_xml().findtext("version")
    assert pendulum_accel.__version__ == xml_version
    assert importlib.metadata.version("pendulum_accel") == xml_version


def test_ament_resource_marker_and_setup_cfg() -> None:
    assert (REPO / "resource" / "pendulum_accel").is_file()
    cfg = (REPO / "setup.cfg").read_text()
    assert "script_dir=$base/lib/pendulum_accel" in cfg
    assert "install_scripts=$base/lib/pendulum_accel" in cfg


def test_console_scripts_point_at_real_functions() -> None:
    scripts = _console_scripts()
    assert set(NODES) | {"pendulum-accel"} <= set(scripts)
    for target in scripts.values():
        module, func = target.split(":")
        assert callable(getattr(importlib.import_module(module), func)), target


def test_the_oldest_python_declared_is_the_one_linted_and_type_checked() -> None:
    """setup.py's python_requires floor is ruff's target and mypy's python_version, and the interpreter
    running the tests meets it. A floor below what the checks use (3.10 once, while the install floors
    numpy 2.4, scipy 1.17 and matplotlib 3.11 need 3.11) promised an install pip cannot make."""
    import tomllib

    tree = ast.parse((REPO / "setup.py").read_text())
    requires = next(
        k.value.value  # type: ignore[attr-defined]
        for k in ast.walk(tree)
        if isinstance(k, ast.keyword) and k.arg == "python_requires"
    )
    assert requires.startswith(">=")
    floor = tuple(int(part) for part in requires[2:].split("."))
    tools = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert tools["tool"]["ruff"]["target-version"] == f"py{floor[0]}{floor[1]}"
    assert tools["tool"]["mypy"]["python_version"] == f"{floor[0]}.{floor[1]}"
    assert sys.version_info[:2] >= floor


def test_ros_wheels_are_not_a_hard_dependency() -> None:
    requires = importlib.metadata.requires("pendulum_accel") or []
    assert not [r for r in requires if r.lower().startswith(("ros-", "rclpy"))]
    pinned = [
        line for line in (REPO / "requirements-ros.txt").read_text().splitlines() if line.startswith("ros-")
    ]
    assert pinned and all("==" in line for line in pinned)


# The shared build (conftest's colcon_workspace: colcon, then numba's compile in the install step) takes
# minutes on a loaded machine, and the first test to ask for it waits for it: a longer limit than the
# suite's 600 s, not a speed threshold.
@pytest.mark.slow
@pytest.mark.timeout(2400)
def test_colcon_build_installs_ros2_run_layout(colcon_workspace: Path) -> None:
    """colcon build of a clean checkout (the one build the suite shares) installs the ros2 run layout."""
    workspace = colcon_workspace
    prefix = workspace / "install" / "pendulum_accel"
    for name in (*NODES, "pendulum-accel"):
        assert (prefix / "lib" / "pendulum_accel" / name).is_file(), name
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "pendulum_accel").is_file()
    assert (prefix / "share" / "pendulum_accel" / "package.xml").is_file()
    assert list((prefix / "share" / "pendulum_accel" / "scenes").glob("*.yaml"))
    # Where `ros2 launch pendulum_accel chain.launch.py` and --params-file look.
    assert (prefix / "share" / "pendulum_accel" / "launch" / "chain.launch.py").is_file()
    assert (prefix / "share" / "pendulum_accel" / "config" / "pendulum_accel.params.yaml").is_file()
    # The viewer layouts the README tells Foxglove and PlotJuggler users to load.
    layouts = {p.name for p in (prefix / "share" / "pendulum_accel" / "layouts").iterdir()}
    assert layouts == {p.name for p in (REPO / "layouts").iterdir()} and layouts
    # Package data travels with the installed module: scenes and the Fast DDS profile.
    installed = list(prefix.glob("lib/python3*/site-packages/pendulum_accel"))
    assert len(installed) == 1, installed
    assert (installed[0] / "nodes" / "fastdds_profile.xml").is_file()
    assert len(list((installed[0] / "scenes").glob("*.yaml"))) == len(BUNDLED_SCENE_NAMES)
    # The recorded motion the real-motion scenes read, beside them as in the source tree.
    assert (installed[0] / "scenes" / "real_motion" / "udds.csv").is_file()
    assert (prefix / "share" / "pendulum_accel" / "scenes" / "real_motion" / "husky_odom.csv").is_file()


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
    assert imported_from(env, PYTHON) == site / "pendulum_accel"
    assert not cold(env, PYTHON, Path("/"))  # the install step compiled it beside the installed modules
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
    assert warm.returncode == 0, story(warm.stderr)
    assert COMPILING not in warm.stderr
    assert_recorded(tmp_path / "warm")
    assert cold({**env, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}, PYTHON, Path("/"))


def test_a_pip_install_puts_the_share_files_where_the_readme_says(tmp_path: Path) -> None:
    """setup.py's data files (what `pip install .` and colcon install) hold the URDF, the launch file and
    the parameters under share/pendulum_accel; the README says so, and says that `pip install -e .`, its
    own pip route, installs none (setuptools' editable installs leave data files out), naming where
    they are then."""
    subprocess.run(
        [sys.executable, "setup.py", "-q", "install_data", "--install-dir", str(tmp_path)],
        cwd=REPO,
        check=True,
        capture_output=True,
    )
    share = tmp_path / "share" / "pendulum_accel"
    for installed in (
        "urdf/pendulum_accel.urdf",
        "launch/chain.launch.py",
        "config/pendulum_accel.params.yaml",
    ):
        assert (share / installed).is_file(), installed
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    (row,) = [line for line in readme.splitlines() if line.startswith("| `urdf` |")]
    assert "share/pendulum_accel/urdf/pendulum_accel.urdf" in row and "`pip install .`" in row
    assert "`pip install -e .`" in row and "`urdf/`" in row and "installs no `share/`" in row
