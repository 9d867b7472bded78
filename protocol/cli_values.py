"""Command-line values the project's programs (``agent``, ``server_stub``, ``optimizer``) check
the same way: ports, finite and positive numbers, rates. Each error names what is wrong and
argparse adds the flag. Kept here because ``protocol`` is the one package all three import."""

from __future__ import annotations

import argparse
import math
from typing import TypeVar

T = TypeVar("T")


def checked(value: T, ok: bool, problem: str) -> T:
    """``value`` if ``ok``, else argparse's error with ``problem`` (what is wrong, the value)."""
    if not ok:
        raise argparse.ArgumentTypeError(problem)
    return value


def number(text: str) -> float:
    """A finite number (``nan`` and ``inf`` refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    return checked(value, math.isfinite(value), f"must be finite, got {text}")


def whole(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None


def positive_float(text: str) -> float:
    value = number(text)
    return checked(value, value > 0, f"must be > 0, got {text}")


def non_negative(text: str) -> float:
    value = number(text)
    return checked(value, value >= 0, f"must be >= 0, got {text}")


def probability(text: str) -> float:
    value = number(text)
    return checked(value, 0.0 <= value <= 1.0, f"must be a rate within [0, 1], got {text}")


def positive_int(text: str) -> int:
    value = whole(text)
    return checked(value, value >= 1, f"must be >= 1, got {value}")


def count(text: str) -> int:
    """A whole number >= 0 (0 usually turns something off)."""
    value = whole(text)
    return checked(value, value >= 0, f"must be >= 0, got {value}")


def port(text: str) -> int:
    """A TCP port to connect to, 1-65535."""
    value = whole(text)
    return checked(value, 1 <= value <= 65535, f"port must be 1-65535, got {value}")


def listening_port(text: str) -> int:
    """A TCP port to listen on, 0-65535 (0: any free port, the system picks)."""
    value = whole(text)
    return checked(value, 0 <= value <= 65535, f"port must be 0-65535 (0 = any free port), got {value}")
