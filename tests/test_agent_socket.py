"""The agent over real TCP sockets against a scripted server that replays real-server perceptions.

The scripted server is written here with plain sockets and struct (not the protocol package), so a
framing mistake shared by the agent and the protocol package cannot hide.
"""

from __future__ import annotations

import re
import socket
import struct
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from protocol.nao import SPEED_CAP

REPO = Path(__file__).resolve().parents[1]


def _recv_exact(conn: socket.socket, n: int) -> bytes | None:
    data = b""
    while len(data) < n:
        chunk = conn.recv(n - len(data))
        if not chunk:
            return None
        data += chunk
    return data


def _read_frame(conn: socket.socket) -> bytes | None:
    head = _recv_exact(conn, 4)
    if head is None:
        return None
    return _recv_exact(conn, struct.unpack("!I", head)[0])


class ScriptedServer:
    """Sends the given perceptions one per received reply; records every message the agent sent."""

    def __init__(self, perceptions: list[str], sync: bool, close_after: int | None = None) -> None:
        self.perceptions = perceptions
        self.sync = sync
        self.close_after = close_after
        self.received: list[str] = []
        self.nodelay: bool | None = None
        self._listener = socket.socket()
        self._listener.bind(("127.0.0.1", 0))
        self._listener.listen(1)
        self.port = self._listener.getsockname()[1]
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        conn, _ = self._listener.accept()
        conn.settimeout(10)
        with conn:
            first = _read_frame(conn)
            self.received.append(first.decode())
            for k, text in enumerate(self.perceptions):
                if self.close_after is not None and k >= self.close_after:
                    return
                body = text.encode()
                conn.sendall(struct.pack("!I", len(body)) + body)
                while True:  # skip the bare (syn) nudges an agent sends before its first perception
                    reply = _read_frame(conn)
                    if reply is None:
                        return
                    if reply != b"(syn)" or k > 0:
                        break
                self.received.append(reply.decode())

    def join(self) -> None:
        self._thread.join(15)
        self._listener.close()


def _run_agent(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "agent", *args], cwd=REPO, capture_output=True, text=True, timeout=60)


@pytest.fixture(scope="module")
def first20(fixtures_dir) -> list[str]:
    return (fixtures_dir / "agent_perceptions_first20.txt").read_text().splitlines()


def _play_on(lines: list[str]) -> list[str]:
    return [line.replace("(pm BeforeKickOff)", "(pm PlayOn)") for line in lines]


def test_sync_handshake_beam_syn_and_velocity_cap(fixtures_dir, first20: list[str]) -> None:
    perceptions = first20[:3] + _play_on(
        (fixtures_dir / "agent_perceptions_full_run.txt").read_text().splitlines()[3:60]
    )
    server = ScriptedServer(perceptions, sync=True)
    done = _run_agent(
        "--port", str(server.port), "--sync", "--team", "Probe", "--beam", "-1", "0", "0", "--duration", "0.5"
    )
    server.join()
    assert done.returncode == 0, done.stderr
    sent = server.received
    assert sent[0] == "(scene rsg/agent/nao/nao.rsg)"
    assert sent[1] == "(init (unum 1)(teamname Probe))(syn)"
    assert sent[2] == "(beam -1 0 0)(syn)"
    assert all(message.endswith("(syn)") for message in sent[1:])
    values = [float(v) for message in sent[3:] for v in re.findall(r"\(\w+ (-?[\d.]+)\)", message)]
    assert values and max(abs(v) for v in values) <= SPEED_CAP
    assert any(abs(v) == SPEED_CAP for v in values)  # the first moves into the pose are capped
    # 25 settling cycles + 0.5 s of walking = 25 cycles, then a clean exit
    assert len(sent) == 1 + 2 + 25 + 25


def test_real_time_mode_sends_no_syn(fixtures_dir) -> None:
    perceptions = (fixtures_dir / "agent_perceptions_first20_realtime_mode.txt").read_text().splitlines()
    server = ScriptedServer(perceptions, sync=False, close_after=10)
    done = _run_agent("--port", str(server.port), "--beam", "-1", "0", "0")
    server.join()
    assert done.returncode == 0, done.stderr  # no --duration: the server closing ends the run
    assert server.received[1] == "(init (unum 1)(teamname GALA))"
    assert not any("(syn)" in m for m in server.received)


def test_server_closing_early_is_a_one_line_error(first20: list[str]) -> None:
    server = ScriptedServer(first20, sync=True, close_after=5)
    done = _run_agent("--port", str(server.port), "--sync", "--duration", "15")
    server.join()
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "closed the connection" in lines[0]


def test_nothing_listening_is_a_one_line_error() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    done = _run_agent("--port", str(port), "--timeout", "2")
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    assert "cannot reach the server" in done.stderr and str(port) in done.stderr


@pytest.mark.parametrize(
    "args, words",
    [
        (["--port", "70000"], "port"),
        (["--unum", "12"], "unum"),
        (["--duration", "-1"], "duration"),
        (["--type", "7"], "type"),
        (["--beam", "1", "nan", "0"], "beam"),
    ],
)
def test_bad_arguments_are_refused_naming_the_flag(args: list[str], words: str) -> None:
    done = _run_agent(*args)
    assert done.returncode == 2
    assert words in done.stderr and "Traceback" not in done.stderr


def test_bad_gait_file_is_refused_before_connecting(tmp_path) -> None:
    bad = tmp_path / "gait.json"
    bad.write_text('{"format": "tfs-gait/1", "params": {}}')
    done = _run_agent("--gait", str(bad), "--port", "1")
    assert done.returncode == 2 and "missing parameters" in done.stderr


def test_agent_sets_tcp_nodelay_and_sends_each_message_whole(first20: list[str]) -> None:
    """Each message must arrive as one segment train without waiting: check that a reply's
    4-byte prefix and body come in one recv on loopback (two sends would split them)."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(1)
    port = listener.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "agent", "--port", str(port), "--duration", "0.1"],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    conn, _ = listener.accept()
    conn.settimeout(10)
    whole = 0
    with conn:
        scene = conn.recv(65536)
        assert scene[4:] == b"(scene rsg/agent/nao/nao.rsg)"
        for text in first20[:5]:
            conn.sendall(struct.pack("!I", len(text)) + text.encode())
            chunk = conn.recv(65536)
            length = struct.unpack("!I", chunk[:4])[0]
            whole += len(chunk) == 4 + length
    proc.kill()
    proc.wait()
    listener.close()
    assert whole == 5


def test_connection_sets_tcp_nodelay() -> None:
    from agent.connection import ServerConnection

    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        conn = ServerConnection("127.0.0.1", listener.getsockname()[1], timeout=5)
        try:
            assert conn._sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) == 1
        finally:
            conn.close()
