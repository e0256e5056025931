"""The Dask scheduler address of analyze and design (--scheduler, $DASK_SCHEDULER_ADDRESS): a malformed one, a
refused port, a server that is not Dask or says nothing, each one line before any work, nothing written.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.cluster import scheduler_address
from test.conftest import cli
from test.fleet_rows import _no_leftover_workers  # noqa: F401 (the autouse fixture)
from test.refusal import error_line


@contextlib.contextmanager
def _server(greeting: bytes | None) -> Iterator[str]:
    """tcp://127.0.0.1:PORT of a listener that is not Dask: it sends ``greeting`` to each connection (an
    SSH server's, say), or nothing (None: a server waiting for its client to speak first, as HTTP does)."""
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    held: list[socket.socket] = []

    def serve() -> None:
        with contextlib.suppress(OSError):
            while True:
                conn, _ = listener.accept()
                held.append(conn)
                if greeting is not None:
                    conn.sendall(greeting)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{port}"
    finally:
        listener.close()
        for conn in held:
            conn.close()


def _refused_port() -> str:
    """tcp://127.0.0.1:PORT where nothing listens: a port bound, never listened on, so connect is refused."""
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    _UNLISTENED.append(sock)  # held for the session, so no other process takes the port meanwhile
    return f"tcp://127.0.0.1:{port}"


_UNLISTENED: list[socket.socket] = []

BAD_ADDRESSES = {
    "garbage": ("garbage", "has no port"),
    "http": ("http://10.0.0.5:8787", "is a web address"),
    "port_abc": ("tcp://h:abc", "the port 'abc' is not a number from 1 to 65535"),
    "inproc": ("inproc://x", "names a scheduler inside the process that started it"),
    "empty": ("", "--scheduler is empty"),
    "unknown_scheme": ("udp://h:8786", "unknown scheme 'udp'"),
}


@pytest.fixture(scope="module")
def one_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One generated bag, 1 s: what analyze needs to reach its scheduler."""
    bag = tmp_path_factory.mktemp("one_bag") / "b"
    done = cli("generate", "lecture_constant", "--duration", "1", "--out", str(bag))
    assert done.returncode == 0, done.stderr
    return bag


def _fleet_command(command: str, bag: Path, out: Path) -> list[str]:
    """analyze of ``bag`` twice (a fleet: the scheduler is used), or the smallest design, to ``out``."""
    if command == "analyze":
        return ["analyze", str(bag), str(bag), "--out", str(out)]
    grid = ["--lengths", "1", "--damping-ratios", "0.7", "--rates", "50", "--noises", "1e-3", "--seeds", "1"]
    return ["design", "--out", str(out), *grid, "--profiles", "lecture_constant", "--duration", "3"]


@pytest.mark.parametrize("command", ["analyze", "design"])
@pytest.mark.parametrize("case", list(BAD_ADDRESSES))
def test_a_bad_scheduler_address_is_one_line(
    one_bag: Path, tmp_path: Path, command: str, case: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """garbage, http://, tcp://h:abc, inproc://x, '' and an unknown scheme: one line naming --scheduler,
    exit 2, nothing written (each was Dask's traceback, and '' ran a local cluster unasked)."""
    address, words = BAD_ADDRESSES[case]
    out = tmp_path / "t.csv"
    code = main([*_fleet_command(command, one_bag, out), "--scheduler", address])
    error_line(code, capsys.readouterr().err, words)
    assert not out.exists()


def test_dask_scheduler_address_is_checked_as_the_option_is(
    one_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """$DASK_SCHEDULER_ADDRESS=tcp://h:abc: one line naming the variable; set empty, it is unset (the
    shell's way), and a fleet runs on the local cluster."""
    out = tmp_path / "t.csv"
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://h:abc")
    code = main(_fleet_command("analyze", one_bag, out))
    error_line(code, capsys.readouterr().err, "$DASK_SCHEDULER_ADDRESS 'tcp://h:abc'", "not a number")
    assert not out.exists()
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "")
    assert scheduler_address(None) is None


@pytest.mark.parametrize("command", ["analyze", "design"])
def test_a_port_where_something_else_answers_is_one_line(
    one_bag: Path, tmp_path: Path, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """An SSH server's greeting read as Dask's frame length asked numpy for 3.07 EiB (ArrayMemoryError);
    a refused port went through Dask's retries. Each is one line, exit 2, nothing written."""
    out = tmp_path / "t.csv"
    with _server(b"SSH-2.0-OpenSSH_9.6\r\n") as address:
        code = main([*_fleet_command(command, one_bag, out), "--scheduler", address])
    error_line(code, capsys.readouterr().err, f"{address} answers, but not as a Dask scheduler", "SSH-2.0-")
    refused = _refused_port()
    code = main([*_fleet_command(command, one_bag, out), "--scheduler", refused])
    error_line(code, capsys.readouterr().err, f"no Dask scheduler at {refused}")
    assert not out.exists()


def test_a_server_that_does_not_speak_first_is_not_waited_on_for_dask_s_30_s(
    one_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A listener that accepts and says nothing (an HTTP server): one line once cluster.PROBE_TIMEOUT has
    passed without Dask's handshake (a scheduler sends it as it accepts), naming that timeout."""
    from pendulum_accel.cluster import PROBE_TIMEOUT

    out = tmp_path / "t.csv"
    with _server(None) as address:
        code = main([*_fleet_command("analyze", one_bag, out), "--scheduler", address])
    error_line(code, capsys.readouterr().err, "sent no Dask handshake", f"within {PROBE_TIMEOUT:g} s")
    assert not out.exists()
