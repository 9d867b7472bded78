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
in-process episodes do not make it. The planned targets are led by ``lag_comp`` times their
rate, against the agent's proportional controller, which trails a moving target by 1/gain; the
rate is the planned targets' change over the next cycle (the step state advanced 0.02 s under
the same command: the joint targets planned for the next cycle), into arrays of the walker's own.
With ``lag_comp`` 0 the lead adds exactly 0: the walk is the one before the gene.

Calibration (the last five genes): a robot walks less than its steps plan (its feet slip, its
joints lag), some 70-85% of it, and stepping sideways turns it. So the command, in the speeds the
robot is to walk, is planned as ``gain_*`` times itself (forward or backward, sideways, turning)
plus ``side_turn`` times its sideways speed as turning, and the odometry and the top speeds are
taken back through the same map: a command of 0.5 m/s walks about 0.5 m/s. The top speeds
(``max_*``) cap the planned speeds, so the calibration moves no step of a walk at its top speed.
They are measured, not searched (``python -m optimizer.calibrate``; ``OMNI.held``: a refinement
keeps them), and gains of 1 and no ``side_turn`` plan the command as it is: the walk before them.

Speed: the per-cycle math is numba kernels over robot rows (here ``tilt_into``,
``targets_into``, ``planned_into``, ``feedback_into``; the steps' and the legs' in their modules,
each kernel calling only kernels of its own file, as numba's disk cache checks a kernel against
its own file only). The walker keeps the arrays they write, so a cycle (``sense``,
``joint_target_array``, ``moved``) makes none but the targets it returns, which the agent takes
as they are (``gait.family.ArrayWalker``), and costs some 40 us (``bench.bench_omni_cycle``; of
them some 10 plan the next cycle, for ``lag_comp``'s rate); the first walker of a process loads
the kernels (``warm_up``).

At construction the command is full forward, so the straight-walk objective (paper eq. 9) and
every search, check and card take an omni gait unchanged. The genes' box keeps each gene where
the robot can follow it (hip height below the leg's length, lifts and sways a few cm, steps of
at most ``period`` x top speed); joint targets are clamped inside the limits besides.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numba import njit

from gait.family import Command, GaitFamily, Limits, Vec3
from gait.leg_ik import LEFT_RIGHT, LEG_LENGTH, ik_into, legs_ik
from gait.nao_legs import LIMIT_MARGIN_DEG
from gait.omni_steps import (
    OmniParams,
    StepState,
    advance,
    advance_into,
    clip_into,
    empty_state,
    feet,
    feet_into,
    param_rows,
    standing,
)

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
    "lag_comp": "s",
    "gain_forward": "1",
    "gain_backward": "1",
    "gain_left": "1",
    "gain_turn": "1",
    "side_turn": "deg/m",
}

#: The arms hang at -90 deg of shoulder pitch (docs/robot_and_server.md section 1).
ARMS_DOWN = -90.0
#: Share of the gap to each new tilt reading taken per cycle: a 0.1 s time constant, five cycles.
TILT_SMOOTHING = 0.2
#: The joint controller's time constant is 1/15 s (agent.config: gain 15/s): leading a target by
#: its rate times that much cancels the lag a planned motion suffers; the box allows 1.5 times it.
_LAG_COMP_MAX = 0.1
#: The interval over which a planned target's rate is taken (one control cycle, s).
RATE_STEP = 0.02
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
        [0.0, _LAG_COMP_MAX],  # lag_comp
        [0.5, 2.5],  # gain_forward
        [0.5, 2.5],  # gain_backward
        [0.5, 2.5],  # gain_left
        [0.5, 2.5],  # gain_turn
        [-200.0, 200.0],  # side_turn
    ]
)

#: The effectors an omni walker drives, in the order of ``joint_angles``'s last axis.
EFFECTORS: tuple[str, ...] = tuple(f"{side}le{k}" for side in "lr" for k in range(1, 7)) + ("lae1", "rae1")


