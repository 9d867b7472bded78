"""The agent's TCP link to the server: length-prefixed frames, one ``send`` per message.

TCP_NODELAY and a single send per message matter: with Nagle's algorithm on, a message split over
two sends waited for the peer's delayed ACK and cost 88 ms per cycle on loopback.
"""

from __future__ import annotations

import socket
from typing import overload

from agent.errors import AgentError
from protocol.framing import FrameDecoder, encode_frame


class ServerConnection:
    def __init__(self, host: str, port: int, timeout: float) -> None:
        self.address = f"{host}:{port}"
        try:
            self._sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as exc:
            raise AgentError(f"cannot reach the server at {self.address}: {exc.strerror or exc}") from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._timeout = timeout
        self._decoder = FrameDecoder()
        self._pending: list[bytes] = []

    def send(self, message: str) -> None:
        try:
            self._sock.sendall(encode_frame(message))
        except OSError as exc:
            raise AgentError(f"server at {self.address} closed the connection ({exc.strerror or exc})") from None

    @overload
    def receive(self) -> bytes: ...

    @overload
    def receive(self, timeout: float) -> bytes | None: ...

    def receive(self, timeout: float | None = None) -> bytes | None:
        """The next whole message; None if ``timeout`` passes first (only when a timeout is given)."""
        while not self._pending:
            self._sock.settimeout(self._timeout if timeout is None else timeout)
            try:
                chunk = self._sock.recv(65536)
            except TimeoutError:
                if timeout is not None:
                    return None
                raise AgentError(f"no message from the server at {self.address} for {self._timeout:g} s") from None
            except OSError as exc:
                raise AgentError(f"server at {self.address} closed the connection ({exc.strerror or exc})") from None
            if not chunk:
                raise ConnectionClosed(f"server at {self.address} closed the connection")
            self._pending.extend(self._decoder.feed(chunk))
        return self._pending.pop(0)

    def close(self) -> None:
        try:
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._sock.close()


class ConnectionClosed(AgentError):
    """The server closed the connection (an orderly EOF)."""
