"""Errors raised while reading the wire format.

One exception type for every malformed input, so a server can drop a bad message from one agent
(and an agent a bad message from a server) without catching unrelated bugs: ``ProtocolError`` is a
``ValueError`` that says where the input went wrong and what the reader wanted there.
"""
from __future__ import annotations


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
            text += f", found {found!r}"
        super().__init__(text)


class FrameTooLarge(ProtocolError):
    """A length prefix announced more bytes than the receiver accepts (checked before buffering)."""
