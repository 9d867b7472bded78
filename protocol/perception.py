"""Perceptions (server -> agent): one message per cycle, read into a typed ``Perception``.

Two readers produce the same result. The fast path is a set of compiled regular expressions over
the exact shapes rcssserver3d 0.7.3 prints (docs/robot_and_server.md section 5); it runs only when one regular
expression accounts for the whole message, so nothing is skipped silently. Anything else (other
spacing, another perceptor order, ``hear``, unknown perceptors, malformed text) goes to the slow
path: the generic reader plus a validating walk that keeps unknown perceptors and raises
``ProtocolError`` naming the position and what was expected.

Grammar (one message; perceptors in scene-graph order, section 5)::

    message   := perceptor*
    perceptor := (time (now <t>))
               | (GS [(unum <n>)] [(team <left|right>)] (sl <n>) (sr <n>) (t <t>) (pm <mode>))
               | (GYR (n <name>) (rt <x> <y> <z>))          deg/s, torso frame
               | (ACC (n <name>) (a <x> <y> <z>))           m/s^2, torso frame
               | (HJ (n <name>) (ax <deg>))
               | (FRP (n <lf|rf>) (c <x> <y> <z>) (f <x> <y> <z>))   only while touching
               | (See <seen>*)                              every 3rd cycle
               | (hear [<team>] <t> <self|direction> <message>)
               | (<other> ...)                              kept raw in ``unknown``
    seen      := (<object> (pol <d> <h> <v>))              F1L ... G2R, B
               | (L (pol <d> <h> <v>) (pol <d> <h> <v>))
               | (P (team <name>) (id <n>) (<part> (pol <d> <h> <v>))*)
               | (mypos <x> <y> <z>) | (myorien <deg>) | (ballpos <x> <y> <z>)
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from operator import itemgetter
from typing import NamedTuple

from protocol.errors import ProtocolError
from protocol.nao import HJ_BEFORE_FRP_LF, HJ_BEFORE_FRP_RF, HJ_BEFORE_SEE, HJ_LAST, JOINTS
from protocol.sexp import SExp, decode_ascii, parse_sexp

Vec3 = tuple[float, float, float]


class Polar(NamedTuple):
    """A seen point: distance (m), horizontal and vertical angle (deg) relative to the head."""

    distance: float
    horizontal: float
    vertical: float


@dataclass(slots=True)
class GameState:
    """``GS``: unum and team come only in the first GS after ``init``; None when absent."""

    unum: int | None = None
    team: str | None = None
    score_left: int | None = None
    score_right: int | None = None
    time: float | None = None
    play_mode: str | None = None


@dataclass(slots=True)
class ForceResistance:
    """``FRP``: centre of pressure (m) and total force (N), both in the foot frame."""

    centre: Vec3
    force: Vec3


@dataclass(slots=True)
class SeenPlayer:
    """A ``P`` entry: the body parts of one robot that are in view (possibly the agent's own)."""

    team: str
    id: int
    parts: dict[str, Polar]


@dataclass(slots=True)
class Vision:
    """``See``: flags, goal posts and ball by name, field lines, players, optional ground truth."""

    objects: dict[str, Polar] = field(default_factory=dict)
    lines: list[tuple[Polar, Polar]] = field(default_factory=list)
    players: list[SeenPlayer] = field(default_factory=list)
    mypos: Vec3 | None = None
    myorien: float | None = None
    ballpos: Vec3 | None = None


@dataclass(slots=True)
class Hear:
    """``hear``: ``direction`` is ``'self'`` or the horizontal angle as the server printed it."""

    time: float
    team: str | None
    direction: str
    message: str


@dataclass(slots=True, eq=False)
class Perception:
    """One cycle's message. ``joints`` in degrees by perceptor name; ``frp`` has no key for a foot
    without contact; ``unknown`` holds the raw text of perceptors this reader does not know.

    ``vision`` is read from the message on first use: reading a ``See`` took the fast path 4 to 10
    times as long as the rest of the message, and an agent that only walks never looks at it. Its
    layout (which entries) is checked when the message is parsed, its numbers on first use, which
    raises ``ProtocolError`` for a bad one, naming its place in the message.
    """

    time: float
    game: GameState
    gyro: Vec3 | None
    acc: Vec3 | None
    joints: dict[str, float]
    frp: dict[str, ForceResistance]
    #: the Vision, or (message, start, end) of its unread See
    _vision: Vision | tuple[str, int, int] | None = field(repr=False)
    hear: list[Hear]
    unknown: list[str]

    @property
    def vision(self) -> Vision | None:
        """``See`` (vision cycles only), None in the other cycles."""
        if isinstance(self._vision, tuple):
            self._vision = _read_vision_later(*self._vision)
        return self._vision

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Perception):
            return NotImplemented
        return (
            self.time,
            self.game,
            self.gyro,
            self.acc,
            self.joints,
            self.frp,
            self.vision,
            self.hear,
            self.unknown,
        ) == (
            other.time,
            other.game,
            other.gyro,
            other.acc,
            other.joints,
            other.frp,
            other.vision,
            other.hear,
            other.unknown,
        )


