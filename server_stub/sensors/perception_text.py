"""The text of one agent perception, printed as rcssserver3d 0.7.3 prints it.

Runs every cycle for every robot, so everything that does not change (the ``HJ`` name prefixes,
the order of perceptors) is laid out once at import and a message is one ``%``-format per block
and one join. Format (docs/robot_and_server.md section 5; fixtures ``agent_perceptions_*.txt``), numbers with
2 decimals as the server's printf does (``-0.00`` included)::

    (time (now <t>))(GS [(unum <n>) (team <left|right>)] (sl <n>) (sr <n>) (t <t>) (pm <mode>))
    [(hear <team> <t> <self|deg> <message>)...]
    (GYR (n torso) (rt <x> <y> <z>))(ACC (n torso) (a <x> <y> <z>))
    (HJ (n hj1) (ax <deg>))(HJ (n hj2) (ax <deg>))[(See ...)]
    (HJ raj1..4)(HJ laj1..4)(HJ rlj1..5)[(FRP (n rf) (c <x> <y> <z>) (f <x> <y> <z>))](HJ rlj6)
    (HJ llj1..5)[(FRP (n lf) (c ...) (f ...))](HJ llj6)

The order is the server's scene-graph order: perceptors are collected walking the robot's body
tree, so ``hear`` follows ``GS`` (both hang under the torso's AgentState), the head's ``See`` sits
between the neck/head joints and the arms, and each foot's ``FRP`` just before the ankle-roll
joint of that leg (a toe's ``FRP`` and joint after it, on a type with toes).
``protocol.nao.PerceptionLayout`` holds each type's order.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache

from protocol.nao import LAYOUT, PerceptionLayout

Vec3 = tuple[float, float, float]
#: One foot's contact: centre of pressure and total force, both in the foot frame.
FootContact = tuple[Vec3, Vec3]


@dataclass(frozen=True, slots=True)
class GameStateText:
    """What ``GS`` reports. ``unum`` and ``team`` ('left'/'right') are set only for the first
    perception after ``init`` was processed (the server sends them once)."""

    score_left: int
    score_right: int
    time: float
    play_mode: str
    unum: int | None = None
    team: str | None = None


def _hj_template(names: Sequence[str]) -> str:
    return "".join(f"(HJ (n {name}) (ax %.2f))" for name in names)


_HEADER_T = "(time (now %.2f))%s(GYR (n torso) (rt %.2f %.2f %.2f))(ACC (n torso) (a %.2f %.2f %.2f))"
_FRP_T = "(FRP (n %s) (c %.2f %.2f %.2f) (f %.2f %.2f %.2f))"


@cache
def _templates(layout: PerceptionLayout) -> tuple[str, tuple[tuple[str, str, tuple[str, ...]], ...]]:
    """A layout's message, laid out once: the head's template (time to the first joint block),
    then each later block as (the FRP before it, '' for none; its template; its perceptors)."""
    head = _HEADER_T + _hj_template(layout.blocks[0])
    later = tuple((foot, _hj_template(block), block) for foot, block in zip(("",) + layout.feet, layout.blocks[1:]))
    return head, later


def format_game_state(gs: GameStateText) -> str:
    """``(GS [(unum <n>) (team <side>)] (sl <n>) (sr <n>) (t <t>) (pm <mode>))``."""
    ident = ""
    if gs.unum is not None:
        ident += f"(unum {gs.unum}) "
    if gs.team is not None:
        ident += f"(team {gs.team}) "
    return f"(GS {ident}(sl {gs.score_left}) (sr {gs.score_right}) (t {gs.time:.2f}) (pm {gs.play_mode}))"


def format_hear(team: str, time: float, direction: float | None, message: str) -> str:
    """``(hear <team> <t> <self|angle> <message>)``: ``team`` the speaker's, ``time`` the game
    time; ``direction`` None means the robot heard itself, else the direction (deg) towards the
    speaker in the listener's field frame (``server_stub.sensors.sensing.hear_direction``)."""
    source = "self" if direction is None else f"{direction:.2f}"
    return f"(hear {team} {time:.2f} {source} {message})"


def _frp(key: str, contact: FootContact) -> str:
    (cx, cy, cz), (fx, fy, fz) = contact
    return _FRP_T % (key, cx, cy, cz, fx, fy, fz)


def format_perception(
    now: float,
    game: GameStateText,
    gyro: Vec3,
    acc: Vec3,
    joints_deg: Mapping[str, float],
    frp: Mapping[str, FootContact],
    see: str | None = None,
    hear: Sequence[str] = (),
    layout: PerceptionLayout = LAYOUT,
) -> str:
    """One perception message. ``joints_deg`` needs every perceptor of ``layout`` (the robot
    type's, ``protocol.nao.perception_layout``); ``frp`` holds only the parts touching something
    ('lf', 'rf', and a toe's 'lf1', 'rf1'); ``see`` is a full ``(See ...)`` entry (vision cycles
    only); ``hear`` entries come from ``format_hear``, printed right after ``GS`` as the real
    server prints them (recorded: ``tests/test_hear.py``)."""
    j = joints_deg
    head, later = _templates(layout)
    parts = [
        head
        % (
            now,
            format_game_state(game) + "".join(hear),
            gyro[0],
            gyro[1],
            gyro[2],
            acc[0],
            acc[1],
            acc[2],
            *[j[n] for n in layout.blocks[0]],
        ),
    ]
    if see is not None:
        parts.append(see)
    for foot, template, block in later:
        contact = frp.get(foot) if foot else None
        if contact is not None:
            parts.append(_frp(foot, contact))
        parts.append(template % tuple([j[n] for n in block]))
    return "".join(parts)
