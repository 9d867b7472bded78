"""``omni``: an omnidirectional walk engine. It walks the command it is given (forward, sideways,
turning, any mix), starts from standing, stops to standing, and keeps the robot up with the gyro.

Why a new family: the TFS families walk one way at one speed, the way their genes fix; a soccer
agent has to go where the ball is. Here the genes describe *how* to step (period, heights, width,
sway, lean, swing shape, top speeds, accelerations, feedback gains, arm swing) and the command
*where*; ``gait.omni_steps`` plans the steps, ``gait.leg_ik`` turns the planned soles (flat,
yawed: turning is le1, its 45-deg axis compensated by the other hip joints) into joint angles.

Feedback (``sense``): the gyro's pitch rate moves both ankle pitches and hip pitches, its roll
rate both ankle rolls; the torso's tilt, read from the accelerometer (smoothed over ~0.1 s: a
walk's own accelerations average out, a fall's lean stays), moves the hip pitches (pitch beyond
``lean``) and hip rolls; each by its gain, of either sign (which way steadies is the search's to
find, not an assumption about the joints' axes). Foot pressure is not used: the optimizer's
in-process episodes do not make it.

At construction the command is full forward, so the straight-walk objective (paper eq. 9) and
every search, check and card take an omni gait unchanged. The genes' box keeps each gene where
the robot can follow it (hip height below the leg's length, lifts and sways a few cm, steps of
at most ``period`` x top speed); joint targets are clamped inside the limits besides.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from gait.family import Command, GaitFamily, Limits, Vec3
from gait.leg_ik import LEG_LENGTH, leg_ik
from gait.nao_legs import LIMIT_MARGIN_DEG
from gait.omni_steps import OmniParams, StepState, advance, clip_command, foot_offsets, sole_targets, standing

GENE_NAMES: tuple[str, ...] = OmniParams._fields
GENE_UNITS: dict[str, str] = {
    "period": "s",
    "hip_height": "m",
    "width": "m",
    "x_offset": "m",
    "lean": "deg",
    "lift": "m",
    "sway": "m",
    "double_support": "1",
    "max_forward": "m/s",
    "max_backward": "m/s",
    "max_left": "m/s",
    "max_turn": "deg/s",
    "ramp": "1",
    "gyro_pitch": "deg/(deg/s)",
    "gyro_roll": "deg/(deg/s)",
    "gyro_hip": "deg/(deg/s)",
    "arm": "deg/m",
    "tilt_pitch": "deg/deg",
    "tilt_roll": "deg/deg",
}

#: The arms hang at -90 deg of shoulder pitch (docs/robot_and_server.md section 1).
ARMS_DOWN = -90.0
#: Share of the gap to each new tilt reading taken per cycle: a 0.1 s time constant, five cycles.
TILT_SMOOTHING = 0.2
#: The shortest step: 5 control cycles, 2.5 times the server's action latency.
_SHORTEST_STEP = 0.1
#: The hip may stand no higher than this below the leg's full length (m): a straight knee has no
#: room left to lower the hip, and a knee at its stop cannot be commanded (it is left stuck).
_KNEE_ROOM = 0.01

BOUNDS: np.ndarray = np.array(
    [
        [_SHORTEST_STEP, 0.5],  # period
        [0.15, LEG_LENGTH - _KNEE_ROOM],  # hip_height
        [0.0, 0.05],  # width
        [-0.05, 0.05],  # x_offset
        [-10.0, 30.0],  # lean
        [0.0, 0.06],  # lift
        [0.0, 0.06],  # sway
        [0.0, 0.5],  # double_support
        [0.05, 1.5],  # max_forward
        [0.05, 1.2],  # max_backward
        [0.02, 1.0],  # max_left
        [5.0, 200.0],  # max_turn
        [0.05, 1.0],  # ramp
        [-0.2, 0.2],  # gyro_pitch
        [-0.2, 0.2],  # gyro_roll
        [-0.2, 0.2],  # gyro_hip
        [-400.0, 400.0],  # arm
        [-1.0, 1.0],  # tilt_pitch
        [-1.0, 1.0],  # tilt_roll
    ]
)

#: The effectors an omni walker drives, in the order of ``joint_angles``'s last axis.
EFFECTORS: tuple[str, ...] = tuple(f"{side}le{k}" for side in "lr" for k in range(1, 7)) + ("lae1", "rae1")


def tilt(acc: np.ndarray) -> np.ndarray:
    """The torso's pitch forward and roll to the right (n, 2; deg) that put gravity where the
    accelerometer (n, 3; m/s^2 in the torso frame, x right, y forward, z up) feels it."""
    pitch = np.degrees(np.arctan2(-acc[:, 1], acc[:, 2]))
    roll = np.degrees(np.arctan2(-acc[:, 0], acc[:, 2]))
    return np.stack([pitch, roll], axis=-1)


def joint_angles(state: StepState, p: OmniParams, gyro: np.ndarray, tilted: np.ndarray) -> np.ndarray:
    """Joint targets (n, 14; degrees, ``EFFECTORS`` order, not yet clamped) for each robot's
    planned soles, plus the feedback of the gyro (``gyro`` (n, 3), deg/s in the torso frame: x
    is the pitch rate, y the roll rate) and of the torso's tilt (``tilted`` (n, 2), ``tilt``'s),
    and the arm swing."""
    sole, rotation = sole_targets(state, p)
    legs = [np.degrees(leg_ik(side, sole[:, k], rotation[:, k])) for k, side in enumerate("lr")]
    out = np.concatenate([*legs, np.zeros((len(sole), 2))], axis=-1)
    pitch_rate, roll_rate = gyro[:, 0], gyro[:, 1]
    for first in (0, 6):
        out[:, first + 2] += np.asarray(p.gyro_hip) * pitch_rate
        out[:, first + 4] += np.asarray(p.gyro_pitch) * pitch_rate
        out[:, first + 5] += np.asarray(p.gyro_roll) * roll_rate
        out[:, first + 2] += np.asarray(p.tilt_pitch) * (tilted[:, 0] - np.asarray(p.lean))
        out[:, first + 1] += np.asarray(p.tilt_roll) * tilted[:, 1]
    offsets, _ = foot_offsets(state, p)
    ahead = offsets[:, 1, 0] - offsets[:, 0, 0]  # right foot ahead of the left (m)
    out[:, 12] = ARMS_DOWN + np.asarray(p.arm) * ahead  # the left arm with the right leg
    out[:, 13] = ARMS_DOWN - np.asarray(p.arm) * ahead
    return out


def _limits_array(limits: Limits) -> tuple[np.ndarray, np.ndarray]:
    low = np.array([limits[name][0] for name in EFFECTORS]) + LIMIT_MARGIN_DEG
    high = np.array([limits[name][1] for name in EFFECTORS]) - LIMIT_MARGIN_DEG
    return low, high


class OmniWalker:
    """One robot's omni walk (``gait.family.Steerable``): the step generator's row, its clock,
    the gyro it last felt and the odometry not yet collected."""

    def __init__(self, genes: tuple[float, ...]) -> None:
        self.params = OmniParams(*genes)
        self.command = Command(float(self.params.max_forward), 0.0, 0.0)
        self._state = standing(1)
        self._time: float | None = None
        self._gyro = np.zeros((1, 3))
        self._tilt = np.array([[float(self.params.lean), 0.0]])  # as planned until felt
        self._pose = np.zeros(3)  # x m, y m, heading rad since the last ``moved``
        self._limits: tuple[Limits, tuple[np.ndarray, np.ndarray]] | None = None

    @property
    def max_command(self) -> Command:
        p = self.params
        return Command(float(p.max_forward), float(p.max_left), float(p.max_turn))

    @property
    def max_backward(self) -> float:
        return float(self.params.max_backward)

    @property
    def standing(self) -> bool:
        """Whether it stands still (at the start, and after a zero command's last step)."""
        return not bool(self._state.walking[0])

    def sense(self, gyro: Vec3 | None, acc: Vec3 | None, joints: Mapping[str, float]) -> None:
        if gyro is not None:
            self._gyro = np.array([gyro], dtype=float)
        if acc is not None and any(acc):
            self._tilt += TILT_SMOOTHING * (tilt(np.array([acc], dtype=float)) - self._tilt)

    def moved(self) -> Command:
        x, y, heading = self._pose
        self._pose = np.zeros(3)
        return Command(float(x), float(y), math.degrees(heading))

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        p = self.params
        dt = 0.0 if self._time is None else min(max(t - self._time, 0.0), 0.99 * float(p.period))
        self._time = t if self._time is None else max(t, self._time)
        command = clip_command(np.array([self.command], dtype=float), p)
        self._state, odometry = advance(self._state, dt, command, p)
        self._integrate(odometry[0])
        if self._limits is None or self._limits[0] is not limits:
            self._limits = (limits, _limits_array(limits))
        low, high = self._limits[1]
        angles = np.minimum(np.maximum(joint_angles(self._state, p, self._gyro, self._tilt)[0], low), high)
        return dict(zip(EFFECTORS, angles.tolist()))

    def _integrate(self, step: np.ndarray) -> None:
        """Adds one cycle's odometry (forward, left in the torso's frame then; turn deg)."""
        x, y, heading = self._pose
        c, s = math.cos(heading), math.sin(heading)
        self._pose = np.array(
            [x + c * step[0] - s * step[1], y + s * step[0] + c * step[1], heading + math.radians(step[2])]
        )


def _check(genes: tuple[float, ...]) -> None:
    for name, value, (low, high) in zip(GENE_NAMES, genes, BOUNDS):
        if not low <= value <= high:
            raise ValueError(f"omni gene {name} must lie in [{low:g}, {high:g}], got {value}")


def _repair(genes: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    return np.clip(np.asarray(genes, dtype=float), bounds[:, 0], bounds[:, 1])


def _walker(genes: tuple[float, ...]) -> OmniWalker:
    return OmniWalker(genes)


OMNI = GaitFamily(
    name="omni",
    about="an omnidirectional walk engine: steps from a command, analytic leg IK, gyro and tilt feedback (19 genes)",
    gene_names=GENE_NAMES,
    gene_units=GENE_UNITS,
    boxes={"robot": BOUNDS},
    check=_check,
    repair=_repair,
    walker=_walker,
)
