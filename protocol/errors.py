"""Errors raised while reading the wire format.

One exception type for every malformed input, so a server can drop a bad message from one agent
(and an agent a bad message from a server) without catching unrelated bugs: ``ProtocolError`` is a
``ValueError`` that says where the input went wrong and what the reader wanted there.
"""

from __future__ import annotations

#: Most characters of offending input an error message quotes: enough to recognise it, never a
#: 900 KB atom echoed into a log line.
QUOTE_LIMIT = 200


def excerpt(text: str | bytes, limit: int = QUOTE_LIMIT) -> str:
    """``text`` fit for one log line: at most ``limit`` characters of it, every control or
    non-ASCII character escaped (``\\x1b``), and how much was cut said at the end. Input comes
    from untrusted clients, so a raw escape sequence or newline must never reach a terminal or
    split a log line."""
    if isinstance(text, bytes):
        head = text[:limit].decode("latin-1")
    else:
        head = text[:limit]
    shown = head.encode("ascii", "backslashreplace").decode("ascii")
    shown = "".join(c if " " <= c <= "~" else f"\\x{ord(c):02x}" for c in shown)
    if len(text) > limit:
        shown += f"...[{len(text) - limit} more]"
    return shown


class ProtocolError(ValueError):
    """Malformed input: ``position`` is the character/byte offset (None if unknown), ``expected``
    says what the reader wanted there, ``found`` (optional) what it saw instead."""

    def __init__(self, position: int | None, expected: str, found: str | None = None) -> None:
        self.position = position
        self.expected = expected
        self.found = found
        where = "at an unknown position" if position is None else f"at position {position}"
        text = f"{where}: expected {expected}"
        if found is not None:
            text += f", found '{excerpt(found)}'"
        super().__init__(text)


class FrameTooLarge(ProtocolError):
    """A length prefix announced more bytes than the receiver accepts (checked before buffering)."""
