"""Servers an episode runs on: a stub subprocess this worker owns, a real rcssserver3d it owns
(``optimizer.episode.real_server``), or a server run elsewhere, known by its address.

The optimizer talks to servers only through their public interfaces: it starts the stub as a
process (``python -m server_stub``) on free ports and reads the ports it prints; a server run
elsewhere is just an address.
"""

from __future__ import annotations

import os
import select
import subprocess
import sys
from dataclasses import dataclass
from typing import Protocol

_LISTENING = "server_stub listening: agent port "


@dataclass(frozen=True)
class ServerAddress:
    host: str
    agent_port: int
    monitor_port: int

    @classmethod
    def parse(cls, text: str) -> ServerAddress:
        """``HOST:AGENT_PORT:MONITOR_PORT``, e.g. ``127.0.0.1:3100:3200``."""
        parts = text.rsplit(":", 2)
        if len(parts) != 3 or not parts[0]:
            raise ValueError(f"server {text!r} must be HOST:AGENT_PORT:MONITOR_PORT")
        try:
            agent_port, monitor_port = int(parts[1]), int(parts[2])
        except ValueError:
            raise ValueError(f"server {text!r}: ports must be integers") from None
        for port in (agent_port, monitor_port):
            if not 1 <= port <= 65535:
                raise ValueError(f"server {text!r}: port {port} is outside 1-65535")
        return cls(parts[0], agent_port, monitor_port)

    def __str__(self) -> str:
        return f"{self.host}:{self.agent_port}:{self.monitor_port}"


class ServerStartError(RuntimeError):
    """A server process could not be started: an infrastructure failure, not the gait's."""


class ManagedServer(Protocol):
    """A server process a worker owns: started on demand, restarted after a failure, stopped."""

    def ensure_running(self) -> ServerAddress:
        """The server's address, after starting it if it is not running (or died)."""
        ...

    def restart(self) -> None: ...

    def stop(self) -> None: ...


#: Seconds a stub may take to print its ports: its first start after installing also compiles the
#: physics kernels (numba, ~13 s alone, longer with every worker doing it at once).
START_TIMEOUT = 60.0


class ServerProcess:
    """A ``ManagedServer`` that is one child process: started on the first need, started again
    when it died. Subclasses say how to ``restart`` (start) and ``stop`` it."""

    def __init__(self) -> None:
        self._process: subprocess.Popen | None = None
        self.address: ServerAddress | None = None

    def ensure_running(self) -> ServerAddress:
        if self._process is None or self._process.poll() is not None:
            self.restart()
        assert self.address is not None
        return self.address

    @property
    def pid(self) -> int | None:
        """The server's process id while it is started (what an operator, or a test, would kill)."""
        return None if self._process is None else self._process.pid

    def restart(self) -> None:
        raise NotImplementedError

    def stop(self) -> None:
        raise NotImplementedError


class StubProcess(ServerProcess):
    """A ``server_stub`` in sync mode, real time off, on free loopback ports, owned by one worker."""

    def __init__(self, seed: int = 0, start_timeout: float = START_TIMEOUT) -> None:
        super().__init__()
        self.seed = seed
        self.start_timeout = start_timeout

    def restart(self) -> None:
        self.stop()
        # exact starts: the server's beam noise draws from one stream for all of a worker's
        # episodes, so an episode's walk would depend on how many ran before it on that worker
        # (and a resumed or Dask run would differ); a stability check moves the start itself,
        # from a seed of its own key, which works on any server
        command = [
            sys.executable,
            "-m",
            "server_stub",
            "--sync",
            "--no-realtime",
            "--no-beam-noise",
            "--sense-mypos",  # as the real server's sync profile
            "--agent-port",
            "0",
            "--monitor-port",
            "0",
            "--seed",
            str(self.seed),
            "--exit-with-parent",
        ]
        self._process = subprocess.Popen(
            command,
            stdout=subprocess.PIPE,
            stderr=None,
            text=True,
            env=dict(os.environ),
        )
        assert self._process.stdout is not None
        ready, _, _ = select.select([self._process.stdout], [], [], self.start_timeout)
        line = self._process.stdout.readline() if ready else ""
        if not line.startswith(_LISTENING):
            code = self._process.poll()
            self.stop()
            raise ServerStartError(f"server_stub did not start (exit code {code}, said {line.strip()!r})")
        ports = line[len(_LISTENING) :].split(", monitor port ")
        self.address = ServerAddress("127.0.0.1", int(ports[0]), int(ports[1]))

    def stop(self) -> None:
        if self._process is not None:
            if self._process.poll() is None:
                self._process.terminate()
                try:
                    self._process.wait(5.0)
                except subprocess.TimeoutExpired:
                    self._process.kill()
                    self._process.wait()
            if self._process.stdout is not None:
                self._process.stdout.close()
        self._process = None
        self.address = None
