"""Numbers as command text carries them: no exponent (the server reads plain decimals)."""

from __future__ import annotations

import math
from decimal import Decimal


def number_text(value: float) -> str:
    """Shortest decimal text that reads back as ``value``, without exponent: ``-1.0 -> "-1"``,
    ``0.4 -> "0.4"``, ``1e-07 -> "0.0000001"``. Raises ``ValueError`` on nan or infinity."""
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"not a finite number: {value!r}")
    # repr() is Python's shortest round-trip text; Decimal re-prints it without an exponent.
    text = format(Decimal(repr(number)), "f")
    if text.endswith(".0"):
        text = text[:-2]
    return "0" if text == "-0" else text


def typed_number_text(value: float) -> str:
    """Like ``number_text`` but a float keeps a decimal point (``-3.0``) and an int stays an int
    (``90``): the form of the captured trainer commands (``monitor_commands_sent.txt``)."""
    text = number_text(value)
    if isinstance(value, float) and "." not in text:
        text += ".0"
    return text
