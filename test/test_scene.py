"""Scene files: every bundled scene loads, round-trips, and every kind of bad file is one clear line."""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pendulum_accel import scene_yaml
from pendulum_accel.cli.main import main
from pendulum_accel.errors import SceneError
from pendulum_accel.physics.profiles import Constant, Table
from pendulum_accel.scene import (
    DEFAULT_SCENE,
    SCENE_NAMES,
    SCENES_DIR,
    list_scenes,
    load_scene,
    scene_from_yaml,
    scene_to_dict,
    scene_to_yaml,
    write_scene_file,
)
from pendulum_accel.scene_yaml import scene_text_without_motion

Doc = dict[str, Any]


def base_doc() -> Doc:
    """The lecture scene's YAML mapping, with every optional section present (elastic k, force)."""
    doc: Doc = yaml.safe_load((SCENES_DIR / "lecture_constant.yaml").read_text(encoding="utf-8"))
    doc["pendulum"]["stiffness"] = 1.0e7
    return doc


def write(tmp_path: Path, doc: Doc, name: str = "scene.yaml") -> Path:
    """Dump ``doc`` to tmp_path/name."""
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def test_every_bundled_scene_loads_and_is_listed() -> None:
    """All contract names exist, load, and list_scenes gives them in order with descriptions."""
    scenes = list_scenes()
    assert tuple(s.name for s in scenes) == SCENE_NAMES
    assert DEFAULT_SCENE in SCENE_NAMES
    for scene in scenes:
        assert scene.description.strip()
        assert scene.source == SCENES_DIR / f"{scene.name}.yaml"
        assert load_scene(scene.name) == scene


def test_bundled_scenes_cover_the_lecture_cases() -> None:
    """The bundled list: at rest, lecture a, step, braking, stop-and-go, past 90°, elastic, multiplier."""
    s = {scene.name: scene for scene in list_scenes()}
    assert s["at_rest"].profile == Constant(0.0)
    assert isinstance(s["lecture_constant"].profile, Constant) and s["lecture_constant"].theta0 == 0.0
    assert 10.0 <= s["at_rest"].duration <= 20.0 and 10.0 <= s["lecture_constant"].duration <= 20.0
    assert s["step_start"].profile.kind == "step" and s["step_start"].profile(0.0) == 0.0
    braking = s["braking"]
    assert braking.profile.kind == "braking" and braking.profile(braking.duration) == 0.0
    assert isinstance(s["stop_and_go"].profile, Table)  # read from stop_and_go.csv next to the YAML
    assert abs(s["large_swing"].theta0) > math.pi / 2
    assert s["elastic_string"].wants_stretch and s["elastic_string"].wants_tension
    assert s["multiplier_lecture"].model == "multiplier"
    noisy = [scene for scene in s.values() if scene.sensor.noise_std > 0.0]
    assert len(noisy) >= 6


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_yaml_round_trip(name: str, tmp_path: Path) -> None:
    """scene_to_yaml → file → load_scene gives an equal scene (a CSV profile becomes an inline table)."""
    scene = load_scene(name)
    text = scene_to_yaml(scene)
    path = tmp_path / f"{name}.yaml"  # same stem: a copy named after a differently named file is renamed
    path.write_text(text, encoding="utf-8")
    assert load_scene(path) == scene
    assert scene_from_yaml(text) == scene


def _library_text(scene: Any) -> str:
    """The scene's text as PyYAML's pure-Python safe dumper writes it (with the scene loader's float
    resolver, so a string such as '1e5' is quoted), in scene_to_yaml's layout."""
    return str(
        yaml.dump(
            scene_to_dict(scene),
            Dumper=scene_yaml._SceneDumper,
            sort_keys=False,
            allow_unicode=True,
            width=100,
        )
    )


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_scene_text_is_the_librarys_character_for_character(name: str) -> None:
    """scene_to_yaml writes float lists itself (a node per number made a million-row table take a minute):
    the text is the library's dumper's, exactly, on every bundled scene (tables, speed traces given inline,
    unicode descriptions). Text equality, no tolerance: both spell each float as repr does."""
    scene = load_scene(name)
    assert scene_to_yaml(scene) == _library_text(scene)


