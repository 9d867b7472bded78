"""Reading what an agent sends: effector messages such as ``(lle3 0.5)(syn)``, ``(beam -1 0 0)``.

Most messages are a run of flat ``(name value)`` pairs, read with one regular expression; anything
else (``scene``, ``init``, ``say``...) goes through the general S-expression reader, which reports
malformed input with its position.
"""

from __future__ import annotations

import re

from protocol.sexp import parse_sexp

#: A message made only of flat, one-argument commands: ``(<name> <atom>)`` repeated.
_FLAT_MESSAGE = re.compile(rb"(?:\s*\([A-Za-z]\w* [^()\s]+\)|\s*\(syn\))*\s*")
_FLAT_COMMAND = re.compile(rb"\(([A-Za-z]\w*)(?: ([^()\s]+))?\)")


def flat_commands(frame: bytes) -> list[tuple[bytes, bytes]] | None:
    """The ``(name, value)`` pairs of a message made only of one-argument commands and ``(syn)``
    (whose value is ``b""``), undecoded: every cycle's effector message takes this path, so the
    server reads it without building lists or strings. None for any other message, and for one
    that is not ASCII (the general reader reports where)."""
    if frame.isascii() and _FLAT_MESSAGE.fullmatch(frame):
        return _FLAT_COMMAND.findall(frame)
    return None


def read_commands(frame: bytes) -> list[list]:
    """Commands as ``[name, arg, ...]`` lists (sub-expressions as nested lists)."""
    pairs = flat_commands(frame)
    if pairs is not None:
        return [[name.decode(), value.decode()] if value else [name.decode()] for name, value in pairs]
    return [expr if isinstance(expr, list) else [expr] for expr in parse_sexp(frame)]


def has_syn(frame: bytes) -> bool:
    """Cheap check done as a frame arrives: the cycle may go on before the frame is parsed."""
    return b"(syn)" in frame
