"""The package's layers (docs/architecture.md): every import points down or sideways, ROS only in nodes/.

Imports inside functions count too: a lazy import that runs back up is still an arrow up.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pendulum_accel"

# Bottom to top; a unit may import units of its own layer or below. Same table as docs/architecture.md.
LAYERS: tuple[frozenset[str], ...] = (
    frozenset({"errors", "textfile"}),
    frozenset({"physics", "bag"}),
    frozenset({"estimators", "sensor", "kernel_cache"}),
    frozenset({"scene"}),
    frozenset({"conditioning"}),
    frozenset({"overrides", "planner"}),
    frozenset({"scene_run", "sweep"}),
    frozenset({"recording"}),
    frozenset({"lecture", "animation", "allan"}),
    frozenset({"nodes"}),
    frozenset({"cli"}),
)
LEVEL = {unit: level for level, units in enumerate(LAYERS) for unit in units}
# Modules that import ROS 2 (rclpy or message packages); everything below nodes/ runs on numpy alone.
ROS_ROOTS = {"rclpy", "rcl_interfaces", "builtin_interfaces", "rosidl_runtime_py"}


def unit_of(path: Path) -> str:
    """Top-level unit of a module: the subpackage name, or the module name for a top-level module."""
    return path.relative_to(PACKAGE).with_suffix("").parts[0]


def imported_modules(path: Path) -> list[str]:
    """Absolute module names a file imports anywhere (module level or inside functions)."""
    names: list[str] = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.append(node.module)
            names += [f"{node.module}.{alias.name}" for alias in node.names]
    return names


def package_units(names: list[str]) -> set[str]:
    """The pendulum_accel units among imported names (the package root itself is not a unit)."""
    units = set()
    for name in names:
        parts = name.split(".")
        if parts[0] == "pendulum_accel" and len(parts) > 1 and parts[1] in LEVEL:
            units.add(parts[1])
    return units


MODULES = sorted(p for p in PACKAGE.rglob("*.py") if unit_of(p) != "__init__")


def test_every_unit_has_a_layer() -> None:
    units = {unit_of(p) for p in MODULES}
    assert units <= set(LEVEL), f"units without a layer: {sorted(units - set(LEVEL))}"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path: Path) -> None:
    unit = unit_of(path)
    up = {other for other in package_units(imported_modules(path)) if LEVEL[other] > LEVEL[unit]}
    assert not up, f"{path.relative_to(PACKAGE)} ({unit}) imports a layer above it: {sorted(up)}"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_ros_only_in_nodes(path: Path) -> None:
    if unit_of(path) == "nodes":
        return
    ros = {
        n for n in imported_modules(path) if n.split(".")[0] in ROS_ROOTS or n.split(".")[0].endswith("_msgs")
    }
    assert not ros, f"{path.relative_to(PACKAGE)} imports ROS 2: {sorted(ros)}"


def test_the_bag_library_imports_no_domain() -> None:
    """bag/ is reusable rosbag2 I/O: it may import only itself and errors."""
    for path in (PACKAGE / "bag").glob("*.py"):
        assert package_units(imported_modules(path)) <= {"bag", "errors"}, path.name


def test_a_planted_upward_import_is_caught(tmp_path: Path) -> None:
    """The checker itself: a physics module importing the scene is an arrow up."""
    fake = tmp_path / "x.py"
    fake.write_text("def f():\n    from pendulum_accel.scene import load_scene\n")
    assert package_units(imported_modules(fake)) == {"scene"}
    assert LEVEL["scene"] > LEVEL["physics"]