# Values up to 1e100 and steps from 1e-3: the table's slopes (Δa/Δt, at most 2e103) stay finite, while the
# values still span subnormals, ±0.0 and exponents of every width.
finite = st.floats(min_value=-1e100, max_value=1e100)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    steps=st.lists(st.floats(min_value=1e-3, max_value=1e6), min_size=1, max_size=40),
    accels=st.lists(finite, min_size=41, max_size=41),
    # Not the characters YAML folds as line breaks (CR, NEL, LS, PS): the library's own text of such a
    # string reads back changed, and a description read from a YAML file never holds one.
    description=st.text(st.characters(blacklist_characters="\r\x85\u2028\u2029"), max_size=30),
)
def test_any_table_is_written_as_the_library_writes_it(
    steps: list[float], accels: list[float], description: str
) -> None:
    """Any values (subnormal, ±0.0, 1e100, exponents with no point such as 1e-05, which YAML 1.1 reads as a
    float only as 1.0e-05) and any description (one such as '0E0' had been written plain and read back as
    a number): the library's text, and it reads back equal."""
    times = [0.0]
    for step in steps:
        if times[-1] + step > times[-1]:
            times.append(times[-1] + step)
    table = Table(tuple(times), tuple(accels[: len(times)]))
    scene = dataclasses.replace(load_scene("lecture_constant"), profile=table, description=description)
    text = scene_to_yaml(scene)
    assert text == _library_text(scene)
    assert scene_from_yaml(text) == scene


def test_non_finite_floats_and_a_placeholder_lookalike_are_the_librarys() -> None:
    """The float lines spell nan and ±inf as the representer does, and a scene whose description spells
    the placeholder scene_to_yaml uses is dumped by the library whole (its text is still the library's)."""
    values = [math.nan, math.inf, -math.inf, 1e-05, -0.0, 5e-324]
    assert scene_yaml._float_block(values, "  ") == yaml.safe_dump({"k": {"v": values}}).split("\n", 2)[2]
    lookalike = f"x: {scene_yaml._NUMBERS.format(0)}\ny"
    scene = dataclasses.replace(
        load_scene("stop_and_go"), description=f"a: {scene_yaml._NUMBERS.format(0)}\n{lookalike}"
    )
    assert scene_to_yaml(scene) == _library_text(scene)
    assert scene_from_yaml(scene_to_yaml(scene)) == scene


def _library_data(text: str) -> Any:
    """What the scene loader's library parse gives for ``text``, or the refusal's type and message."""
    try:
        return yaml.load(text, Loader=scene_yaml._SceneLoader)
    except yaml.YAMLError as err:
        return (type(err).__name__, str(err))


def _hand_data(text: str) -> Any:
    """What scene_from_yaml's parse (scene_yaml.load_scene_data) gives for ``text``, or the refusal's type and
    text."""
    try:
        return scene_yaml.load_scene_data(text)
    except yaml.YAMLError as err:
        return (type(err).__name__, str(err))


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_float_lists_read_by_hand_are_the_librarys(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every float list of a bundled scene's stored text, cut out and read by hand (down to one item, so
    every list is), gives the library's data. Compared through repr: exact, and nan equal to nan."""
    monkeypatch.setattr(scene_yaml, "_FLOAT_RUN_MIN", 1)
    text = scene_to_yaml(load_scene(name))
    lists = sum(
        isinstance(v, list) and v != [] and all(type(x) is float for x in v)
        for v in _walk_values(_library_data(text))
    )
    cut = scene_yaml._float_runs(text)
    assert (cut is not None) == (lists > 0)
    assert repr(_hand_data(text)) == repr(_library_data(text))


def _walk_values(node: Any) -> list[Any]:
    """Every value below ``node``'s mappings and sequences, depth first."""
    values = list(node.values()) if isinstance(node, dict) else list(node) if isinstance(node, list) else []
    return values + [v for value in values for v in _walk_values(value)]


