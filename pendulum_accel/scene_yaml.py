"""The scene files' YAML codec: text to plain data and back, for scene.py to check and build a Scene from.

YAML 1.2 floats (``1e-3`` is a number, not the string YAML 1.1 makes of it), both ways: the loader resolves
them so, and the dumper quotes a string that would read back as one. The library makes a node per number,
so a recorded log's table (millions of numbers) is read and written by hand around it: long float lists
are cut out of the text before the library parses the rest and put back after (load_scene_data), and
written as lines beside the library's text of the rest (dump_scene_data). Either way the data and the
text are the library's own, character for character, or the library does the whole.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping
from typing import Any

import yaml


class _SceneLoader(yaml.SafeLoader):
    """yaml.SafeLoader whose floats follow YAML 1.2, so ``1e-3`` is a number and not the string '1e-3'."""


_YAML12_FLOAT = re.compile(
    r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.VERBOSE,
)


class _SceneDumper(yaml.SafeDumper):
    """yaml.SafeDumper that resolves plain scalars as _SceneLoader does, so a string such as '1e5' (a
    number to the scene loader, a string to YAML 1.1) is quoted: scene_to_yaml's text always reads back."""


for _resolving in (_SceneLoader, _SceneDumper):
    _resolving.add_implicit_resolver("tag:yaml.org,2002:float", _YAML12_FLOAT, list("-+0123456789."))


# The ignore below: the base is chosen at run time (libyaml's loader where PyYAML was built with it), and
# mypy cannot type a computed base class.
class _CSceneLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """_SceneLoader's resolvers on libyaml's C parser: a recorded log's table (millions of numbers) parses
    about 5x faster. Only ever tried first: what it refuses is parsed again by _SceneLoader, whose error
    messages (with their line) are the ones users see."""


_CSceneLoader.yaml_implicit_resolvers = _SceneLoader.yaml_implicit_resolvers

# Any: yaml.dump's keyword arguments, of several types (bool, int), passed on as **_DUMP_STYLE.
_DUMP_STYLE: dict[str, Any] = {"sort_keys": False, "allow_unicode": True, "width": 100}
"""scene_to_yaml's layout: the scene's own field order, characters as they are, lines up to 100."""

_NUMBERS = "pendulum-accel-numbers-{}"
"""scene_to_yaml's placeholder for a list of floats, written in its place by _float_block."""


def load_scene_data(text: str) -> object:
    """The data yaml.load(text, Loader=_SceneLoader) gives, its long float lists read by hand.

    A recorded log's table is millions of numbers, one line each, and the library makes a node per number:
    half a minute and 3 GB for an hour of a phone's 400 Hz log. Each long block sequence of floats spelled
    as scene_to_yaml spells them, the whole value of a plain key, is cut out of the text (_float_runs) and
    its floats put back into the data the rest parses to (_put_back_float_lists). Where the cut cannot be
    sure (the placeholder in a flow collection or a string, the rest refused), the whole text is parsed:
    the data is always the library's, and a refusal the library's, with the user's own line."""
    cut = _float_runs(text)
    if cut is not None:
        light, lists = cut
        try:
            data = yaml.load(light, Loader=_CSceneLoader)
            trusted = _in_block_context(light, lists) and _put_back_float_lists(data, lists)
        except yaml.YAMLError:
            trusted = False
        if trusted:
            return data
    try:
        return yaml.load(text, Loader=_CSceneLoader)  # safe loaders both: no objects
    except yaml.YAMLError:
        return yaml.load(text, Loader=_SceneLoader)  # the same refusal, worded as users see it


_FLOAT_TOKEN = r"(?:-?[0-9]+\.[0-9]+(?:e[-+][0-9]+)?|\.nan|-?\.inf)"  # as _float_block spells a float
_KEY_THEN_ITEM = re.compile(r"^( *)[A-Za-z_][A-Za-z0-9_]*:\n( *)- ", re.MULTILINE)  # KEY: alone, then an item
_SAFE = yaml.constructor.SafeConstructor
_SPECIAL_FLOATS = {".nan": _SAFE.nan_value, ".inf": _SAFE.inf_value, "-.inf": -_SAFE.inf_value}  # its own
_FLOAT_RUN_MIN = 64  # a shorter list costs the library microseconds: not worth a cut


