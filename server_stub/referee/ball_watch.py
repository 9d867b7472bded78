"""What the referee knows about the ball (rcssserver3d's BallStateAspect): who touched it last and
when, whether it is in the field, where it last was in the field, whether it is in a goal."""

from __future__ import annotations

from collections.abc import Sequence

from server_stub.agent_state import AgentState
from server_stub.physics.world import World
from server_stub.referee.areas import Vec3, ball_on_field, goal_entered


class BallWatch:
    """Filled twice a cycle: ``before_step`` notes what touches the ball as the step begins (the
    collision pass of the real server's step, where its ball and goal sensors record), and
    ``after_step`` turns that into the state the referee reads, at the new game time."""

    def __init__(self) -> None:
        #: (side, unum) of the robot that touched the ball last, and the game time it did
        self.last_toucher: tuple[str, int] | None = None
        self.last_touch_time = 0.0
        self.on_field = True
        #: the ball's last position inside the field (the real server starts it at the origin)
        self.last_valid: Vec3 = (0.0, 0.0, 0.0)
        #: the goal ('left' / 'right') the ball was in as this cycle's step began, if any
        self.goal: str | None = None
        self._touchers: list[tuple[str, int]] = []
        self._goal: str | None = None

    def before_step(self, world: World, agents: Sequence[AgentState]) -> None:
        ball = world.ball_position()
        touching = world.robots_touching_ball(ball)
        self._touchers = []
        if touching:
            sides = {id(s.robot): (s.side, s.unum) for s in agents if s.robot is not None}
            self._touchers = [
                (side, unum)
                for side, unum in (sides.get(id(robot), (None, None)) for robot in touching)
                if side is not None and unum is not None
            ]
        self._goal = goal_entered(ball)

    def after_step(self, game_time: float, ball: Vec3) -> None:
        if self._touchers:
            self.last_toucher = self._touchers[0]
            self.last_touch_time = game_time
        self.on_field = ball_on_field(ball)
        if self.on_field:
            self.last_valid = ball
        self.goal = self._goal

    def touched_since(self, t: float) -> bool:
        """Someone touched the ball after game time ``t``."""
        return self.last_toucher is not None and self.last_touch_time > t

    def forget_touches(self) -> None:
        """The field emptied: the next robots start with a ball nobody has played. (The real
        server remembers the last toucher for its whole life; the stand-in, like its ``init``
        rows, lets an episode not depend on the ones before it.)"""
        self.last_toucher = None
        self.last_touch_time = 0.0