# Items: the writer's spellings (any float through _float_block) and ones the cut must leave to the library
# (YAML 1.2's 1e5, a sign, underscores, ints, hex, a comment, other nan spellings, a string, an empty item).
_ITEM = st.one_of(
    st.floats().map(lambda v: scene_yaml._float_block([v], "")[2:-1]),
    st.sampled_from(["1e5", "+1.0", "1_0.5", "7", "0x1f", "1.5E3", ".NaN", "abc", "1.0 # c", "", "1.0:"]),
)
# What comes before the run: nothing, a block scalar, a flow mapping, an anchor (merged after), a set,
# an open quote.
_BEFORE = ["", "description: |\n", "inline: {a: 1,\n", "base: &b\n", "s: !!set\n", "d: 'a\n"]
# What follows it: the end, a sibling key, a deeper line, a blank line, a comment, another item (at the
# items' indent, or deeper), a closing brace, the merge of the anchored mapping, the closing quote, a tab,
# a document's end, a second document.
_AFTER = ["", "other: 1\n", "     deeper\n", "\n- 2.0\n", "# c\n", "- 2.0\n", "    - 2.0\n", "}\n",
          "m:\n  <<: *b\n", "'\n", "\tother: 1\n", "...\n", "---\nx: 1\n"]  # fmt: skip


@settings(max_examples=400, deadline=None)
@given(
    before=st.sampled_from(_BEFORE),
    key_indent=st.sampled_from(["", "  "]),
    extra=st.sampled_from(["", "  ", "    "]),
    items=st.lists(_ITEM, min_size=1, max_size=6),
    after=st.sampled_from(_AFTER),
    missing_newline=st.booleans(),
)
def test_any_layout_around_a_float_run_reads_as_the_library_reads_it(
    before: str, key_indent: str, extra: str, items: list[str], after: str, missing_newline: bool
) -> None:
    """A run of items under a key, in any of the layouts around it that could make it something else than
    the key's whole list (a block scalar's text, a flow mapping, an anchor merged twice, a set, a string,
    a sequence going on after a blank line or a comment, a last item continued on a deeper line): the hand
    read gives the library's data, or the library's refusal word for word."""
    indent = key_indent + extra
    text = before + f"{key_indent}times:\n" + "".join(f"{indent}- {item}\n" for item in items) + after
    if missing_newline:
        text = text.rstrip("\n")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(scene_yaml, "_FLOAT_RUN_MIN", 1)
        assert repr(_hand_data(text)) == repr(_library_data(text))


def test_a_long_table_is_read_by_hand(monkeypatch: pytest.MonkeyPatch) -> None:
    """At the real threshold: a 2000-row table's text is cut (both lists), reads back to the equal scene,
    and a table one row short of _FLOAT_RUN_MIN is left to the library."""
    n = 2000
    table = Table(tuple(0.01 * k for k in range(n)), tuple(math.sin(0.37 * k) * 1e-3 for k in range(n)))
    scene = dataclasses.replace(load_scene("lecture_constant"), profile=table)
    text = scene_to_yaml(scene)
    cut = scene_yaml._float_runs(text)
    assert cut is not None and [len(v) for v in cut[1].values()] == [n, n]
    assert len(cut[0]) < 2000
    assert scene_from_yaml(text) == scene
    short = scene_yaml._FLOAT_RUN_MIN - 1
    small = Table(table.times[:short], table.accels[:short])
    assert scene_yaml._float_runs(scene_to_yaml(dataclasses.replace(scene, profile=small))) is None


