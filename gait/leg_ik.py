"""The NAO's leg as a kinematic chain: forward kinematics and an analytic inverse that places a
sole anywhere in reach with any orientation (the omni walk asks for flat, yawed soles).

Why analytic: an omnidirectional walk plans where the feet go, not joint angles; solving the six
joints in closed form costs a few array operations a cycle, for one robot or many (every function
takes arrays with any leading axes, e.g. one row per robot).

Frames and figures are the robot model's (docs/robot_and_server.md sections 1-3): the body frame
has +x to the robot's right, +y forward, +z up; each hinge turns by the right-hand rule about its
axis. All six leg joints of one side hang off the hip anchor: le1 (hip yaw-pitch) about a 45-deg
axis in the x-z plane, le2 (hip roll) about y, le3 (hip pitch) about x, le4 (knee) about x 0.12 m
below (and 5 mm ahead of) the hip, le5 (ankle pitch) about x 0.10 m below the knee, le6 (ankle
roll) about y 5 mm below that; the sole is 0.045 m below the ankle roll axis.

The inverse works from the foot up: the knee follows from the hip-ankle distance; seen from the
foot, the hip's direction gives the ankle roll and pitch; what is left of the orientation is
le1 * le2 * le3, and turning the frame by 45 deg about y makes le1's axis the z axis, so those
three are a z-y-x (yaw-pitch-roll) decomposition. The 5 mm between the ankle's two axes depends
on the ankle roll it helps to find: a few fixed-point passes (each shrinks the error ~100-fold).
"""

from __future__ import annotations

import math

import numpy as np

#: Hip anchor of each side relative to the torso centre (m, body frame): le1, le2 and le3 meet there.
HIP_ANCHOR: dict[str, tuple[float, float, float]] = {"l": (-0.055, -0.010, -0.115), "r": (0.055, -0.010, -0.115)}
#: Hip to knee (in the thigh's frame), knee to ankle pitch, ankle pitch to ankle roll, ankle roll
#: to the sole (in the foot's frame), all in the zero pose.
THIGH = np.array([0.0, 0.005, -0.120])
SHANK = np.array([0.0, 0.0, -0.100])
ANKLE_GAP = np.array([0.0, 0.0, -0.005])
SOLE_BELOW_ANKLE = np.array([0.0, 0.0, -0.045])
#: Hip anchor to sole with every joint at 0 (m): the leg's full length.
LEG_LENGTH: float = -float(THIGH[2] + SHANK[2] + ANKLE_GAP[2] + SOLE_BELOW_ANKLE[2])

_L1 = float(np.linalg.norm(THIGH))
_L2 = float(np.linalg.norm(SHANK))
#: the thigh's forward slant from straight down (rad)
_DELTA = math.atan2(THIGH[1], -THIGH[2])
_Q = math.radians(45.0)
_PASSES = 5


def rot_x(a: np.ndarray | float) -> np.ndarray:
    """Rotation matrices about x by ``a`` (rad), shape ``a.shape + (3, 3)``."""
    return _rot(np.asarray(a, dtype=float), 1, 2)


def rot_y(a: np.ndarray | float) -> np.ndarray:
    """Rotation matrices about y by ``a`` (rad)."""
    return _rot(np.asarray(a, dtype=float), 2, 0)


def rot_z(a: np.ndarray | float) -> np.ndarray:
    """Rotation matrices about z by ``a`` (rad)."""
    return _rot(np.asarray(a, dtype=float), 0, 1)


def _rot(a: np.ndarray, i: int, j: int) -> np.ndarray:
    """The rotation by ``a`` in the plane of axes i -> j (right-handed about the third axis)."""
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    out[..., k, k] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., j, i] = s
    out[..., i, j] = -s
    return out


def _hip_yaw_pitch(side: str, a: np.ndarray) -> np.ndarray:
    """le1's rotation: about (-1, 0, 1)/sqrt 2 (right) or (-1, 0, -1)/sqrt 2 (left)."""
    if side == "r":
        return rot_y(-_Q) @ rot_z(a) @ rot_y(_Q)
    return rot_y(_Q) @ rot_z(-a) @ rot_y(-_Q)


def _apply(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", r, v)


def leg_fk(side: str, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the sole point under the ankle is relative to the hip anchor (m, body frame) and the
    foot's orientation, for joint angles ``angles[..., 0:6]`` = le1..le6 (rad)."""
    a = np.asarray(angles, dtype=float)
    r123 = _hip_yaw_pitch(side, a[..., 0]) @ rot_y(a[..., 1]) @ rot_x(a[..., 2])
    r4 = rot_x(a[..., 3])
    r5 = r123 @ r4 @ rot_x(a[..., 4])
    foot = r5 @ rot_y(a[..., 5])
    ankle = _apply(r123, THIGH + _apply(r4, SHANK))
    sole = ankle + _apply(r5, ANKLE_GAP) + _apply(foot, SOLE_BELOW_ANKLE)
    return sole, foot


def leg_ik(side: str, sole: np.ndarray, foot: np.ndarray) -> np.ndarray:
    """Joint angles le1..le6 (rad, shape ``sole.shape[:-1] + (6,)``) that put the sole point
    under the ankle at ``sole`` (relative to the hip anchor, body frame) with the foot turned by
    the rotation ``foot``. Out of reach, the leg stretches towards the target (never NaN);
    joint limits are the caller's."""
    sole = np.asarray(sole, dtype=float)
    roll_anchor = sole - _apply(foot, SOLE_BELOW_ANKLE)
    foot_t = np.swapaxes(foot, -1, -2)
    a6 = np.zeros(sole.shape[:-1])
    for _ in range(_PASSES):
        pitch_anchor = roll_anchor - _apply(foot @ np.swapaxes(rot_y(a6), -1, -2), ANKLE_GAP)
        q = _apply(foot_t, pitch_anchor)  # the ankle pitch axis -> hip, seen from the foot (negated)
        down = np.where(q[..., 2] <= 0.0, 1.0, -1.0)  # le6 within +-90 deg, whichever way the hip lies
        a6 = np.arctan2(down * q[..., 0], -down * q[..., 2])
    w = _apply(rot_y(a6), q)  # in the ankle's y-z plane
    reach = np.clip((np.sum(w * w, axis=-1) - _L1**2 - _L2**2) / (2 * _L1 * _L2), -1.0, 1.0)
    bend = np.arccos(reach)
    a4 = _DELTA - bend
    # v: the same vector as the leg's joints make it, before the ankle pitch turns it onto w
    vy = _L1 * np.sin(bend)
    vz = -_L1 * np.cos(bend) - _L2
    a5 = np.arctan2(vz, vy) - np.arctan2(w[..., 2], w[..., 1])
    a5 = (a5 + math.pi) % (2 * math.pi) - math.pi
    r123 = foot @ np.swapaxes(rot_y(a6), -1, -2) @ np.swapaxes(rot_x(a5), -1, -2) @ np.swapaxes(rot_x(a4), -1, -2)
    m = (rot_y(_Q) if side == "r" else rot_y(-_Q)) @ r123  # = Rz(+-le1) Ry(le2 +- 45 deg) Rx(le3)
    yaw = np.arctan2(m[..., 1, 0], m[..., 0, 0])
    pitch = -np.arcsin(np.clip(m[..., 2, 0], -1.0, 1.0))
    a3 = np.arctan2(m[..., 2, 1], m[..., 2, 2])
    a1 = yaw if side == "r" else -yaw
    a2 = pitch - _Q if side == "r" else pitch + _Q
    return np.stack([a1, a2, a3, a4, a5, a6], axis=-1)
