"""Helpers for tests that talk to a running server_stub over real sockets.

Deliberately independent of the project's protocol package: framing with struct, parsing with
regular expressions, as another team's client would do it.
"""

from __future__ import annotations

import re
import socket
import struct
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


class RawClient:
    """A minimal rcssserver3d client: 4-byte big-endian length prefix + ASCII S-expressions."""

    def __init__(self, port: int, timeout: float = 10.0) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buffer = b""

    def send(self, text: str | bytes) -> None:
        body = text.encode() if isinstance(text, str) else text
        self.sock.sendall(struct.pack("!I", len(body)) + body)

    def send_raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def receive(self) -> str:
        while True:
            if len(self._buffer) >= 4:
                (n,) = struct.unpack("!I", self._buffer[:4])
                if len(self._buffer) >= 4 + n:
                    body, self._buffer = self._buffer[4 : 4 + n], self._buffer[4 + n :]
                    return body.decode("ascii")
            chunk = self.sock.recv(1 << 16)
            if not chunk:
                raise ConnectionError("server closed the connection")
            self._buffer += chunk

    def close(self) -> None:
        self.sock.close()


def joint(message: str, name: str) -> float:
    return float(re.search(rf"\(HJ \(n {name}\) \(ax (-?[\d.]+)\)\)", message).group(1))


def torso_sensor(message: str, name: str) -> tuple[float, ...]:
    """The torso's ``GYR`` (rt) or ``ACC`` (a) triple."""
    found = re.search(rf"\({name} \(n torso\) \((?:a|rt) ([^)]*)\)\)", message)
    assert found, message[:200]
    return tuple(float(v) for v in found.group(1).split())


def now(message: str) -> float:
    return float(re.search(r"\(time \(now (-?[\d.]+)\)\)", message).group(1))


def torso_from_monitor(message: str) -> tuple[float, float, float] | None:
    """Torso translation from a full scene (RSG): the TRF two levels above the naobody mesh."""
    mesh = message.find("models/naobody")
    if mesh < 0:
        return None
    # walk back to the grandparent transform's SLT: the second '(nd TRF (SLT' before the mesh
    starts = [m.start() for m in re.finditer(r"\(nd TRF \(SLT ", message[:mesh])]
    slt = re.match(r"\(nd TRF \(SLT ([^)]*)\)", message[starts[-2] :]).group(1).split()
    return float(slt[12]), float(slt[13]), float(slt[14])


class StubProcess:
    """``python -m server_stub`` on free ports; stops it on exit."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "server_stub", "--agent-port", "0", "--monitor-port", "0", *args],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self._stderr = ""
        line = self.proc.stdout.readline()
        match = re.search(r"agent port (\d+), monitor port (\d+)", line)
        if not match:
            err = self.stop()
            raise RuntimeError(f"stub did not start: {line!r} {err}")
        self.agent_port, self.monitor_port = int(match.group(1)), int(match.group(2))

    def stop(self) -> str:
        """Stop the server (once); returns what it wrote to stderr."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if not self.proc.stderr.closed:
            self._stderr = self.proc.stderr.read()
            self.proc.stdout.close()
            self.proc.stderr.close()
        return self._stderr

    def __enter__(self) -> StubProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