def test_the_launchers_scene_file_keeps_a_table_beside_it(tmp_path: Path) -> None:
    """write_scene_file puts a table profile in NAME.accel.csv (the csv profile's file) and the rest in
    NAME.yaml: load_scene reads back an equal scene, every float bit for bit (Table equality is tuple
    equality: exact). A scene without a table is one file."""
    scene = load_scene("stop_and_go")
    assert isinstance(scene.profile, Table)
    path = write_scene_file(scene, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stop_and_go.accel.csv", "stop_and_go.yaml"]
    assert yaml.safe_load(path.read_text(encoding="utf-8"))["acceleration"] == {
        "type": "csv",
        "path": "stop_and_go.accel.csv",
    }
    assert load_scene(path) == scene
    other = tmp_path / "other"
    other.mkdir()
    constant = load_scene("lecture_constant")
    assert load_scene(write_scene_file(constant, other)) == constant
    assert [p.name for p in other.iterdir()] == ["lecture_constant.yaml"]


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_a_stored_scene_read_without_its_motion_keeps_everything_else(name: str) -> None:
    """scene_text_without_motion cuts the acceleration block out of scene_to_yaml's text and puts a = 0 in
    its place: the scene read from it equals the whole one in every field but the profile. libyaml's loader
    (tried first) and the Python loader read each text to equal data."""
    scene = load_scene(name)
    text = scene_to_yaml(scene)
    light = scene_text_without_motion(text)
    assert light is not None
    assert scene_from_yaml(light) == dataclasses.replace(scene, profile=Constant(0.0))
    for each in (text, light):
        assert yaml.load(each, Loader=scene_yaml._CSceneLoader) == yaml.load(
            each, Loader=scene_yaml._SceneLoader
        )


def test_the_motion_block_is_not_parsed_when_it_is_not_needed() -> None:
    """A stored scene whose table would not even parse still gives its name and settings without it (so a
    recorded log's million-number table is never read for them), and the whole scene is still refused.
    Text not laid out as scene_to_yaml writes it (flow style) is not cut: None."""
    text = scene_to_yaml(load_scene("lecture_constant"))
    start = text.index("acceleration:")
    end = text.index("\n", text.index("a: 2.0", start)) + 1
    broken = text[:start] + "acceleration:\n  type: table\n  times: [0.0, 1.0\n" + text[end:]
    with pytest.raises(SceneError, match="malformed YAML"):
        scene_from_yaml(broken)
    light = scene_text_without_motion(broken)
    assert light is not None and scene_from_yaml(light).name == "lecture_constant"
    assert scene_text_without_motion("{name: x, acceleration: {type: constant, a: 1}}") is None


def test_exponent_without_dot_is_a_number(tmp_path: Path) -> None:
    """YAML 1.1 would read 1e-3 as a string; scene files read it as the number 0.001."""
    text = (SCENES_DIR / "lecture_constant.yaml").read_text(encoding="utf-8")
    text = text.replace("noise_std: 1.0e-3", "noise_std: 1e-3").replace(
        "max_angle_error: 1.0e-6", "max_angle_error: 1e-6"
    )
    scene = scene_from_yaml(text)
    assert scene.sensor.noise_std == 1e-3
    assert scene.accuracy == 1e-6


def test_defaults_for_optional_fields(tmp_path: Path) -> None:
    """Only the required fields: gravity standard, mass 1, no damping, at rest, angle output, seed 0."""
    doc = {
        "name": "minimal",
        "description": "",
        "duration": 1,
        "pendulum": {"length": 2},
        "acceleration": {"type": "constant", "a": 1},
        "sensor": {"rate_hz": 10},
        "accuracy": {"max_angle_error": 1e-3},
    }
    scene = load_scene(write(tmp_path, doc))
    assert scene.pendulum.gravity == pytest.approx(9.80665)
    assert (scene.pendulum.mass, scene.pendulum.damping, scene.theta0, scene.theta_dot0) == (
        1.0,
        0.0,
        0.0,
        0.0,
    )
    assert scene.outputs == ("angle",)
    assert scene.sensor.seed == 0 and scene.model is None


def _set(path: str, value: object) -> Callable[[Doc], None]:
    """Mutation: set doc[a][b]… = value."""

    def mutate(doc: Doc) -> None:
        *head, last = path.split(".")
        target = doc
        for key in head:
            target = target[key]
        target[last] = value

    return mutate


def _drop(path: str) -> Callable[[Doc], None]:
    """Mutation: delete doc[a][b]…."""

    def mutate(doc: Doc) -> None:
        *head, last = path.split(".")
        target = doc
        for key in head:
            target = target[key]
        del target[last]

    return mutate


def _both(first: Callable[[Doc], None], second: Callable[[Doc], None]) -> Callable[[Doc], None]:
    """Mutation: ``first`` then ``second``."""

    def mutate(doc: Doc) -> None:
        first(doc)
        second(doc)

    return mutate


RAMP = {"type": "ramp", "t_start": 0, "t_end": 1, "a_start": 0, "a_end": 1}

# (mutation, field path the message must name, a word of what was expected)
BAD_SCENES: list[tuple[str, Callable[[Doc], None], str, str]] = [
    ("missing name", _drop("name"), "name", "missing"),
    ("missing duration", _drop("duration"), "duration", "missing"),
    ("missing pendulum", _drop("pendulum"), "pendulum", "missing"),
    ("missing length", _drop("pendulum.length"), "pendulum.length", "missing"),
    ("missing sensor rate", _drop("sensor.rate_hz"), "sensor.rate_hz", "missing"),
    ("missing accuracy", _drop("accuracy"), "accuracy", "missing"),
    ("missing target", _drop("accuracy.max_angle_error"), "accuracy.max_angle_error", "missing"),
    ("missing acceleration", _drop("acceleration"), "acceleration", "missing"),
    ("name with space", _set("name", "two words"), "name", "letters"),
    ("name a number", _set("name", 3), "name", "text"),
    ("description a list", _set("description", ["a"]), "description", "text"),
    ("duration text", _set("duration", "long"), "duration", "number"),
    ("duration zero", _set("duration", 0), "duration", "> 0"),
    ("duration inf", _set("duration", math.inf), "duration", "finite"),
    ("duration bool", _set("duration", True), "duration", "number"),
    ("gravity negative", _set("gravity", -9.8), "gravity", "> 0"),
    ("pendulum a list", _set("pendulum", [1, 2]), "pendulum", "mapping"),
    ("length negative", _set("pendulum.length", -1.0), "pendulum.length", "> 0"),
    ("length nan", _set("pendulum.length", math.nan), "pendulum.length", "finite"),
    ("mass zero", _set("pendulum.mass", 0.0), "pendulum.mass", "> 0"),
    ("damping negative", _set("pendulum.damping", -0.1), "pendulum.damping", ">= 0"),
    ("theta0 text", _set("pendulum.theta0", "up"), "pendulum.theta0", "number"),
    ("theta_dot0 null", _set("pendulum.theta_dot0", None), "pendulum.theta_dot0", "number"),
    ("stiffness zero", _set("pendulum.stiffness", 0.0), "pendulum.stiffness", "> 0"),
    ("pendulum typo", _set("pendulum.lenght", 1.0), "pendulum.lenght", "unknown"),
    ("top-level typo", _set("durration", 1.0), "durration", "unknown"),
    ("profile type", _set("acceleration.type", "jerk"), "acceleration", "type"),
    ("profile field", _set("acceleration.b", 1.0), "acceleration", "unknown field 'b'"),
    ("profile value", _set("acceleration.a", "fast"), "acceleration", "'a'"),
    ("profile missing", _drop("acceleration.a"), "acceleration", "missing field 'a'"),
    ("csv missing", _set("acceleration", {"type": "csv", "path": "no.csv"}), "acceleration", "no.csv"),
    ("sensor typo", _set("sensor.noise", 1e-3), "sensor.noise", "unknown"),
    ("rate zero", _set("sensor.rate_hz", 0), "sensor.rate_hz", "> 0"),
    ("noise negative", _set("sensor.noise_std", -1e-3), "sensor.noise_std", ">= 0"),
    ("bias text", _set("sensor.bias", "small"), "sensor.bias", "number"),
    ("walk negative", _set("sensor.bias_random_walk", -1.0), "sensor.bias_random_walk", ">= 0"),
    ("quantization negative", _set("sensor.quantization", -1.0), "sensor.quantization", ">= 0"),
    ("seed float", _set("sensor.seed", 1.5), "sensor.seed", "integer"),
    ("seed negative", _set("sensor.seed", -2), "sensor.seed", "integer"),
    ("too many samples", _set("sensor.rate_hz", 1e9), "sensor.rate_hz", "samples"),
    ("outputs not a list", _set("outputs", "angle"), "outputs", "list"),
    ("unknown output", _set("outputs", ["angle", "speed"]), "outputs[1]", "one of"),
    ("repeated output", _set("outputs", ["angle", "angle"]), "outputs[1]", "twice"),
    ("target zero", _set("accuracy.max_angle_error", 0.0), "accuracy.max_angle_error", "> 0"),
    ("accuracy typo", _set("accuracy.max_error", 1e-3), "accuracy.max_error", "unknown"),
    ("force unknown model", _set("force", {"model": "spring"}), "force.model", "one of"),
    ("force typo", _set("force", {"modle": "rigid"}), "force.modle", "unknown"),
    ("force bad method", _set("force", {"model": "rigid", "method": "leapfrog"}), "force.method", "one of"),
    ("method without model", _set("force", {"method": "rk4"}), "force.model", "missing"),
    ("closed form stepped", _set("force", {"model": "exact", "method": "rk4"}), "force.method", "closed"),
    ("exact with damping", _both(_set("pendulum.damping", 0.1), _set("force", {"model": "exact"})),
     "force.model", "undamped"),
    ("linear with ramp", _both(_set("acceleration", RAMP), _set("force", {"model": "linear"})),
     "force.model", "piecewise-constant"),
    ("stretch without k", _both(_drop("pendulum.stiffness"), _set("outputs", ["angle", "stretch"])),
     "pendulum.stiffness", "stretch"),
    ("elastic without k", _both(_drop("pendulum.stiffness"), _set("force", {"model": "elastic"})),
     "pendulum.stiffness", "elastic"),
    ("stretch with rigid", _both(_set("outputs", ["stretch"]), _set("force", {"model": "rigid"})),
     "force.model", "elastic"),
    ("document a list", lambda d: d.clear(), "scene", "mapping"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("mutate", "field", "expected"), [case[1:] for case in BAD_SCENES], ids=[case[0] for case in BAD_SCENES]
)
def test_bad_scene_is_one_line_naming_file_and_field(
    tmp_path: Path, mutate: Callable[[Doc], None], field: str, expected: str
) -> None:
    """Each mutation of a valid scene gives SceneError: one line, '<file>: <field>: … <expected> …'."""
    doc = base_doc()
    mutate(doc)
    path = write(tmp_path, doc if doc else [], "bad.yaml")  # type: ignore[arg-type]
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert f" {field}:" in message or f" {field} " in message or message.startswith(f"{path}: {field}")
    assert expected in message


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (_set("acceleration.type", "jerk"), "acceleration.type"),
        (_set("acceleration.b", 1.0), "acceleration.b"),
        (_set("acceleration.a", "fast"), "acceleration.a"),
        (_drop("acceleration.a"), "acceleration.a"),
        (_set("acceleration", {"type": "table", "times": [0, "x"], "accels": [0, 1]}), "acceleration.times"),
        (_set("acceleration", {"type": "table", "times": [0], "accels": [0, 1]}), "acceleration"),
    ],
)
def test_profile_error_path_is_carried_as_data(
    tmp_path: Path, mutate: Callable[[Doc], None], field: str
) -> None:
    """The profile's ParameterError.path, not its wording, gives the field path after 'acceleration'."""
    doc = base_doc()
    mutate(doc)
    path = write(tmp_path, doc, "bad.yaml")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: {field}: ")