@functools.cache
def _item_patterns(indent: int) -> tuple[str, re.Pattern[str], re.Pattern[str]]:
    """For items at ``indent``: their prefix (``indent- ``), the first line break not followed by one, and
    one float item's line.

    A run is checked by removing every item line (subn) rather than by one repeated pattern, which keeps a
    backtracking frame per line (0.5 GB for a million) unless its repeat is possessive."""
    prefix = " " * indent + "- "
    return prefix, re.compile(rf"\n(?!{prefix})"), re.compile(rf"{prefix}{_FLOAT_TOKEN}\n")


def _float_runs(text: str) -> tuple[str, dict[str, list[float]]] | None:
    """``text`` with each run of at least _FLOAT_RUN_MIN float items that is a plain key's whole value cut
    out (``KEY:`` + run → ``KEY: PLACEHOLDER``), and each placeholder's floats; None when nothing is cut.

    The whole value: the line before the run is ``KEY:`` alone, indented no deeper than the items, and the
    line after is a line no deeper than that key that is not blank, a comment or an item (any of which
    could carry the sequence on). Text that already spells a placeholder is not cut. Each float is
    float(item) as the loader's constructor takes it, .nan and ±.inf its own values."""
    if _NUMBERS.format("") in text:
        return None
    pieces: list[str] = []
    lists: dict[str, list[float]] = {}
    done = 0
    for head in _KEY_THEN_ITEM.finditer(text):
        key_indent, indent = len(head.group(1)), len(head.group(2))
        start = head.end() - indent - 2  # the first item's line
        if key_indent > indent or start < done:
            continue
        prefix, run_end, item_line = _item_patterns(indent)
        stop = run_end.search(text, start)
        if stop is None:  # the text ends in an item with no line break: it could be anything
            continue
        end = stop.start() + 1
        count = text.count("\n", start, end)
        line_end = text.find("\n", end)
        after = text[end:] if line_end < 0 else text[end:line_end]
        rest = after.lstrip(" ")
        ends = end == len(text) or (len(after) - len(rest) <= key_indent and rest[:1] not in ("", "#", "-"))
        if count < _FLOAT_RUN_MIN or not ends:
            continue
        if item_line.subn("", text[start:end]) != ("", count):  # an item that is not a float as written
            continue
        tokens = text[start + len(prefix) : end - 1].split(f"\n{prefix}")
        name = _NUMBERS.format(len(lists))
        lists[name] = [float(t) if t[-1].isdigit() else _SPECIAL_FLOATS[t] for t in tokens]
        pieces += [text[done : start - 1], f" {name}\n"]
        done = end
    if not lists:
        return None
    pieces.append(text[done:])
    return "".join(pieces), lists


def _in_block_context(light: str, lists: dict[str, list[float]]) -> bool:
    """True when no placeholder of ``lists`` sits inside a flow collection of ``light`` (``{…}``, ``[…]``,
    where YAML refuses a block sequence: there the whole text must be parsed, to be refused)."""
    depth = 0
    for token in yaml.scan(light, Loader=_CSceneLoader):
        if isinstance(token, (yaml.FlowMappingStartToken, yaml.FlowSequenceStartToken)):
            depth += 1
        elif isinstance(token, (yaml.FlowMappingEndToken, yaml.FlowSequenceEndToken)):
            depth -= 1
        elif depth and isinstance(token, yaml.ScalarToken) and token.value in lists:
            return False
    return True


def _put_back_float_lists(data: object, lists: dict[str, list[float]]) -> bool:
    """Each placeholder that is a mapping's value in ``data`` replaced by its floats, in place; False (the
    data to be thrown away) unless each was found exactly once and nowhere else (cut out of a block scalar,
    one would sit inside a string; under a merge key, twice; in a !!set, lost)."""
    found: set[str] = set()
    marker = _NUMBERS.format("")
    stack = [data] if isinstance(data, (dict, list)) else []  # iterative: nesting as deep as the loader's
    seen: set[int] = set()  # an alias visited once
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        items = list(node.items()) if isinstance(node, dict) else list(enumerate(node))  # a dict or a list
        for key, value in items:
            if isinstance(key, str) and marker in key:
                return False
            if isinstance(value, str) and marker in value:
                if not isinstance(node, dict) or value not in lists or value in found:
                    return False
                found.add(value)
                node[key] = lists[value]
            elif isinstance(value, (dict, list)):
                stack.append(value)
    return found == set(lists)


