"""The referee's state the stub keeps: play mode, game clock, teams, uniform numbers, beam rules.

Only what a walker, a trainer and a multi-agent test touch; no ball rules, no fouls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from protocol.nao import BEAM_PLAY_MODES, CYCLE, PLAY_MODES
from server_stub import field as soccer_field

#: Modes in which the game clock stands still (docs/robot_and_server.md section 5: "stays 0 before kick-off").
_CLOCK_STOPPED = frozenset({"BeforeKickOff", "GameOver"})
#: Own-half clipping of ``beam`` (docs/robot_and_server.md section 6): x in [-15, 0], y in [-10, 10].
BEAM_X_RANGE = (-soccer_field.HALF_LENGTH, 0.0)
BEAM_Y_RANGE = (-soccer_field.HALF_WIDTH, soccer_field.HALF_WIDTH)
MAX_UNUM = 11


class GameError(ValueError):
    """A request the referee refuses (full team, third team, unknown play mode...)."""


@dataclass
class Game:
    play_mode: str = "BeforeKickOff"
    time: float = 0.0
    half: int = 1
    score_left: int = 0
    score_right: int = 0
    team_left: str | None = None
    team_right: str | None = None
    #: unums taken per side ('left' / 'right').
    taken: dict[str, set[int]] = field(default_factory=lambda: {"left": set(), "right": set()})

    def advance(self) -> None:
        if self.play_mode not in _CLOCK_STOPPED:
            self.time += CYCLE

    def set_play_mode(self, name: str) -> None:
        if name not in PLAY_MODES:
            raise GameError(f"unknown play mode {name!r}")
        self.play_mode = name

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

    def leave(self, side: str, unum: int) -> None:
        self.taken[side].discard(unum)
        if not self.taken[side]:
            if side == "left":
                self.team_left = None
            else:
                self.team_right = None


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
