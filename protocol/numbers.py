"""Numbers as text carries them: command text with no exponent (the server reads plain decimals),
and numbers rounded as ``%.2f`` prints them."""

from __future__ import annotations

import math
from collections.abc import Iterable
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


#: Below this magnitude (2**20) a float product ``v * 10**digits`` lies within 2**-33 of the exact
#: one, far closer than ``_HALF_DOUBT``.
_PRODUCT_EXACT_BELOW = float(2**20)
#: How near a half the scaled value may come before the float product is not trusted.
_HALF_DOUBT = 1e-6


def rounded(values: Iterable[float], digits: int) -> list[float]:
    """``[round(v, digits) for v in values]``, bit for bit, in 60% of the time: the numbers a
    perception or a command carries after ``%.{digits}f``, for the embedded episodes, which
    round every joint's angle and command every cycle as the wire would.

    ``round`` returns the float nearest to n / 10**digits, n the whole number nearest to the
    exact ``v * 10**digits`` (ties to even). Below 2**20 the float product is within 2**-33 of
    the exact one, so its nearest whole number is n unless it lies within ``_HALF_DOUBT`` of a
    half; and n / 10**digits, both exact, is correctly rounded by the division. Numbers in doubt,
    larger or not finite go to ``round`` itself."""
    if not 0 <= digits <= 22:  # beyond, 10**digits is no exact float
        return [round(v, digits) for v in values]
    scale = 10.0**digits
    out = []
    for v in values:
        scaled = v * scale
        if -_PRODUCT_EXACT_BELOW < scaled < _PRODUCT_EXACT_BELOW:
            n = round(scaled)
            if abs(abs(scaled - n) - 0.5) > _HALF_DOUBT:
                out.append(n / scale if n else v * 0.0)  # -0.001 rounds to -0.0
                continue
        out.append(round(v, digits))
    return out