def tilt(acc: np.ndarray) -> np.ndarray:
    """The torso's pitch forward and roll to the right (n, 2; deg) that put gravity where the
    accelerometer (n, 3; m/s^2 in the torso frame, x right, y forward, z up) feels it."""
    acc = np.ascontiguousarray(acc, dtype=float)
    out = np.zeros((len(acc), 2))
    tilt_into(acc, 1.0, out)
    return out


def planned_angles(state: StepState, p: OmniParams) -> np.ndarray:
    """Joint targets (n, 14; degrees, ``EFFECTORS`` order, not clamped) that put each robot's
    soles where its steps plan them, and swing its arms."""
    offsets, _, sole, rotation = feet(state, p)
    out = np.empty((len(sole), len(EFFECTORS)))
    planned_into(legs_ik(sole, rotation), offsets, param_rows(p), out)
    return out


def feedback_angles(p: OmniParams, gyro: np.ndarray, tilted: np.ndarray) -> np.ndarray:
    """What the sensors add to the targets (n, 14): the gyro's (``gyro`` (n, 3), deg/s in the
    torso frame: x is the pitch rate, y the roll rate) and the torso tilt's (``tilted`` (n, 2),
    ``tilt``'s)."""
    gyro, tilted = np.ascontiguousarray(gyro, dtype=float), np.ascontiguousarray(tilted, dtype=float)
    out = np.zeros((len(gyro), len(EFFECTORS)))
    feedback_into(gyro, tilted, param_rows(p), out)
    return out


def joint_angles(
    state: StepState, command: np.ndarray, p: OmniParams, gyro: np.ndarray, tilted: np.ndarray
) -> np.ndarray:
    """Joint targets (n, 14; degrees, ``EFFECTORS`` order, not clamped): the planned ones led by
    ``lag_comp`` times their rate (taken over the next cycle under ``command``, (n, 3) clipped),
    plus the feedback."""
    offsets, _, sole, rotation = feet(state, p)
    following, _ = advance(state, RATE_STEP, command, p)
    next_offsets, _, next_sole, next_rotation = feet(following, p)
    gyro, tilted = np.ascontiguousarray(gyro, dtype=float), np.ascontiguousarray(tilted, dtype=float)
    out = np.empty((len(sole), len(EFFECTORS)))
    targets_into(
        legs_ik(sole, rotation),
        offsets,
        legs_ik(next_sole, next_rotation),
        next_offsets,
        gyro,
        tilted,
        param_rows(p),
        _NO_LOW,
        _NO_HIGH,
        out,
    )
    return out


#: The calibration's genes: measured by ``optimizer.calibrate``, kept by a search (``held``).
CALIBRATION_GENES = ("gain_forward", "gain_backward", "gain_left", "gain_turn", "side_turn")
_NO_LOW, _NO_HIGH = np.full(len(EFFECTORS), -np.inf), np.full(len(EFFECTORS), np.inf)
_DEG = 180.0 / math.pi
#: the genes' columns in ``param_rows`` (literal: a compiled kernel keeps the values it was compiled with)
_LEAN, _GYRO_PITCH, _GYRO_ROLL, _GYRO_HIP, _ARM, _TILT_PITCH, _TILT_ROLL, _LAG_COMP = 4, 13, 14, 15, 16, 17, 18, 19
assert [
    GENE_NAMES[k] for k in (_LEAN, _GYRO_PITCH, _GYRO_ROLL, _GYRO_HIP, _ARM, _TILT_PITCH, _TILT_ROLL, _LAG_COMP)
] == ["lean", "gyro_pitch", "gyro_roll", "gyro_hip", "arm", "tilt_pitch", "tilt_roll", "lag_comp"]


