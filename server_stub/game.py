"""The game's state: play mode, game clock, halves, score, teams, uniform numbers, beam rules.

rcssserver3d's GameStateAspect: what the referee (``server_stub.referee``) reads and changes each
cycle, what the trainer sets, what perceptions and the monitor report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from protocol.nao import BEAM_PLAY_MODES, CYCLE, PLAY_MODES
from server_stub import field as soccer_field

#: Modes in which the game clock stands still (docs/robot_and_server.md section 5: "stays 0 before
#: kick-off"; section 8: and after the game).
_CLOCK_STOPPED = frozenset({"BeforeKickOff", "GameOver"})
#: The real server's clock step: a float32 0.02 added to a float32 sum (GameStateAspect's TTime).
_CYCLE32 = np.float32(CYCLE)
#: Own-half clipping of ``beam`` (docs/robot_and_server.md section 6): x in [-15, 0], y in [-10, 10].
BEAM_X_RANGE = (-soccer_field.HALF_LENGTH, 0.0)
BEAM_Y_RANGE = (-soccer_field.HALF_WIDTH, soccer_field.HALF_WIDTH)
MAX_UNUM = 11


class GameError(ValueError):
    """A request the referee refuses (full team, third team, unknown play mode...)."""


@dataclass
class Game:
    play_mode: str = "BeforeKickOff"
    #: game time (s) as perceptions and the monitor report it: the exact sum of the cycles
    time: float = 0.0
    #: the game time as the real server keeps it, a float32 sum of float32 cycles, which lags the
    #: exact one (299.9937 after 15,000 cycles, so the half ends one cycle later, at 300.01 on a
    #: real server): the referee's timeouts and the halves run on it
    clock32: float = 0.0
    #: ``clock32`` at the last change of play mode (``mode_time``)
    last_mode_change: float = 0.0
    half: int = 1
    score_left: int = 0
    score_right: int = 0
    team_left: str | None = None
    team_right: str | None = None
    #: unums taken per side ('left' / 'right').
    taken: dict[str, set[int]] = field(default_factory=lambda: {"left": set(), "right": set()})
    #: where the next ``init`` of each side puts its robot, in float32 as the real server keeps it
    _next_init: dict[str, np.ndarray] = field(
        default_factory=lambda: {side: _first_init_place(side) for side in ("left", "right")}, init=False, repr=False
    )

    def advance(self) -> None:
        if self.play_mode not in _CLOCK_STOPPED:
            self.time += CYCLE
            self.clock32 = float(np.float32(self.clock32) + _CYCLE32)

    def set_time(self, t: float) -> None:
        """The trainer's ``(time T)``: the clock only; the mode keeps its start, as on the real
        server (so ``(time 295)`` in a kick-off makes it time out at once)."""
        self.time = max(0.0, t)
        self.clock32 = float(np.float32(self.time))

    def set_play_mode(self, name: str) -> None:
        """A new play mode starts now (its ``mode_time`` from 0); setting the current one again
        changes nothing, as on the real server."""
        if name not in PLAY_MODES:
            raise GameError(f"unknown play mode {name!r}")
        if name != self.play_mode:
            self.play_mode = name
            self.last_mode_change = self.clock32

    @property
    def mode_time(self) -> float:
        """Game time since the play mode began, in float32 as the real referee compares it with
        its timeouts (a kick-off from t = 0 times out at 15.000154 > 15, 750 cycles in)."""
        return float(np.float32(self.clock32) - np.float32(self.last_mode_change))

    def kick_off(self, side: str) -> None:
        self.set_play_mode("KickOff_Left" if side == "left" else "KickOff_Right")

    def score_for(self, side: str) -> None:
        """A goal for ``side``: its score and the Goal_Left / Goal_Right pause."""
        if side == "left":
            self.score_left += 1
            self.set_play_mode("Goal_Left")
        else:
            self.score_right += 1
            self.set_play_mode("Goal_Right")

    @property
    def play_mode_index(self) -> int:
        return PLAY_MODES.index(self.play_mode)

    def beam_allowed(self) -> bool:
        return self.play_mode in BEAM_PLAY_MODES

    def join(self, team: str, unum: int) -> tuple[str, int]:
        """Side and uniform number for an ``init``; the first team name seen plays left."""
        if self.team_left is None or self.team_left == team:
            self.team_left = team
            side = "left"
        elif self.team_right is None or self.team_right == team:
            self.team_right = team
            side = "right"
        else:
            raise GameError(f"two teams ({self.team_left}, {self.team_right}) are already playing; {team!r} refused")
        taken = self.taken[side]
        if unum == 0:
            free = [n for n in range(1, MAX_UNUM + 1) if n not in taken]
            if not free:
                raise GameError(f"team {team!r} is full")
            unum = free[0]
        elif not 1 <= unum <= MAX_UNUM or unum in taken:
            raise GameError(f"uniform number {unum} of team {team!r} is taken or out of 1-{MAX_UNUM}")
        taken.add(unum)
        return side, unum

    def init_pose(self, side: str) -> tuple[float, float, float]:
        """World (x, y, heading; 0 = +x) where the real server moves a robot when it sends
        ``init``, before any beam (rcssserver3d's InitEffector: GameStateAspect's
        RequestInitPosition and RequestInitOrientation): down the side line at y = +10 in a row
        3 agent radii apart, starting 2 radii in from the corner of the own goal line; past the
        other side line the next row starts 2 radii further along +x (for both sides, so the right
        team's rows move out past its goal line); facing the opponent goal. The rows start again
        when a side empties (``leave``). So robots created together stand apart until they beam,
        and none stands in the other half before kick-off."""
        place = self._next_init[side]
        x, y = float(place[0]), float(place[1])
        radius = np.float32(soccer_field.AGENT_RADIUS)
        place[1] -= radius * np.float32(3)
        if place[1] < -np.float32(soccer_field.WIDTH) / np.float32(2):
            place[1] = np.float32(soccer_field.WIDTH) / np.float32(2) - radius * np.float32(2)
            place[0] += radius * np.float32(2)
        return x, y, (0.0 if side == "left" else 180.0)

    def leave(self, side: str, unum: int) -> None:
        """A side whose last robot left is free for any team, and its ``init`` row starts again.
        (The real server's row runs on for its whole life, so where a robot stands before its first
        beam depends on every robot before it; here it does not, and an episode walks the same
        whichever episodes a stand-in served before it: a resumed search gives the same scores.)"""
        self.taken[side].discard(unum)
        if not self.taken[side]:
            if side == "left":
                self.team_left = None
            else:
                self.team_right = None
            self._next_init[side] = _first_init_place(side)


def _first_init_place(side: str) -> np.ndarray:
    """GameStateAspect::OnLink's first init place of a side: 2 agent radii in from the corner at
    y = +10 of its own goal line."""
    radius = np.float32(soccer_field.AGENT_RADIUS)
    x = np.float32(soccer_field.LENGTH) / np.float32(2) - radius * np.float32(2)
    y = np.float32(soccer_field.WIDTH) / np.float32(2) - radius * np.float32(2)
    return np.array([-x if side == "left" else x, y], dtype=np.float32)


def beam_pose(side: str, x: float, y: float, rot: float) -> tuple[float, float, float]:
    """World (x, y, heading) for a beam, clipped to the own half and mirrored for the right team.

    Headings: 0 faces the opponent goal, i.e. +x for the left team and -x for the right team.
    """
    if not all(math.isfinite(v) for v in (x, y, rot)):
        raise GameError(f"beam values must be finite, got ({x}, {y}, {rot})")
    x = min(max(x, BEAM_X_RANGE[0]), BEAM_X_RANGE[1])
    y = min(max(y, BEAM_Y_RANGE[0]), BEAM_Y_RANGE[1])
    if side == "right":
        return -x, -y, rot + 180.0
    return x, y, rot