def test_malformed_yaml_names_file_and_line(tmp_path: Path) -> None:
    """Broken YAML: '<file>:<line>: malformed YAML: …' on one line."""
    path = tmp_path / "broken.yaml"
    path.write_text("name: x\ndescription: y\nduration: [1, 2\nsensor: {}\n", encoding="utf-8")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}:") and "malformed YAML" in message
    line = int(message[len(str(path)) + 1 :].split(":")[0])
    assert 3 <= line <= 5


def test_unsafe_yaml_tag_is_refused(tmp_path: Path) -> None:
    """The safe loader constructs no Python objects: a python/object tag is an error, not a call."""
    path = tmp_path / "evil.yaml"
    path.write_text("name: !!python/object/apply:os.system ['true']\n", encoding="utf-8")
    with pytest.raises(SceneError, match="malformed YAML"):
        load_scene(path)


def test_every_missing_top_level_key_is_named_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A scene written from scratch that lacks several required keys hears of all of them in one line, each
    with what it expects; and the command the line suggests writes a scene that loads."""
    doc = base_doc()
    for key in ("description", "sensor", "accuracy"):
        del doc[key]
    path = write(tmp_path, doc, "bad.yaml")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: description, sensor, accuracy: missing (expected description: text; ")
    assert "accuracy: a mapping with max_angle_error" in message
    command = message.split("'")[1]  # 'pendulum-accel scenes step_start > scene.yaml'
    program, subcommand, name, redirect, target = command.split()
    assert (program, redirect, target) == ("pendulum-accel", ">", "scene.yaml")
    assert main([subcommand, name]) == 0
    (tmp_path / target).write_text(capsys.readouterr().out, encoding="utf-8")
    # A copy of a bundled scene is named after its file (scene._named_after_copy); the rest is its own.
    assert load_scene(tmp_path / target) == dataclasses.replace(load_scene(name), name="scene")
    # One missing key keeps its own line (BAD_SCENES: "missing accuracy"), with no list and no hint.


def test_a_home_relative_path_is_expanded_in_the_scene_and_its_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``~`` in a scene path (a launch argument ``scene:=~/my.yaml`` is not expanded by the shell) and in a
    profile's data path (a YAML file never is) is the user's home, as it is on the command line."""
    monkeypatch.setenv("HOME", str(tmp_path))
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "traffic.csv").write_text("t,a\n0,0\n1,2\n3,2\n4,0\n", encoding="utf-8")
    doc = base_doc()
    doc["acceleration"] = {"type": "csv", "path": "~/data/traffic.csv"}
    write(tmp_path, doc, "mine.yaml")
    scene = load_scene("~/mine.yaml")
    assert scene.profile(2.0) == 2.0 and scene.source == tmp_path / "mine.yaml"