@njit(cache=True)
def tilt_into(acc: np.ndarray, share: float, tilted: np.ndarray) -> None:
    """Moves ``tilted`` (n, 2) by ``share`` of the way to ``tilt(acc)`` (share 1 from zeros: sets it)."""
    for r in range(len(acc)):
        pitch = math.atan2(-acc[r, 1], acc[r, 2]) * _DEG
        roll = math.atan2(-acc[r, 0], acc[r, 2]) * _DEG
        tilted[r, 0] += share * (pitch - tilted[r, 0])
        tilted[r, 1] += share * (roll - tilted[r, 1])


@njit(cache=True)
def _planned(legs: np.ndarray, offsets: np.ndarray, arm: float, r: int, k: int) -> float:
    """Row ``r``'s planned target of effector ``k`` (deg) from its legs' angles (rad) and feet's
    offsets: a leg joint's angle, or a shoulder's swing of ``arm`` deg per m."""
    if k < 12:
        return legs[r, k // 6, k % 6] * _DEG
    ahead = offsets[r, 1, 0] - offsets[r, 0, 0]  # right foot ahead of the left (m)
    return ARMS_DOWN + arm * ahead if k == 12 else ARMS_DOWN - arm * ahead  # the left arm with the right leg


@njit(cache=True)
def _add_feedback(gyro: np.ndarray, tilted: np.ndarray, g: np.ndarray, r: int, out: np.ndarray) -> None:
    """Adds row ``r``'s gyro and tilt feedback to ``out[r]``, by the genes ``g``."""
    pitch_rate, roll_rate = gyro[r, 0], gyro[r, 1]
    for first in (0, 6):
        out[r, first + 2] += g[_GYRO_HIP] * pitch_rate
        out[r, first + 4] += g[_GYRO_PITCH] * pitch_rate
        out[r, first + 5] += g[_GYRO_ROLL] * roll_rate
        out[r, first + 2] += g[_TILT_PITCH] * (tilted[r, 0] - g[_LEAN])
        out[r, first + 1] += g[_TILT_ROLL] * tilted[r, 1]


@njit(cache=True)
def planned_into(legs: np.ndarray, offsets: np.ndarray, genes: np.ndarray, out: np.ndarray) -> None:
    """``planned_angles`` into ``out``, from the legs' angles (n, 2, 6; rad) and the feet's
    offsets (n, 2, 3), the genes as ``gait.omni_steps.param_rows``."""
    for r in range(len(legs)):
        g = genes[r if len(genes) > 1 else 0]
        for k in range(out.shape[1]):
            out[r, k] = _planned(legs, offsets, g[_ARM], r, k)


@njit(cache=True)
def feedback_into(gyro: np.ndarray, tilted: np.ndarray, genes: np.ndarray, out: np.ndarray) -> None:
    """Adds ``feedback_angles`` to ``out``, the genes as ``gait.omni_steps.param_rows``."""
    for r in range(len(gyro)):
        _add_feedback(gyro, tilted, genes[r if len(genes) > 1 else 0], r, out)


@njit(cache=True)
def targets_into(
    legs: np.ndarray,
    offsets: np.ndarray,
    next_legs: np.ndarray,
    next_offsets: np.ndarray,
    gyro: np.ndarray,
    tilted: np.ndarray,
    genes: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    out: np.ndarray,
) -> None:
    """``joint_angles`` into ``out``, from the legs' angles (n, 2, 6; rad) and the feet's offsets
    (n, 2, 3) now and one cycle on (``next_``), the genes as ``gait.omni_steps.param_rows``; each
    clamped into [low, high]. With ``lag_comp`` 0 the lead adds exactly 0: the planned targets."""
    for r in range(len(legs)):
        g = genes[r if len(genes) > 1 else 0]
        for k in range(len(low)):
            now = _planned(legs, offsets, g[_ARM], r, k)
            rate = (_planned(next_legs, next_offsets, g[_ARM], r, k) - now) / RATE_STEP
            out[r, k] = now + g[_LAG_COMP] * rate
        _add_feedback(gyro, tilted, g, r, out)
        for k in range(len(low)):
            out[r, k] = min(max(out[r, k], low[k]), high[k])


def _limits_array(limits: Limits) -> tuple[np.ndarray, np.ndarray]:
    low = np.array([limits[name][0] for name in EFFECTORS]) + LIMIT_MARGIN_DEG
    high = np.array([limits[name][1] for name in EFFECTORS]) - LIMIT_MARGIN_DEG
    return low, high


class OmniWalker:
    """One robot's omni walk (``gait.family.Steerable``): the step generator's row, its clock,
    the gyro it last felt and the odometry not yet collected. Each cycle runs the kernels on
    arrays of its own (a row each), made once: no array is made per cycle."""

    #: the joints of ``joint_target_array``, in its order
    target_effectors: tuple[str, ...] = EFFECTORS

    def __init__(self, genes: tuple[float, ...]) -> None:
        self.params = OmniParams(*genes)
        p = self.params
        #: the calibration, read once: forward, backward, sideways and turn gains, side_turn
        self._gains = tuple(float(g) for g in (p.gain_forward, p.gain_backward, p.gain_left, p.gain_turn, p.side_turn))
        self.command = Command(self.max_command.forward, 0.0, 0.0)
        self._genes = param_rows(self.params)
        self._state, self._next = standing(1), empty_state(1)
        self._time: float | None = None
        self._gyro = np.zeros((1, 3))
        self._tilt = np.array([[float(self.params.lean), 0.0]])  # as planned until felt
        self._pose = (0.0, 0.0, 0.0)  # x m, y m, heading rad since the last ``moved``
        self._limits: tuple[Limits, tuple[np.ndarray, np.ndarray]] | None = None
        # the cycle's arrays: accelerometer, command, clipped, dt, odometry, the feet's
        # offsets, heights, soles and rotations, the legs' angles, the targets; and the plan
        # one cycle on (for the targets' rate): its state, dt, odometry, feet and legs
        self._acc = np.zeros((1, 3))
        self._command, self._clipped, self._dt, self._odometry = (
            np.zeros((1, 3)),
            np.zeros((1, 3)),
            np.zeros(1),
            np.zeros((1, 3)),
        )
        self._feet = np.zeros((1, 2, 3)), np.zeros((1, 2)), np.zeros((1, 2, 3)), np.zeros((1, 2, 3, 3))
        self._legs = np.zeros((1, 2, 6))
        self._angles = np.zeros((1, len(EFFECTORS)))
        self._ahead, self._rate_step, self._ahead_odometry = empty_state(1), np.full(1, RATE_STEP), np.zeros((1, 3))
        self._ahead_feet = np.zeros((1, 2, 3)), np.zeros((1, 2)), np.zeros((1, 2, 3)), np.zeros((1, 2, 3, 3))
        self._ahead_legs = np.zeros((1, 2, 6))
        warm_up()

    @property
    def max_command(self) -> Command:
        """The top speeds it walks (the planned ones, ``max_*``, taken back through the calibration)."""
        p, (ahead, _, left, turn, _) = self.params, self._gains
        return Command(float(p.max_forward) / ahead, float(p.max_left) / left, float(p.max_turn) / turn)

    @property
    def max_backward(self) -> float:
        return float(self.params.max_backward) / self._gains[1]

    def planned(self, command: Command) -> tuple[float, float, float]:
        """The speeds to plan steps for so that the robot walks ``command``: the calibration."""
        ahead, back, sideways, turning, side_turn = self._gains
        forward, left, turn = command
        return forward * (ahead if forward >= 0.0 else back), left * sideways, turn * turning + side_turn * left

    @property
    def standing(self) -> bool:
        """Whether it stands still (at the start, and after a zero command's last step)."""
        return not bool(self._state.walking[0])

    def sense(self, gyro: Vec3 | None, acc: Vec3 | None, joints: Mapping[str, float]) -> None:
        if gyro is not None:
            self._gyro[0] = gyro
        if acc is not None and any(acc):
            self._acc[0] = acc
            tilt_into(self._acc, TILT_SMOOTHING, self._tilt)

    def moved(self) -> Command:
        x, y, heading = self._pose
        self._pose = (0.0, 0.0, 0.0)
        return Command(x, y, math.degrees(heading))

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        return dict(zip(EFFECTORS, self.joint_target_array(t, limits).tolist()))

    def joint_target_array(self, t: float, limits: Limits) -> np.ndarray:
        """``joint_targets``' values, in ``target_effectors`` order (``gait.family.ArrayWalker``)."""
        genes = self._genes
        dt = 0.0 if self._time is None else min(max(t - self._time, 0.0), 0.99 * float(self.params.period))
        self._time = t if self._time is None else max(t, self._time)
        self._command[0] = self.planned(self.command)
        clip_into(self._command, genes, self._clipped)
        self._dt[0] = dt
        advance_into(*self._state, self._dt, self._clipped, genes, *self._next, self._odometry)
        self._state, self._next = self._next, self._state
        self._integrate(*self._odometry[0].tolist())
        if self._limits is None or self._limits[0] is not limits:
            self._limits = (limits, _limits_array(limits))
        low, high = self._limits[1]
        state, (offsets, _, sole, rotation) = self._state, self._feet
        feet_into(state.phase, state.swing, state.walking, state.start, state.end, genes, *self._feet)
        ik_into(LEFT_RIGHT, sole[0], rotation[0], self._legs[0])
        # the plan one cycle on, under the same command: the targets' rate
        advance_into(*state, self._rate_step, self._clipped, genes, *self._ahead, self._ahead_odometry)
        ahead, (ahead_offsets, _, ahead_sole, ahead_rotation) = self._ahead, self._ahead_feet
        feet_into(ahead.phase, ahead.swing, ahead.walking, ahead.start, ahead.end, genes, *self._ahead_feet)
        ik_into(LEFT_RIGHT, ahead_sole[0], ahead_rotation[0], self._ahead_legs[0])
        targets_into(
            self._legs, offsets, self._ahead_legs, ahead_offsets, self._gyro, self._tilt, genes, low, high, self._angles
        )
        return self._angles[0].copy()

    def _integrate(self, forward: float, left: float, turn: float) -> None:
        """Adds one cycle's odometry (the planned steps' forward, left in the torso's frame then;
        turn deg), taken back through the calibration to what the robot walked."""
        ahead, back, sideways, turning, side_turn = self._gains
        forward /= ahead if forward >= 0.0 else back
        left /= sideways
        turn = (turn - side_turn * left) / turning
        x, y, heading = self._pose
        c, s = math.cos(heading), math.sin(heading)
        self._pose = (x + c * forward - s * left, y + s * forward + c * left, heading + math.radians(turn))


_warm = False


def warm_up() -> None:
    """Compile the per-cycle kernels (or load them from numba's disk cache: once per checkout) now,
    as the first walker is made, rather than in a walk's first cycle: a walker's first cycles,
    with its argument types."""
    global _warm
    if _warm:
        return
    _warm = True
    walker = OmniWalker(tuple(BOUNDS.mean(axis=1)))
    limits = dict.fromkeys(EFFECTORS, (-90.0, 90.0))
    walker.sense((1.0, 2.0, 3.0), (0.0, 0.0, 9.81), {})
    walker.joint_targets(0.0, limits)
    walker.joint_targets(0.02, limits)
    joint_angles(walker._state, walker._clipped, walker.params, walker._gyro, walker._tilt)


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
    about=(
        "an omnidirectional walk engine: steps from a command, analytic leg IK, gyro and tilt feedback, "
        "calibrated commands (25 genes)"
    ),
    gene_names=GENE_NAMES,
    gene_units=GENE_UNITS,
    boxes={"robot": BOUNDS},
    check=_check,
    repair=_repair,
    walker=_walker,
    held=tuple(GENE_NAMES.index(name) for name in CALIBRATION_GENES),
)
