"""chain.launch.py under ROS 2's own launch machinery, where launch_testing is installed.

The PyPI ROS 2 wheels (requirements-ros.txt) ship neither launch nor launch_testing, so on such a
machine this module is skipped with that reason; the static checks of the launch file
(test_launch_files.py) run everywhere. With a sourced ROS 2 install and the package built
(colcon), it launches a short recorded scene in a namespace and checks the bag it leaves.
"""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip(
    "launch_testing",
    reason="launch_testing is not installed: the ROS 2 PyPI wheels have no launch/launch_testing; "
    "source a ROS 2 install (and colcon build this package) to run the launch file itself",
)

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from test.conftest import REPO

pytestmark = [pytest.mark.ros]


def test_chain_launch_file_records_a_namespaced_scene(tmp_path: Path) -> None:
    from launch import LaunchService
    from launch.actions import IncludeLaunchDescription
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    service = LaunchService()
    arguments = {"scene": "step_start", "fast": "true", "record": str(tmp_path / "bag"), "namespace": "lt"}
    service.include_launch_description(
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(REPO / "launch_scripts" / "chain.launch.py")),
            launch_arguments=arguments.items(),
        )
    )
    assert service.run() == 0
    bag = read_bag(tmp_path / "bag")
    joint = bm.find_topic(bag.topics, bm.JOINT_STATES)
    assert joint == "/lt/pendulum/joint_states"
    estimate = bm.find_topic(bag.topics, bm.ACCEL_ESTIMATE)
    assert estimate is not None and bag.topics[estimate].count == bag.topics[joint].count > 0
