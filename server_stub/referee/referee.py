"""The referee's turn each cycle: what each play mode waits for, what ends it and what comes next
(rcssserver3d 0.7.3's SoccerRuleAspect::Update; docs/robot_and_server.md section 8).

- **Kick-off**: play on at the first touch after it began, or a drop ball where the ball is once
  it has lasted over ``drop_ball_time`` untouched; until then robots are kept out of the other half.
- **Play on**: a ball in a goal scores for the other side (Goal_Left / Goal_Right); a ball out of
  the field, once some robot has touched it, is a kick-in for the other side of the last toucher
  over a side line, over a goal line a goal kick (the attackers touched it last) or a corner (the
  defenders did). A ball nobody has touched may leave the field: play goes on.
- **Kick-in, corner, goal kick, free kick**: ``kick_in_pause_time`` of nothing; then the ball is
  held on the spot until a touch more than ``kick_touch_margin`` after the pause (at a goal kick,
  once the ball has also left the penalty area) gives play on, or over ``drop_ball_time`` a drop
  ball on the spot.
- **Goal**: ``goal_pause_time``, then the ball to the centre and a kick-off for the side scored on.
- **Before kick-off**: the ball is put back on the centre spot every cycle while any agent is
  connected, and each side is cleared from the other half.
- **Halves**: at ``half_time`` the first half ends in BeforeKickOff of the second (sides are not
  swapped); at twice it the game is over (GameOver: the clock stops; the server keeps running).
- **A robot that stays down**, after the play mode's rules: ``fouls.IncapableRule``.

Timeouts are compared on the game's float32 clock (``Game.clock32``), as the real server's runs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from server_stub import field
from server_stub.agent_state import AgentState
from server_stub.config import RefereeConfig
from server_stub.game import Game
from server_stub.physics.world import World
from server_stub.referee import clearing
from server_stub.referee.areas import PENALTY_AREAS, Vec3, other
from server_stub.referee.ball_watch import BallWatch
from server_stub.referee.fouls import IncapableRule

#: The set pieces: play mode -> (kind, side taking it).
_SET_PIECES = {
    "KickIn_Left": ("kick_in", "left"),
    "KickIn_Right": ("kick_in", "right"),
    "corner_kick_left": ("corner", "left"),
    "corner_kick_right": ("corner", "right"),
    "goal_kick_left": ("goal_kick", "left"),
    "goal_kick_right": ("goal_kick", "right"),
    "free_kick_left": ("free_kick", "left"),
    "free_kick_right": ("free_kick", "right"),
    "direct_free_kick_left": ("free_kick", "left"),
    "direct_free_kick_right": ("free_kick", "right"),
}
_KICK_OFFS = {"KickOff_Left": "left", "KickOff_Right": "right"}
_GOALS = {"Goal_Left": "left", "Goal_Right": "right"}
#: The play modes in which the real referee pauses its foul counts (its GameStateAspect::IsPaused).
_PAUSED = frozenset({"BeforeKickOff", *_GOALS})
#: Set pieces whose ball is never placed while no robot has ever touched it (the real referee
#: waits for a first toucher before its hold at corners and goal kicks, not at kick-ins).
_WAIT_FOR_A_TOUCHER = frozenset({"corner", "goal_kick"})


def _out_of_penalty_areas(x: float, y: float) -> tuple[float, float]:
    """A drop ball or free kick is not taken inside a penalty area: such a spot moves to the
    area's front corner on its side (x = +-13.2, y = +-3.0)."""
    for area in PENALTY_AREAS.values():
        if area.contains(x, y):
            return (area.x_max if area.x_min < 0 else area.x_min, area.y_min if y < 0 else area.y_max)
    return x, y


