"""Walking to a pose: the pose error turned into a walk command each cycle.

The robot goes to its poses in order. On the way to one it either keeps the pose's heading and
walks there in whatever direction that takes (forward, sideways, backwards, any mix), or, when
that is slower, turns to face its way, walks forward and turns to the pose's heading near the end:
the plan is chosen when a leg begins, by the time each would take at the walk's top speeds
(``Steerable.max_command``). Speed falls with the distance left, to ``pass_speed`` at a pose that
is not the last (the walk goes on through it) and to a stand at the last one.

The pose it steers by comes from a ``PoseSource`` (``agent.localization``); a pose counts as
reached by the agent's own ``reach``, tighter than a course's, since what it believes is not quite
where it is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from agent.localization import Pose, PoseSource, readable_vision
from gait import Command
from protocol.perception import Perception


@dataclass(frozen=True)
class GotoConfig:
    #: The agent counts a pose reached within these metres and degrees of it (by its own estimate).
    reach: tuple[float, float] = (0.12, 7.0)
    #: Speed (m/s) per metre left, and turn rate (deg/s) per degree of heading error: the
    #: approach's stiffness, in speeds walked (a calibrated walk walks what it is commanded,
    #: ``gait.omni``). Set for the shipped walk on the stand-in's courses (the issue's and a short
    #: one of three tight legs, 80 and 600 dithered walks): stiffer, it overshoots a pose and falls
    #: turning back to it more often.
    gain: float = 0.9
    turn_gain: float = 1.85
    #: The speed (m/s) at which the walk passes a pose that is not the last one.
    pass_speed: float = 0.23
    #: A leg is walked facing its way only when that saves this share of the time, and only
    #: farther than ``face_beyond`` metres from the pose; the last metres are walked in the pose's
    #: heading.
    face_saving: float = 0.2
    face_beyond: float = 0.8
    #: While walking and turning at once the translation is slowed by this much per radian of
    #: heading error (a walk turning fast while stepping far falls).
    turn_slowdown: float = 0.5


def wrapped(degrees: float) -> float:
    """An angle in (-180, 180]."""
    return -((-degrees + 180.0) % 360.0 - 180.0)


def in_torso_frame(dx: float, dy: float, heading_deg: float) -> tuple[float, float]:
    """A field-frame displacement as (forward, left) of a torso facing ``heading_deg``."""
    h = math.radians(heading_deg)
    c, s = math.cos(h), math.sin(h)
    return dx * c + dy * s, -dx * s + dy * c


#: A top speed below this counts as this (a walk that cannot go one way is not divided by zero).
_SLOWEST = 1e-3


class ServerPoseWhereSent:
    """The server's ground truth where it sends it, else the robot's own estimate: which one is
    decided by the first perception with vision (``mypos`` in it or not); both are kept until then."""

    def __init__(self, true: PoseSource, own: PoseSource) -> None:
        self._candidates: tuple[PoseSource, ...] = (true, own)
        self._true = true

    def update(self, perception: Perception, odometry: Command) -> None:
        for source in self._candidates:
            source.update(perception, odometry)
        vision = readable_vision(perception)
        if vision is not None and len(self._candidates) == 2:
            self._candidates = (self._candidates[0] if vision.mypos is not None else self._candidates[1],)

    def reset(self, start: Pose) -> None:
        for source in self._candidates:
            source.reset(start)

    @property
    def uses_server_pose(self) -> bool:
        return self._candidates[0] is self._true

    @property
    def pose(self) -> Pose:
        return self._candidates[0].pose


def _omni_time(forward: float, left: float, turn: float, top: Command, backward: float) -> float:
    """Seconds to cover (forward, left) and turn ``turn`` degrees at once at the top speeds."""
    return max(
        abs(forward) / max(top.forward if forward >= 0 else backward, _SLOWEST),
        abs(left) / max(top.left, _SLOWEST),
        abs(turn) / max(top.turn, _SLOWEST),
    )


class GoTo:
    """The poses to walk to and where the walk is along them; ``command`` is asked once a cycle
    with the current pose estimate."""

    def __init__(self, poses: Sequence[Pose], config: GotoConfig = GotoConfig()) -> None:
        self.poses = tuple(poses)
        self.config = config
        #: the pose being walked to (``len(poses)`` once all are reached)
        self.index = 0
        #: the current leg's heading while walking it (None: the pose's own heading)
        self._facing: float | None = None
        self._planned = -1

    @property
    def done(self) -> bool:
        return self.index >= len(self.poses)

    def command(self, pose: Pose, top: Command, backward: float) -> Command:
        """The command that takes the robot from ``pose`` on along the poses (a stand once all
        are reached). ``top`` and ``backward`` are the walk's top speeds."""
        reach_m, reach_deg = self.config.reach
        while not self.done and self._reached(pose, self.poses[self.index], reach_m, reach_deg):
            self.index += 1
        if self.done:
            return Command()
        goal = self.poses[self.index]
        if self._planned != self.index:
            self._facing = self._plan(pose, goal, top, backward)
            self._planned = self.index
        dx, dy = goal[0] - pose[0], goal[1] - pose[1]
        distance = math.hypot(dx, dy)
        if self._facing is not None and distance < self.config.face_beyond:
            self._facing = None  # the last metres in the pose's own heading
        if self._facing is not None:
            self._facing = math.degrees(math.atan2(dy, dx))  # keep aiming at the pose
        heading_error = wrapped((goal[2] if self._facing is None else self._facing) - pose[2])
        return self._towards(dx, dy, distance, pose[2], heading_error, top, backward)

    def _towards(
        self, dx: float, dy: float, distance: float, heading: float, heading_error: float, top: Command, backward: float
    ) -> Command:
        cfg = self.config
        last = self.index == len(self.poses) - 1
        speed = cfg.gain * distance + (0.0 if last else cfg.pass_speed)
        speed /= 1.0 + cfg.turn_slowdown * abs(math.radians(heading_error))
        forward, left = in_torso_frame(dx, dy, heading)
        if distance > 1e-9:
            forward, left = forward / distance * speed, left / distance * speed
        # within the walk's top speeds, keeping the direction: an ellipse of forward/backward and sideways
        reach_forward = max(top.forward if forward >= 0 else backward, _SLOWEST)
        load = math.hypot(forward / reach_forward, left / max(top.left, _SLOWEST))
        if load > 1.0:
            forward, left = forward / load, left / load
        turn = max(-top.turn, min(top.turn, cfg.turn_gain * heading_error))
        return Command(forward, left, turn)

    def _plan(self, pose: Pose, goal: Pose, top: Command, backward: float) -> float | None:
        """Face the leg's way (its heading) or keep the pose's heading (None), whichever is faster."""
        dx, dy = goal[0] - pose[0], goal[1] - pose[1]
        distance = math.hypot(dx, dy)
        if distance <= self.config.face_beyond:
            return None
        forward, left = in_torso_frame(dx, dy, pose[2])
        keep = _omni_time(forward, left, wrapped(goal[2] - pose[2]), top, backward)
        way = math.degrees(math.atan2(dy, dx))
        turning = abs(wrapped(way - pose[2])) + abs(wrapped(goal[2] - way))
        face = turning / max(top.turn, _SLOWEST) + distance / max(top.forward, _SLOWEST)
        return way if face < (1.0 - self.config.face_saving) * keep else None

    @staticmethod
    def _reached(pose: Pose, goal: Pose, metres: float, degrees: float) -> bool:
        return math.hypot(pose[0] - goal[0], pose[1] - goal[1]) <= metres and abs(wrapped(pose[2] - goal[2])) <= degrees
