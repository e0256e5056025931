"""The install lists are complete: what the package imports at run time against setup.py's
install_requires (and extras), package.xml's dependencies and the README's pip line for colcon.

A module the package imports that no list installs makes every command that loads it end in an
ImportError on a machine set up by that list; this test names it instead.
"""

from __future__ import annotations

import ast
import functools
import importlib.metadata
import re
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIRST_PARTY = {"pendulum_accel", "benchmarks"}
RUNTIME_CODE = (ROOT / "pendulum_accel", ROOT / "launch_scripts")

ROSDEP_TO_DIST = {
    "python3-numpy": "numpy",
    "python3-scipy": "scipy",
    "python3-yaml": "pyyaml",
    "python3-matplotlib": "matplotlib",
    "python3-tqdm": "tqdm",
    "python3-pytest": "pytest",
    "python3-hypothesis": "hypothesis",
    "python3-numba": "numba",
    "python3-rosbags-pip": "rosbags",
}
"""rosdep keys (python3-*) and the PyPI distribution each installs (canonical names)."""

IMPORT_TO_DIST_FALLBACK = {"yaml": "pyyaml", "PIL": "pillow"}
"""Import names whose distribution has another name, for when it is not installed here to ask."""

PIP_LINE = re.compile(r"^\s*pip install ([A-Za-z0-9_.\-<>=~ ]+?)\s*#.*pip-only", re.MULTILINE)
"""The colcon instructions' pip line: `pip install a b c  # pip-only dependencies (no rosdep keys)`."""


def canonical(name: str) -> str:
    """PEP 503 name: lower case, runs of -_. as one -."""
    return re.sub(r"[-_.]+", "-", name).lower()


def requirement_name(spec: str) -> str:
    """'numpy>=2.4.6' → 'numpy' (canonical)."""
    match = re.match(r"[A-Za-z0-9_.\-]+", spec.strip())
    assert match, spec
    return canonical(match.group(0))


def imports(files: Iterable[Path]) -> dict[str, set[str]]:
    """Top-level third-party import names (absolute imports, in functions too, and the string constants
    given to ``importlib.import_module``/``lazy_module``, which import on first use) → the files importing
    them."""
    found: dict[str, set[str]] = {}
    for path in files:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif (
                isinstance(node, ast.Call)
                and getattr(node.func, "id", getattr(node.func, "attr", ""))
                in ("import_module", "lazy_module")
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
            ):
                names = [node.args[0].value]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names and top not in FIRST_PARTY and top != "__future__":
                    found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def setup_requirements() -> tuple[set[str], dict[str, set[str]]]:
    """setup.py's install_requires and extras_require, read from its AST (setup.py is not run)."""
    tree = ast.parse((ROOT / "setup.py").read_text(encoding="utf-8"))
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "setup")
    keywords = {
        k.arg: ast.literal_eval(k.value)
        for k in call.keywords
        if k.arg in ("install_requires", "extras_require")
    }
    required = {requirement_name(s) for s in keywords["install_requires"]}
    extras = {
        name: {requirement_name(s) for s in specs} for name, specs in keywords["extras_require"].items()
    }
    return required, extras


def package_xml() -> dict[str, set[str]]:
    """package.xml's dependency keys by tag (exec_depend, test_depend, depend, …)."""
    deps: dict[str, set[str]] = {}
    for element in ET.parse(ROOT / "package.xml").getroot():
        if element.tag.endswith("depend") and element.text:
            deps.setdefault(element.tag, set()).add(element.text.strip())
    return deps


def colcon_pip_line(path: Path) -> set[str]:
    """The distributions on the colcon instructions' pip-only line of ``path`` (exactly one such line)."""
    lines = PIP_LINE.findall(path.read_text(encoding="utf-8"))
    assert len(lines) == 1, f"{path.name}: expected one `pip install …  # pip-only …` line, found {lines}"
    return {requirement_name(token) for token in lines[0].split()}


@functools.cache
def installed_distributions() -> Mapping[str, list[str]]:
    """importlib.metadata.packages_distributions(), read once: it walks every installed distribution's file
    list (the ROS wheels' are long), tens of seconds a call on a loaded machine."""
    return importlib.metadata.packages_distributions()


def distribution_of(module: str) -> str | None:
    """The installed distribution providing import name ``module`` (canonical), else the fallback table."""
    dists = installed_distributions().get(module)
    if dists:
        return canonical(dists[0])
    return IMPORT_TO_DIST_FALLBACK.get(module)


@functools.cache
def runtime_imports() -> Mapping[str, set[str]]:
    """Third-party imports of the installed package and its launch files (parsed once: read-only)."""
    return imports(p for folder in RUNTIME_CODE for p in sorted(folder.rglob("*.py")))


def split_ros(found: Mapping[str, set[str]], ros_keys: set[str]) -> tuple[dict[str, str], set[str]]:
    """(PyPI import → distribution, ROS package names): a ROS package is a package.xml key that is not a
    python3-* rosdep key, or a module installed by a ros-* wheel, or one with no distribution here."""
    pypi: dict[str, str] = {}
    ros: set[str] = set()
    for module in found:
        dist = distribution_of(module)
        if module in ros_keys or dist is None or dist.startswith("ros-"):
            ros.add(module)
        else:
            pypi[module] = dist
    return pypi, ros


