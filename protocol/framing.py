"""Length-prefixed framing: every message on both ports, in both directions, is a 4-byte
big-endian unsigned length followed by that many bytes (docs/robot_and_server.md section 6).

The decoder is incremental because TCP delivers arbitrary chunks, and it checks every prefix
against a cap before buffering the body, so a hostile or corrupt prefix (up to 4 GiB) costs nothing.
"""

from __future__ import annotations

import struct

from protocol.errors import FrameTooLarge

#: Largest frame body accepted by default. The biggest real message seen is a full monitor scene
#: of about 50 KB (fixtures ``monitor_messages.txt``), so 1 MiB leaves a wide margin.
MAX_FRAME_SIZE: int = 1 << 20

_PREFIX = struct.Struct(">I")
_PREFIX_LIMIT = (1 << 32) - 1


def encode_frame(payload: str | bytes) -> bytes:
    """Prefix ``payload`` with its length. Text must be ASCII: the server reads bytes as ASCII."""
    data = payload.encode("ascii") if isinstance(payload, str) else bytes(payload)
    if len(data) > _PREFIX_LIMIT:
        raise FrameTooLarge(None, f"a payload of at most {_PREFIX_LIMIT} bytes", f"{len(data)} bytes")
    return _PREFIX.pack(len(data)) + data


class FrameDecoder:
    """Turns a byte stream into frame bodies.

    Grammar read: ``<uint32 big-endian n> <n bytes>``, repeated.
    """

    def __init__(self, max_size: int = MAX_FRAME_SIZE) -> None:
        self.max_size = max_size
        self._buffer = bytearray()
        #: Stream offset of ``_buffer[0]``, so an error can name where the bad prefix sits.
        self._offset = 0

    def feed(self, data: bytes) -> list[bytes]:
        """Add a chunk; return every frame it completes, in order.

        Raises ``FrameTooLarge`` as soon as a prefix over ``max_size`` is seen, before any of its
        body is buffered. The bad prefix stays in place, so the decoder keeps refusing: the stream
        cannot be resynchronised and the caller should close the connection.
        """
        buf = self._buffer
        buf += data
        frames: list[bytes] = []
        pos = 0
        end = len(buf)
        while end - pos >= 4:
            (size,) = _PREFIX.unpack_from(buf, pos)
            if size > self.max_size:
                self._consume(pos)
                raise FrameTooLarge(self._offset, f"a frame length of at most {self.max_size} bytes", str(size))
            if end - pos - 4 < size:
                break
            frames.append(bytes(buf[pos + 4 : pos + 4 + size]))
            pos += 4 + size
        self._consume(pos)
        return frames

    def _consume(self, count: int) -> None:
        # One deletion per feed keeps many small frames in one chunk linear, not quadratic.
        if count:
            del self._buffer[:count]
            self._offset += count

    @property
    def buffered(self) -> int:
        """Bytes held waiting for the rest of a frame."""
        return len(self._buffer)
