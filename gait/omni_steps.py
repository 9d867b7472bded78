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
broadcast against it), so many robots step at once; ``gait.omni`` wraps one row.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from gait.leg_ik import rot_x, rot_z

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
    zeros = np.zeros((n, 2, 3))
    return StepState(np.zeros(n), np.zeros(n, dtype=int), np.zeros(n, dtype=bool), np.zeros((n, 3)), zeros, zeros)


def top_speeds(p: OmniParams, command: np.ndarray) -> np.ndarray:
    """The top speed each way that ``command`` (n, 3) points: forward or backward, sideways, turning."""
    forward = np.where(command[..., 0] >= 0.0, p.max_forward, p.max_backward)
    return np.stack(np.broadcast_arrays(forward, p.max_left, p.max_turn), axis=-1)


def clip_command(command: np.ndarray, p: OmniParams) -> np.ndarray:
    """``command`` (n, 3) scaled down, direction kept, onto the ellipsoid of the top speeds when
    it lies outside: one axis at its top leaves no room for the others."""
    command = np.asarray(command, dtype=float)
    norm = np.sqrt(np.sum((command / top_speeds(p, command)) ** 2, axis=-1, keepdims=True))
    return command / np.maximum(norm, 1.0)


def _step(speed: np.ndarray, swing: np.ndarray, period: np.ndarray) -> np.ndarray:
    """The displacement (forward m, left m, yaw rad) of a step of ``swing``'s foot at ``speed``:
    sideways and turning only on the leading foot's step, twice as far."""
    leads_left, leads_right = swing == 0, swing == 1
    left, turn = speed[..., 1], speed[..., 2]
    side = np.where((leads_left & (left > 0)) | (leads_right & (left < 0)), 2.0 * left, 0.0)
    yaw = np.where((leads_left & (turn > 0)) | (leads_right & (turn < 0)), 2.0 * np.radians(turn), 0.0)
    return np.stack([speed[..., 0], side, yaw], axis=-1) * np.asarray(period)[..., None]


def _support_offset(state: StepState, phase: np.ndarray) -> np.ndarray:
    """The support foot's offset (n, 3) at ``phase`` of the current step (it moves linearly)."""
    rows = np.arange(len(phase))
    support = 1 - state.swing
    a, b = state.start[rows, support], state.end[rows, support]
    return a + (b - a) * phase[:, None]


def advance(
    state: StepState, dt: float | np.ndarray, command: np.ndarray, p: OmniParams
) -> tuple[StepState, np.ndarray]:
    """The state ``dt`` seconds later (less than a step) under ``command`` (n, 3, already
    clipped), and the odometry of that time: how far the planned steps carried each torso
    (n, 3: forward m, left m, turn deg)."""
    period = np.broadcast_to(np.asarray(p.period, dtype=float), state.phase.shape)
    phase = state.phase + np.where(state.walking, np.asarray(dt) / period, 0.0)
    wrap = state.walking & (phase >= 1.0)
    moving = np.any(command != 0.0, axis=-1)
    start_now = ~state.walking & moving
    odometry = _support_offset(state, state.phase) - _support_offset(state, np.minimum(phase, 1.0))

    latch = wrap | start_now
    first = np.where((command[:, 1] < 0) | ((command[:, 1] == 0) & (command[:, 2] < 0)), 1, 0)
    swing = np.where(start_now, first, np.where(wrap, 1 - state.swing, state.swing))
    tops = np.stack(np.broadcast_arrays(np.maximum(p.max_forward, p.max_backward), p.max_left, p.max_turn), axis=-1)
    limit = np.asarray(p.ramp)[..., None] * tops
    speed = np.where(latch[:, None], state.speed + np.clip(command - state.speed, -limit, limit), state.speed)
    d = _step(speed, swing, period)
    rows = np.arange(len(phase))
    end = state.end.copy()
    end[rows, swing] = d / 2
    end[rows, 1 - swing] = -d / 2
    at_rest = np.all(np.abs(state.end) < _AT_REST, axis=(1, 2))
    stop = wrap & ~moving & np.all(speed == 0.0, axis=-1) & at_rest
    new = latch & ~stop
    next_state = StepState(
        phase=np.where(wrap, phase - 1.0, np.where(start_now | stop, 0.0, phase)) * ~stop,
        swing=swing,
        walking=(state.walking & ~stop) | start_now,
        speed=np.where(stop[:, None], 0.0, speed),
        start=np.where((new | stop)[:, None, None], state.end, state.start),
        end=np.where(new[:, None, None], end, np.where(stop[:, None, None], 0.0, state.end)),
    )
    # after a wrap, the new support foot's share of the step walked so far
    walked = np.where(wrap & ~stop, next_state.phase, 0.0)
    odometry = odometry + np.where(
        (wrap & ~stop)[:, None],
        _support_offset(next_state, np.zeros_like(walked)) - _support_offset(next_state, walked),
        0.0,
    )
    odometry[:, 2] = np.degrees(odometry[:, 2])
    return next_state, odometry


def foot_offsets(state: StepState, p: OmniParams) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's offset from its standing place now (n, 2, 3: forward m, left m, yaw rad) and
    its height above the ground (n, 2): support feet move linearly, the swing foot along a
    cosine in the part of the step it is off the ground."""
    ds = np.asarray(p.double_support)
    u = np.clip((state.phase - ds / 2) / (1.0 - ds), 0.0, 1.0)
    share = np.stack([state.phase, (1.0 - np.cos(math.pi * u)) / 2], axis=-1)  # (n, 2): support, swing
    rows = np.arange(len(state.phase))
    swing = state.swing
    by_foot = np.empty((len(rows), 2))
    by_foot[rows, swing] = share[:, 1]
    by_foot[rows, 1 - swing] = share[:, 0]
    offsets = state.start + (state.end - state.start) * by_foot[..., None]
    height = np.zeros((len(rows), 2))
    height[rows, swing] = np.asarray(p.lift) * np.sin(math.pi * u) * state.walking
    return offsets, height


def sole_targets(state: StepState, p: OmniParams) -> tuple[np.ndarray, np.ndarray]:
    """Each sole's target relative to its hip anchor in the torso's body frame (n, 2, 3; x right,
    y forward, z up: ``gait.leg_ik``'s) and the foot's rotation in that frame (n, 2, 3, 3):
    flat on the ground, yawed by its offset, with the torso leaned forward by ``lean``."""
    offsets, height = foot_offsets(state, p)
    side = np.array([1.0, -1.0])  # left, right
    home_y = side * (HIP_HALF_WIDTH + np.asarray(p.width)[..., None])
    x = np.asarray(p.x_offset)[..., None] + offsets[..., 0]
    y = home_y + offsets[..., 1]
    yaw = offsets[..., 2]
    c, s = np.cos(yaw), np.sin(yaw)
    sway = np.asarray(p.sway) * np.sin(math.pi * state.phase) * np.where(state.swing == 0, 1.0, -1.0) * state.walking
    forward = c * x - s * y
    left = s * x + c * y + sway[:, None] - side * HIP_HALF_WIDTH
    down = height - np.asarray(p.hip_height)[..., None]
    body = np.stack([-left, forward, down], axis=-1)
    lean = rot_x(np.radians(np.atleast_1d(p.lean)))[:, None]  # (n or 1, 1, 3, 3)
    sole = np.einsum("...ij,...j->...i", lean, body)
    return sole, lean @ rot_z(yaw)
