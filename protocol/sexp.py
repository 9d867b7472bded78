"""A small generic S-expression reader.

Used where messages are short or rare (agent commands and trainer commands on the server side,
the validating slow path of the perception parser, tests). Hot paths (perceptions, monitor
deltas) use specialised readers instead, because building a tree per message is slow at 50 Hz.
"""

from __future__ import annotations

import re

from protocol.errors import ProtocolError

#: Deepest nesting accepted. Real messages nest at most 6 deep (the monitor's scene graph, fixtures
#: ``monitor_messages.txt``); without a cap, 1,000 parentheses built a list that ``repr`` and
#: ``str`` (an error message, a ``say``) cannot walk without a ``RecursionError``, which no
#: caller expects from malformed input.
MAX_DEPTH = 64

#: Every non-blank character belongs to a token, so ``finditer`` skips only whitespace.
_TOKEN = re.compile(r"[()]|[^\s()]+")


class SExp(list):
    """A parsed list that remembers where it came from.

    Behaves as a plain ``list`` (compares equal to one); ``start``/``end`` delimit its text
    (``text[start:end]`` includes both parentheses) and ``positions[i]`` is where element ``i`` starts,
    so callers can report errors by position.
    """

    __slots__ = ("start", "end", "positions")

    def __init__(self, start: int) -> None:
        super().__init__()
        self.start = start
        self.end = start
        self.positions: list[int] = []


def decode_ascii(text: str | bytes) -> str:
    """Bytes to text; the protocol is ASCII, so any other byte is malformed input."""
    if isinstance(text, str):
        return text
    try:
        return text.decode("ascii")
    except UnicodeDecodeError as exc:
        raise ProtocolError(exc.start, "an ASCII character", repr(text[exc.start : exc.start + 1])) from None


def parse_sexp(text: str | bytes, max_depth: int = MAX_DEPTH) -> list:
    """Read a sequence of top-level expressions.

    Grammar read::

        message := expr*
        expr    := '(' (atom | expr)* ')'
        atom    := any run of characters other than whitespace and parentheses

    Returns one ``SExp`` (a list of ``str`` atoms and nested lists) per top-level expression.
    Raises ``ProtocolError`` naming the position on an unmatched ``)``, an atom outside any
    expression, text that ends before every ``(`` is closed (a truncated message), or a ``(``
    nested more than ``max_depth`` deep, so that what is returned can always be walked by
    recursive code.
    """
    text = decode_ascii(text)
    top = SExp(0)
    current = top
    stack: list[SExp] = []
    for match in _TOKEN.finditer(text):
        token = match.group()
        pos = match.start()
        if token == "(":
            if len(stack) >= max_depth:
                raise ProtocolError(pos, f"at most {max_depth} nested parentheses", "(")
            node = SExp(pos)
            current.append(node)
            current.positions.append(pos)
            stack.append(current)
            current = node
        elif token == ")":
            if not stack:
                raise ProtocolError(pos, "'(' (this ')' closes nothing)", ")")
            current.end = pos + 1
            current = stack.pop()
        else:
            if not stack:
                raise ProtocolError(pos, "'(' (atoms must be inside an expression)", token)
            current.append(token)
            current.positions.append(pos)
    if stack:
        raise ProtocolError(len(text), f"')' closing the '(' at position {current.start}", "end of text")
    return top