def parse_perception(msg: str | bytes) -> Perception:
    """Read one perception message (grammar in the module docstring).

    Raises ``ProtocolError`` (position, expected) on unbalanced parentheses, a truncated message,
    a word where a number belongs, a known perceptor missing a field, or no ``time`` perceptor.
    """
    text = decode_ascii(msg)
    match = _TYPICAL.fullmatch(text)
    if match is not None:
        return _parse_typical(match)
    match = _KNOWN.fullmatch(text)
    if match is not None:
        return _parse_known(text, match)
    return _parse_slow(text)


# ---------------------------------------------------------------------------------------------
# Fast paths: the server's exact output format. Two compiled expressions, tried in turn:
# ``_TYPICAL`` is the whole message of a type-0 NAO in scene-graph order (section 5) and captures
# every value in one match; ``_KNOWN`` admits the known perceptors in any order after the header
# (other robot types, other servers) and the values are then collected with ``findall``.

_N = r"-?\d+(?:\.\d+)?"
_ATOM = r"[^\s()]+"
_VEC = rf"({_N}) ({_N}) ({_N})"
_POL = rf"\(pol {_VEC}\)"
_POL_NC = rf"\(pol {_N} {_N} {_N}\)"


def _see(number: str, integer: str) -> str:
    """``See`` with the given patterns for numbers. Lines first: they are the most frequent
    entry, and trying them first halves the match time."""
    pol = rf"\(pol {number} {number} {number}\)"
    return (
        rf"\(See(?: \((?:L {pol} {pol}|[A-Z]\w* {pol}"
        rf"|P \(team {_ATOM}\) \(id {integer}\)(?: \([a-z]\w* {pol}\))*"
        rf"|mypos {number} {number} {number}|myorien {number}|ballpos {number} {number} {number})\))*\)"
    )


#: Parsing a message checks only the layout of its See (numbers as any text without parentheses
#: or spaces): checking each number took 30 times as long. ``_SEE`` checks them on first use.
_SEE_LAYOUT = _see(_ATOM, _ATOM)
_SEE = re.compile(_see(_N, r"\d+"))
#: time, GS, GYR, ACC; groups 1-13.
_HEADER = (
    rf"\(time \(now ({_N})\)\)"
    rf"(?:\(GS(?: \(unum (\d+)\))?(?: \(team ({_ATOM})\))? \(sl (\d+)\) \(sr (\d+)\) \(t ({_N})\) \(pm ({_ATOM})\)\))?"
    rf"(?:\(GYR \(n {_ATOM}\) \(rt {_VEC}\)\))?"
    rf"(?:\(ACC \(n {_ATOM}\) \(a {_VEC}\)\))?"
)
_HEADER_GROUPS = 13


def _hj(name: str) -> str:
    return rf"\(HJ \(n {name}\) \(ax (?P<{name}>{_N})\)\)"


def _frp(name: str) -> str:
    return rf"(?:\(FRP \(n {name}\) \(c (?P<{name}>{_N}) ({_N}) ({_N})\) \(f {_VEC}\)\))?"


_PERCEPTORS = [j.perceptor for j in JOINTS]
#: The message's layout (``protocol.nao``'s blocks of joint perceptors): See after the first
#: block, FRP rf after the second, FRP lf after the third.
_TYPICAL = re.compile(
    _HEADER
    + "".join(map(_hj, HJ_BEFORE_SEE))
    + rf"(?P<see>{_SEE_LAYOUT})?"
    + "".join(map(_hj, HJ_BEFORE_FRP_RF))
    + _frp("rf")
    + "".join(map(_hj, HJ_BEFORE_FRP_LF))
    + _frp("lf")
    + "".join(map(_hj, HJ_LAST))
)
#: Where each value sits in ``_TYPICAL``'s ``groups()`` tuple.
_TYPICAL_INDEX = {name: index - 1 for name, index in _TYPICAL.groupindex.items()}
_TYPICAL_JOINTS = itemgetter(*(_TYPICAL_INDEX[name] for name in _PERCEPTORS))

