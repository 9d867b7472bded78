"""Perception parser: every real message, the fast paths against the validating slow path,
round trips of generated messages, and precise errors on malformed input."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from protocol.errors import ProtocolError
from protocol.nao import JOINTS, PLAY_MODES
from protocol.perception import (
    ForceResistance,
    GameState,
    Hear,
    Perception,
    Polar,
    SeenPlayer,
    Vision,
    _parse_slow,
    parse_perception,
)

PERCEPTION_FILES = ("agent_perceptions_*.txt", "walk_calibration/run*_perceptions.txt")


def fixture_messages(folder: Path) -> list[str]:
    files = [f for pattern in PERCEPTION_FILES for f in sorted(folder.glob(pattern))]
    assert len(files) == 7, files
    return [line for f in files for line in f.read_text().splitlines() if line]


@pytest.fixture(scope="session")
def messages(fixtures_dir: Path) -> list[str]:
    return fixture_messages(fixtures_dir)


@pytest.fixture(scope="session")
def first20(fixtures_dir: Path) -> list[str]:
    return (fixtures_dir / "agent_perceptions_first20.txt").read_text().splitlines()


def test_every_fixture_message_parses_and_fast_paths_agree_with_the_slow_path(messages: list[str]) -> None:
    assert len(messages) == 2896
    seen_feet = set()
    for text in messages:
        p = parse_perception(text)
        assert p == _parse_slow(text)
        assert list(p.joints) == [j.perceptor for j in JOINTS]
        assert p.gyro is not None and p.acc is not None and p.game.play_mode in PLAY_MODES
        assert p.unknown == [] and p.hear == []
        assert (p.vision is not None) == ("(See " in text)
        assert set(p.frp) == set(re.findall(r"\(FRP \(n (\w+)\)", text))
        seen_feet.update(p.frp)
    assert seen_feet == {"lf", "rf"}


def test_values_of_real_messages(first20: list[str]) -> None:
    p1, _, p3, p4 = map(parse_perception, first20[:4])
    assert p1.time == 552.90 and p1.game == GameState(None, None, 0, 0, 0.0, "BeforeKickOff")
    assert p3.game.unum == 1 and p3.game.team == "left"  # first GS after init only
    assert p4.game.unum is None and p4.game.team is None
    assert p3.acc == (-0.0, -0.0, 29.42)  # the spike right after the beam
    assert p1.vision is not None and p1.vision.mypos == (-0.0, -1.0, 1.64) and p1.vision.myorien == 90.0
    assert p1.vision.objects["F1L"] == Polar(18.68, 53.47, -4.95)
    assert p1.vision.lines[0] == (Polar(1.90, -0.23, -59.76), Polar(11.13, 0.05, -8.40))
    assert p4.vision is not None and p4.vision.players == [
        SeenPlayer("Probe", 1, {"rlowerarm": Polar(0.19, -35.67, -21.46), "llowerarm": Polar(0.18, 32.90, -22.08)})
    ]
    assert p4.vision.ballpos == (0.0, 0.0, 0.04)
    assert p1.joints["hj1"] == -0.0 and len(p1.joints) == 22


def test_unknown_perceptors_and_hear_are_kept(first20: list[str]) -> None:
    text = first20[3]
    extended = text.replace("(HJ (n raj1)", "(TCH (n bumper) (val 1))(hear 12.30 -45.5 hello)(HJ (n raj1)", 1)
    extended = extended.replace("(L (pol", "(XYZ 1 2) (L (pol", 1)
    p = parse_perception(extended)
    base = parse_perception(text)
    assert p.unknown == ["(XYZ 1 2)", "(TCH (n bumper) (val 1))"]  # message order
    assert p.hear == [Hear(12.3, None, "-45.5", "hello")]
    assert p.joints == base.joints and p.vision == base.vision and p.game == base.game
    newer = parse_perception(text + "(hear Probe 12.30 self hi!)")
    assert newer.hear == [Hear(12.3, "Probe", "self", "hi!")]


def test_other_spacing_and_order_give_the_same_perception(first20: list[str]) -> None:
    text = first20[3]
    spaced = text.replace(") (", ")\n  (").replace(")(", ") (")
    assert parse_perception(spaced) == parse_perception(text)
    parts = re.findall(r"\(HJ \(n \w+\) \(ax [-\d.]+\)\)", text)
    shuffled = text.replace(parts[0], "").replace(parts[5], parts[5] + parts[0])
    assert parse_perception(shuffled).joints == parse_perception(text).joints


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda t: t.replace("(ax 0.00))(HJ (n raj2)", "(ax abc))(HJ (n raj2)"), "a number (HJ ax)"),
        (lambda t: t.replace("(t 0.00)", "(t zero)"), "a number (GS t)"),
        (lambda t: t.replace("(pol 18.68 53.47 -4.95)", "(pol 18.68 nan -4.95)"), "a number (F1L)"),
        (lambda t: t.replace("(rt 0.00 -0.00 0.00)", "(rt 0.00 -0.00)"), "a number (GYR rt)"),
        (lambda t: t.replace("(n hj2) (ax -0.00)", "(n hj2)"), "(ax <deg>) in HJ"),
    ],
)
def test_a_wrong_field_names_its_position_and_what_was_expected(first20: list[str], edit, expected: str) -> None:
    bad = edit(first20[0])
    assert bad != first20[0]
    with pytest.raises(ProtocolError) as info:
        _ = parse_perception(bad).vision  # a See's numbers are checked on first use
    assert info.value.expected == expected
    assert expected in str(info.value) and str(info.value.position) in str(info.value)
    assert info.value.position is not None and 0 <= info.value.position <= len(bad)
    word = {"a number (HJ ax)": "abc", "a number (GS t)": "zero", "a number (F1L)": "nan"}.get(expected)
    if word is not None:
        assert bad[info.value.position :].startswith(word)


def test_a_see_is_read_on_first_use(first20: list[str]) -> None:
    text = first20[0]
    bad = text.replace("(pol 18.68 53.47 -4.95)", "(pol 18.68 nan -4.95)")
    p = parse_perception(bad)
    assert p.joints == parse_perception(text).joints and p.time == 552.90  # the rest is read at once
    with pytest.raises(ProtocolError, match="F1L"):
        _ = p.vision
    other_form = parse_perception(text.replace("(pol 18.68 53.47 -4.95)", "(pol 1.868e1 +53.47 -4.95)"))
    assert other_form.vision is not None and other_form.vision.objects["F1L"] == Polar(18.68, 53.47, -4.95)
    # the layout is checked at once: an entry of unknown shape inside See goes to the slow path
    odd = parse_perception(text.replace("(L (pol", "(XYZ 1 2) (L (pol", 1))
    assert odd.unknown == ["(XYZ 1 2)"]


def test_unbalanced_truncated_and_empty_messages_raise(first20: list[str]) -> None:
    text = first20[0]
    with pytest.raises(ProtocolError) as info:
        parse_perception(text[:-1])
    assert info.value.position == len(text) - 1 and "')'" in info.value.expected
    with pytest.raises(ProtocolError) as info:
        parse_perception(text + ")")
    assert info.value.position == len(text)
    with pytest.raises(ProtocolError, match="time"):
        parse_perception("")
    with pytest.raises(ProtocolError, match="ASCII"):
        parse_perception(text.encode() + b"\xe9")


@given(st.data())
def test_random_truncation_raises_protocol_error_only(messages: list[str], data: st.DataObject) -> None:
    text = data.draw(st.sampled_from(messages))
    cut = data.draw(st.integers(min_value=0, max_value=len(text) - 1))
    prefix = text[:cut]
    at_boundary = prefix.count("(") == prefix.count(")") and (cut == 0 or prefix.endswith(")"))
    if not at_boundary:
        with pytest.raises(ProtocolError):
            parse_perception(prefix)
        return
    try:  # a cut between perceptors leaves a shorter, well-formed message
        p = parse_perception(prefix)
    except ProtocolError:
        return
    full = parse_perception(text)
    assert list(p.joints.items()) == list(full.joints.items())[: len(p.joints)]


@given(st.binary(max_size=200))
def test_arbitrary_bytes_raise_only_protocol_error(raw: bytes) -> None:
    try:
        parse_perception(raw)
    except ProtocolError:
        pass


# --- round trip of generated messages -------------------------------------------------------

cents = st.integers(min_value=-99999, max_value=99999)


def num(value: int) -> str:
    return f"{value / 100:.2f}"


vec = st.tuples(cents, cents, cents)
pol = st.tuples(st.integers(0, 9999), cents, cents)
names = st.text(alphabet="abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789", min_size=1, max_size=8)


def vtext(v: tuple[int, int, int]) -> str:
    return " ".join(map(num, v))


def vval(v: tuple[int, int, int]) -> tuple[float, float, float]:
    return tuple(float(num(x)) for x in v)  # type: ignore[return-value]


@st.composite
def generated(draw: st.DrawFn) -> tuple[str, Perception]:
    """A message in the server's shape from random values with 2 decimals, and what it means."""
    now = draw(st.integers(0, 10**7))
    unum = draw(st.none() | st.integers(0, 11))
    team = draw(st.none() | st.sampled_from(["left", "right"]))
    sl, sr = draw(st.integers(0, 20)), draw(st.integers(0, 20))
    t, pm = draw(st.integers(0, 60000)), draw(st.sampled_from(PLAY_MODES))
    gyr, acc = draw(vec), draw(vec)
    all_joints = [j.perceptor for j in JOINTS]
    chosen = draw(
        st.just(all_joints)
        | st.lists(st.sampled_from(all_joints), unique=True).map(lambda c: [n for n in all_joints if n in c])
    )
    angles = {n: draw(cents) for n in chosen}
    feet = {f: (draw(vec), draw(vec)) for f in ("rf", "lf") if draw(st.booleans())}
    see = draw(st.booleans())

    text = f"(time (now {num(now)}))(GS"
    text += f" (unum {unum})" if unum is not None else ""
    text += f" (team {team})" if team is not None else ""
    text += f" (sl {sl}) (sr {sr}) (t {num(t)}) (pm {pm}))"
    text += f"(GYR (n torso) (rt {vtext(gyr)}))(ACC (n torso) (a {vtext(acc)}))"
    vision = None
    if see:
        objects = draw(
            st.dictionaries(st.sampled_from(["F1L", "F2L", "F1R", "F2R", "G1L", "G2L", "G1R", "G2R", "B"]), pol)
        )
        lines = draw(st.lists(st.tuples(pol, pol), max_size=6))
        players = draw(
            st.lists(
                st.tuples(
                    names,
                    st.integers(1, 11),
                    st.dictionaries(
                        st.sampled_from(["head", "rlowerarm", "llowerarm", "rfoot", "lfoot"]), pol, min_size=1
                    ),
                ),
                max_size=3,
            )
        )
        mypos, myorien, ballpos = draw(st.none() | vec), draw(st.none() | cents), draw(st.none() | vec)
        items = [f"({k} (pol {vtext(v)}))" for k, v in objects.items()]
        items += [("P", tm, i, parts) for tm, i, parts in players]
        items += [f"(mypos {vtext(mypos)})"] if mypos else []
        items += [f"(myorien {num(myorien)})"] if myorien is not None else []
        items += [f"(ballpos {vtext(ballpos)})"] if ballpos else []
        items += [("L", a, b) for a, b in lines]
        items = draw(st.permutations(items))  # the parser must not depend on the order inside See

        def see_item(item: str | tuple) -> str:
            if isinstance(item, str):
                return item
            if item[0] == "L":
                return f"(L (pol {vtext(item[1])}) (pol {vtext(item[2])}))"
            return (
                f"(P (team {item[1]}) (id {item[2]})"
                + "".join(f" ({k} (pol {vtext(v)}))" for k, v in item[3].items())
                + ")"
            )

        see_text = "(See" + "".join(" " + see_item(i) for i in items) + ")"
        vision = Vision(
            {k: Polar(*vval(v)) for k, v in objects.items()},
            [(Polar(*vval(i[1])), Polar(*vval(i[2]))) for i in items if isinstance(i, tuple) and i[0] == "L"],
            [
                SeenPlayer(i[1], i[2], {k: Polar(*vval(v)) for k, v in i[3].items()})
                for i in items
                if isinstance(i, tuple) and i[0] == "P"
            ],
            vval(mypos) if mypos else None,
            float(num(myorien)) if myorien is not None else None,
            vval(ballpos) if ballpos else None,
        )
    for name in all_joints:
        if name == "rlj6" and "rf" in feet:
            text += f"(FRP (n rf) (c {vtext(feet['rf'][0])}) (f {vtext(feet['rf'][1])}))"
        if name == "llj6" and "lf" in feet:
            text += f"(FRP (n lf) (c {vtext(feet['lf'][0])}) (f {vtext(feet['lf'][1])}))"
        if name in angles:
            text += f"(HJ (n {name}) (ax {num(angles[name])}))"
        if name == "hj2" and see:
            text += see_text
    expected = Perception(
        float(num(now)),
        GameState(unum, team, sl, sr, float(num(t)), pm),
        vval(gyr),
        vval(acc),
        {n: float(num(a)) for n, a in angles.items()},
        {f: ForceResistance(vval(c), vval(force)) for f, (c, force) in sorted(feet.items(), reverse=True)},
        vision,
        [],
        [],
    )
    return text, expected


@given(generated())
def test_round_trip_of_generated_messages(case: tuple[str, Perception]) -> None:
    text, expected = case
    assert parse_perception(text) == expected
    assert _parse_slow(text) == expected
    assert parse_perception(text.encode("ascii")) == expected
