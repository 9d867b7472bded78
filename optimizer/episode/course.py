"""The course objective: a walk to a list of poses in order, scored by the time it takes.

A robot in a game walks to poses, not 15 s in a straight line. A course file says where it is
beamed, which poses it must reach in order, how close counts as reached and how long it may take::

    {"format": "course/1", "start": [-12, 0, 0],
     "poses": [[-6, 0, 0], [-6, 3, 0], ...], "reach": [0.25, 15], "time_limit": 120}

(field coordinates: x towards the opponent goal, y left, metres; headings in degrees, 0 = +x).
A pose is reached when the torso is within ``reach[0]`` metres of its (x, y) and its heading
within ``reach[1]`` degrees of its heading; then the next pose counts. The walk ends at the last
pose, at a fall (the judge's fall rule of eq. 9) or at ``time_limit`` seconds of game time.

Score (higher is better, as the search wants): a course's *size* is the sum of its legs' sizes,
a leg's size its length plus ``TURN_METRES`` per radian its heading turns (a turn on the spot is
work too). A walk that does not finish scores 10 x the metres of course done: the legs reached
and the part of the current leg no longer left to go. A finished walk scores 10 x the size times
(2 - time / time_limit): always more than any unfinished walk, and more the faster it was.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from optimizer.episode.config import EpisodeConfig, EpisodeResult
from optimizer.episode.scoring import TracePoint, fallen, heading_of, judged_robot, thinned_track
from protocol.monitor import MonitorState

#: The format name a course file must carry.
FORMAT = "course/1"
#: A pose on the field: x, y (m) and heading (deg).
Pose = tuple[float, float, float]
#: Metres of course a radian of turning counts as (a leg's size; about what a walk covers while it
#: turns that far).
TURN_METRES = 0.5


class CourseError(ValueError):
    """A course file or document that is not a usable course; the message says which field and why."""


def _angle_error(a_deg: float, b_deg: float) -> float:
    """|a - b| in degrees, the short way round (0-180)."""
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


def _pose(value: Any, what: str) -> Pose:
    if not (isinstance(value, list) and len(value) == 3 and all(_finite(v) for v in value)):
        raise CourseError(f"{what} must be [x, y, deg], three numbers, found {json.dumps(value)[:60]}")
    return float(value[0]), float(value[1]), float(value[2])


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Course:
    """A course: the beam pose, the poses to reach in order, what counts as reached, the time allowed."""

    start: Pose
    poses: tuple[Pose, ...]
    reach: tuple[float, float] = (0.25, 15.0)
    time_limit: float = 120.0

    def __post_init__(self) -> None:
        if not self.poses:
            raise CourseError('"poses" must hold at least one pose')
        metres, degrees = self.reach
        if not (metres > 0 and 0 < degrees <= 180):
            raise CourseError(f'"reach" must be [metres > 0, degrees in (0, 180]], found {list(self.reach)}')
        if not self.time_limit > 0:
            raise CourseError(f'"time_limit" must be > 0 s, found {self.time_limit}')

    @classmethod
    def from_document(cls, document: Any) -> Course:
        if not isinstance(document, dict):
            raise CourseError("a course is a JSON object")
        if document.get("format") != FORMAT:
            raise CourseError(f'"format" must be "{FORMAT}", found {json.dumps(document.get("format"))}')
        unknown = set(document) - {"format", "start", "poses", "reach", "time_limit", "name"}
        if unknown:
            raise CourseError(f"unknown field(s) {', '.join(sorted(unknown))}")
        poses = document.get("poses")
        if not isinstance(poses, list):
            raise CourseError('"poses" must be a list of [x, y, deg]')
        reach = document.get("reach", [0.25, 15.0])
        if not (isinstance(reach, list) and len(reach) == 2 and all(map(_finite, reach))):
            raise CourseError(f'"reach" must be [metres, degrees], found {json.dumps(reach)[:60]}')
        limit = document.get("time_limit", 120.0)
        if not _finite(limit):
            raise CourseError(f'"time_limit" must be a number of seconds, found {json.dumps(limit)[:60]}')
        return cls(
            start=_pose(document.get("start"), '"start"'),
            poses=tuple(_pose(p, f'"poses"[{i}]') for i, p in enumerate(poses)),
            reach=(float(reach[0]), float(reach[1])),
            time_limit=float(limit),
        )

    @classmethod
    def load(cls, path: str | Path) -> Course:
        """The course in a file; ``CourseError`` naming the file and the problem otherwise."""
        try:
            document = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise CourseError(f"{path}: cannot read a course: {exc}") from None
        try:
            return cls.from_document(document)
        except CourseError as exc:
            raise CourseError(f"{path}: {exc}") from None

    def to_document(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "start": list(self.start),
            "poses": [list(p) for p in self.poses],
            "reach": list(self.reach),
            "time_limit": self.time_limit,
        }

    def leg_sizes(self) -> tuple[float, ...]:
        """Each leg's size (m): from the previous pose (the start for the first) to its pose."""
        corners = (self.start, *self.poses)
        return tuple(_leg_size(a, b) for a, b in zip(corners, corners[1:]))

    @property
    def size(self) -> float:
        return sum(self.leg_sizes())

    def reached(self, pose: Pose, index: int) -> bool:
        """Whether the torso at ``pose`` has reached pose ``index``."""
        x, y, heading = self.poses[index]
        return math.hypot(pose[0] - x, pose[1] - y) <= self.reach[0] and _angle_error(pose[2], heading) <= self.reach[1]

    def fitness(self, reached: int, left_in_leg: float, time: float) -> float:
        """The score of a walk that reached ``reached`` poses, with ``left_in_leg`` metres of
        the current leg still to go (ignored once all are reached), after ``time`` seconds."""
        sizes = self.leg_sizes()
        if reached >= len(self.poses):
            return 10.0 * self.size * (2.0 - min(time, self.time_limit) / self.time_limit)
        leg = sizes[reached]
        done = sum(sizes[:reached]) + leg * max(0.0, 1.0 - left_in_leg / leg if leg > 0 else 0.0)
        return 10.0 * done


