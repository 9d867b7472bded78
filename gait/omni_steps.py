"""The omni walk's step generator: a command -> steps -> where each sole is, cycle by cycle.

Why a step generator rather than joint waves: a walk that goes any way at any speed, and changes
its mind, plans foot placements. Each step (``period`` seconds) one foot swings and the other
supports. Each foot carries an offset from its standing place (forward m, left m, yaw rad). A
step of displacement d = (dx, dy, dyaw) moves the swing foot to +d/2 along a smooth curve, lifted
by ``lift`` at mid-swing, and the support foot linearly to -d/2, which carries the torso d over
the ground. The torso sways sideways over the support foot (``sway`` x sin(pi phase)). Rules that
keep the legs apart and inside the hip's range:

- sideways, only the foot on the side of the motion steps out (2 vy period on its step, 0 on the
  other's), so the feet never cross; turning likewise: le1 turns a foot only outwards, so the
  foot on the side of the turn leads (2 w period) and the other follows (0);
- at each step's start the walked speed moves towards the command by at most ``ramp`` times the
  top speed each way (the acceleration limit), and a zero command ends in a step that brings the
  feet side by side, after which the generator stands still until the command is not zero.

All functions take arrays with a leading robot axis (one row per robot; ``OmniParams`` fields
broadcast against it), so many robots step at once; ``gait.omni`` wraps one row. The math is in
numba kernels (``clip_into``, ``advance_into``, ``feet_into``) that loop over the rows with scalar
math inside and write into arrays the caller gives, the genes as ``param_rows``: numpy's overhead
on arrays of a few elements was most of a cycle. The functions without ``_into`` make the arrays;
a walker that keeps its own makes none per cycle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

#: Half the distance between the hip anchors (m): where the feet stand with ``width`` 0.
HIP_HALF_WIDTH = 0.055
#: A foot this close (m, rad) to its standing place is there.
_AT_REST = 1e-9


#: A gene's value: one robot's float, or an array of one per robot.
Gene = float | np.ndarray


class OmniParams(NamedTuple):
    """The omni walk's genes (``gait.omni.GENE_NAMES`` in order; floats or arrays of one per robot)."""

    period: Gene  # s, one step
    hip_height: Gene  # m, hip anchor above the sole
    width: Gene  # m, each foot further out than its hip
    x_offset: Gene  # m, feet ahead of the hips
    lean: Gene  # deg, torso pitched forward at the hips
    lift: Gene  # m, swing foot's height at mid-swing
    sway: Gene  # m, torso's sideways shift over the support foot
    double_support: Gene  # share of a step both feet are down
    max_forward: Gene  # m/s
    max_backward: Gene  # m/s
    max_left: Gene  # m/s, either side
    max_turn: Gene  # deg/s, either way
    ramp: Gene  # share of the top speed the speed may change per step
    gyro_pitch: Gene  # deg of ankle pitch per deg/s of pitch rate
    gyro_roll: Gene  # deg of ankle roll per deg/s of roll rate
    gyro_hip: Gene  # deg of hip pitch per deg/s of pitch rate
    arm: Gene  # deg of shoulder pitch per m of the other foot ahead
    tilt_pitch: Gene  # deg of hip pitch per deg the torso pitches beyond ``lean`` (accelerometer)
    tilt_roll: Gene  # deg of hip roll per deg the torso rolls (accelerometer)
    lag_comp: Gene  # s: targets led by this times their rate, against the joint controller's lag
    gain_forward: Gene  # planned forward speed per commanded (the walk's calibration, ``gait.omni``)
    gain_backward: Gene  # planned backward speed per commanded
    gain_left: Gene  # planned sideways speed per commanded
    gain_turn: Gene  # planned turn rate per commanded
    side_turn: Gene  # deg/s of planned turn per m/s of commanded sideways speed


class StepState(NamedTuple):
    """Where each robot is in its walk (arrays, first axis the robot)."""

    phase: np.ndarray  # (n,) share of the current step done
    swing: np.ndarray  # (n,) the swinging foot: 0 left, 1 right
    walking: np.ndarray  # (n,) bool; False: standing still
    speed: np.ndarray  # (n, 3) walked speed: forward m/s, left m/s, turn deg/s
    start: np.ndarray  # (n, 2, 3) each foot's offset (forward m, left m, yaw rad) at the step's start
    end: np.ndarray  # (n, 2, 3) and where the step puts it


def standing(n: int) -> StepState:
    """``n`` robots standing, feet side by side."""
    return empty_state(n, np.zeros)


def empty_state(n: int, make: Callable[..., np.ndarray] = np.empty) -> StepState:
    """A state of ``n`` robots (arrays by ``make``: not set yet, ``advance_into``'s output)."""
    return StepState(
        make(n), make(n, dtype=np.int64), make(n, dtype=np.bool_), make((n, 3)), make((n, 2, 3)), make((n, 2, 3))
    )


