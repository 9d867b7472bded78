"""Where the robot stands: the torso's x, y and heading in the field frame, every cycle.

Two sources behind one interface (``PoseSource``), both fed once per cycle with the perception
and the walk engine's odometry (its planned displacement since the last cycle):

- ``TruePose`` reads the server's ground truth where it sends it (``mypos``/``myorien`` inside
  ``See``, every third cycle, when the server is set to send them): the head's centre and heading,
  moved to the torso through the neck angles and the torso's tilt.
- ``VisionPose`` estimates the pose from what the camera sees: the named flags and goal posts,
  and the field lines matched to the known ones. Each vision cycle fits the torso's full pose
  (x, y, heading, height, pitch, roll) to every seen point by Gauss-Newton, with the predicted
  pose and the accelerometer's tilt as a prior: an iterated Kalman update. The lines carry most
  of the information where few flags are in view: every seen line point lies on the ground (the
  camera's height and tilt), lies on its matched line (the position across it and the heading),
  and a line end the view did not cut is the line's end (the position along it).

Between vision cycles both carry the pose with the odometry, turned by the gyro's yaw rate: the
gyro is exact in the server, the walk engine's planned turn is not.

Frames (docs/robot_and_server.md section 1): the field frame of the robot's own team (the right
team's is turned half round, as its beam and ``mypos`` are); the torso frame x right, y forward,
z up; heading 0 along field +x, left positive.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Protocol

import numpy as np

from agent import pose_fit
from agent.field_model import CAMERA_ABOVE_PITCH, LANDMARKS, LINES, NECK_PITCH_HEIGHT, mirrored
from gait import Command
from protocol.errors import ProtocolError
from protocol.nao import CYCLE
from protocol.perception import Perception, Vision

Pose = tuple[float, float, float]


def readable_vision(perception: Perception) -> Vision | None:
    """This cycle's See, or None: also when it cannot be read. The real server now and then
    prints ``nan`` for a line end (seen once in some 20,000 cycles, a robot beamed along the
    course), and the parser refuses the whole See then; that cycle counts as one without vision."""
    try:
        return perception.vision
    except ProtocolError:
        return None


class PoseSource(Protocol):
    """The torso's pose in the field frame, kept up to date once per cycle."""

    def update(self, perception: Perception, odometry: Command) -> None:
        """This cycle's perception and the walk's planned displacement since the last cycle
        (forward m, left m, turn deg in the torso frame)."""
        ...

    @property
    def pose(self) -> Pose:
        """The torso's x, y (m) and heading (deg, 0 = +x, left positive, in [-180, 180))."""
        ...

    def reset(self, start: Pose) -> None:
        """The robot was beamed to ``start`` (x m, y m, heading deg): the estimate starts again
        there, as uncertain as a beam's noise makes it."""
        ...