def dump_scene_data(data: Mapping[str, object]) -> str:
    """YAML text of a scene's mapping that load_scene_data reads back into equal data (the text stored in
    bags).

    _SceneDumper's text, character for character (test_scene holds it to the library). Its representer
    makes a node per number, so a recorded log's table (a million rows) took a minute and 1.2 GB; each
    list of floats is put in as a placeholder and its lines are written here instead (_float_block).
    """
    lists: list[list[float]] = []
    light = _with_placeholders(data, lists)
    text: str = yaml.dump(light, Dumper=_SceneDumper, **_DUMP_STYLE)  # pure Python: libyaml escapes emoji
    markers = [f": {_NUMBERS.format(k)}\n" for k in range(len(lists))]
    if any(text.count(marker) != 1 for marker in markers):  # a string of the scene spells one: no splice
        return str(yaml.dump(data, Dumper=_SceneDumper, **_DUMP_STYLE))
    pieces, done = [], 0
    for at, marker, values in sorted((text.index(m), m, v) for m, v in zip(markers, lists, strict=True)):
        start = text.rindex("\n", 0, at) + 1
        indent = " " * (len(text[start:at]) - len(text[start:at].lstrip(" ")))
        pieces += [text[done:at], ":\n", _float_block(values, indent)]
        done = at + len(marker)
    return "".join([*pieces, text[done:]])


def _with_placeholders(node: Mapping[str, object], lists: list[list[float]]) -> dict[str, object]:
    """A copy of ``node`` with each non-empty list of floats in its mappings moved to ``lists`` and replaced
    by its placeholder (_NUMBERS with its index); ``node`` itself is left as it is."""
    out: dict[str, object] = {}
    for key, value in node.items():
        if isinstance(value, dict):
            out[key] = _with_placeholders(value, lists)
        elif isinstance(value, list) and value and all(type(v) is float for v in value):
            out[key] = _NUMBERS.format(len(lists))
            lists.append(value)
        else:
            out[key] = value
    return out


def _float_block(values: list[float], indent: str) -> str:
    """A block sequence of floats as yaml's emitter writes it under a mapping key: ``indent- x`` per line,
    x as SafeRepresenter.represent_float spells it (repr, lower case, '.0' put before an exponent that has
    no point, so YAML 1.1 resolves it as a float; .nan, .inf, -.inf)."""
    out = []
    for v in values:
        if not math.isfinite(v):
            r = ".nan" if v != v else (".inf" if v > 0 else "-.inf")
        else:
            r = repr(v).lower()
            if "." not in r and "e" in r:
                r = r.replace("e", ".0e", 1)
        out.append(f"{indent}- {r}\n")
    return "".join(out)


_TOP_LEVEL_KEY = re.compile(r"^[^\s#-][^:\n]*:", re.MULTILINE)  # a mapping key at column 0
_STILL = "acceleration:\n  type: constant\n  a: 0.0\n"  # a(t) = 0: stands in for a profile not read


def scene_text_without_motion(text: str) -> str | None:
    """Scene YAML ``text`` with its top-level ``acceleration:`` block cut out as text and a constant a = 0
    in its place; None when the text has no such block at column 0 followed by indented lines (as
    ``scene_to_yaml`` writes it), e.g. flow style.

    What depends on the name, the pendulum, the sensor or the motion key but not on a(t) (a bag's
    ``info``, ``analyze``'s estimator settings) reads this in milliseconds: a recorded log's table of
    millions of numbers takes seconds to parse and convert."""
    start = re.search(r"^acceleration:[ \t]*\n", text, re.MULTILINE)
    if start is None:
        return None
    after = _TOP_LEVEL_KEY.search(text, start.end())
    end = after.start() if after is not None else len(text)
    return text[: start.start()] + _STILL + text[end:]
