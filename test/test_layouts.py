"""The shipped Foxglove and PlotJuggler layouts reference only topics and fields a recorded bag has."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.export import VISUAL_ROLES, topic_table
from pendulum_accel.bag.reader import read_bag
from test.conftest import REPO

GOLDEN = REPO / "bags" / "step_start"
LAYOUTS = REPO / "layouts"


def test_foxglove_layout_paths_exist_in_a_golden_bag() -> None:
    layout = json.loads((LAYOUTS / "foxglove_pendulum_accel.json").read_text(encoding="utf8"))
    bag = read_bag(GOLDEN)
    fields = {topic: set(bag.decode(topic).fields) for topic in bag.topics}
    scripts = {}
    for node in layout["userNodes"].values():
        source = node["sourceCode"]
        output = re.search(r'export const output = "([^"]+)"', source)
        inputs = re.search(r"export const inputs = \[([^\]]*)\]", source)
        assert output and inputs
        topics = re.findall(r'"([^"]+)"', inputs.group(1))
        read = re.findall(r"event\.message\.([\w.\[\]]+)", source)
        for topic in topics:
            for path in read:
                if path != "header":
                    assert path in fields[topic], (topic, path)
        scripts[output.group(1)] = set(re.findall(r"\b(upper|lower): ", source))
    plotted = []
    for panel_id, config in layout["configById"].items():
        if panel_id.startswith("Plot!"):
            for entry in config["paths"]:
                topic, _, path = entry["value"].partition(".")
                plotted.append(topic)
                if topic in scripts:
                    assert path in scripts[topic], entry["value"]
                else:
                    assert topic in fields and path in fields[topic], entry["value"]
        elif panel_id.startswith("DiagnosticSummary!"):
            assert config["topicToRender"] in bag.topics
    assert {"/pendulum/joint_states", "/car/accel/truth", "/car/accel/estimate", "/diagnostics"} <= set(
        plotted
    )
    panels = json.dumps(layout["layout"])
    assert all(panel_id in panels for panel_id in layout["configById"])  # every panel is placed


def test_plotjuggler_layout_series_exist_in_a_golden_bag() -> None:
    """Every curve is a series PlotJuggler's ROS 2 parser makes of the bag (the export's column names)
    or one of the layout's snippets, whose sources are such series."""
    root = ET.parse(LAYOUTS / "plotjuggler_pendulum_accel.xml").getroot()
    bag = read_bag(GOLDEN)
    tables = [topic_table(bag, t) for t in bag.topics if bm.role_of(t) not in VISUAL_ROLES]
    series = {str(c) for table in tables for c in table.columns}
    snippets = {s.get("name"): s for s in root.iter("snippet")}
    for snippet in snippets.values():
        sources = [snippet.findtext("linked_source")] + [
            v.text for v in snippet.find("additional_sources") or []
        ]
        assert sources and all(src in series for src in sources), sources
        assert "math.sqrt(v1)" in (snippet.findtext("function") or "")
    curves = [c.get("name") for c in root.iter("curve")]
    assert len(curves) >= 6
    for name in curves:
        assert name in series or name in snippets, name
    assert {"estimate_plus_2sigma", "estimate_minus_2sigma"} <= set(curves)
    assert root.find("Plugins/plugin").get("ID") == "DataLoad MCAP"  # type: ignore[union-attr]


def test_foxglove_3d_panel_shows_the_markers_and_the_urdf_in_base_link() -> None:
    """The 3D panel follows base_link and shows the topics the simulator and estimator publish for it,
    as a root-namespace run records them."""
    layout = json.loads((LAYOUTS / "foxglove_pendulum_accel.json").read_text(encoding="utf8"))
    panels = {k: v for k, v in layout["configById"].items() if k.startswith("3D!")}
    assert len(panels) == 1
    config = next(iter(panels.values()))
    assert config["followTf"] == bm.FRAME_ID
    assert {"/" + bm.MARKERS, "/" + bm.ROBOT_DESCRIPTION} <= set(config["topics"])
    # A golden bag holds them, as a live recording does: opened in the layout, it shows the swing.
    golden = read_bag(GOLDEN)
    assert {bm.TOPIC_MARKERS, bm.TOPIC_ROBOT_DESCRIPTION, bm.TOPIC_IMU} <= set(golden.topics)
    (urdf_msg,) = golden.raw(bm.TOPIC_ROBOT_DESCRIPTION)[1]
    assert 'type="continuous"' in bm.deserialize(urdf_msg, bm.STRING_MSG).data  # type: ignore[attr-defined]


def test_plotjuggler_layout_names_the_mcap_loader() -> None:
    """docs/ros.md opens the .mcap with `plotjuggler -d`, which goes through the MCAP loader."""
    text = (LAYOUTS / "plotjuggler_pendulum_accel.xml").read_text(encoding="utf8")
    assert '<plugin ID="DataLoad MCAP">' in text and "ROS2 bags" not in text
    assert "DataLoad MCAP" in (REPO / "docs" / "ros.md").read_text(encoding="utf8")
