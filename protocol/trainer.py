"""Trainer commands (monitor port, monitor -> server), as in ``monitor_commands_sent.txt`` and
docs/robot_and_server.md section 9. On this port team sides are capitalised: ``Left``, ``Right``.

Numbers keep their Python type in the text (``-3.0`` for a float, ``90`` for an int), which is
how the captured commands look; the server reads either.
"""

from __future__ import annotations

from protocol.nao import PLAY_MODES
from protocol.numbers import number_text, typed_number_text

_SIDES = {"left": "Left", "right": "Right"}


def _side(team: str) -> str:
    try:
        return _SIDES[team.lower()]
    except (KeyError, AttributeError):
        raise ValueError(f"team must be 'Left' or 'Right', got {team!r}") from None


def _player(unum: int, team: str) -> str:
    if not isinstance(unum, int) or unum < 1:
        raise ValueError(f"unum must be an int >= 1, got {unum!r}")
    return f"(unum {unum}) (team {_side(team)})"


def _numbers(*values: float) -> str:
    return " ".join(map(typed_number_text, values))


def play_mode(name: str) -> str:
    """``(playMode PlayOn)``; ``name`` must be one of the server's play modes."""
    if name not in PLAY_MODES:
        raise ValueError(f"unknown play mode {name!r}; known: {', '.join(PLAY_MODES)}")
    return f"(playMode {name})"


def kick_off(side: str) -> str:
    """``(kickOff Left)``: the given side kicks off."""
    return f"(kickOff {_side(side)})"


def set_time(t: float) -> str:
    """``(time T)``: set the game clock; ``(time 0)`` each episode keeps the half from ending
    (section 11)."""
    return f"(time {number_text(t)})"


def agent_pos(unum: int, team: str, x: float, y: float, z: float) -> str:
    """``(agent (unum 1) (team Left) (pos x y z))``: move the whole robot so the torso centre is at
    (x, y, z); orientation and joint angles kept, velocities zeroed."""
    return f"(agent {_player(unum, team)} (pos {_numbers(x, y, z)}))"


def agent_move(unum: int, team: str, x: float, y: float, z: float, a: float) -> str:
    """``(agent (unum 1) (team Left) (move x y z a))``: like ``agent_pos`` but also sets the torso
    upright with yaw ``a`` degrees, where **a = 0 faces world +y and a = -90 faces +x** (no team
    offset, unlike ``beam``; docs/robot_and_server.md section 9)."""
    return f"(agent {_player(unum, team)} (move {_numbers(x, y, z, a)}))"


def ball(pos: tuple[float, float, float], vel: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
    """``(ball (pos x y z) (vel vx vy vz))``: place the ball and set its velocity (m, m/s)."""
    if len(pos) != 3 or len(vel) != 3:
        raise ValueError(f"ball needs 3 coordinates for pos and vel, got {pos!r}, {vel!r}")
    return f"(ball (pos {_numbers(*pos)}) (vel {_numbers(*vel)}))"


def kill(unum: int, team: str) -> str:
    """``(kill (unum 1) (team Left))``: remove that robot from the game."""
    return f"(kill {_player(unum, team)})"


def repos(unum: int, team: str) -> str:
    """``(repos (unum 1) (team Left))``: let the referee reposition that robot."""
    return f"(repos {_player(unum, team)})"


def req_full_state() -> str:
    """``(reqfullstate)``: ask for a full scene (RSG) in the next monitor message."""
    return "(reqfullstate)"


def kill_sim() -> str:
    """``(killsim)``: the server exits cleanly."""
    return "(killsim)"