def test_missing_file_and_unknown_name() -> None:
    """A missing path and an unknown bundled name are one-line SceneErrors."""
    with pytest.raises(SceneError, match="not found"):
        load_scene("/nonexistent/scene.yaml")
    with pytest.raises(SceneError, match=r"no bundled scene named 'nosuch'.*lecture_constant"):
        load_scene("nosuch")


def test_csv_profile_is_read_next_to_the_scene(tmp_path: Path) -> None:
    """type: csv with a relative path reads the file beside the YAML."""
    (tmp_path / "traffic.csv").write_text("t,a\n0,0\n1,2\n3,2\n4,0\n", encoding="utf-8")
    doc = base_doc()
    doc["acceleration"] = {"type": "csv", "path": "traffic.csv"}
    scene = load_scene(write(tmp_path, doc))
    assert scene.profile(2.0) == 2.0 and scene.profile(0.5) == 1.0


def test_replace_revalidates() -> None:
    """dataclasses.replace on a Scene re-checks cross-field rules (nodes override fields this way)."""
    scene = load_scene("lecture_constant")
    with pytest.raises(SceneError, match="duration"):
        dataclasses.replace(scene, duration=-1.0)
    with pytest.raises(SceneError, match=r"pendulum\.stiffness"):
        dataclasses.replace(scene, outputs=("angle", "stretch"))


