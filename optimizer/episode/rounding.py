"""Numbers as the wire would carry them, for the embedded episodes: ``round(v, digits)``, bit for
bit, i.e. what ``%.{digits}f`` prints and the reader parses back.

An in-process episode (``optimizer.episode.inprocess``) rounds every joint angle, the gyro and the
accelerometer (2 decimals) and every velocity command (4) each cycle, as the text would: about 50
numbers a cycle (the perception's in one compiled pass with the joints' conversion to degrees,
``perception_numbers``). A Python loop (with ``round`` only near halves) took about 11 us for a cycle's
22 angles; this compiled loop, called from Python, about 4.5 us, with the same floats.

``round`` returns the float nearest to n / 10**digits, n the whole number nearest to the exact
``v * 10**digits`` (ties to even). Below 2**20 the float product is within 2**-33 of the exact
one, so its nearest whole number (``rint``, ties to even) is n unless it lies within
``_HALF_DOUBT`` of a half; and n / 10**digits, both exact, is correctly rounded by the division.
Numbers in doubt, larger or not finite go to ``round`` itself.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numba import njit

#: Below this magnitude (2**20) a float product ``v * 10**digits`` lies within 2**-33 of the exact
#: one, far closer than ``_HALF_DOUBT``.
_PRODUCT_EXACT_BELOW = float(2**20)
#: How near a half the scaled value may come before the float product is not trusted.
_HALF_DOUBT = 1e-6
#: ``np.degrees``' factor: it multiplies by this double, 180 / pi
_DEGREES_PER_RADIAN = 180.0 / np.pi


@njit(cache=True)
def _trusted(v: float, scale: float) -> tuple[float, bool]:
    """``v`` rounded to ``1 / scale`` and True, if the float product can round it; else False."""
    scaled = v * scale
    if -_PRODUCT_EXACT_BELOW < scaled < _PRODUCT_EXACT_BELOW:
        n = np.rint(scaled)
        if abs(abs(scaled - n) - 0.5) > _HALF_DOUBT:
            # a zero keeps the sign of ``v``: -0.001 rounds to -0.0, as ``round`` gives it
            return (n / scale if n != 0.0 else v * 0.0), True
    return v, False


@njit(cache=True)
def _round_trusted(values: np.ndarray, scale: float, out: np.ndarray, doubtful: np.ndarray) -> int:
    """``out[i]`` = ``values[i]`` rounded, for each value the float product can round; the others'
    indices go to ``doubtful``, whose count is returned."""
    count = 0
    for i in range(values.shape[0]):
        rounded, trusted = _trusted(values[i], scale)
        if trusted:
            out[i] = rounded
        else:
            doubtful[count] = i
            count += 1
    return count


@njit(cache=True)
def _perception_trusted(sensed: np.ndarray, radians: np.ndarray, out: np.ndarray, doubtful: np.ndarray) -> int:
    """``out[r]``: ``sensed[r]`` and ``radians[r]`` in degrees (``np.degrees``' product), each
    rounded to 2 decimals where the float product can round it, else left as it is and its flat
    index put in ``doubtful``, whose count is returned."""
    count = 0
    first = sensed.shape[1]
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            v = sensed[r, c] if c < first else radians[r, c - first] * _DEGREES_PER_RADIAN
            rounded, trusted = _trusted(v, 100.0)
            out[r, c] = rounded
            if not trusted:
                doubtful[count] = r * out.shape[1] + c
                count += 1
    return count


def perception_numbers(sensed: np.ndarray, radians: np.ndarray) -> np.ndarray:
    """A row per robot of its perception's numbers as printed (``%.2f``): ``sensed[r]`` (its
    clocks, gyro, accelerometer: any numbers) and then ``np.degrees(radians[r])`` (its joints),
    each ``round(v, 2)``; one compiled pass where ``rounded_array`` of a row put together took
    three times as long."""
    out = np.empty((sensed.shape[0], sensed.shape[1] + radians.shape[1]))
    doubtful = np.empty(out.size, dtype=np.int64)
    count = _perception_trusted(sensed, radians, out, doubtful)
    if count:  # rare: a number next to a half, large or not finite
        flat = out.reshape(-1)
        for i in doubtful[:count].tolist():
            flat[i] = round(float(flat[i]), 2)
    return out


def rounded_array(values: np.ndarray, digits: int) -> np.ndarray:
    """``[round(v, digits) for v in values]`` of a float64 array, as an array."""
    if not 0 <= digits <= 22:  # beyond, 10**digits is no exact float
        return np.array([round(v, digits) for v in values.tolist()], dtype=float)
    out = np.empty(values.shape[0])
    doubtful = np.empty(values.shape[0], dtype=np.int64)
    count = _round_trusted(values, 10.0**digits, out, doubtful)
    if count:  # rare: a number next to a half, large or not finite
        for i in doubtful[:count].tolist():
            out[i] = round(float(values[i]), digits)
    return out


def rounded(values: Iterable[float], digits: int) -> list[float]:
    """``[round(v, digits) for v in values]``, bit for bit."""
    return rounded_array(np.fromiter(values, dtype=float), digits).tolist()


def warm_up() -> None:
    """Compile (or load from numba's disk cache) before the first episode needs it."""
    rounded([0.0], 2)
    perception_numbers(np.zeros((1, 8)), np.zeros((1, 22)))