def param_rows(p: OmniParams) -> np.ndarray:
    """The genes as the kernels take them: one row per robot (m, 25), m = 1 when every gene is
    one float (all robots alike)."""
    try:
        genes = np.array(p, dtype=float)
    except ValueError:  # floats and arrays mixed
        genes = np.array(np.broadcast_arrays(*(np.asarray(g, dtype=float) for g in p)))
    return np.ascontiguousarray(genes.reshape(len(p), -1).T)


def clip_command(command: np.ndarray, p: OmniParams) -> np.ndarray:
    """``command`` (n, 3) scaled down, direction kept, onto the ellipsoid of the top speeds when
    it lies outside: one axis at its top leaves no room for the others (forward or backward,
    sideways, turning: the top speed each way the command points)."""
    command = np.ascontiguousarray(command, dtype=float)
    out = np.empty_like(command)
    clip_into(command, param_rows(p), out)
    return out


def advance(
    state: StepState, dt: float | np.ndarray, command: np.ndarray, p: OmniParams
) -> tuple[StepState, np.ndarray]:
    """The state ``dt`` seconds later (less than a step) under ``command`` (n, 3, already
    clipped), and the odometry of that time: how far the planned steps carried each torso
    (n, 3: forward m, left m, turn deg)."""
    n = len(state.phase)
    dts = np.empty(n)
    dts[:] = dt
    new, odometry = empty_state(n), np.empty((n, 3))
    advance_into(*state, dts, np.ascontiguousarray(command, dtype=float), param_rows(p), *new, odometry)
    return new, odometry