def _leg_size(a: Pose, b: Pose) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1]) + TURN_METRES * math.radians(_angle_error(a[2], b[2]))


def left_to_go(course: Course, pose: Pose, index: int) -> float:
    """Metres (turning counted as ``TURN_METRES`` a radian) from ``pose`` to pose ``index``."""
    return _leg_size(pose, course.poses[index])


class CourseJudge:
    """The course's judge: fed monitor states in order, it follows the torso from pose to pose and
    ends the walk at the last pose, a fall or the time limit (``EpisodeConfig.course``). Its
    ``result`` is an ``EpisodeResult`` whose ``distance`` is the metres of course done, with
    ``finished``, ``reached`` (poses) and ``legs`` (the game time each was reached)."""

    def __init__(self, config: EpisodeConfig, trace: bool = False) -> None:
        if config.course is None:
            raise ValueError("a CourseJudge needs an episode config with a course")
        self.config = config
        self.course: Course = config.course
        self.result: EpisodeResult | None = None
        self.legs: list[float] = []
        self.trace: list[TracePoint] | None = [] if trace else None

    def feed(self, state: MonitorState) -> None:
        robot = None if self.result is not None else judged_robot(state, self.config.unum)
        if robot is None:
            return
        x, y, _ = robot.position
        heading = heading_of(robot)
        if self.trace is not None:
            self.trace.append(TracePoint.of(state.game_time, robot))
        course, now = self.course, state.game_time
        while len(self.legs) < len(course.poses) and course.reached((x, y, heading), len(self.legs)):
            self.legs.append(now)
        fell = fallen(robot, self.config)
        finished = len(self.legs) == len(course.poses)
        if finished or fell or now >= course.time_limit - 1e-6:
            t = min(now, course.time_limit)
            left = 0.0 if finished else left_to_go(course, (x, y, heading), len(self.legs))
            fitness = course.fitness(len(self.legs), left, t)
            done = fitness / 10.0 if not finished else course.size
            track = None if self.trace is None else thinned_track(self.trace)
            speed = done / t if t > 0 else 0.0
            self.result = EpisodeResult(
                done,
                fell,
                t,
                fitness,
                speed,
                finished=finished,
                reached=len(self.legs),
                legs=tuple(self.legs),
                track=track,
            )


def leg_durations(legs: Sequence[float]) -> list[float]:
    """Each reached leg's own duration (s) from the times its poses were reached (the walk's
    start, game time 0, before the first)."""
    times = (0.0, *legs)
    return [b - a for a, b in zip(times, times[1:])]
