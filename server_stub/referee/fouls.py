"""The referee's "incapable" foul: a robot that stays down is lifted and put outside the field
(rcssserver3d 0.7.3's SoccerRuleAspect: ProcessAgentState, AnalyseFouls, ClearPlayersAutomatic,
RepositionOutsidePos; naosoccersim.rb's values; docs/robot_and_server.md section 8).

While the game runs (not before kick-off, not in a goal's pause: there every count starts again
each cycle), the referee counts for each robot inside the field (|y| < half width + 0.1 m) the
cycles its torso centre spends below 0.25 m ("not standing"; 0.5 s above it clears that count)
and below 0.15 m ("on the ground"; any cycle above 0.25 m clears it). A field player past
``ground_max_time`` on the ground or ``not_standing_max_time`` not standing (the goalie, number
1, past its own two) has committed the foul. From then on, each cycle for ``foul_hold_time`` it
is held in the air, its torso put 1 m up plus 1 cm per cycle of the foul; then it is put outside
the field, on the side line away from the ball at x = -+0.6 (7 - number) (its own half), torso at
0.4 m, and its counts start again. Every one of those cycles records a foul, which the monitor
stream reports as ``(foul index type team number)``.

Left out: the other fouls (charging, touching, crowding, illegal defence). In the games measured
(``bench/real_fouls.py``) only touching fired, once in two real games, and the real server
picks at random whom it moves for it. Also left out: before putting a robot outside, the real
referee looks for a free spot near that place (away from the ball and from other robots' boxes),
and it takes players in a random order, which orders the indices of fouls recorded in the same
cycle; the stand-in takes them left before right, by number. And where the real referee keeps
each number's counts for good, the stand-in starts them again when the field empties, so that an
episode never inherits a foul from the one before.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from server_stub import field
from server_stub.agent_state import AgentState
from server_stub.config import RefereeConfig
from server_stub.physics.robot import Robot

#: The real referee turns its times into cycle counts by dividing by 0.02 s, whatever the step.
_CYCLE = 0.02
#: Below this torso height a robot is not standing, and below ``_GROUND`` it is on the ground.
_STANDING = 0.25
_GROUND = 0.15
#: A count runs only while the torso centre's |y| is under this: inside the side lines, and 0.1 m.
_COUNTED_WITHIN = field.HALF_WIDTH + 0.1
#: After a foul or a pause a robot counts as having stood for 5 s.
_STOOD_AFTER_RESET = int(5 / _CYCLE)
#: SimSpark's foul type number of "incapable" (its EFoulType), and its team numbers.
INCAPABLE = 4
TEAM_INDEX = {"left": 1, "right": 2}


@dataclass(frozen=True)
class Foul:
    """One recorded foul, as the monitor stream reports it."""

    index: int
    kind: int
    side: str
    unum: int

    def monitor_item(self) -> str:
        return f"(foul {self.index} {self.kind} {TEAM_INDEX[self.side]} {self.unum})"


@dataclass
class _Counts:
    """One player's counts, in cycles."""

    not_standing: int = 0
    ground: int = 0
    standing: int = _STOOD_AFTER_RESET
    foul_time: int = 0
    fouled: bool = False

    def reset(self) -> None:
        self.not_standing = self.ground = self.foul_time = 0
        self.standing = _STOOD_AFTER_RESET
        self.fouled = False

    @property
    def live(self) -> bool:
        """Something to analyse: a foul, or a count of cycles down."""
        return self.fouled or self.ground > 0 or self.not_standing > 0

    @property
    def enforceable(self) -> bool:
        return self.fouled and self.foul_time > 0

    def count(self, z: float, inside: bool) -> None:
        if z < _STANDING and inside:
            self.not_standing += 1
            self.standing = 0
        if z < _GROUND and inside:
            self.ground += 1
        if z >= _STANDING:
            self.standing += 1
            self.ground = 0
        if self.standing > 0.5 / _CYCLE:
            self.not_standing = 0


def _player_key(player: tuple[tuple[str, int], Robot]) -> tuple[str, int]:
    return player[0]


class IncapableRule:
    """The counts of every player (numbers 1-11 of each side, connected or not, as the real
    referee keeps them) and the fouls recorded so far."""

    def __init__(self, config: RefereeConfig) -> None:
        self.config = config
        self._counts = {(side, unum): _Counts() for side in TEAM_INDEX for unum in range(1, 12)}
        #: the players whose counts may hold something to analyse (the others' are all 0 and not
        #: fouled): a cycle looks at these, not at all 22
        self._live: set[tuple[str, int]] = set()
        self.fouls: list[Foul] = []

    def forget(self) -> None:
        """Every count starts again (the fouls recorded stay)."""
        for counts in self._counts.values():
            counts.reset()

    def update(self, agents: Iterable[AgentState], paused: bool, ball_y: float) -> None:
        """One cycle of the rule, after the play mode's own rules; ``paused`` before kick-off and
        in a goal's pause; ``ball_y``: the ball's y (a robot is put out on the other side line)."""
        if paused:
            self.forget()
            return
        players: list[tuple[tuple[str, int], Robot]] = [
            ((state.side, state.unum), state.robot)
            for state in agents
            if state.side in TEAM_INDEX and state.unum is not None and 1 <= state.unum <= 11 and state.robot is not None
        ]
        players.sort(key=_player_key)  # fouls of one cycle: left before right, by number
        for key, robot in players:
            _, y, z = robot.torso_position()
            counts = self._counts[key]
            counts.count(z, abs(y) < _COUNTED_WITHIN)
            if counts.live:
                self._live.add(key)
        # every player with something to analyse, connected or not, as the real referee does
        for key in list(self._live):
            counts = self._counts[key]
            if counts.live:
                self._analyse(key[1], counts)
            else:
                self._live.discard(key)
        for key, robot in players:
            self._clear(key, robot, ball_y)

    def _analyse(self, unum: int, counts: _Counts) -> None:
        if counts.enforceable:
            return
        c = self.config
        ground, not_standing = (
            (c.goalie_ground_max_time, c.goalie_not_standing_max_time)
            if unum == 1
            else (c.ground_max_time, c.not_standing_max_time)
        )
        if counts.ground > ground / _CYCLE or counts.not_standing > not_standing / _CYCLE:
            counts.foul_time += 1
            counts.fouled = True
        else:
            counts.foul_time = 0
            counts.fouled = False

    def _clear(self, key: tuple[str, int], robot: Robot, ball_y: float) -> None:
        counts = self._counts[key]
        if not counts.enforceable:
            return
        side, unum = key
        self.fouls.append(Foul(len(self.fouls) + 1, INCAPABLE, side, unum))
        if counts.foul_time <= self.config.foul_hold_time / _CYCLE:
            counts.foul_time += 1
            x, y, _ = robot.torso_position()
            robot.place(x, y, 1.0 + counts.foul_time * 0.01)
            return
        sign = -1.0 if side == "left" else 1.0
        away = 1.0 if ball_y < 0 else -1.0
        robot.place(sign * 0.6 * (7 - unum), away * (field.HALF_WIDTH + 0.5), field.AGENT_RADIUS)
        counts.reset()
