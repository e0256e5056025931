"""The launcher checks a chain before any node starts (nodes/preflight.py): scene, overrides, estimator and
output directory. A mistake is one line from the launcher, no node started and no empty bag left behind.
(Names of the chain, checked there too by rcl's rules: test_ros_names.py.)"""

from __future__ import annotations

from pathlib import Path

import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.errors import ParameterError, SceneError
from test.conftest import cli
from test.refusal import one_line_error
from test.tiny_filesystem import tiny_filesystem


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--estimator", "nope"), ("unknown estimator",)),
        (("no_such_scene",), ("no bundled scene",)),
        (("--set", "length=-1"), ("length must be in",)),
        (("--set", "seed=1.5"), ("integer",)),
    ],
)
def test_the_launcher_refuses_before_starting_anything(
    tmp_path: Path, args: tuple[str, ...], words: tuple[str, ...]
) -> None:
    result = cli("run", *args, "--record", str(tmp_path / "bag"))
    one_line_error(result, *words)
    assert "started" not in result.stderr  # no node was started
    assert not (tmp_path / "bag").exists()  # and no empty bag blocks the next run


def test_the_launcher_refuses_a_read_only_output_directory(tmp_path: Path) -> None:
    with tiny_filesystem(tmp_path / "ro", "64k", "ro") as ro:
        result = cli("run", "--record", str(ro / "bag"))
        one_line_error(result, "not writable")
        assert "started" not in result.stderr


def test_preflight_is_a_function_of_the_config(tmp_path: Path) -> None:
    from pendulum_accel.nodes.launcher import ChainConfig
    from pendulum_accel.nodes.preflight import check_chain

    check_chain(ChainConfig(scene="lecture_constant", record=tmp_path / "new"))
    (tmp_path / "old").mkdir()
    with pytest.raises(ParameterError, match="exists already"):
        check_chain(ChainConfig(scene="lecture_constant", record=tmp_path / "old"))
    with pytest.raises(SceneError):
        check_chain(ChainConfig(scene=str(tmp_path / "missing.yaml")))
    # Missing directories above the bag are created, as rosbag2 creates them; a file on the way is refused.
    check_chain(ChainConfig(scene="lecture_constant", record=tmp_path / "a" / "b"))
    (tmp_path / "file").write_text("")
    with pytest.raises(ParameterError, match="is a file, not a directory"):
        check_chain(ChainConfig(scene="lecture_constant", record=tmp_path / "file" / "b"))


@pytest.mark.ros
def test_run_records_where_the_directories_above_the_bag_do_not_exist_yet(tmp_path: Path) -> None:
    """``run --record a/b/bag`` with no a/: made, as ``ros2 bag record -o a/b/bag`` makes it (refused
    before)."""
    bag = tmp_path / "a" / "b" / "bag"
    result = cli("run", "at_rest", "--fast", "--set", "duration=0.3", "--record", str(bag))
    assert result.returncode == 0, result.stderr
    assert (bag / "metadata.yaml").is_file() and read_bag(bag).topics[bm.TOPIC_JOINT_STATES].count == 31