SECTIONS = ("", "pendulum", "sensor", "accuracy")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(section=st.sampled_from(SECTIONS), key=st.from_regex(r"[a-z][a-z_]{0,12}", fullmatch=True))
def test_any_unknown_key_is_refused(tmp_path: Path, section: str, key: str) -> None:
    """Property: an extra key anywhere (not a real field) is an error naming '<section>.<key>'."""
    doc = base_doc()
    target = doc[section] if section else doc
    if key in target:
        return
    doc = copy.deepcopy(doc)
    (doc[section] if section else doc)[key] = 1
    path = write(tmp_path, doc, "extra.yaml")
    field = f"{section}.{key}" if section else key
    with pytest.raises(SceneError, match=f"{path}: {field}: unknown key"):
        load_scene(path)


def test_sensor_density_form_converts_and_excludes_noise_std() -> None:
    """noise_density N gives σ = N·√rate; giving noise_std too is a one-line error naming both."""
    base = (
        "name: s\ndescription: d\nduration: 1.0\npendulum: {length: 1.0}\n"
        "acceleration: {type: constant, a: 0.0}\naccuracy: {max_angle_error: 1.0e-6}\n"
    )
    scene = scene_from_yaml(
        base + "sensor: {rate_hz: 400.0, noise_density: 5.0e-5, range: 1.2, bias_mean: 0.01}"
    )
    assert scene.sensor.noise_std == pytest.approx(5.0e-5 * 20.0)
    assert scene.sensor.range == 1.2 and scene.sensor.bias_mean == 0.01
    assert scene_from_yaml(scene_to_yaml(scene)) == scene
    with pytest.raises(SceneError, match=r"noise_std .* or noise_density .* not both"):
        scene_from_yaml(base + "sensor: {rate_hz: 100.0, noise_std: 1.0e-3, noise_density: 1.0e-4}")