_JOINTS_AND_FEET = (
    rf"(?:\(HJ \(n {_ATOM}\) \(ax {_N}\)\)"
    rf"|\(FRP \(n {_ATOM}\) \(c {_N} {_N} {_N}\) \(f {_N} {_N} {_N}\)\))*"
)
#: Known perceptors in any order after the header, at most one See (group 14).
_KNOWN = re.compile(_HEADER + rf"{_JOINTS_AND_FEET}(?:({_SEE_LAYOUT}){_JOINTS_AND_FEET})?")
_HJ = re.compile(rf"\(HJ \(n ({_ATOM})\) \(ax ({_N})\)\)")
_FRP = re.compile(rf"\(FRP \(n ({_ATOM})\) \(c {_VEC}\) \(f {_VEC}\)\)")
# Extraction runs only on text a validating expression accepted, so these can be loose (and faster).
_LOOSE_POL = r"\(pol ([^ ]+) ([^ ]+) ([^)]+)\)"
_SEEN_OBJECT = re.compile(rf"\(([A-Z]\w*) {_LOOSE_POL}\)")
_SEEN_LINE = re.compile(rf"\(L {_LOOSE_POL} {_LOOSE_POL}\)")
_SEEN_PLAYER = re.compile(rf"\(P \(team ({_ATOM})\) \(id (\d+)\)((?: \([a-z]\w* {_POL_NC}\))*)\)")
_PLAYER_PART = re.compile(rf"\(([a-z]\w*) {_LOOSE_POL}\)")
_MYPOS = re.compile(rf"\(mypos {_VEC}\)")
_MYORIEN = re.compile(rf"\(myorien ({_N})\)")
_BALLPOS = re.compile(rf"\(ballpos {_VEC}\)")

_new_tuple = tuple.__new__


def _polar(d: str, h: str, v: str) -> Polar:
    # tuple.__new__ skips the NamedTuple's Python-level __new__: a third of the cost per point.
    return _new_tuple(Polar, (float(d), float(h), float(v)))


def _vec3(x: str, y: str, z: str) -> Vec3:
    return (float(x), float(y), float(z))


def _foot(g: tuple[str | None, ...], i: int) -> ForceResistance | None:
    if g[i] is None:
        return None
    return ForceResistance(_vec3(*g[i : i + 3]), _vec3(*g[i + 3 : i + 6]))  # type: ignore[arg-type]


def _perception_from_header(
    g: tuple[str | None, ...],
    joints: dict[str, float],
    frp: dict[str, ForceResistance],
    see: tuple[str, int, int] | None,
) -> Perception:
    """Assemble a ``Perception`` from ``_HEADER``'s groups and the already collected rest;
    ``see``: (message, start, end) of the See, read on first use."""
    game = GameState(
        None if g[1] is None else int(g[1]),
        g[2],
        None if g[3] is None else int(g[3]),
        None if g[4] is None else int(g[4]),
        None if g[5] is None else float(g[5]),
        g[6],
    )
    gyro = None if g[7] is None else _vec3(g[7], g[8], g[9])  # type: ignore[arg-type]
    acc = None if g[10] is None else _vec3(g[10], g[11], g[12])  # type: ignore[arg-type]
    return Perception(float(g[0]), game, gyro, acc, joints, frp, see, [], [])  # type: ignore[arg-type]


def _span(m: re.Match[str], group: str | int) -> tuple[str, int, int] | None:
    start, end = m.span(group)
    return None if start < 0 else (m.string, start, end)


def _read_vision_later(text: str, start: int, end: int) -> Vision:
    """A See whose layout the fast path accepted: read it here if its numbers have the server's
    form, else by the slow path, which reads other forms (1e5, +1) or names the first bad one."""
    if _SEE.fullmatch(text, start, end) is None:
        vision = _parse_slow(text).vision
        assert vision is not None  # the message has a See
        return vision
    return _read_vision_fast(text[start:end])


def _parse_typical(m: re.Match[str]) -> Perception:
    g = m.groups()
    joints = dict(zip(_PERCEPTORS, map(float, _TYPICAL_JOINTS(g))))
    # FRP rf comes before lf in the message; keep that order, as the other paths do.
    frp = {}
    for key in ("rf", "lf"):
        foot = _foot(g, _TYPICAL_INDEX[key])
        if foot is not None:
            frp[key] = foot
    return _perception_from_header(g, joints, frp, _span(m, "see"))


def _parse_known(text: str, m: re.Match[str]) -> Perception:
    g = m.groups()
    joints = {name: float(ax) for name, ax in _HJ.findall(text)}
    frp = {found[0]: foot for found in _FRP.findall(text) if (foot := _foot(found, 1)) is not None}
    return _perception_from_header(g, joints, frp, _span(m, _HEADER_GROUPS + 1))


