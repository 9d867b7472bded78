"""Where an episode is scored (paper eq. 9), from monitor states alone.

Fitness = 10 x the torso's displacement along the walking direction from where it stood when its
walk began, taken when the robot falls (torso up-vector z < 0.6 or torso height < 0.25 m, the
community's run-benchmark rule) or when ``walk_time`` seconds of game time have passed. A
``Judge`` is fed the monitor states in order and decides from their content alone, so the outcome
does not depend on when the states happen to be read.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

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

    @classmethod
    def of(cls, game_time: float, robot: RobotPose) -> TracePoint:
        """The torso of ``robot`` as the judge sees it at ``game_time``."""
        x, y, z = robot.position
        return cls(game_time, x, y, z, robot.up[2], heading_of(robot))

    def rounded(self) -> tuple[float, ...]:
        """The point as ``TRACK_FIELDS``, to 4 decimals (0.1 mm, 1e-4 deg): a log's size, not a loss."""
        return tuple(round(v, 4) for v in (self.game_time, self.x, self.y, self.z, self.up_z, self.heading))


#: The forward axis's azimuth is the robot's heading only while the torso is upright: a torso
#: tipping over swings it by tens of degrees in a few states (up z 0.8 = 37 deg of tilt).
UPRIGHT_UP_Z = 0.8


def heading_change(track: Sequence[TracePoint], upright_up_z: float = UPRIGHT_UP_Z) -> float:
    """Degrees the torso turned about the vertical from the first traced state to the last one in
    which it was still upright (up z >= ``upright_up_z``), left positive; unwrapped, so a walk
    that turns past +-180 deg is not read as a small turn."""
    upright = [i for i, p in enumerate(track) if p.up_z >= upright_up_z]
    if len(track) < 2 or not upright:
        return 0.0
    headings = np.unwrap(np.radians([p.heading for p in track[: upright[-1] + 1]]))
    return float(math.degrees(headings[-1] - headings[0]))


def sideways_drift(track: Sequence[TracePoint], heading_deg: float) -> float:
    """Metres the torso ended to the left (+) or right (-) of the line it started on, the line
    along ``heading_deg`` through where it stood in the first traced state."""
    if len(track) < 2:
        return 0.0
    return left_of(track[-1].x - track[0].x, track[-1].y - track[0].y, math.radians(heading_deg))


def left_of(dx: float, dy: float, heading_rad: float) -> float:
    """How far a displacement (dx, dy) lies to the left (+) of the direction ``heading_rad``."""
    return -dx * math.sin(heading_rad) + dy * math.cos(heading_rad)


#: A traced walk's track keeps every this many monitor states (0.2 s at the servers' 0.04 s) and the
#: last: enough to draw the walk and see where it fell, at ~4 kB a 15-s walk in the episode log.
TRACK_EVERY = 5
#: What each point of a kept track holds (``TracePoint``'s fields, in its order).
TRACK_FIELDS = ("game_time", "x", "y", "z", "up_z", "heading")


def heading_of(robot: RobotPose) -> float:
    """The azimuth of the torso's forward axis (deg): the robot's heading while it is upright."""
    return math.degrees(math.atan2(robot.forward[1], robot.forward[0]))


def fallen(robot: RobotPose, config: EpisodeConfig) -> bool:
    """The community's run-benchmark fall rule: torso up-vector z or torso height too low."""
    return robot.up[2] < config.fall_up_z or robot.position[2] < config.fall_height


def judged_robot(state: MonitorState, unum: int) -> RobotPose | None:
    """The left team's robot ``unum`` in a state a judge counts (PlayOn), else None."""
    return find_robot(state, "left", unum) if state.play_mode == "PlayOn" else None


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
        robot = None if self.result is not None else judged_robot(state, self.config.unum)
        if robot is None:
            return
        x, y, _ = robot.position
        if self._origin is None:
            self._origin = (x, y)
        if self.trace is not None:
            self.trace.append(TracePoint.of(state.game_time, robot))
        fell = fallen(robot, self.config)
        if fell or state.game_time >= self.config.walk_time - 1e-6:
            sx, sy = self._origin
            distance = (x - sx) * math.cos(self._heading) + (y - sy) * math.sin(self._heading)
            t = min(state.game_time, self.config.walk_time)
            speed = distance / t if t > 0 else 0.0
            fitness = 10.0 * distance
            if self.config.drift_penalty:
                drift = left_of(x - sx, y - sy, self._heading)  # what ``sideways_drift`` gives a traced walk
                fitness = 10.0 * (distance - self.config.drift_penalty * abs(drift))
            self.result = EpisodeResult(distance, fell, t, fitness, speed, **self._shape())

    def _shape(self) -> dict[str, Any]:
        """A traced walk's drift, turn and thinned track (nothing for an untraced one)."""
        if self.trace is None:
            return {}
        return {
            "drift": sideways_drift(self.trace, self.config.heading),
            "heading_change": heading_change(self.trace),
            "track": thinned_track(self.trace),
        }


def thinned_track(trace: Sequence[TracePoint]) -> tuple[tuple[float, ...], ...]:
    """Every ``TRACK_EVERY``-th traced point and the last, rounded: what an episode log keeps."""
    kept = list(trace[::TRACK_EVERY])
    if trace and kept[-1] is not trace[-1]:
        kept.append(trace[-1])
    return tuple(point.rounded() for point in kept)
