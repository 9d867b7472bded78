"""The soccer field of the real server's default configuration (naosoccersim.rb;
docs/robot_and_server.md section 7): sizes, landmarks, lines and the ball, in one place for the
physics world, the camera, the monitor header and the referee.

Field frame: origin at the centre spot, +x towards the goal the left team attacks, z up.
"""

from __future__ import annotations

import math

Vec3 = tuple[float, float, float]

LENGTH = 30.0
WIDTH = 20.0
#: The monitor header's FieldHeight (the height of the simulated space).
HEIGHT = 40.0
GOAL_WIDTH = 2.1
GOAL_DEPTH = 0.6
GOAL_HEIGHT = 0.8
PENALTY_DEPTH = 1.8
PENALTY_WIDTH = 6.0
#: Radius of the centre circle (the referee's FreeKickDistance).
CENTRE_CIRCLE_RADIUS = 2.0
BALL_RADIUS = 0.042
BALL_MASS = 0.026
#: How far behind the centre line the referee puts a robot that stands in the other half before
#: kick-off (naosoccersim.rb's FreeKickMoveDist).
FREE_KICK_MOVE_DIST = 2.5
#: naosoccersim.rb's AgentRadius: the torso height of a beam and of an ``init``, and the spacing of
#: the places robots are put at their ``init`` (``game.Game.init_pose``).
AGENT_RADIUS = 0.4

HALF_LENGTH = LENGTH / 2
HALF_WIDTH = WIDTH / 2

#: The flags and goal posts the camera reports, in the order the real server lists them.
LANDMARKS: tuple[tuple[str, Vec3], ...] = (
    ("G1L", (-HALF_LENGTH, GOAL_WIDTH / 2, GOAL_HEIGHT)),
    ("G2L", (-HALF_LENGTH, -GOAL_WIDTH / 2, GOAL_HEIGHT)),
    ("G2R", (HALF_LENGTH, -GOAL_WIDTH / 2, GOAL_HEIGHT)),
    ("G1R", (HALF_LENGTH, GOAL_WIDTH / 2, GOAL_HEIGHT)),
    ("F1L", (-HALF_LENGTH, HALF_WIDTH, 0.0)),
    ("F2L", (-HALF_LENGTH, -HALF_WIDTH, 0.0)),
    ("F1R", (HALF_LENGTH, HALF_WIDTH, 0.0)),
    ("F2R", (HALF_LENGTH, -HALF_WIDTH, 0.0)),
)


def _lines() -> tuple[tuple[Vec3, Vec3], ...]:
    """The field's lines as segments: centre line, goal lines, touch lines, the penalty areas and
    the centre circle as ten chords."""
    box_front, box_half = HALF_LENGTH - PENALTY_DEPTH, PENALTY_WIDTH / 2
    lines: list[tuple[Vec3, Vec3]] = [
        ((0.0, HALF_WIDTH, 0.0), (0.0, -HALF_WIDTH, 0.0)),
        ((HALF_LENGTH, -HALF_WIDTH, 0.0), (HALF_LENGTH, HALF_WIDTH, 0.0)),
        ((-HALF_LENGTH, -HALF_WIDTH, 0.0), (-HALF_LENGTH, HALF_WIDTH, 0.0)),
        ((HALF_LENGTH, HALF_WIDTH, 0.0), (-HALF_LENGTH, HALF_WIDTH, 0.0)),
        ((HALF_LENGTH, -HALF_WIDTH, 0.0), (-HALF_LENGTH, -HALF_WIDTH, 0.0)),
    ]
    for s in (-1.0, 1.0):
        lines += [
            ((s * box_front, box_half, 0.0), (s * box_front, -box_half, 0.0)),
            ((s * box_front, box_half, 0.0), (s * HALF_LENGTH, box_half, 0.0)),
            ((s * box_front, -box_half, 0.0), (s * HALF_LENGTH, -box_half, 0.0)),
        ]
    r = CENTRE_CIRCLE_RADIUS
    corners = [(r * math.cos(math.radians(36 * k)), r * math.sin(math.radians(36 * k)), 0.0) for k in range(11)]
    lines += [(corners[k], corners[k + 1]) for k in range(10)]
    return tuple(lines)


LINES: tuple[tuple[Vec3, Vec3], ...] = _lines()