def test_every_runtime_import_is_in_setup_py() -> None:
    found = runtime_imports()
    required, extras = setup_requirements()
    deps = package_xml()
    ros_keys = {k for k in deps.get("exec_depend", set()) if not k.startswith("python3-")}
    pypi, _ = split_ros(found, ros_keys)
    optional = extras["export"] | extras.get("bench", set()) | extras.get("fleet", set())
    missing = {
        f"{m} ({d}, imported by {sorted(found[m])[0]})"
        for m, d in pypi.items()
        if d not in required | optional
    }
    assert missing == set(), f"imported but not in setup.py's install_requires or extras: {sorted(missing)}"
    unused = required - set(pypi.values())
    assert unused == set(), f"in install_requires but never imported by the package: {sorted(unused)}"


def test_every_ros_import_is_an_exec_depend_of_package_xml() -> None:
    found = runtime_imports()
    deps = package_xml()
    exec_deps = deps.get("exec_depend", set()) | deps.get("depend", set())
    ros_keys = {k for k in exec_deps if not k.startswith("python3-")}
    _, ros = split_ros(found, ros_keys)
    missing = {f"{m} (imported by {sorted(found[m])[0]})" for m in ros if m not in exec_deps}
    assert missing == set(), f"ROS packages imported but not exec_depend in package.xml: {sorted(missing)}"


def test_rosdep_keys_and_the_readme_pip_line_install_all_of_install_requires() -> None:
    """colcon: rosdep installs package.xml's python3-* keys, the README's pip line the rest."""
    required, _ = setup_requirements()
    deps = package_xml()
    python_keys = {k for k in deps.get("exec_depend", set()) if k.startswith("python3-")}
    unknown = python_keys - set(ROSDEP_TO_DIST)
    assert unknown == set(), f"add these rosdep keys' PyPI names to ROSDEP_TO_DIST: {sorted(unknown)}"
    by_rosdep = {ROSDEP_TO_DIST[k] for k in python_keys}
    for page in (ROOT / "README.md", ROOT / "docs" / "install.md"):
        by_pip = colcon_pip_line(page)
        missing = required - by_rosdep - by_pip
        assert missing == set(), (
            f"{page.name}: after `rosdep install` and its pip line these are still missing: {sorted(missing)}"
        )
        stray = by_pip - required
        assert stray == set(), (
            f"{page.name}: its pip line installs what setup.py does not ask for: {sorted(stray)}"
        )


def test_the_check_catches_a_missing_distribution() -> None:
    """The comparison above is not vacuous: mcap (pip-only, no rosdep key), dropped from the pip line, is
    reported missing."""
    required, _ = setup_requirements()
    by_rosdep = {ROSDEP_TO_DIST[k] for k in package_xml().get("exec_depend", set()) if k in ROSDEP_TO_DIST}
    by_pip = colcon_pip_line(ROOT / "README.md") - {"mcap"}
    assert "mcap" in required and required - by_rosdep - by_pip == {"mcap"}
    assert "mcap" in {distribution_of(m) for m in runtime_imports()}


def test_the_docs_extra_is_what_make_docs_installs_and_covers_mkdocs_yml() -> None:
    """setup.py's `docs` extra names exactly the distributions requirements-docs.txt pins (what `make docs`
    installs into .venv-docs), and those, or mkdocs' own dependencies, provide mkdocs.yml's theme and every
    Markdown extension it names (a bare name is Python-Markdown's markdown.extensions.<name>)."""
    import yaml

    _, extras = setup_requirements()
    pinned = {
        requirement_name(line)
        for line in (ROOT / "requirements-docs.txt").read_text(encoding="utf-8").splitlines()
        if line.strip() and not line.startswith("#")
    }
    assert extras["docs"] == pinned
    assert "-r requirements-docs.txt" in (ROOT / "requirements-dev.txt").read_text(encoding="utf-8")
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    requires = importlib.metadata.requires("mkdocs") or []
    with_mkdocs = {requirement_name(r) for r in requires if "extra" not in r}
    modules = {str(config["theme"]["name"])} | {
        (name if "." in name else f"markdown.extensions.{name}").split(".")[0]
        for entry in config["markdown_extensions"]
        for name in ([entry] if isinstance(entry, str) else list(entry))
    }
    missing = {m: distribution_of(m) for m in modules if distribution_of(m) not in pinned | with_mkdocs}
    assert missing == {}, f"mkdocs.yml needs these, which the docs extra does not install: {missing}"
    assert "material" in modules and distribution_of("material") == "mkdocs-material"


def test_the_core_install_pulls_no_test_tools() -> None:
    """No test or docs tool (pytest, sphinx) is a core requirement, nor anything the package imports at run
    time: allantools, which requires both, is a test dependency (test_allan checks the package's own ADEV
    against it)."""
    required, extras = setup_requirements()
    tools = {"pytest", "sphinx", "numpydoc", "allantools", "hypothesis"}
    assert required & tools == set()
    assert "allantools" in extras["test"]
    assert {distribution_of(m) for m in runtime_imports()} & tools == set()
