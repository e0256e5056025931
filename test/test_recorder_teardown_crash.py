"""A recorder that dies by a signal after closing its bag: the chain stands on the bag it verifies.

A real chain runs (simulator, estimator, the real recorder node); the recorder's process runs the node's
own ``main`` and, once that returned (bag closed, summary written), kills itself with SIGSEGV, as a
crash in rclpy's teardown would. A bag that reads complete keeps the run's exit 0
with one warning; a bag damaged after the close, or a recorder that never reported the close, keeps
the failure.
"""

from __future__ import annotations

import re
import signal
from pathlib import Path

import pytest

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.nodes.launcher import Chain, ChainConfig

pytestmark = [pytest.mark.ros]

# The recorder node's own main, then what the case asks, then SIGSEGV at the default action (no core
# file: RLIMIT_CORE 0). ``summary_file:="…"`` is the launcher's -p rule naming the recorder's summary.
_RECORD_THEN_SEGV = """
import json, os, resource, signal, sys
from pathlib import Path
from pendulum_accel.nodes.recorder_node import main
main()
case = {case!r}
if case == "damaged":
    from mcap.reader import make_reader
    (mcap,) = Path({bag!r}).glob("*.mcap")
    with mcap.open("rb") as handle:
        first = min(make_reader(handle).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    data = bytearray(mcap.read_bytes())
    data[first.chunk_start_offset + first.chunk_length // 2] ^= 0xFF  # inside the chunk's records
    mcap.write_bytes(bytes(data))
elif case == "unreported":
    rule = next(a for a in sys.argv if a.startswith("summary_file:="))
    Path(json.loads(rule.partition(":=")[2])).unlink()
resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
signal.signal(signal.SIGSEGV, signal.SIG_DFL)
os.kill(os.getpid(), signal.SIGSEGV)
"""


class _RecorderSegfaultsAfterClose(Chain):
    """The chain with its recorder process replaced by _RECORD_THEN_SEGV for ``case``."""

    def __init__(self, config: ChainConfig, case: str, output: Path) -> None:
        """As Chain, logging the nodes to ``output``."""
        super().__init__(config, output=output)
        self.case = case

    def commands(self, scene_arg: str, summaries: Path) -> list[tuple[str, list[str]]]:
        """Chain.commands with ``python -c _RECORD_THEN_SEGV`` for ``python -m …recorder_node``."""
        out = []
        for role, command in super().commands(scene_arg, summaries):
            if role == "recorder":
                assert command[1:3] == ["-m", "pendulum_accel.nodes.recorder_node"], command
                code = _RECORD_THEN_SEGV.format(case=self.case, bag=str(self.config.record))
                command = [command[0], "-c", code, *command[3:]]
            out.append((role, command))
        return out


@pytest.mark.parametrize(("case", "expected"), [("intact", 0), ("damaged", 1), ("unreported", 1)])
def test_a_recorder_killed_after_closing_a_bag_that_verifies_fails_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str, expected: int
) -> None:
    bag = tmp_path / "bag"
    log = tmp_path / "nodes.log"
    config = ChainConfig(
        scene="at_rest", record=bag, realtime=False, estimator="instant", overrides={"duration": 1.0}
    )
    chain = _RecorderSegfaultsAfterClose(config, case, log)
    code = chain.run()
    err = capsys.readouterr().err
    context = f"{err}\n--- nodes ---\n{log.read_text() if log.exists() else ''}"
    recorder = chain.child("recorder")
    assert recorder is not None and recorder.process.returncode == -signal.SIGSEGV, context
    assert "bag_recorder: bag closed:" in log.read_text(), context
    assert code == expected, context
    warnings = [line for line in err.splitlines() if line.startswith("WARNING")]
    ended = re.search(r"recorder ended with killed by SIGSEGV$", err, re.MULTILINE)
    if case == "intact":
        assert read_bag(bag).problem is None, context
        assert len(warnings) == 1 and "SIGSEGV" in warnings[0] and "verified complete" in warnings[0], context
        assert ended is None, context
        assert chain.accounting is not None and chain.accounting.losses(recording=True) == [], context
    else:
        assert warnings == [], context
        assert ended is not None, context
        assert (read_bag(bag).problem is not None) == (case == "damaged"), context
