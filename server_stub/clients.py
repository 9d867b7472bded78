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
from dataclasses import dataclass, field

from protocol.framing import FrameDecoder, encode_frame

log = logging.getLogger("server_stub")


class Client:
    def __init__(self, sock: socket.socket, kind: str, max_frame: int, out_cap: int) -> None:
        self.sock = sock
        peer = sock.getpeername()
        self.name = f"{kind} {peer[0]}:{peer[1]}"
        self.decoder = FrameDecoder(max_frame)
        self.out = bytearray()
        self.out_cap = out_cap
        self.closed = False
        self.last_heard = time.monotonic()
        self._warned: set[str] = set()

    def warn(self, problem: str, key: str | None = None) -> None:
        """One warning line naming the client and the problem; repeated problems are logged once."""
        key = key or problem
        if key not in self._warned:
            self._warned.add(key)
            log.warning("%s: %s", self.name, problem)

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


@dataclass
class AgentState:
    """What the server knows about one agent connection's robot."""

    robot: object | None = None
    robot_type: int = 0
    side: str | None = None
    team: str | None = None
    unum: int | None = None
    #: the first GS after init carries unum and team (facts section 5)
    announce_identity: bool = False
    #: a perception was sent and no ``(syn)`` has come back since
    awaiting_syn: bool = False
    sent_at: float = 0.0
    #: perception computed after the last step, sent at the next cycle boundary
    next_perception: str | None = None
    #: frames received since the last step, applied after the next perception goes out
    inbox: list[bytes] = field(default_factory=list)
    vision: object | None = None
