"""What the agent knows of the field and of its own head: the landmarks' and the lines' places and
where the camera sits on the body, the fixed facts its localization measures against.

The agent keeps its own copy rather than importing the stand-in's (``server_stub.field``): the
agent plays on the real server, and the stand-in is only one of the servers it may meet
(``tests/test_localization.py`` checks the two agree). Field frame of the left team
(docs/robot_and_server.md section 1): origin at the centre spot, +x towards the goal it attacks,
+y to its left, z up; the right team's frame is this one turned half round (``mirrored``).
"""

from __future__ import annotations

import math

import numpy as np

HALF_LENGTH = 15.0
HALF_WIDTH = 10.0
GOAL_HALF_WIDTH = 1.05
GOAL_HEIGHT = 0.8
PENALTY_DEPTH = 1.8
PENALTY_HALF_WIDTH = 3.0
CENTRE_CIRCLE_RADIUS = 2.0

#: Flags and goal posts by the name the camera gives them (section 7), in the left team's frame.
LANDMARKS: dict[str, tuple[float, float, float]] = {
    "G1L": (-HALF_LENGTH, GOAL_HALF_WIDTH, GOAL_HEIGHT),
    "G2L": (-HALF_LENGTH, -GOAL_HALF_WIDTH, GOAL_HEIGHT),
    "G1R": (HALF_LENGTH, GOAL_HALF_WIDTH, GOAL_HEIGHT),
    "G2R": (HALF_LENGTH, -GOAL_HALF_WIDTH, GOAL_HEIGHT),
    "F1L": (-HALF_LENGTH, HALF_WIDTH, 0.0),
    "F2L": (-HALF_LENGTH, -HALF_WIDTH, 0.0),
    "F1R": (HALF_LENGTH, HALF_WIDTH, 0.0),
    "F2R": (HALF_LENGTH, -HALF_WIDTH, 0.0),
}


def _lines() -> np.ndarray:
    """The 21 painted segments the camera reports (server_stub/sensors/vision.py): the halfway
    line, the goal lines, the touch lines, each penalty area as three segments and the centre
    circle as ten chords with corners every 36 deg from the +x axis; (n, 2, 2) ends, x and y."""
    front, half = HALF_LENGTH - PENALTY_DEPTH, PENALTY_HALF_WIDTH
    lines = [
        ((0.0, HALF_WIDTH), (0.0, -HALF_WIDTH)),
        ((HALF_LENGTH, -HALF_WIDTH), (HALF_LENGTH, HALF_WIDTH)),
        ((-HALF_LENGTH, -HALF_WIDTH), (-HALF_LENGTH, HALF_WIDTH)),
        ((HALF_LENGTH, HALF_WIDTH), (-HALF_LENGTH, HALF_WIDTH)),
        ((HALF_LENGTH, -HALF_WIDTH), (-HALF_LENGTH, -HALF_WIDTH)),
    ]
    for s in (-1.0, 1.0):
        lines += [
            ((s * front, half), (s * front, -half)),
            ((s * front, half), (s * HALF_LENGTH, half)),
            ((s * front, -half), (s * HALF_LENGTH, -half)),
        ]
    r = CENTRE_CIRCLE_RADIUS
    corners = [(r * math.cos(math.radians(36 * k)), r * math.sin(math.radians(36 * k))) for k in range(11)]
    lines += [(corners[k], corners[k + 1]) for k in range(10)]
    return np.array(lines, dtype=float)


#: The field's lines, (n, 2, 2): segment, end, (x, y); all lie on the ground (z 0).
LINES: np.ndarray = _lines()
LINES.flags.writeable = False


def mirrored(landmarks: dict[str, tuple[float, float, float]]) -> dict[str, tuple[float, float, float]]:
    """The landmarks in the right team's frame: the field turned half round about the centre
    spot (the camera names a flag by where it stands, not by whose half it is in). The lines
    are symmetric under this turn, so only the named landmarks move."""
    return {name: (-x, -y, z) for name, (x, y, z) in landmarks.items()}


# The head on the torso (docs/robot_and_server.md sections 2-3, type 0): the neck's yaw hinge he1
# (about the torso's z) at 0.09 m above the torso centre, the pitch hinge he2 (about the neck's x,
# to the right) at 0.15 m, and the camera at the head's centre, 0.005 m above the pitch hinge.
NECK_PITCH_HEIGHT = 0.15
CAMERA_ABOVE_PITCH = 0.005