@dataclass(frozen=True)
class LocalizationConfig:
    """How much the estimator trusts each source; the camera's figures are the server's
    (docs/robot_and_server.md section 5)."""

    #: turn by the gyro's yaw rate rather than the odometry's planned turn
    use_gyro: bool = True
    #: how far each cycle's tilt moves towards the accelerometer's (a 1-s time constant)
    acc_weight: float = 0.02
    #: a seen point's error across the line of sight per metre of distance (the angle noise,
    #: about 0.15 deg, plus some for the torso's motion within the cycle)
    angle_sigma: float = 0.003
    #: a seen point's error at any distance: the camera's fixed offset (up to 5 mm per axis)
    #: and the printed two decimals
    point_sigma: float = 0.008
    #: a line end farther out than this (deg) from the view's centre was cut by the view's edge
    #: (60 deg), so it is a point of the line but not its end
    cut_margin_deg: float = 59.0
    #: seen line pieces shorter than this (m) are only used as ground points, not matched
    min_line_length: float = 0.3
    #: a seen line matches a known line when both its ends lie within this (m) of it, widened by
    #: ``match_sigmas`` times the pose's uncertainty at the line's distance, capped at ``max_gate``
    match_gate: float = 0.25
    match_sigmas: float = 3.0
    max_gate: float = 1.5
    #: Gauss-Newton steps per vision cycle (the first two with the named landmarks only)
    iterations: int = 5
    #: the torso centre's height (m) and the spread allowed around it
    torso_height: float = 0.37
    height_sigma: float = 0.05
    #: the accelerometer's tilt is trusted to within this (deg)
    tilt_sigma_deg: float = 4.0
    #: uncertainty of the start pose (the server's beam adds up to 0.05 m and 10 deg)
    start_sigma_xy: float = 0.05
    start_sigma_deg: float = 7.0
    #: odometry's error per cycle (m, deg) plus per metre moved and per degree turned
    cycle_sigma_xy: float = 0.015
    cycle_sigma_deg: float = 0.3
    moved_sigma: float = 0.2
    turned_sigma: float = 0.1
    #: a fit this far (in the prior's standard deviations) from the prediction is not trusted
    max_innovation: float = 12.0
    #: how much a rejected fit widens the prior, so that a lost robot finds itself again
    reject_inflation: float = 4.0


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def torso_rotation(heading: float, pitch: float, roll: float) -> np.ndarray:
    """The torso's axes in the field (columns x right, y forward, z up) for a heading, pitch
    (about its x, nose up positive) and roll (about its y), radians. The heading is exactly the
    direction of the forward axis on the ground."""
    return _rz(heading - math.pi / 2) @ _rx(pitch) @ _ry(roll)


def tilt(up: tuple[float, float, float]) -> tuple[float, float]:
    """(pitch, roll) in radians of a torso whose frame sees the world's up direction as ``up``:
    ``torso_rotation``'s transpose maps (0, 0, 1) to (-sin r cos p, sin p, cos r cos p)."""
    return math.asin(max(-1.0, min(1.0, up[1]))), math.atan2(-up[0], up[2])


@lru_cache(maxsize=8)
def _neck(yaw_deg: float, pitch_deg: float) -> tuple[np.ndarray, np.ndarray]:
    a, b = math.radians(yaw_deg), math.radians(pitch_deg)
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    rotation = np.array([[ca, -sa * cb, sa * sb], [sa, ca * cb, -ca * sb], [0.0, sb, cb]])  # Rz(a) Rx(b)
    camera = np.array([0.0, 0.0, NECK_PITCH_HEIGHT]) + rotation[:, 2] * CAMERA_ABOVE_PITCH
    rotation.flags.writeable = camera.flags.writeable = False
    return rotation, camera