def feet(state: StepState, p: OmniParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``foot_offsets`` and ``sole_targets`` at once: offsets (n, 2, 3), heights (n, 2), soles
    (n, 2, 3) and the feet's rotations (n, 2, 3, 3)."""
    n = len(state.phase)
    out = np.empty((n, 2, 3)), np.empty((n, 2)), np.empty((n, 2, 3)), np.empty((n, 2, 3, 3))
    feet_into(state.phase, state.swing, state.walking, state.start, state.end, param_rows(p), *out)
    return out


def foot_offsets(state: StepState, p: OmniParams) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's offset from its standing place now (n, 2, 3: forward m, left m, yaw rad) and
    its height above the ground (n, 2): support feet move linearly, the swing foot along a
    cosine in the part of the step it is off the ground."""
    offsets, height, _, _ = feet(state, p)
    return offsets, height


def sole_targets(state: StepState, p: OmniParams) -> tuple[np.ndarray, np.ndarray]:
    """Each sole's target relative to its hip anchor in the torso's body frame (n, 2, 3; x right,
    y forward, z up: ``gait.leg_ik``'s) and the foot's rotation in that frame (n, 2, 3, 3):
    flat on the ground, yawed by its offset, with the torso leaned forward by ``lean``."""
    _, _, sole, rotation = feet(state, p)
    return sole, rotation


# The kernels: one robot per row, the genes' row ``r`` of m rows (``param_rows``) or row 0 of one.
_PERIOD, _HIP_HEIGHT, _WIDTH, _X_OFFSET, _LEAN, _LIFT, _SWAY, _DOUBLE_SUPPORT = range(8)
_MAX_FORWARD, _MAX_BACKWARD, _MAX_LEFT, _MAX_TURN, _RAMP = range(8, 13)
_RAD = math.pi / 180.0
_DEG = 180.0 / math.pi


@njit(cache=True)
def clip_into(command: np.ndarray, genes: np.ndarray, out: np.ndarray) -> None:
    """``clip_command`` into ``out``, the genes as ``param_rows``."""
    for r in range(len(command)):
        g = genes[r if len(genes) > 1 else 0]
        forward = g[_MAX_FORWARD] if command[r, 0] >= 0.0 else g[_MAX_BACKWARD]
        a, b, c = command[r, 0] / forward, command[r, 1] / g[_MAX_LEFT], command[r, 2] / g[_MAX_TURN]
        norm = max(math.sqrt(a * a + b * b + c * c), 1.0)
        for k in range(3):
            out[r, k] = command[r, k] / norm


@njit(cache=True)
def advance_into(
    phase: np.ndarray,
    swing: np.ndarray,
    walking: np.ndarray,
    speed: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    dt: np.ndarray,
    command: np.ndarray,
    genes: np.ndarray,
    phase_out: np.ndarray,
    swing_out: np.ndarray,
    walking_out: np.ndarray,
    speed_out: np.ndarray,
    start_out: np.ndarray,
    end_out: np.ndarray,
    odometry: np.ndarray,
) -> None:
    """``advance`` (a state's arrays, each row's ``dt``) into the next state's arrays (not the
    same) and ``odometry``, the genes as ``param_rows``."""
    d = np.empty(3)
    for r in range(len(phase)):
        g = genes[r if len(genes) > 1 else 0]
        period = g[_PERIOD]
        now = phase[r] + (dt[r] / period if walking[r] else 0.0)
        wrap = walking[r] and now >= 1.0
        c0, c1, c2 = command[r, 0], command[r, 1], command[r, 2]
        moving = c0 != 0.0 or c1 != 0.0 or c2 != 0.0
        start_now = not walking[r] and moving
        # the support foot moves linearly: the odometry is how far it went back
        support = 1 - swing[r]
        until = min(now, 1.0)
        for k in range(3):
            a, b = start[r, support, k], end[r, support, k]
            odometry[r, k] = (a + (b - a) * phase[r]) - (a + (b - a) * until)
        latch = wrap or start_now
        if start_now:
            new_swing = 1 if c1 < 0 or (c1 == 0 and c2 < 0) else 0
        else:
            new_swing = 1 - swing[r] if wrap else swing[r]
        tops = (max(g[_MAX_FORWARD], g[_MAX_BACKWARD]), g[_MAX_LEFT], g[_MAX_TURN])
        still = True
        for k in range(3):
            v = speed[r, k]
            if latch:
                limit = g[_RAMP] * tops[k]
                v = v + min(max(command[r, k] - v, -limit), limit)
            speed_out[r, k] = v
            still = still and v == 0.0
        # the step: sideways and turning only on the leading foot's step, twice as far
        left, turn = speed_out[r, 1], speed_out[r, 2]
        leads_left, leads_right = new_swing == 0, new_swing == 1
        d[0] = speed_out[r, 0] * period
        d[1] = (2.0 * left if (leads_left and left > 0) or (leads_right and left < 0) else 0.0) * period
        d[2] = (2.0 * (turn * _RAD) if (leads_left and turn > 0) or (leads_right and turn < 0) else 0.0) * period
        at_rest = True
        for f in range(2):
            for k in range(3):
                at_rest = at_rest and abs(end[r, f, k]) < _AT_REST
        stop = wrap and not moving and still and at_rest
        new = latch and not stop
        if stop:
            phase_out[r] = 0.0
        elif wrap:
            phase_out[r] = now - 1.0
        else:
            phase_out[r] = 0.0 if start_now else now
        swing_out[r] = new_swing
        walking_out[r] = (walking[r] and not stop) or start_now
        for f in range(2):
            for k in range(3):
                start_out[r, f, k] = end[r, f, k] if new or stop else start[r, f, k]
                if new:
                    end_out[r, f, k] = d[k] / 2 if f == new_swing else -d[k] / 2
                else:
                    end_out[r, f, k] = 0.0 if stop else end[r, f, k]
        if stop:
            speed_out[r, :] = 0.0
        if wrap and not stop:  # the new support foot's share of the step walked so far
            support = 1 - new_swing
            for k in range(3):
                a, b = start_out[r, support, k], end_out[r, support, k]
                odometry[r, k] += (a + (b - a) * 0.0) - (a + (b - a) * phase_out[r])
        odometry[r, 2] = odometry[r, 2] * _DEG


@njit(cache=True)
def feet_into(
    phase: np.ndarray,
    swing: np.ndarray,
    walking: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    genes: np.ndarray,
    offsets: np.ndarray,
    height: np.ndarray,
    sole: np.ndarray,
    rotation: np.ndarray,
) -> None:
    """``feet`` (a state's arrays) into its four outputs, the genes as ``param_rows``."""
    for r in range(len(phase)):
        g = genes[r if len(genes) > 1 else 0]
        ds = g[_DOUBLE_SUPPORT]
        u = min(max((phase[r] - ds / 2) / (1.0 - ds), 0.0), 1.0)
        swinging = (1.0 - math.cos(math.pi * u)) / 2
        lift = g[_LIFT] * math.sin(math.pi * u) if walking[r] else 0.0
        sway = g[_SWAY] * math.sin(math.pi * phase[r]) * (1.0 if swing[r] == 0 else -1.0) if walking[r] else 0.0
        lean = g[_LEAN] * _RAD
        cl, sl = math.cos(lean), math.sin(lean)
        for f in range(2):
            share = swinging if f == swing[r] else phase[r]
            for k in range(3):
                offsets[r, f, k] = start[r, f, k] + (end[r, f, k] - start[r, f, k]) * share
            height[r, f] = lift if f == swing[r] else 0.0
            side = 1.0 if f == 0 else -1.0
            x = g[_X_OFFSET] + offsets[r, f, 0]
            y = side * (HIP_HALF_WIDTH + g[_WIDTH]) + offsets[r, f, 1]
            yaw = offsets[r, f, 2]
            c, s = math.cos(yaw), math.sin(yaw)
            forward = c * x - s * y
            left = s * x + c * y + sway - side * HIP_HALF_WIDTH
            down = height[r, f] - g[_HIP_HEIGHT]
            # rot_x(lean) @ (-left, forward, down), and rot_x(lean) @ rot_z(yaw)
            sole[r, f, 0] = -left
            sole[r, f, 1] = cl * forward + -sl * down
            sole[r, f, 2] = sl * forward + cl * down
            rot = rotation[r, f]
            rot[0, 0], rot[0, 1], rot[0, 2] = c, -s, 0.0
            rot[1, 0], rot[1, 1], rot[1, 2] = cl * s, cl * c, -sl
            rot[2, 0], rot[2, 1], rot[2, 2] = sl * s, sl * c, cl