def test_a_bag_stores_the_table_its_run_reads() -> None:
    """A 5 s run of a 357 s logged table stores the table's points over [0, 5 s] (and one each side), and
    that stored scene gives the same a(t) on [0, 5 s], float for float (linear between the same points),
    and the same simulated angles; a run as long as its table stores all of it."""
    import numpy as np

    from pendulum_accel.scene import stored_scene_text
    from pendulum_accel.scene_run import run_scene

    full = load_scene("phone_corolla_trip2")
    assert isinstance(full.profile, Table) and full.profile.times[-1] > 300.0
    short = dataclasses.replace(full, duration=5.0)
    stored = scene_from_yaml(stored_scene_text(short))
    assert isinstance(stored.profile, Table)
    times = stored.profile.times
    assert times[0] <= 0.0 and times[-1] >= 5.0 and times[-2] < 5.0 and len(times) < len(full.profile.times)
    t = np.linspace(0.0, 5.0, 5001)
    assert np.array_equal(stored.profile(t), full.profile(t))
    original, again = run_scene(short), run_scene(stored)
    # Each run meets the scene's accuracy (its plan's predicted max angle error): they differ by at most
    # twice that, whatever step the planner picked for the shorter table.
    np.testing.assert_allclose(again.theta_measured, original.theta_measured, rtol=0, atol=2 * short.accuracy)
    whole = dataclasses.replace(full, duration=full.profile.times[-1])  # a run that reads all of it
    assert scene_from_yaml(stored_scene_text(whole)).profile == full.profile


def test_a_scene_without_its_motion_reads_no_log(tmp_path: Path) -> None:
    """load_scene(motion=False), the estimator node's: the pendulum, sensor and motion key as written, a(t)
    = 0, and the acceleration's file not read (here it does not even exist, which load_scene refuses)."""
    text = (SCENES_DIR / "phone_corolla_trip2.yaml").read_text(encoding="utf8")
    doc = yaml.safe_load(text)
    doc["acceleration"]["path"] = str(tmp_path / "gone.csv")
    doc["motion"] = "car"
    path = tmp_path / "sensor.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf8")
    with pytest.raises(SceneError, match=r"gone\.csv"):
        load_scene(path)
    light = load_scene(path, motion=False)
    full = load_scene("phone_corolla_trip2")
    assert light.profile == Constant(0.0) and light.motion == "car"
    assert (light.pendulum, light.sensor, light.duration) == (full.pendulum, full.sensor, full.duration)
