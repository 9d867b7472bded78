"""A trainer's link to a server's monitor port: commands out, monitor states in."""

from __future__ import annotations

import select
import socket

from optimizer.episode.servers import ServerAddress
from protocol.framing import FrameDecoder, encode_frame
from protocol.monitor import MonitorReader, MonitorState


class EpisodeFailure(RuntimeError):
    """The server or the agent died, hung or misbehaved: not the gait's fault."""


#: Bytes asked of the monitor socket per read (a full scene larger than this arrives in several).
#: Not more: ``recv(n)`` allocates n bytes every call, and 1 MB cost ~13 us per read.
_RECV_SIZE = 1 << 16


class MonitorLink:
    """A trainer's connection to the monitor port: sends commands, follows the stream."""

    def __init__(self, address: ServerAddress, timeout: float) -> None:
        self._sock = socket.create_connection((address.host, address.monitor_port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._decoder = FrameDecoder()
        self.reader = MonitorReader()

    def send(self, *commands: str) -> None:
        for command in commands:
            self._sock.sendall(encode_frame(command))

    def poll(self, wait: float = 0.0) -> list[MonitorState]:
        """Every monitor state that arrived, oldest first (waits up to ``wait`` s for the first)."""
        states: list[MonitorState] = []
        while True:
            ready, _, _ = select.select([self._sock], [], [], wait)
            if not ready:
                return states
            data = self._sock.recv(_RECV_SIZE)
            if not data:
                raise EpisodeFailure("the server closed the monitor connection")
            states.extend(self.reader.feed(frame) for frame in self._decoder.feed(data))
            wait = 0.0

    def close(self) -> None:
        self._sock.close()
