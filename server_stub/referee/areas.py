"""The field's areas as the referee tests them: halves, penalty areas, goal boxes, the field's
bounds for the ball, and a robot's footprint (docs/robot_and_server.md sections 7 and 8)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from server_stub import field
from server_stub.physics.robot import Robot

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle on the ground, edges included (salt's AABB2)."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float

    def contains(self, x: float, y: float) -> bool:
        return self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max

    def intersects(self, other: Rect) -> bool:
        return not (
            self.x_min > other.x_max or self.x_max < other.x_min or self.y_min > other.y_max or self.y_max < other.y_min
        )

    def within_circle(self, radius: float) -> bool:
        """All four corners closer than ``radius`` to the centre spot."""
        r2 = radius * radius
        return all(x * x + y * y < r2 for x in (self.x_min, self.x_max) for y in (self.y_min, self.y_max))

    def near(self, x: float, y: float, radius: float) -> bool:
        """Whether a circle of ``radius`` around (x, y) reaches the rectangle."""
        dx = max(self.x_min - x, 0.0, x - self.x_max)
        dy = max(self.y_min - y, 0.0, y - self.y_max)
        return dx * dx + dy * dy <= radius * radius


#: The referee's halves, oversized by 10 m beyond the lines so that nobody sneaks round behind.
_REACH = 10.0
HALVES = {
    "left": Rect(-field.HALF_LENGTH - _REACH, 0.0, -field.HALF_WIDTH - _REACH, field.HALF_WIDTH + _REACH),
    "right": Rect(0.0, field.HALF_LENGTH + _REACH, -field.HALF_WIDTH - _REACH, field.HALF_WIDTH + _REACH),
}
#: The penalty areas: 1.8 m deep, 6.0 m wide (naosoccersim.rb's PenaltyWidth 3.9 plus the goal's 2.1).
_PENALTY_FRONT = field.HALF_LENGTH - field.PENALTY_DEPTH
PENALTY_AREAS = {
    "left": Rect(-field.HALF_LENGTH, -_PENALTY_FRONT, -field.PENALTY_WIDTH / 2, field.PENALTY_WIDTH / 2),
    "right": Rect(_PENALTY_FRONT, field.HALF_LENGTH, -field.PENALTY_WIDTH / 2, field.PENALTY_WIDTH / 2),
}


def other(side: str) -> str:
    return "right" if side == "left" else "left"


def ball_on_field(ball: Vec3) -> bool:
    """BallStateAspect's test: the ball's centre within the lines grown by its radius and 1 mm."""
    margin = field.BALL_RADIUS + 0.001
    return abs(ball[0]) < field.HALF_LENGTH + margin and abs(ball[1]) < field.HALF_WIDTH + margin


def goal_entered(ball: Vec3) -> str | None:
    """Which goal ('left' at x < 0, 'right') the ball touches the sensor box of: goal.rsg's box
    inside each goal, the goal's depth and width less the ball's diameter, its full height. The
    box begins at x = 15.042, so the ball reaches it once its centre is on the goal line between
    the posts (|y| <= 1.05) and under the bar (z <= 0.842)."""
    r = field.BALL_RADIUS
    if abs(ball[0]) < field.HALF_LENGTH - r:
        return None  # short of both boxes: the test every cycle of play costs
    half = (field.GOAL_DEPTH / 2 - r, field.GOAL_WIDTH / 2 - r, field.GOAL_HEIGHT / 2)
    for side, sign in (("left", -1.0), ("right", 1.0)):
        centre = (sign * (field.HALF_LENGTH + field.GOAL_DEPTH / 2), 0.0, field.GOAL_HEIGHT / 2)
        gap = [max(abs(ball[i] - centre[i]) - half[i], 0.0) for i in range(3)]
        if math.fsum(g * g for g in gap) <= r * r:
            return side
    return None


def footprint(robot: Robot) -> Rect:
    """The rectangle the referee takes a robot to cover: its torso box (``Robot.x_extent``, as
    measured on the real server), as wide in y as in x, which an upright torso is."""
    low, high = robot.x_extent()
    _, y, _ = robot.torso_position()
    half = (high - low) / 2
    return Rect(low, high, y - half, y + half)
