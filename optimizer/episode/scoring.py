"""Where an episode is scored (paper eq. 9), from monitor states alone.

Fitness = 10 x the torso's displacement along the walking direction from where it stood when its
walk began, taken when the robot falls (torso up-vector z < 0.6 or torso height < 0.25 m, the
community's run-benchmark rule) or when ``walk_time`` seconds of game time have passed. A
``Judge`` is fed the monitor states in order and decides from their content alone, so the outcome
does not depend on when the states happen to be read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from optimizer.episode.config import EpisodeConfig, EpisodeResult
from protocol.monitor import MonitorState, RobotPose


@dataclass(frozen=True)
class TracePoint:
    """What the judge saw of the torso in one PlayOn monitor state (``EpisodeRunner(trace=True)``):
    the walk's shape (drift, turning, the moment of a fall), which the score alone hides.
    ``heading`` is the azimuth of the torso's forward axis (deg, atan2 of its y over its x)."""

    game_time: float
    x: float
    y: float
    z: float
    up_z: float
    heading: float


def find_robot(state: MonitorState, side: str, unum: int) -> RobotPose | None:
    for robot in state.robots:
        if robot.team == side and robot.unum == unum:
            return robot
    return None


class Judge:
    """Watches monitor states in order and decides, from their content alone, when and how an
    episode ends; so the outcome does not depend on when the states happen to be read.

    The distance is the torso's displacement from where it stood when the walk began (the first
    PlayOn state), along the configured heading. Not from the configured start: a server moves a
    beam off its target (the left team's beam is clipped to x <= 0, so a stability check's start
    at x = +0.03 lands at 0, and a real server adds up to 5 cm of beam noise), and the torso
    settles away from the beamed point (by a median 2 mm, up to 6 cm for random gaits); measured
    from the target, each of these would be counted as walking."""

    def __init__(self, config: EpisodeConfig, trace: bool = False) -> None:
        self.config = config
        self.result: EpisodeResult | None = None
        self._heading = math.radians(config.heading)
        self._origin: tuple[float, float] | None = None
        #: every PlayOn state judged, when asked for (None otherwise: the search does not pay for it)
        self.trace: list[TracePoint] | None = [] if trace else None

    def feed(self, state: MonitorState) -> None:
        if self.result is not None or state.play_mode != "PlayOn":
            return
        robot = find_robot(state, "left", self.config.unum)
        if robot is None:
            return
        x, y, z = robot.position
        if self._origin is None:
            self._origin = (x, y)
        if self.trace is not None:
            fx, fy = robot.forward[0], robot.forward[1]
            self.trace.append(TracePoint(state.game_time, x, y, z, robot.up[2], math.degrees(math.atan2(fy, fx))))
        fell = robot.up[2] < self.config.fall_up_z or z < self.config.fall_height
        if fell or state.game_time >= self.config.walk_time - 1e-6:
            sx, sy = self._origin
            distance = (x - sx) * math.cos(self._heading) + (y - sy) * math.sin(self._heading)
            t = min(state.game_time, self.config.walk_time)
            speed = distance / t if t > 0 else 0.0
            self.result = EpisodeResult(distance, fell, t, 10.0 * distance, speed)