def _last(pattern: re.Pattern[str], key: str, body: str) -> tuple[str, ...] | None:
    """Groups of the last ``pattern`` match (last wins, as in the slow path); ``str.find`` first
    because these entries are often absent (off by default in the server)."""
    if body.find(key) < 0:
        return None
    found = pattern.findall(body)
    return found[-1] if found else None


def _read_vision_fast(body: str) -> Vision:
    # Objects are capitalised (F1L, B), player parts are not (head, lfoot): the two patterns
    # cannot take each other's entries. The fast expressions only admit messages where that holds.
    players = [
        SeenPlayer(team, int(unum), {p: _polar(d, h, v) for p, d, h, v in _PLAYER_PART.findall(parts)})
        for team, unum, parts in (_SEEN_PLAYER.findall(body) if "(P " in body else ())
    ]
    objects = {name: _polar(d, h, v) for name, d, h, v in _SEEN_OBJECT.findall(body)}
    lines = [(_polar(a, b, c), _polar(d, e, f)) for a, b, c, d, e, f in _SEEN_LINE.findall(body)]
    mypos = _last(_MYPOS, "(mypos ", body)
    myorien = _last(_MYORIEN, "(myorien ", body)
    ballpos = _last(_BALLPOS, "(ballpos ", body)
    return Vision(
        objects,
        lines,
        players,
        None if mypos is None else _vec3(*mypos),
        None if myorien is None else float(myorien),  # type: ignore[arg-type]
        None if ballpos is None else _vec3(*ballpos),
    )


# ---------------------------------------------------------------------------------------------
# Slow path: any spacing and order, unknown perceptors kept, precise errors.

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_INTEGER = re.compile(r"[-+]?\d+")


def _atom(node: SExp, i: int, what: str) -> str:
    if i >= len(node):
        raise ProtocolError(node.end - 1, what, ")")
    item = node[i]
    if not isinstance(item, str):
        raise ProtocolError(node.positions[i], what, "(")
    return item


def _number(node: SExp, i: int, what: str) -> float:
    """``node[i]`` as a float; a word (``nan`` included) where a number belongs is an error."""
    atom = _atom(node, i, f"a number ({what})")
    if _NUMBER.fullmatch(atom) is None:
        raise ProtocolError(node.positions[i], f"a number ({what})", atom)
    return float(atom)


def _integer(node: SExp, i: int, what: str) -> int:
    atom = _atom(node, i, f"an integer ({what})")
    if _INTEGER.fullmatch(atom) is None:
        raise ProtocolError(node.positions[i], f"an integer ({what})", atom)
    return int(atom)


def _exact(node: SExp, count: int, what: str) -> None:
    """``node`` must hold its name and ``count`` values, no more."""
    if len(node) > count + 1:
        raise ProtocolError(node.positions[count + 1], f"')' closing {what}", str(node[count + 1]))


def _vec(node: SExp, what: str) -> Vec3:
    """Grammar: ``(<name> <x> <y> <z>)``."""
    _exact(node, 3, what)
    return (_number(node, 1, what), _number(node, 2, what), _number(node, 3, what))


def _fields(node: SExp) -> dict[str, SExp]:
    """Named sub-lists ``(<key> ...)`` of ``node`` by key; later ones win."""
    return {item[0]: item for item in node[1:] if isinstance(item, SExp) and item and isinstance(item[0], str)}


def _required(fields: dict[str, SExp], key: str, node: SExp, shape: str) -> SExp:
    try:
        return fields[key]
    except KeyError:
        raise ProtocolError(node.start, f"{shape} in {node[0]}", None) from None


def _polar_node(node: SExp, what: str) -> Polar:
    """Grammar: ``(pol <d> <h> <v>)``."""
    if not (isinstance(node, list) and node and node[0] == "pol"):
        raise ProtocolError(getattr(node, "start", None), f"(pol <d> <h> <v>) in {what}")
    return Polar(*_vec(node, what))


def _is_object(item: SExp) -> bool:
    return len(item) == 2 and isinstance(item[1], list) and bool(item[1]) and item[1][0] == "pol"


