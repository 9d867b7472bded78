"""Rows of numbers printed as C's ``%g`` prints them, compiled: the monitor stream's ``SLT`` text.

A walking robot moves every body part between two monitor updates, so each delta prints 16
numbers for each of ~23 transforms; ``%``-formatting them costs more than the rest of the delta.
The kernel writes the same characters: 6 significant digits, fixed notation for exponents -4 ... 5
and ``d.ddddde+XX`` otherwise, trailing zeros and a bare point dropped, ``-0`` for negative zero.

Rounding to 6 digits must match C's, which rounds the exact binary value half to even. The
kernel scales by an exact power of ten (one rounding, ~1e-10 of a unit in the 6th digit), so its
rounding can only differ when the scaled value lies within that of a rounding boundary; rows with
a number that close to one (or not finite, or outside about 1e-17 ... 1e27, where the powers of
ten stop being exact) are printed by Python instead.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_POW10 = np.array([10.0**k for k in range(23)])
#: scaled values this close to a rounding boundary go to Python (the kernel's error is ~1e-10)
_MARGIN = 1e-7
_MAX_CHARS = 13  # "-1.23457e-17" and a separator


@njit(cache=True)
def _put_g(value: float, buf: np.ndarray, pos: int, pow10: np.ndarray) -> int:
    """Write ``%g`` of ``value`` at ``pos``; the position after it, or -1 to leave it to Python."""
    if not math.isfinite(value):
        return -1
    if value == 0.0:
        if math.copysign(1.0, value) < 0.0:
            buf[pos] = 45  # '-'
            pos += 1
        buf[pos] = 48  # '0'
        return pos + 1
    a = abs(value)
    # decimal exponent from the binary one (log10(2) = 0.30103); the loop fixes it by one
    exponent = int(math.floor((math.frexp(a)[1] - 1) * 0.30102999566398120))
    scaled = 0.0
    for _ in range(3):  # the estimate may be off by one
        k = 5 - exponent
        if abs(k) > 22:
            return -1
        scaled = a * pow10[k] if k >= 0 else a / pow10[-k]
        if abs(scaled - 99999.5) < _MARGIN or abs(scaled - 999999.5) < _MARGIN:
            return -1
        if scaled < 99999.5:
            exponent -= 1
        elif scaled >= 999999.5:
            exponent += 1
        else:
            break
    else:
        return -1
    whole = math.floor(scaled)
    fraction = scaled - whole
    if abs(fraction - 0.5) < _MARGIN:
        return -1
    n = int(whole) + (1 if fraction > 0.5 else 0)  # the 6 digits, 100000 ... 999999
    digits = (n // 100000, n // 10000 % 10, n // 1000 % 10, n // 100 % 10, n // 10 % 10, n % 10)
    used = 6
    while used > 1 and digits[used - 1] == 0:
        used -= 1
    if value < 0.0:
        buf[pos] = 45
        pos += 1
    if -4 <= exponent < 6:
        if exponent >= 0:
            for i in range(exponent + 1):
                buf[pos] = 48 + digits[i]
                pos += 1
            first_decimal = exponent + 1
        else:
            buf[pos] = 48
            pos += 1
            first_decimal = 0
        if used > first_decimal:
            buf[pos] = 46  # '.'
            pos += 1
            for _ in range(-exponent - 1):
                buf[pos] = 48
                pos += 1
            for i in range(first_decimal, used):
                buf[pos] = 48 + digits[i]
                pos += 1
        return pos
    buf[pos] = 48 + digits[0]
    pos += 1
    if used > 1:
        buf[pos] = 46
        pos += 1
        for i in range(1, used):
            buf[pos] = 48 + digits[i]
            pos += 1
    buf[pos] = 101  # 'e'
    buf[pos + 1] = 45 if exponent < 0 else 43  # '-' / '+'
    pos += 2
    e = abs(exponent)  # two digits: exponents past +-22 went to Python above
    buf[pos] = 48 + e // 10
    buf[pos + 1] = 48 + e % 10
    return pos + 2


@njit(cache=True)
def format_rows(values: np.ndarray, pow10: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All rows, numbers separated by one space, back to back in one buffer; ``ends[i]`` is where
    row i stops, ``by_python[i]`` marks a row the kernel could not print exactly (left empty)."""
    rows, columns = values.shape
    buf = np.empty(rows * columns * _MAX_CHARS, np.uint8)
    ends = np.empty(rows, np.int64)
    by_python = np.zeros(rows, np.bool_)
    pos = 0
    for r in range(rows):
        start = pos
        for c in range(columns):
            if c > 0:
                buf[pos] = 32
                pos += 1
            pos = _put_g(values[r, c], buf, pos, pow10)
            if pos < 0:
                by_python[r] = True
                pos = start
                break
        ends[r] = pos
    return buf[:pos], ends, by_python


def g_rows(values: np.ndarray) -> list[str]:
    """``' '.join('%g' % v for v in row)`` for each row of a 2-D array, the same text."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    buf, ends, by_python = format_rows(values, _POW10)
    text = buf.tobytes().decode("ascii")
    rows, start = [], 0
    for end in ends.tolist():
        rows.append(text[start:end])
        start = end
    if by_python.any():
        template = " ".join(["%g"] * values.shape[1])
        for r in np.flatnonzero(by_python).tolist():
            rows[r] = template % tuple(values[r].tolist())
    return rows


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the kernel before the first cycle needs it."""
    g_rows(np.zeros((1, 1)))
