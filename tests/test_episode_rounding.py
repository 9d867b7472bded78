"""``optimizer.episode.rounding``: the embedded episodes' rounding must give ``round``'s floats, bit
for bit, or an episode without text would walk differently from one over the wire."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from optimizer.episode.inprocess import _printed
from optimizer.episode.rounding import rounded, rounded_array, warm_up


@pytest.fixture(autouse=True, scope="module")
def compiled() -> None:
    """The kernel compiled (or loaded) before hypothesis times its first example."""
    warm_up()


def same_float(a: float, b: float) -> bool:
    """Equal bits: -0.0 is not 0.0 here, and NaN is NaN."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


def assert_as_round(values: list[float], digits: int) -> None:
    got = rounded(values, digits)
    assert len(got) == len(values)
    for value, mine in zip(values, got):
        assert same_float(mine, round(value, digits)), (value, digits, mine, round(value, digits))


@given(st.lists(st.floats(), max_size=30), st.sampled_from([2, 4]))
def test_rounded_is_round_for_any_float(values: list[float], digits: int) -> None:
    assert_as_round(values, digits)


@given(st.lists(st.floats(min_value=-400.0, max_value=400.0), max_size=30), st.sampled_from([2, 4]))
def test_rounded_is_round_for_angles_and_speeds(values: list[float], digits: int) -> None:
    assert_as_round(values, digits)


@given(st.integers(min_value=-(10**7), max_value=10**7), st.sampled_from([2, 4]), st.integers(-3, 3))
def test_rounded_is_round_next_to_a_half(whole: int, digits: int, ulps: int) -> None:
    """Halfway between two printed numbers, and a few floats either side: where a float product
    alone would round the wrong way."""
    value = (whole + 0.5) / 10**digits
    for _ in range(abs(ulps)):
        value = math.nextafter(value, math.copysign(math.inf, ulps))
    assert_as_round([value, -value], digits)


def test_rounded_examples() -> None:
    values = [0.125, 0.375, 1.005, 2.675, -2.675, -0.001, -0.0, 0.0, 1e-9, -1e-9, 89.995, 1e300, math.inf]
    assert_as_round(values, 2)
    assert_as_round(values, 4)
    assert rounded([-0.001, 0.125, 2.675], 2) == [-0.0, 0.12, 2.67]
    assert math.copysign(1.0, rounded([-0.001], 2)[0]) == -1.0
    for digits in (-2, 0, 1, 23):
        assert_as_round([1234.5678, -0.5, 2.5, 1e-30], digits)


@given(st.lists(st.floats(), max_size=30), st.sampled_from([2, 4]))
def test_rounded_array_is_round_of_each_element(values: list[float], digits: int) -> None:
    """The array form (the in-process episode's velocity commands) gives the same floats as ``round``."""
    got = rounded_array(np.array(values, dtype=float), digits)
    assert got.shape == (len(values),)
    for value, mine in zip(values, got.tolist()):
        assert same_float(mine, round(value, digits)), (value, digits, mine)


@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=12))
def test_the_monitor_views_numbers_are_printed_with_g_as_one_at_a_time(values: list[float]) -> None:
    """The in-process episodes' monitor view prints its numbers with one ``%g`` format for them all;
    each must come back as ``float(f"{v:g}")`` does alone, to the bit."""
    got = _printed(values)
    assert len(got) == len(values)
    assert all(same_float(a, float(f"{v:g}")) for a, v in zip(got, values, strict=True))
