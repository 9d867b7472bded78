"""Effector commands (agent -> server), byte for byte as a real agent sent them
(``tests/data/rcssserver3d/agent_commands_sent.txt``). Several may be concatenated in one message."""

from __future__ import annotations

import math
from collections.abc import Mapping

from protocol.nao import JOINT_BY_EFFECTOR, NAO_HETERO_RSG, NAO_RSG, ROBOT_TYPES
from protocol.numbers import number_text

#: Longest ``say`` message the server relays (rcssserver3d's say effector rule).
SAY_MAX_LENGTH = 20


def _check_atom(text: str, what: str) -> str:
    if not text or any(c.isspace() or c in "()" for c in text) or not text.isascii():
        raise ValueError(f"{what} must be non-empty ASCII without spaces or parentheses: {text!r}")
    return text


def scene(robot_type: int | None = None) -> str:
    """``(scene rsg/agent/nao/nao.rsg)`` for the default robot, or
    ``(scene rsg/agent/nao/nao_hetero.rsg T)`` for heterogeneous type T (section 6)."""
    if robot_type is None:
        return f"(scene {NAO_RSG})"
    if robot_type not in ROBOT_TYPES:
        raise ValueError(f"robot type must be one of {ROBOT_TYPES}, got {robot_type!r}")
    return f"(scene {NAO_HETERO_RSG} {robot_type})"


def init(unum: int, team: str) -> str:
    """``(init (unum N)(teamname NAME))``; unum 0 asks the server for the next free number."""
    if not isinstance(unum, int) or unum < 0:
        raise ValueError(f"unum must be an int >= 0, got {unum!r}")
    return f"(init (unum {unum})(teamname {_check_atom(team, 'team name')}))"


def beam(x: float, y: float, rot: float) -> str:
    """``(beam x y rot)``: torso to (x, y), heading ``rot`` deg; honoured only in BeforeKickOff and
    after a goal (section 6). Numbers in their shortest form: ``beam(-1.0, 0.0, 0.0) -> (beam -1 0 0)``."""
    return f"(beam {number_text(x)} {number_text(y)} {number_text(rot)})"


#: The NAO's effector names (every type's): valid atoms, so the every-cycle command needs no check of them.
_EFFECTORS = frozenset(JOINT_BY_EFFECTOR)


def hinge_velocities(velocities: Mapping[str, float]) -> str:
    """``(lle3 0.1880)(lle4 -0.1880)``: target motor speeds in rad/s, 4 decimals, in mapping order.

    Values are not clipped here: the server clips to the speed cap itself (section 3)."""
    for name, value in velocities.items():
        if not math.isfinite(value):
            raise ValueError(f"velocity of {name} is not finite: {value!r}")
        if name not in _EFFECTORS:
            _check_atom(name, "effector name")
    return "".join([f"({name} {value:.4f})" for name, value in velocities.items()])


def syn() -> str:
    """``(syn)``: the agent is done with this cycle (needed once per cycle in sync mode)."""
    return "(syn)"


def say_problem(message: str) -> str | None:
    """What breaks the server's rule for a ``say`` message, or None: at most 20 characters of
    printable ASCII (0x21-0x7e), no space, no parentheses. The one statement of the rule: agents
    refuse to send such a message, and the stand-in refuses to relay it."""
    if not message:
        return "message is empty"
    if len(message) > SAY_MAX_LENGTH:
        return f"message is {len(message)} characters, at most {SAY_MAX_LENGTH} allowed"
    for index, char in enumerate(message):
        if char in "()":
            return f"parenthesis {char!r} at index {index} is not allowed"
        if not "\x21" <= char <= "\x7e":
            return f"character {char!r} at index {index} is not printable ASCII other than space"
    return None


def say(message: str) -> str:
    """``(say MSG)``. The server drops messages that break its rules, so refuse them here."""
    problem = say_problem(message)
    if problem is not None:
        raise ValueError(f"say: {problem}")
    return f"(say {message})"
