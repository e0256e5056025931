"""Node parameter tables: ROS-free, one entry per name, overrides taken from the one override table."""

from __future__ import annotations

import subprocess
import sys

import pytest

from pendulum_accel.nodes.parameters import (
    ESTIMATOR_CONFIG,
    FROM_SCENE,
    NODE_PARAMETERS,
    SIMULATOR,
    ParamSpec,
)
from pendulum_accel.overrides import OVERRIDES


def test_tables_import_without_rclpy() -> None:
    """Importing the tables (and printing every help line) loads no rclpy module."""
    code = (
        "import sys\n"
        "from pendulum_accel.nodes.parameters import NODE_PARAMETERS\n"
        "lines = [s.help_line() for specs in NODE_PARAMETERS.values() for s in specs]\n"
        "ros = [m for m in sys.modules if m.startswith(('rclpy', 'rcl_interfaces'))]\n"
        "assert lines and not ros, ros\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


@pytest.mark.parametrize("node", list(NODE_PARAMETERS))
def test_names_unique_and_defaults_in_range(node: str) -> None:
    """Each name once per node; every fixed default is of its type and inside its range."""
    specs = NODE_PARAMETERS[node]
    assert len({s.name for s in specs}) == len(specs)
    kinds = {"bool": bool, "integer": int, "double": float, "string": str, "string_array": tuple}
    for spec in specs:
        if spec.default is FROM_SCENE:
            continue
        assert isinstance(spec.default, kinds[spec.type]), spec.name
        if spec.low is not None and spec.high is not None:
            assert spec.low <= spec.default <= spec.high, spec.name  # type: ignore[operator]
        if spec.choices:
            assert spec.default in spec.choices, spec.name


def test_scene_overrides_come_from_the_override_table() -> None:
    """The simulator exposes every override, the estimator a subset, each with the table's range."""
    by_name: dict[str, ParamSpec] = {s.name: s for s in SIMULATOR}
    for override in OVERRIDES:
        spec = by_name[override.name]
        assert (spec.low, spec.high, spec.default) == (override.low, override.high, FROM_SCENE)
        assert spec.type == ("integer" if override.kind is int else "double")
        assert override.description in spec.description
    estimator = {s.name: s for s in NODE_PARAMETERS["accel_estimator"]}
    for override in ESTIMATOR_CONFIG:
        assert (estimator[override.name].low, estimator[override.name].high) == (override.low, override.high)


def test_help_line_states_type_range_default_and_text() -> None:
    """help_line: name, type, range, read-only, default (or 'the scene's') and description."""
    wait = next(s for s in SIMULATOR if s.name == "wait_timeout")
    assert wait.help_line() == (
        "wait_timeout (double, 0..3600, read-only; default 120.0): "
        "give up waiting for the named readers (reader_nodes, recorder_node) after this many seconds "
        "(s); while it waits, INFO lines name those not there yet"
    )
    length = next(s for s in SIMULATOR if s.name == "length")
    assert "default the scene's" in length.help_line()
