"""One agent run: connect, handshake, cycle loop, clean disconnect.

``run()`` is what ``python -m agent`` does. Programs that drive agents themselves (the optimizer's
episode runner) use the same object cycle by cycle: ``connect()``, then ``receive()`` /
``reply()`` pairs until ``finished``, then ``close()``; whatever they send to the server between a
``receive`` and its ``reply`` (a trainer command, say) reaches it at a well-defined cycle.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from agent.behaviour import Phase, WalkBehaviour
from agent.config import AgentConfig
from agent.connection import ConnectionClosed, ServerConnection
from agent.errors import AgentError
from gait import Gait, load_gait
from protocol import commands
from protocol.errors import ProtocolError
from protocol.perception import Perception, parse_perception

log = logging.getLogger("agent")


@dataclass(frozen=True)
class AgentReport:
    cycles: int
    walk_time: float
    fell: bool
    fell_at: float | None
    completed: bool


class NaoAgent:
    """One robot, walking until ``config.duration`` seconds of gait time or until the server closes."""

    def __init__(self, config: AgentConfig, gait: Gait | None = None) -> None:
        """``gait`` overrides ``config.gait`` (a file), so a caller holding genes needs no file."""
        self.config = config
        if gait is None:
            gait = load_gait(config.gait) if config.gait is not None else load_gait()
        self.behaviour = WalkBehaviour(config, gait.walker())
        self.cycles = 0
        self._conn: ServerConnection | None = None
        self._syn = commands.syn() if config.sync else ""
        self._perception: Perception | None = None

    @property
    def finished(self) -> bool:
        return self.behaviour.phase is Phase.DONE

    @property
    def settled(self) -> bool:
        """The robot has held its starting pose for ``config.settle_cycles`` cycles, so its walk can
        begin: with ``start_now`` it begins with the reply to the last perception received. A
        trainer that starts the game clock with the walk sends PlayOn between that ``receive`` and
        its ``reply``."""
        return self.behaviour.settle_cycle >= self.config.settle_cycles

    def report(self, completed: bool = True) -> AgentReport:
        b = self.behaviour
        return AgentReport(self.cycles, b.walk_time, b.fell_at is not None, b.fell_at, completed)

    def connect(self) -> None:
        """Open the connection and ask for a robot (``scene``)."""
        self._conn = ServerConnection(self.config.host, self.config.port, self.config.timeout)
        self._conn.send(commands.scene(self.config.robot_type or None))

    def receive(self) -> Perception:
        """Wait for the next perception (raises ``ConnectionClosed`` / ``AgentError``)."""
        conn = self._require_connection()
        message = self._first_message(conn) if self.cycles == 0 else conn.receive()
        try:
            self._perception = parse_perception(message)
        except ProtocolError as exc:
            raise AgentError(f"unusable message from the server at {conn.address}: {exc}") from None
        self.cycles += 1
        return self._perception

    def reply(self) -> None:
        """Answer the last perception: one message, ending with ``(syn)`` in sync mode."""
        if self._perception is None:
            raise AgentError("reply() needs a perception: call receive() first")
        self._require_connection().send(self.behaviour.reply(self._perception) + self._syn)
        self._perception = None

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def run(self) -> AgentReport:
        """Blocking. Raises ``AgentError`` when the server is unreachable or closes before the end."""
        self.connect()
        try:
            while not self.finished:
                self.receive()
                self.reply()
            return self.report()
        except ConnectionClosed:
            if self.config.duration is None:
                log.info("server closed the connection after %d cycles", self.cycles)
                return self.report()
            raise AgentError(
                f"server at {self._conn_address()} closed the connection after {self.cycles} cycles, "
                f"{self.behaviour.walk_time:.2f} of {self.config.duration:g} s walked"
            ) from None
        finally:
            self.close()

    def _conn_address(self) -> str:
        return f"{self.config.host}:{self.config.port}"

    def _require_connection(self) -> ServerConnection:
        if self._conn is None:
            raise AgentError("not connected: call connect() first")
        return self._conn

    def _first_message(self, conn: ServerConnection) -> bytes:
        """In sync mode the real server answers a silent new agent's ``scene`` only after two 1-s
        waits; a ``(syn)`` every 10 ms gets the first perception in about 20 ms
        (docs/robot_and_server.md section 11)."""
        interval = self.config.syn_nudge_interval
        if not self.config.sync or interval is None:
            return conn.receive()
        deadline = time.monotonic() + self.config.timeout
        while time.monotonic() < deadline:
            message = conn.receive(timeout=interval)
            if message is not None:
                return message
            conn.send(commands.syn())
        raise AgentError(f"no perception from the server at {conn.address} within {self.config.timeout:g} s of scene")