def neck(joints: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The head's rotation in the torso frame and the camera's position there, from the neck's
    yaw (hj1) and pitch (hj2) perceptors in degrees (0 where absent). Cached: a head that does
    not move asks for the same ones every time."""
    return _neck(joints.get("hj1", 0.0), joints.get("hj2", 0.0))


def _known_lines() -> np.ndarray:
    """The field's lines as ``pose_fit`` takes them: start x, y, unit direction x, y, length."""
    start, end = LINES[:, 0], LINES[:, 1]
    length = np.hypot(*(end - start).T)
    return np.column_stack((start, (end - start) / length[:, None], length))


_KNOWN_LINES = _known_lines()


def _wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


class _Attitude:
    """The world's up direction in the torso frame: the gyro (exact in the server) turns it each
    cycle and every accelerometer reading pulls it a little towards the gravity it reads.

    Unlike the fall detector's filter it takes every reading: walking the fastest gait, fewer
    than one reading in ten is within 30 % of 1 g, and a filter fed only those kept a start
    error (its first reading, taken while the robot settled) for many seconds, 14 deg of pitch
    (0.155 m x sin 14 deg = 4 cm of head offset). The torso's own accelerations average out
    over a step. It starts upright, as a robot stands after a beam."""

    def __init__(self, weight: float) -> None:
        self._weight = weight
        self.up = (0.0, 0.0, 1.0)

    def update(self, acc: tuple[float, float, float] | None, gyro: tuple[float, float, float] | None) -> None:
        """One cycle's accelerometer (m/s^2) and gyro (deg/s), both in the torso frame."""
        ux, uy, uz = self.up
        if gyro is not None:  # a direction fixed in the world turns by -w x up in the torso frame
            wx, wy, wz = (math.radians(g) * CYCLE for g in gyro)
            ux, uy, uz = ux - (wy * uz - wz * uy), uy - (wz * ux - wx * uz), uz - (wx * uy - wy * ux)
        if acc is not None:
            norm = math.sqrt(acc[0] ** 2 + acc[1] ** 2 + acc[2] ** 2)
            if norm > 0.0:
                k, keep = self._weight / norm, 1.0 - self._weight
                ux, uy, uz = keep * ux + k * acc[0], keep * uy + k * acc[1], keep * uz + k * acc[2]
        norm = math.sqrt(ux * ux + uy * uy + uz * uz)
        self.up = (ux / norm, uy / norm, uz / norm)


class _Tracker:
    """What both sources share: the torso's tilt (gyro and accelerometer), the team's side, and
    the pose carried by odometry between vision cycles."""

    def __init__(self, start: Pose, config: LocalizationConfig, side: str) -> None:
        self.config = config
        self._x, self._y, self._heading = start[0], start[1], math.radians(start[2])
        self._attitude = _Attitude(config.acc_weight)
        #: the team's side, "left" or "right"; the first GS after ``init`` names it
        self.side = side

    def reset(self, start: Pose) -> None:
        self._x, self._y, self._heading = start[0], start[1], math.radians(start[2])

    @property
    def pose(self) -> Pose:
        return (self._x, self._y, _wrap_deg(math.degrees(self._heading)))

    def _advance(self, perception: Perception, odometry: Command) -> tuple[float, float, float]:
        """Carry the pose by one cycle's motion; returns it (forward m, left m, turn rad)."""
        if perception.game.team is not None:
            self.side = perception.game.team
        gyro = perception.gyro
        self._attitude.update(perception.acc, gyro)
        if gyro is not None and self.config.use_gyro:
            # the yaw rate about the world's vertical, whatever the torso's tilt
            up = self._attitude.up
            turn = math.radians(gyro[0] * up[0] + gyro[1] * up[1] + gyro[2] * up[2]) * CYCLE
        else:
            turn = math.radians(odometry.turn)
        forward, left = odometry.forward, odometry.left
        middle = self._heading + 0.5 * turn
        c, s = math.cos(middle), math.sin(middle)
        self._x += c * forward - s * left
        self._y += s * forward + c * left
        self._heading += turn
        return forward, left, turn


class TruePose(_Tracker):
    """The server's ground truth, moved from the head to the torso, carried by odometry and the
    gyro between the vision cycles that bring it."""

    def __init__(self, start: Pose, config: LocalizationConfig = LocalizationConfig(), side: str = "left") -> None:
        super().__init__(start, config, side)

    def update(self, perception: Perception, odometry: Command) -> None:
        self._advance(perception, odometry)
        vision = readable_vision(perception)
        if vision is None or vision.mypos is None or vision.myorien is None:
            return
        pitch, roll = tilt(self._attitude.up)
        rotation, camera = neck(perception.joints)
        # the head's forward axis in a torso frame turned to heading 90 deg (no turn about z):
        # the whole rotation adds (heading - 90 deg) to its direction on the ground
        forward = _rx(pitch) @ _ry(roll) @ rotation[:, 1]
        heading = math.radians(vision.myorien) + math.pi / 2 - math.atan2(forward[1], forward[0])
        torso = np.asarray(vision.mypos) - torso_rotation(heading, pitch, roll) @ camera
        self._x, self._y, self._heading = float(torso[0]), float(torso[1]), heading


class VisionPose(_Tracker):
    """The robot's own estimate from its camera, odometry and gyro: an extended Kalman filter on
    (x, y, heading) whose vision update is the Gauss-Newton fit described in the module
    docstring."""

    def __init__(self, start: Pose, config: LocalizationConfig = LocalizationConfig(), side: str = "left") -> None:
        super().__init__(start, config, side)
        c = config
        #: the covariance over (x m, y m, heading rad) as its six numbers xx, xy, xh, yy, yh, hh:
        #: kept as floats, so that a cycle without vision costs a few multiplications
        self._cov = self._start_cov = (
            c.start_sigma_xy**2,
            0.0,
            0.0,
            c.start_sigma_xy**2,
            0.0,
            math.radians(c.start_sigma_deg) ** 2,
        )
        self._landmarks: dict[str, tuple[float, float, float]] = LANDMARKS
        self._landmark_side = "left"
        self._settings = np.array(
            [
                c.point_sigma,
                c.angle_sigma,
                math.tan(math.radians(c.cut_margin_deg)),
                c.match_gate,
                c.match_sigmas,
                c.max_gate,
                c.min_line_length,
                c.height_sigma,
                math.radians(c.tilt_sigma_deg),
            ]
        )
        #: how many vision fits were used and how many were rejected
        self.accepted = 0
        self.rejected = 0
        pose_fit.warm_up()  # compiled (or loaded) here, at the beam, not in a walking cycle

    def reset(self, start: Pose) -> None:
        super().reset(start)
        self._cov = self._start_cov

    @property
    def covariance(self) -> np.ndarray:
        """The estimate's covariance over (x m, y m, heading rad)."""
        xx, xy, xh, yy, yh, hh = self._cov
        return np.array([[xx, xy, xh], [xy, yy, yh], [xh, yh, hh]])

    def update(self, perception: Perception, odometry: Command) -> None:
        forward, left, turn = self._advance(perception, odometry)
        c = self.config
        # P <- F P F' + Q, F the motion's Jacobian: identity but for the heading's column (a, b)
        h = self._heading - 0.5 * turn
        cos, sin = math.cos(h), math.sin(h)
        a, b = -sin * forward - cos * left, cos * forward - sin * left
        xx, xy, xh, yy, yh, hh = self._cov
        sxy = c.cycle_sigma_xy + c.moved_sigma * math.hypot(forward, left)
        sh = math.radians(c.cycle_sigma_deg) + c.turned_sigma * abs(turn)
        self._cov = (
            xx + 2.0 * a * xh + a * a * hh + sxy * sxy,
            xy + a * yh + b * xh + a * b * hh,
            xh + a * hh,
            yy + 2.0 * b * yh + b * b * hh + sxy * sxy,
            yh + b * hh,
            hh + sh * sh,
        )
        vision = readable_vision(perception)
        if vision is not None:
            self._correct(vision, perception.joints)

    def _correct(self, vision: Vision, joints: Mapping[str, float]) -> None:
        """The vision update (``agent.pose_fit``); a fit that moves the pose too far from the
        prediction is dropped and the prediction's uncertainty widened instead."""
        if self.side != self._landmark_side:
            self._landmarks = mirrored(LANDMARKS) if self.side == "right" else LANDMARKS
            self._landmark_side = self.side
        landmarks = self._landmarks
        places = [landmarks[name] for name in vision.objects if name in landmarks]
        if not places and not vision.lines:
            return
        # the numbers as one flat list: numpy reads a list of named tuples ten times slower
        seen = [v for name, p in vision.objects.items() if name in landmarks for v in p]
        seen += [v for line in vision.lines for p in line for v in p]
        rotation, camera = neck(joints)
        c = self.config
        pitch, roll = tilt(self._attitude.up)
        state, cov, distance2 = pose_fit.fit(
            np.array(seen).reshape(-1, 3),
            rotation,
            camera,
            np.array(places, dtype=float).reshape(-1, 3),
            _KNOWN_LINES,
            np.array([self._x, self._y, self._heading, c.torso_height, pitch, roll]),
            self.covariance,
            self._settings,
            c.iterations,
        )
        if distance2 > c.max_innovation**2:
            self.rejected += 1
            k = c.reject_inflation
            xx, xy, xh, yy, yh, hh = self._cov
            self._cov = (k * xx, k * xy, k * xh, k * yy, k * yh, k * hh)
            return
        self.accepted += 1
        self._x, self._y, self._heading = float(state[0]), float(state[1]), float(state[2])
        xx, xy, xh, yy, yh, hh = cov[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist()
        self._cov = (xx, xy, xh, yy, yh, hh)