def _read_vision_slow(node: SExp, text: str, unknown: list[str]) -> Vision:
    """Grammar: ``(See <seen>*)``, see the module docstring."""
    vision = Vision()
    for item in node[1:]:
        if not (isinstance(item, SExp) and item and isinstance(item[0], str)):
            unknown.append(text[item.start : item.end] if isinstance(item, SExp) else item)
            continue
        name = item[0]
        if name == "L" and len(item) == 3:
            vision.lines.append((_polar_node(item[1], "L"), _polar_node(item[2], "L")))
        elif name == "P" and not _is_object(item):
            vision.players.append(_read_player(item))
        elif name == "mypos":
            vision.mypos = _vec(item, "mypos")
        elif name == "ballpos":
            vision.ballpos = _vec(item, "ballpos")
        elif name == "myorien":
            _exact(item, 1, "myorien")
            vision.myorien = _number(item, 1, "myorien")
        elif _is_object(item):
            vision.objects[name] = _polar_node(item[1], name)
        else:
            unknown.append(text[item.start : item.end])
    return vision


def _read_player(node: SExp) -> SeenPlayer:
    """Grammar: ``(P (team <name>) (id <n>) (<part> (pol <d> <h> <v>))*)``."""
    fields = _fields(node)
    team = _atom(_required(fields, "team", node, "(team <name>)"), 1, "a team name")
    unum = _integer(_required(fields, "id", node, "(id <n>)"), 1, "player id")
    parts = {key: _polar_node(item[1], f"P {key}") for key, item in fields.items() if key not in ("team", "id")}
    return SeenPlayer(team, unum, parts)


def _read_game_state(node: SExp) -> GameState:
    """Grammar: ``(GS [(unum <n>)] [(team <side>)] [(sl <n>)] [(sr <n>)] [(t <t>)] [(pm <mode>)])``;
    unknown fields are ignored (later servers add some)."""
    fields = _fields(node)
    game = GameState()
    if "unum" in fields:
        game.unum = _integer(fields["unum"], 1, "GS unum")
    if "team" in fields:
        game.team = _atom(fields["team"], 1, "a team side (GS team)")
    if "sl" in fields:
        game.score_left = _integer(fields["sl"], 1, "GS sl")
    if "sr" in fields:
        game.score_right = _integer(fields["sr"], 1, "GS sr")
    if "t" in fields:
        game.time = _number(fields["t"], 1, "GS t")
    if "pm" in fields:
        game.play_mode = _atom(fields["pm"], 1, "a play mode (GS pm)")
    return game


def _read_hear(node: SExp) -> Hear:
    """Grammar: ``(hear [<team>] <t> <self|direction> <message>)`` (the team is newer servers')."""
    if len(node) >= 5:
        team: str | None = _atom(node, 1, "a team name (hear)")
        first = 2
    else:
        team, first = None, 1
    heard_at = _number(node, first, "hear time")
    direction = _atom(node, first + 1, "'self' or a direction (hear)")
    message = _atom(node, first + 2, "a message (hear)")
    _exact(node, first + 2, "hear")
    return Hear(heard_at, team, direction, message)


def _parse_slow(text: str) -> Perception:
    now: float | None = None
    game = GameState()
    gyro = acc = None
    joints: dict[str, float] = {}
    frp: dict[str, ForceResistance] = {}
    vision = None
    hear: list[Hear] = []
    unknown: list[str] = []
    for node in parse_sexp(text):
        name = node[0] if node and isinstance(node[0], str) else None
        fields = _fields(node)
        if name == "time":
            now = _number(_required(fields, "now", node, "(now <t>)"), 1, "time now")
        elif name == "GS":
            game = _read_game_state(node)
        elif name == "GYR":
            gyro = _vec(_required(fields, "rt", node, "(rt <x> <y> <z>)"), "GYR rt")
        elif name == "ACC":
            acc = _vec(_required(fields, "a", node, "(a <x> <y> <z>)"), "ACC a")
        elif name == "HJ":
            joint = _atom(_required(fields, "n", node, "(n <name>)"), 1, "a joint name (HJ n)")
            ax = _required(fields, "ax", node, "(ax <deg>)")
            _exact(ax, 1, "HJ ax")
            joints[joint] = _number(ax, 1, "HJ ax")
        elif name == "FRP":
            foot = _atom(_required(fields, "n", node, "(n <lf|rf>)"), 1, "a foot name (FRP n)")
            frp[foot] = ForceResistance(
                _vec(_required(fields, "c", node, "(c <x> <y> <z>)"), "FRP c"),
                _vec(_required(fields, "f", node, "(f <x> <y> <z>)"), "FRP f"),
            )
        elif name == "See":
            vision = _read_vision_slow(node, text, unknown)
        elif name == "hear":
            hear.append(_read_hear(node))
        else:
            unknown.append(text[node.start : node.end])
    if now is None:
        raise ProtocolError(len(text), "a (time (now <t>)) perceptor in the message", "end of message")
    return Perception(now, game, gyro, acc, joints, frp, vision, hear, unknown)