class Referee:
    """Applies the rules to ``game`` and ``world`` once a cycle: ``before_step`` as the physics step
    begins, ``after_step`` once the step and the clock have run."""

    def __init__(self, config: RefereeConfig, game: Game, world: World) -> None:
        self.config = config
        self.game = game
        self.world = world
        self.ball = BallWatch()
        self.incapable = IncapableRule(config)
        #: where the next set piece or drop ball puts the ball (x, y; on the ground)
        self.spot: tuple[float, float] = (0.0, 0.0)
        self._repel_due = False

    # ----- the cycle -----
    def before_step(self, agents: Sequence[AgentState]) -> None:
        """Before kick-off both sides are cleared from the other half here, before the step (the
        real referee does it after the step, as every other rule here: a robot beamed over the
        line steps once where it was sent before it is moved; the stand-in has always moved it
        first, and walks started there keep the outcome they had)."""
        if self.game.play_mode == "BeforeKickOff":
            clearing.clear_half(agents, "left", self.config)
            clearing.clear_half(agents, "right", self.config)
        self.ball.before_step(self.world, agents)

    def after_step(self, agents: Sequence[AgentState]) -> None:
        game = self.game
        self.ball.after_step(game.clock32, self.world.ball_position())
        self._end_halves()
        mode = game.play_mode
        if mode in _KICK_OFFS:
            self._kick_off(agents, _KICK_OFFS[mode])
        elif mode == "PlayOn":
            self._play_on()
        elif mode in _SET_PIECES:
            self._set_piece(agents, *_SET_PIECES[mode])
        elif mode in _GOALS:
            self._goal_pause(agents, _GOALS[mode])
        elif mode == "BeforeKickOff" and agents:
            # the ball waits at the centre spot while any agent is connected (the clearing is in
            # before_step); a trainer that parks it elsewhere does so with or after PlayOn
            self._place_ball((0.0, 0.0, field.BALL_RADIUS))
        # GameOver, offside and pass modes: nothing to do here
        self.incapable.update(agents, mode in _PAUSED, self.world.ball_position()[1])

    def field_emptied(self) -> None:
        """Nobody is left: the next robots start afresh (the real referee keeps each number's
        foul counts; a number joining again there may inherit a foul, which no episode should)."""
        self.ball.forget_touches()
        self.incapable.forget()

    # ----- the trainer's drop ball, and the referee's -----
    def drop_ball(self, agents: Sequence[AgentState], at: Vec3 | None = None) -> None:
        """Play on with the ball at ``at`` (where it is if None), at its height, still; moved out
        of a penalty area to the area's front corner on its side and in from the side lines; every
        robot within ``free_kick_distance`` of it moved away."""
        x, y, z = self.world.ball_position() if at is None else at
        x, y = _out_of_penalty_areas(x, y)
        limit = field.HALF_WIDTH - field.BALL_RADIUS
        if y <= -field.HALF_WIDTH:
            y = -limit
        elif y >= field.HALF_WIDTH:
            y = limit
        self._place_ball((x, y, z))
        for side in ("left", "right"):
            clearing.clear_circle(agents, side, (x, y), self.config)
        self.game.set_play_mode("PlayOn")

    # ----- the play modes -----
    def _end_halves(self) -> None:
        game, half_time = self.game, self.config.half_time
        if game.half == 1 and game.clock32 >= half_time:
            game.set_play_mode("BeforeKickOff")
            game.half = 2
        elif game.half == 2 and game.clock32 >= 2 * half_time:
            game.set_play_mode("GameOver")

    def _kick_off(self, agents: Sequence[AgentState], side: str) -> None:
        clearing.clear_for_kick_off(agents, side, self.config)
        if self.game.mode_time > self.config.drop_ball_time:
            self.drop_ball(agents, self.world.ball_position())
        elif self.ball.touched_since(self.game.last_mode_change):
            self.game.set_play_mode("PlayOn")

    def _play_on(self) -> None:
        ball = self.ball
        if ball.goal is not None:
            self.game.score_for(other(ball.goal))
            return
        if ball.on_field:
            self.spot = (ball.last_valid[0], ball.last_valid[1])
            return
        if ball.last_toucher is None:
            return
        toucher = ball.last_toucher[0]
        x, y, _ = self.world.ball_position()
        if abs(x) >= field.HALF_LENGTH:
            goal_line = "left" if x < 0 else "right"  # whose goal line the ball crossed
            if toucher == goal_line:
                self._award_corner(other(goal_line), y)
            else:
                self._award_goal_kick(goal_line)
        else:
            self._award_kick_in(other(toucher))

    def _award_kick_in(self, side: str) -> None:
        x, y, _ = self.ball.last_valid
        limit = field.HALF_WIDTH - field.BALL_RADIUS
        self.spot = (x, limit if y > 0 else -limit)
        self.game.set_play_mode("KickIn_Left" if side == "left" else "KickIn_Right")

    def _award_goal_kick(self, side: str) -> None:
        sign = -1.0 if side == "left" else 1.0
        self.spot = (sign * (field.HALF_LENGTH - self.config.goal_kick_dist), 0.0)
        self.game.set_play_mode(f"goal_kick_{side}")

    def _award_corner(self, side: str, ball_y: float) -> None:
        """The corner spot is where rcssserver3d 0.7.3 puts it ("temp value for RoboCup 2012"):
        on the goal line halfway between the post and the corner flag, y = +-5.483."""
        r = field.BALL_RADIUS
        sign = 1.0 if side == "left" else -1.0  # the left side's corners are at the right goal
        y = (field.WIDTH + field.GOAL_WIDTH) / 4 - r
        self.spot = (sign * (field.HALF_LENGTH - r), y if ball_y > 0 else -y)
        self.game.set_play_mode(f"corner_kick_{side}")

    def _set_piece(self, agents: Sequence[AgentState], kind: str, side: str) -> None:
        game, config, ball = self.game, self.config, self.ball
        if game.mode_time < config.kick_in_pause_time:
            self._repel_due = True
            return
        if kind == "free_kick":
            self.spot = _out_of_penalty_areas(*self.spot)
        if kind == "goal_kick":
            clearing.clear_penalty_area(agents, side, config)
        else:
            clearing.clear_circle(agents, other(side), self.spot, config)
        if game.mode_time > config.drop_ball_time:
            self.drop_ball(agents, (*self.spot, field.BALL_RADIUS))
            return
        if kind in _WAIT_FOR_A_TOUCHER and ball.last_toucher is None:
            return
        # the pause's end in float32, the margin added in double, as the real comparison does
        taken_after = float(np.float32(game.last_mode_change) + np.float32(config.kick_in_pause_time))
        taken_after += config.kick_touch_margin
        if not self._repel_due and ball.touched_since(taken_after):
            if kind != "goal_kick" or self._ball_left_penalty_area(side):
                game.set_play_mode("PlayOn")
            return
        if self._repel_due:
            clearing.repel_kickers(agents, side, self.spot, config)
            self._repel_due = False
        self._place_ball((*self.spot, field.BALL_RADIUS))

    def _ball_left_penalty_area(self, side: str) -> bool:
        """A goal kick is taken once the ball is out of the kicker's penalty area: past its front
        line or its sides (or out of the field), not on an edge."""
        area = PENALTY_AREAS[side]
        x, y, _ = self.world.ball_position()
        if area.contains(x, y):
            return False
        if not self.ball.on_field:
            return True
        past_front = x > area.x_max if side == "left" else x < area.x_min
        return past_front or y < area.y_min or y > area.y_max

    def _goal_pause(self, agents: Sequence[AgentState], scorer: str) -> None:
        clearing.clear_for_kick_off(agents, other(scorer), self.config)
        if self.game.mode_time < self.config.goal_pause_time:
            return
        self._place_ball((0.0, 0.0, field.BALL_RADIUS))
        self.game.kick_off(other(scorer))

    def _place_ball(self, at: Vec3) -> None:
        """The ball put still at ``at``; the next set piece's spot is under it."""
        self.world.set_ball(at, (0.0, 0.0, 0.0))
        self.spot = (at[0], at[1])
