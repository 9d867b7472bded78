"""Connected clients of the stub: buffered non-blocking sockets, one per agent or monitor.

Writes never block the server: what the kernel does not take waits in a per-client buffer with a
cap. An agent over its cap is disconnected (it stopped reading); a monitor over its cap simply
misses updates and gets a full scene once it drains, so a trainer that never reads the stream
costs neither time nor memory.
"""

from __future__ import annotations

import logging
import socket
import time

from protocol.errors import excerpt
from protocol.framing import FrameDecoder, encode_frame
from server_stub.agent_state import AgentState
from server_stub.config import ServerConfig

__all__ = ["AgentState", "Client"]

log = logging.getLogger("server_stub")


#: Distinct problems remembered per client for logging each once; past it, only the rate limit holds.
_MAX_REMEMBERED = 256


class Client:
    """One connection. ``peer`` is the address ``accept`` returned: asking the socket again
    (``getpeername``) fails once the peer has reset the connection, which a client may do before
    the server gets to it."""

    def __init__(
        self,
        sock: socket.socket,
        kind: str,
        max_frame: int,
        out_cap: int,
        peer: tuple | None = None,
        config: ServerConfig = ServerConfig(),
    ) -> None:
        self.sock = sock
        if peer is None:
            peer = sock.getpeername()
        self.name = f"{kind} {peer[0]}:{peer[1]}"
        self.decoder = FrameDecoder(max_frame)
        self.out = bytearray()
        self.out_cap = out_cap
        self.closed = False
        self.last_heard = time.monotonic()
        self._config = config
        self._warned: set[str] = set()
        self._lines = 0  # warning lines logged
        self._held = 0  # warnings not logged since the last line
        self._quiet_until = 0.0
        self._allowance = float(config.bad_input_burst)
        self._allowance_at = time.monotonic()

    def warn(self, problem: str, key: str | None = None) -> None:
        """One warning line naming the client and the problem, its input quoted escaped and cut
        (``ServerConfig.warning_quote``). A repeated problem is logged once, and past
        ``warning_burst`` lines at most one line per ``warning_interval`` is written, saying how
        many warnings were held back: a client decides what it sends, never how much is logged."""
        key = (key or problem)[: self._config.warning_quote]
        if key in self._warned:
            return
        if len(self._warned) < _MAX_REMEMBERED:
            self._warned.add(key)
        now = time.monotonic()
        if self._lines >= self._config.warning_burst and now < self._quiet_until:
            self._held += 1
            return
        held = f" ({self._held} more warnings held back)" if self._held else ""
        self._held = 0
        self._lines += 1
        if self._lines >= self._config.warning_burst:
            self._quiet_until = now + self._config.warning_interval
        log.warning("%s: %s%s", self.name, excerpt(problem, self._config.warning_quote), held)

    def refused(self) -> bool:
        """Count one message refused whole; True once the client is over its allowance
        (``bad_input_burst`` refusals beyond ``bad_input_rate`` per second) and should go."""
        now = time.monotonic()
        cfg = self._config
        self._allowance = min(
            float(cfg.bad_input_burst), self._allowance + (now - self._allowance_at) * cfg.bad_input_rate
        )
        self._allowance_at = now
        self._allowance -= 1.0
        return self._allowance < 0.0

    def send(self, payload: bytes | str) -> bool:
        """Queue one framed message; False if the client's buffer is over its cap (nothing queued)."""
        if len(self.out) > self.out_cap:
            return False
        data = encode_frame(payload)
        if not self.out:
            try:
                sent = self.sock.send(data)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self.closed = True
                return False
            data = data[sent:]
        self.out += data
        return True

    def flush(self) -> None:
        """Write what is buffered as far as the socket takes it (called when it is writable)."""
        if not self.out:
            return
        try:
            sent = self.sock.send(self.out)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self.closed = True
            return
        del self.out[:sent]

    def close(self) -> None:
        self.closed = True
        try:
            self.sock.close()
        except OSError:
            pass
