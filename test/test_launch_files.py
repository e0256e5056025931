"""chain.launch.py and the parameters YAML, checked without ``launch``/``launch_ros`` (not on PyPI).

The launch file parses; every executable it starts is a console script colcon installs into
lib/pendulum_accel; every parameter it (and the YAML) sets is one that node declares, with a value
of the declared type inside the declared range and choices (read from the node parameter tables).
"""

from __future__ import annotations

import ast
import importlib.util
import itertools
import signal
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
import yaml

from pendulum_accel.nodes.parameters import NODE_PARAMETERS, ParamSpec
from test.chain_helpers import Output
from test.conftest import PYTHON, REPO, Spawn
from test.test_package import _console_scripts

LAUNCH = REPO / "launch_scripts" / "chain.launch.py"
PARAMS = REPO / "config" / "pendulum_accel.params.yaml"
_KINDS = {"bool": bool, "integer": int, "double": float, "string": str, "string_array": list}


def _launch_module() -> ModuleType:
    """The launch file as a module (it imports launch/launch_ros only inside generate_launch_description)."""
    spec = importlib.util.spec_from_file_location("chain_launch", LAUNCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def check_value(node: str, name: str, value: Any) -> None:
    """AssertionError unless ``node`` declares ``name`` and ``value`` fits its type, range and choices."""
    specs: dict[str, ParamSpec] = {s.name: s for s in NODE_PARAMETERS[node]}
    assert name in specs, f"{node} declares no parameter {name}"
    spec = specs[name]
    kind = _KINDS[spec.type]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    assert isinstance(value, kind) and not (kind is not bool and isinstance(value, bool)), (node, name, value)
    if isinstance(value, list):
        assert all(isinstance(v, str) for v in value), (node, name, value)
    if spec.low is not None and spec.high is not None:
        assert isinstance(value, int | float) and spec.low <= value <= spec.high, (node, name, value)
    if spec.choices:
        assert value in spec.choices, (node, name, value)


def test_launch_file_parses_and_declares_the_arguments() -> None:
    tree = ast.parse(LAUNCH.read_text())
    functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert "generate_launch_description" in functions
    module = _launch_module()
    assert set(module.ARGUMENTS) == {
        "scene",
        "record",
        "estimator",
        "fast",
        "time_source",
        "namespace",
        "namespace_clock",
        "remap",
        "frame_prefix",
        "autostart",
        "use_sim_time",
        "shutdown_on_scene_end",
    }
    # launch_ros.actions.Node's keyword arguments, as its source names them.
    source = LAUNCH.read_text()
    keywords = ("package=", "executable=", "name=", "namespace=", "remappings=", "parameters=", "output=")
    for keyword in keywords:
        assert keyword in source


def test_launch_remaps_give_a_namespaced_chain_its_own_clock() -> None:
    module = _launch_module()
    assert module.remappings("", "true", "") == []  # the root namespace keeps /clock
    assert module.remappings("car1", "true", "") == [("/clock", "/car1/clock")]
    assert module.remappings("/car1", "false", "") == []
    # The user's rules come first: rcl applies the first rule that matches a name.
    rules = module.remappings("car1", "true", "pendulum/joint_states:=angle /clock:=/shared")
    assert rules == [("pendulum/joint_states", "angle"), ("/clock", "/shared"), ("/clock", "/car1/clock")]
    with pytest.raises(ValueError, match="FROM:=TO"):
        module.remappings("car1", "true", "angle")
    for spec in module.chain_nodes("step_start", "", "kalman", "true", "", autostart="false"):
        if spec["executable"] != "bag_recorder":
            assert spec["parameters"]["autostart"] is False


def test_launch_frame_prefix_is_the_namespace_unless_given() -> None:
    """frame_prefix auto: <namespace>/ for the simulator and estimator (none in the root namespace), as
    `pendulum-accel run --namespace`; a given prefix is used as is, an empty one sets none."""
    module = _launch_module()
    assert module.frame_prefix_of("car1", "auto") == "car1/"
    assert module.frame_prefix_of("/fleet/car1", "auto") == "fleet/car1/"
    assert module.frame_prefix_of("", "auto") == ""
    assert module.frame_prefix_of("car1", "left/") == "left/"
    for prefix, expected in (("car1/", {"car1/"}), ("", set())):
        specs = module.chain_nodes("step_start", "bag", "kalman", "true", "", frame_prefix=prefix)
        given = {spec["executable"]: spec["parameters"].get("frame_prefix") for spec in specs}
        assert given["bag_recorder"] is None  # the recorder draws nothing
        assert {given["pendulum_sim"], given["accel_estimator"]} - {None} == expected


def test_a_bringup_can_include_the_launch_file() -> None:
    """Included by a robot bringup (issue 58): shutdown_on_scene_end:=false lets the scene end without
    shutting the bringup down (true, the default, when run alone: the bag closes); use_sim_time, when
    given, is every node's, over time_source; under a bringup's PushRosNamespace the clock remap and the
    frame prefix follow the pushed namespace, as launch_ros resolves the nodes' own. Checked through the
    module's functions and its source: launch and launch_ros are not on the package registry here, so
    the LaunchDescription itself is not built in this suite."""
    module = _launch_module()
    alone = module.chain_nodes("step_start", "bag", "kalman", "true", "")
    assert [spec["executable"] for spec in alone if spec.get("ends_launch")] == ["pendulum_sim"]
    included = module.chain_nodes("step_start", "bag", "kalman", "true", "", shutdown_on_scene_end="false")
    assert not any(spec.get("ends_launch") for spec in included)
    source = LAUNCH.read_text()
    assert 'on_exit=[Shutdown(reason="scene finished")] if spec.get("ends_launch") else None' in source
    for given, expected in (("true", True), ("false", False)):
        specs = module.chain_nodes("step_start", "bag", "kalman", "true", "", use_sim_time=given)
        assert {spec["parameters"]["use_sim_time"] for spec in specs} == {expected}
        assert len(specs) == 3
    unset = module.chain_nodes("step_start", "bag", "kalman", "true", "")
    assert not any("use_sim_time" in spec["parameters"] for spec in unset)  # time_source decides
    with pytest.raises(ValueError, match="use_sim_time"):
        module.chain_nodes("step_start", "", "kalman", "true", "", use_sim_time="maybe")
    # launch_ros: a relative namespace goes under the pushed one, an absolute one stays.
    assert module.chain_namespace("/car1", "") == "/car1"
    assert module.chain_namespace("/fleet", "car1") == "/fleet/car1"
    assert module.chain_namespace("/fleet", "/car1") == "/car1"
    assert module.chain_namespace("", "car1") == "/car1"
    assert module.chain_namespace("/", "") == module.chain_namespace("", "") == ""
    pushed = module.chain_namespace("/car1", "")
    assert module.remappings(pushed, "true", "") == [("/clock", "/car1/clock")]
    assert module.frame_prefix_of(pushed, "auto") == "car1/"
    assert 'context.launch_configurations.get("ros_namespace", "")' in source


def test_every_node_parameter_and_executable_of_the_launch_file_is_real() -> None:
    module = _launch_module()
    scripts = _console_scripts()
    cfg = (REPO / "setup.cfg").read_text()
    assert "script_dir=$base/lib/pendulum_accel" in cfg  # where colcon puts the console scripts
    combos = itertools.product(("", "/tmp/bag"), ("false", "true"), ("", "sim", "wall"))
    seen = set()
    for record, fast, time_source in combos:
        if time_source == "wall" and fast == "true":
            with pytest.raises(ValueError, match="real-time"):
                module.chain_nodes("step_start", record, "kalman", fast, time_source)
            continue
        for spec in module.chain_nodes("step_start", record, "kalman", fast, time_source):
            executable = spec["executable"]
            assert executable in scripts and executable in NODE_PARAMETERS, executable
            assert spec["name"] == executable  # the names the waits expect
            for name, value in spec["parameters"].items():
                check_value(executable, name, value)
            seen.add(executable)
    assert seen == {"pendulum_sim", "accel_estimator", "bag_recorder"}


def test_params_yaml_sets_only_declared_parameters_with_valid_values() -> None:
    doc = yaml.safe_load(PARAMS.read_text())
    assert set(doc) == {"/**", "/**/pendulum_sim", "/**/accel_estimator", "/**/bag_recorder"}
    common = doc["/**"]["ros__parameters"]
    for key, block in doc.items():
        params = block["ros__parameters"]
        nodes = list(NODE_PARAMETERS) if key == "/**" else [key.removeprefix("/**/")]
        for node in nodes:
            declared = {s.name for s in NODE_PARAMETERS[node]}
            for name, value in params.items():
                if key == "/**" and name not in declared:
                    continue  # a shared value: each node takes the names it declares
                check_value(node, name, value)
    # Every shared value is declared by at least the simulator and the estimator.
    for name in common:
        for node in ("pendulum_sim", "accel_estimator"):
            check_value(node, name, common[name])


def test_setup_installs_launch_file_and_params() -> None:
    tree = ast.parse((REPO / "setup.py").read_text())
    text = ast.unparse(tree)
    assert 'f"share/{PACKAGE}/launch"' in text or "share/{PACKAGE}/launch'" in text
    assert "launch_scripts/*.launch.py" in text and "config/*.yaml" in text
    assert Path(REPO / "launch_scripts" / "chain.launch.py").is_file() and PARAMS.is_file()


@pytest.mark.ros
def test_nodes_accept_the_params_file(spawn: Spawn, tmp_path: Path) -> None:
    """The YAML as shipped starts the estimator; an edited copy's value takes effect in the simulator."""
    node = [PYTHON, "-m", "pendulum_accel.nodes.estimator_node"]
    estimator = Output(spawn([*node, "--ros-args", "--params-file", str(PARAMS)]))
    estimator.wait_for(r"estimating with kalman", timeout=90)
    doc = yaml.safe_load(PARAMS.read_text())
    doc["/**"]["ros__parameters"]["scene"] = "at_rest"
    doc["/**/pendulum_sim"]["ros__parameters"]["reader_nodes"] = [""]  # start without a reader
    edited = tmp_path / "params.yaml"
    edited.write_text(yaml.safe_dump(doc))
    cmd = [PYTHON, "-m", "pendulum_accel.nodes.simulator_node", "--ros-args", "--params-file", str(edited)]
    sim = Output(spawn([*cmd, "-p", "duration:=0.5"]))
    sim.wait_for(r"scene at_rest: 51 samples over 0\.500 s", timeout=90)
    assert sim.finish(timeout=60) == 0, sim.text
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=30) == 0, estimator.text
