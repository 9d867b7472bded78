"""The generic S-expression reader: structure, positions in errors, truncation."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from protocol.errors import ProtocolError
from protocol.sexp import parse_sexp

atoms = st.text(alphabet="abcXYZ019.-_/", min_size=1, max_size=6)
trees = st.recursive(atoms, lambda kids: st.lists(kids, max_size=4), max_leaves=20)
expressions = st.lists(st.lists(trees, max_size=4), min_size=1, max_size=4)


def write(tree: str | list) -> str:
    return tree if isinstance(tree, str) else "(" + " ".join(map(write, tree)) + ")"


def test_reads_commands_into_nested_lists() -> None:
    assert parse_sexp("(init (unum 1)(teamname Probe))(syn)") == [
        ["init", ["unum", "1"], ["teamname", "Probe"]],
        ["syn"],
    ]
    assert parse_sexp(b"  ( a  ( b ) )\n") == [["a", ["b"]]]
    assert parse_sexp("") == []


def test_positions_are_kept_for_error_reports() -> None:
    (expr,) = parse_sexp("(HJ (n hj1) (ax 1.5))")
    assert expr.start == 0 and expr.end == 21
    assert expr.positions == [1, 4, 12]
    assert expr[2].positions == [13, 16]


@pytest.mark.parametrize(
    ("text", "position", "expected"),
    [
        ("(a (b)", 6, "')' closing the '(' at position 0"),
        ("(a))", 3, "'(' (this ')' closes nothing)"),
        ("(a) b", 4, "'(' (atoms must be inside an expression)"),
        (b"(a \xff)", 3, "an ASCII character"),
    ],
)
def test_malformed_text_names_position_and_expectation(text: str | bytes, position: int, expected: str) -> None:
    with pytest.raises(ProtocolError) as info:
        parse_sexp(text)
    assert info.value.position == position
    assert info.value.expected == expected
    assert str(position) in str(info.value) and expected in str(info.value)


@given(expressions)
def test_round_trip_of_random_trees(exprs: list[list]) -> None:
    assert parse_sexp("".join(map(write, exprs))) == exprs


@given(expressions, st.data())
def test_cutting_inside_an_expression_always_raises_protocol_error(exprs: list[list], data: st.DataObject) -> None:
    text = "".join(map(write, exprs))
    first = write(exprs[0])
    cut = data.draw(st.integers(min_value=1, max_value=len(first) - 1))
    with pytest.raises(ProtocolError):
        parse_sexp(text[:cut])
