"""Trainer commands arriving on the monitor port (docs/robot_and_server.md section 9), applied to the stub's state.

Grammar read here (team names capitalised on this port, ``Left`` / ``Right``)::

    (playMode <name>)            (kickOff Left|Right)          (time <t>)
    (agent (unum <n>) (team <Left|Right>) (pos <x> <y> <z>))
    (agent (unum <n>) (team <Left|Right>) (move <x> <y> <z> <a>))   a = 0 faces +y, a = -90 faces +x
    (ball (pos <x> <y> <z>) (vel <vx> <vy> <vz>))   (dropBall)   (score (left <l>) (right <r>))
    (repos (unum <n>) (team <side>))   (kill (unum <n>) (team <side>))
    (select ...)   (reqfullstate)   (killsim)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

#: Positions beyond this many metres from the centre are refused as absurd.
MAX_COORDINATE = 100.0


class TrainerError(ValueError):
    """A trainer command the stub cannot apply; the message says which part is wrong."""


class TrainerTarget(Protocol):
    """What the server exposes to trainer commands."""

    def set_play_mode(self, name: str) -> None: ...
    def set_game_time(self, t: float) -> None: ...
    def set_score(self, left: int, right: int) -> None: ...
    def place_agent(self, side: str, unum: int, pos: tuple[float, float, float], yaw_deg: float | None) -> None: ...
    def reposition_agent(self, side: str, unum: int) -> None: ...
    def kill_agent(self, side: str, unum: int) -> None: ...
    def set_ball(self, pos: tuple[float, float, float], vel: tuple[float, float, float]) -> None: ...
    def drop_ball(self) -> None: ...
    def request_full_state(self, monitor: object) -> None: ...
    def kill_sim(self) -> None: ...


@dataclass(frozen=True)
class _Fields:
    values: dict[str, list]

    def numbers(self, key: str, count: int) -> tuple[float, ...]:
        raw = self.values.get(key)
        if raw is None or len(raw) != count:
            raise TrainerError(f"({key} ...) needs {count} numbers")
        try:
            out = tuple(float(v) for v in raw)
        except (TypeError, ValueError):
            raise TrainerError(f"({key} ...) needs numbers, got {raw}") from None
        if not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE * 10 for v in out):
            raise TrainerError(f"({key} ...) values must be finite and reasonable, got {raw}")
        return out


def _fields(args: list) -> _Fields:
    values: dict[str, list] = {}
    for item in args:
        if not isinstance(item, list) or not item or not isinstance(item[0], str):
            raise TrainerError(f"expected (name value...), got {item!r}")
        values[item[0]] = item[1:]
    return _Fields(values)


def _side(fields: _Fields) -> tuple[str, int]:
    team = fields.values.get("team")
    unum = fields.numbers("unum", 1)[0]
    if not team or str(team[0]).lower() not in ("left", "right"):
        raise TrainerError(f"(team Left|Right) expected, got {team}")
    return str(team[0]).lower(), int(unum)


def _position(values: tuple[float, ...]) -> tuple[float, float, float]:
    if any(abs(v) > MAX_COORDINATE for v in values[:3]):
        raise TrainerError(f"position {values[:3]} is more than {MAX_COORDINATE} m away")
    return values[0], values[1], values[2]


def apply_trainer_command(expr: list, target: TrainerTarget, monitor: object) -> None:
    """Apply one parsed command; raises ``TrainerError`` naming what is wrong."""
    if not expr or not isinstance(expr[0], str):
        raise TrainerError(f"not a command: {expr!r}")
    name, args = expr[0], expr[1:]
    if name == "playMode" and len(args) == 1 and isinstance(args[0], str):
        target.set_play_mode(args[0])
    elif name == "kickOff" and len(args) == 1 and str(args[0]).lower() in ("left", "right"):
        target.set_play_mode("KickOff_" + str(args[0]).capitalize())
    elif name == "time" and len(args) == 1:
        target.set_game_time(_Fields({"time": args}).numbers("time", 1)[0])
    elif name == "agent":
        fields = _fields(args)
        side, unum = _side(fields)
        if "move" in fields.values:
            x, y, z, a = fields.numbers("move", 4)
            target.place_agent(side, unum, _position((x, y, z)), a + 90.0)
        elif "pos" in fields.values:
            target.place_agent(side, unum, _position(fields.numbers("pos", 3)), None)
        # other fields of the real server's agent command (battery, temperature) are ignored
    elif name == "ball":
        fields = _fields(args)
        pos = _position(fields.numbers("pos", 3)) if "pos" in fields.values else None
        vx, vy, vz = fields.numbers("vel", 3) if "vel" in fields.values else (0.0, 0.0, 0.0)
        vel = (vx, vy, vz)
        if pos is None:
            raise TrainerError("(ball (pos x y z) ...) needs a position")
        target.set_ball(pos, vel)
    elif name == "dropBall":
        target.drop_ball()
    elif name == "score":
        fields = _fields(args)
        target.set_score(int(fields.numbers("left", 1)[0]), int(fields.numbers("right", 1)[0]))
    elif name == "repos":
        target.reposition_agent(*_side(_fields(args)))
    elif name == "kill":
        target.kill_agent(*_side(_fields(args)))
    elif name == "select":
        pass  # selects a player for a monitor's keyboard commands; nothing to do here
    elif name == "reqfullstate":
        target.request_full_state(monitor)
    elif name == "killsim":
        target.kill_sim()
    else:
        raise TrainerError(f"unknown or malformed trainer command ({name} ...)")
