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
    frozenset({"errors", "textfile", "cluster", "cluster_worker"}),
    frozenset({"physics", "bag"}),
    frozenset({"motion_input"}),
    frozenset({"estimators", "sensor", "kernel_cache"}),
    frozenset({"scene", "scene_yaml"}),
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


@pytest.mark.parametrize("path", sorted((PACKAGE / "bag").glob("*.py")), ids=lambda p: p.name)
def test_the_bag_library_imports_no_domain(path: Path) -> None:
    """bag/ is reusable rosbag2 I/O: it imports only itself and the layer-0 textfile (file kinds, bounded
    text reading). Its errors are its own (bag/errors.py), the one module that imports the package's
    errors, whose BagError is their base."""
    allowed = {"bag", "textfile"} | ({"errors"} if path.name == "errors.py" else set())
    assert package_units(imported_modules(path)) <= allowed, path.name


def module_name(path: Path) -> str:
    """Dotted name of a package file: pendulum_accel.physics.profiles; a package's __init__ is the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


ALL_FILES = sorted(PACKAGE.rglob("*.py"))
MODULE_NAMES = {module_name(p) for p in ALL_FILES}


def runtime_imports(path: Path) -> list[str]:
    """Absolute module names a file imports when it runs: ``from pkg import name`` is pkg.name when that is
    a module of the package, else pkg; imports under ``if TYPE_CHECKING:`` (read only by mypy) are left
    out."""
    tree = ast.parse(path.read_text())
    typing_only = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for stmt in node.body
        for inner in ast.walk(stmt)
    }
    names: list[str] = []
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                names.append(sub if sub in MODULE_NAMES else node.module)
    return names


def import_graph(paths: list[Path]) -> dict[str, set[str]]:
    """module → the package modules it imports when it runs (runtime_imports)."""
    return {
        module_name(path): {n for n in runtime_imports(path) if n in MODULE_NAMES} - {module_name(path)}
        for path in paths
    }


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm): each is a circle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


def test_no_import_circles() -> None:
    """No module reaches itself through imports (module level or inside functions): a circle hides an
    order of initialisation and makes two modules one."""
    assert import_cycles(import_graph(ALL_FILES)) == []


def test_motion_input_is_below_the_scene_and_above_physics() -> None:
    """Motion input reads files and bags into physics' profile types; physics never reads input."""
    assert LEVEL["physics"] < LEVEL["motion_input"] < LEVEL["scene"]
    for path in (PACKAGE / "physics").glob("*.py"):
        assert "motion_input" not in package_units(imported_modules(path)), path.name


def test_a_planted_circle_is_caught(tmp_path: Path) -> None:
    """The circle finder itself: a → b → a is one circle; a → b alone is none."""
    assert import_cycles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert import_cycles({"a": {"b"}, "b": set()}) == []


def test_a_planted_upward_import_is_caught(tmp_path: Path) -> None:
    """The checker itself: a physics module importing the scene is an arrow up."""
    fake = tmp_path / "x.py"
    fake.write_text("def f():\n    from pendulum_accel.scene import load_scene\n")
    assert package_units(imported_modules(fake)) == {"scene"}
    assert LEVEL["scene"] > LEVEL["physics"]


LIBRARY_AND_DOMAIN = sorted([*(PACKAGE / "bag").glob("*.py"), *(PACKAGE / "recording").glob("*.py")])


def _names_any(annotation: ast.expr) -> bool:
    """The annotation mentions typing's Any (``Any``, ``typing.Any``, or inside a string annotation)."""
    for node in ast.walk(annotation):
        if isinstance(node, ast.Name) and node.id == "Any":
            return True
        if isinstance(node, ast.Attribute) and node.attr == "Any":
            return True
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            try:
                inner = ast.parse(node.value, mode="eval").body
            except SyntaxError:
                continue
            if _names_any(inner):
                return True
    return False


def any_parameters(path: Path) -> list[str]:
    """``function(parameter)`` of every parameter in ``path`` whose annotation mentions Any."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            for arg in [*a.posonlyargs, *a.args, *a.kwonlyargs, *(x for x in (a.vararg, a.kwarg) if x)]:
                if arg.annotation is not None and _names_any(arg.annotation):
                    found.append(f"{node.name}({arg.arg})")
    return found


@pytest.mark.parametrize("path", LIBRARY_AND_DOMAIN, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_any_parameter_in_bag_or_recording(path: Path) -> None:
    """bag/ and recording/ state what each function takes: no parameter is annotated Any (a value whose
    type is known only at run time is named once, with the reason, e.g. bag.shapes.Column)."""
    assert not any_parameters(path), f"{path.relative_to(PACKAGE)}: Any parameters {any_parameters(path)}"


def test_the_any_parameter_check_sees_them(tmp_path: Path) -> None:
    """any_parameters finds Any in a plain, a nested, a qualified, a string and a **kwargs annotation."""
    source = tmp_path / "m.py"
    source.write_text(
        "import typing\n"
        "def f(a: int, b: Any, c: dict[str, Any], d: 'list[Any]', *e: typing.Any, **g: object) -> Any: ...\n"
        "def h(**k: Any) -> None: ...\n"
    )
    assert any_parameters(source) == ["f(b)", "f(c)", "f(d)", "f(e)", "h(k)"]
