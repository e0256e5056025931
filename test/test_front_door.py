"""The package's one import point: ``from pendulum_accel import …`` for the names in ``__all__``.

Every name resolves lazily (PEP 562) to the object its home module defines, ``dir()`` lists it, importing
the package loads none of the heavy modules, and the README's and docs' examples (fenced Python, inline
``from pendulum_accel… import …`` spans, the lab notebooks' code cells) import those names from the top.
"""

from __future__ import annotations

import ast
import importlib
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import pendulum_accel
from test.test_docs_figures import FENCE

ROOT = Path(__file__).resolve().parent.parent
INIT = ROOT / "pendulum_accel" / "__init__.py"
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
NOTEBOOKS = sorted((ROOT / "docs").rglob("*.ipynb"))
PUBLIC = frozenset(pendulum_accel.__all__) - {"__version__"}
# An inline code span that is an import of the package: `from pendulum_accel.scene import load_scene`.
INLINE_IMPORT = re.compile(r"`((?:from|import) pendulum_accel[^`]*)`")
PYTHON_FENCE = re.compile(r"^\s*(?:```|~~~)\s*(?:python|py|python3|pycon)\s*$")


def python_snippets(text: str) -> list[tuple[int, str]]:
    """(first line, source) of each fenced Python block and each inline import span of a Markdown page;
    a pycon block's prompts and an inline span's closing ellipsis are stripped."""
    snippets: list[tuple[int, str]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if PYTHON_FENCE.match(lines[i]):
            body: list[str] = []
            j = i + 1
            while j < len(lines) and not FENCE.match(lines[j]):
                body.append(re.sub(r"^(>>>|\.\.\.) ?", "", lines[j]))
                j += 1
            snippets.append((i + 2, "\n".join(body)))
            i = j
        else:
            # An inline span may end its list of names with an ellipsis: "import load_scene, …".
            snippets += [(i + 1, re.sub(r",?\s*…", "", m.group(1))) for m in INLINE_IMPORT.finditer(lines[i])]
        i += 1
    return snippets


def notebook_snippets(path: Path) -> list[tuple[int, str]]:
    """(cell number, source) of each code cell of a notebook, IPython magics (% and !) left out."""
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    out = []
    for n, cell in enumerate(cells):
        if cell["cell_type"] == "code":
            lines = "".join(cell["source"]).splitlines()
            out.append((n, "\n".join(line for line in lines if not line.lstrip().startswith(("%", "!")))))
    return out


def deep_imports(source: str) -> list[str]:
    """'from pendulum_accel.X import name' for each name of __all__ a snippet imports from below the top."""
    return [
        f"from {node.module} import {alias.name}"
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.ImportFrom)
        and node.level == 0
        and (node.module or "").startswith("pendulum_accel.")
        for alias in node.names
        if alias.name in PUBLIC
    ]


def all_snippets() -> list[tuple[str, str]]:
    """(where, source) of every Python snippet of README.md, docs/**/*.md and docs/**/*.ipynb."""
    out = [
        (f"{p.relative_to(ROOT)}:{line}", src) for p in PAGES for line, src in python_snippets(p.read_text())
    ]
    out += [(f"{p.relative_to(ROOT)} cell {n}", src) for p in NOTEBOOKS for n, src in notebook_snippets(p)]
    return out


def test_every_doc_example_imports_the_public_names_from_the_top() -> None:
    snippets = all_snippets()
    top = [where for where, src in snippets if re.search(r"^from pendulum_accel import ", src, re.M)]
    assert len(top) >= 3, f"the extraction found too few examples importing from the top: {top}"
    deep = [f"{where}: {imp}" for where, src in snippets for imp in deep_imports(src)]
    assert deep == [], "import these from pendulum_accel itself:\n" + "\n".join(deep)


def test_the_scanner_finds_a_deep_import_in_each_kind_of_snippet() -> None:
    page = (
        "Load it with `from pendulum_accel.scene import load_scene, …`.\n\n"
        "```python\nfrom pendulum_accel.bag.reader import Bag, read_bag\n```\n\n"
        "```pycon\n>>> from pendulum_accel.estimators import (\n...     estimate_batch,\n... )\n```\n"
        "```sh\nfrom pendulum_accel.planner import plan_scene\n```\n"
    )
    found = [imp for _, src in python_snippets(page) for imp in deep_imports(src)]
    assert found == [
        "from pendulum_accel.scene import load_scene",
        "from pendulum_accel.bag.reader import read_bag",
        "from pendulum_accel.estimators import estimate_batch",
    ]


@pytest.mark.parametrize("name", sorted(pendulum_accel.__all__))
def test_every_public_name_resolves_to_its_home_and_is_listed(name: str) -> None:
    value = getattr(pendulum_accel, name)
    assert name in dir(pendulum_accel)
    if name != "__version__":
        home = importlib.import_module(pendulum_accel._HOMES[name])
        assert value is getattr(home, name)


def test_an_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'lod_scene'"):
        pendulum_accel.lod_scene  # type: ignore[attr-defined]  # noqa: B018  # the misspelling is the point


def test_the_type_checking_imports_and_the_lazy_table_agree() -> None:
    """mypy and IDEs read the TYPE_CHECKING block, the interpreter _HOMES: one name, one home in both,
    and __all__ is exactly those names and __version__."""
    tree = ast.parse(INIT.read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If) and ast.unparse(n.test) == "TYPE_CHECKING")
    typed = {
        alias.name: node.module
        for node in block.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert typed == pendulum_accel._HOMES
    assert set(pendulum_accel.__all__) == set(typed) | {"__version__"}


def test_importing_the_package_loads_no_public_module() -> None:
    """What keeps ``pendulum-accel --version`` fast, stated without a clock: ``import pendulum_accel``
    imports none of its subpackages, nor numpy (a fresh interpreter: this one has them all)."""
    probe = (
        "import sys, pendulum_accel\n"
        "print(sorted(m for m in sys.modules if m.startswith(('pendulum_accel.', 'numpy', 'scipy'))))"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, cwd=ROOT)
    assert done.stdout.strip() == "[]"


def test_no_module_of_the_package_imports_a_public_name_from_the_top() -> None:
    """Inside the package a public name comes from its home: the lazy table is invisible to
    test_architecture's import graph, so an import through the top could close a circle unseen."""
    through_top = []
    for path in sorted((ROOT / "pendulum_accel").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module == "pendulum_accel":
                through_top += [f"{path.relative_to(ROOT)}: {a.name}" for a in node.names if a.name in PUBLIC]
    assert through_top == []
