"""The NAO's leg as a kinematic chain: forward kinematics and an analytic inverse that places a
sole anywhere in reach with any orientation (the omni walk asks for flat, yawed soles).

Why analytic: an omnidirectional walk plans where the feet go, not joint angles; solving the six
joints in closed form costs about a microsecond a leg, compiled (``ik_into``, a numba kernel over
rows with scalar math inside: numpy's overhead on 3 x 3 arrays cost ~1 ms a cycle), for one robot
or many (``leg_ik`` takes arrays with any leading axes, e.g. one row per robot). The forward
kinematics, for checks rather than cycles, stays numpy.

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
from numba import njit

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
    rows = np.ascontiguousarray(sole.reshape(-1, 3))
    feet = np.ascontiguousarray(np.broadcast_to(np.asarray(foot, dtype=float), sole.shape + (3,)).reshape(-1, 3, 3))
    out = np.empty((len(rows), 6))
    ik_into(_RIGHT if side == "r" else _LEFT, rows, feet, out)
    return out.reshape(sole.shape[:-1] + (6,))


def legs_ik(sole: np.ndarray, foot: np.ndarray) -> np.ndarray:
    """``leg_ik`` of both legs of each robot at once: ``sole`` (n, 2, 3) and ``foot`` (n, 2, 3, 3)
    the left's then the right's; joint angles (n, 2, 6)."""
    out = np.empty((len(sole), 2, 6))
    ik_into(LEFT_RIGHT, sole.reshape(-1, 3), foot.reshape(-1, 3, 3), out.reshape(-1, 6))
    return out


#: which leg each row is (``ik_into``'s rows cycle through it): all left, all right, in pairs
_LEFT, _RIGHT, LEFT_RIGHT = np.array([False]), np.array([True]), np.array([False, True])
#: the sole below the ankle roll axis and the gap between the ankle's axes (m, along the foot's z)
_SOLE_Z = float(SOLE_BELOW_ANKLE[2])
_GAP_Z = float(ANKLE_GAP[2])
_L1_SQ = _L1**2
_L2_SQ = _L2**2
_TWO_L1_L2 = 2 * _L1 * _L2
_TWO_PI = 2 * math.pi
#: rot_y(45 deg) (right leg) and rot_y(-45 deg) (left leg)
_TURN_RIGHT = np.ascontiguousarray(rot_y(_Q))
_TURN_LEFT = np.ascontiguousarray(rot_y(-_Q))


@njit(cache=True)
def _times(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """out = a @ b (3 x 3)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(cache=True)
def _times_rot_t(a: np.ndarray, angle: float, i: int, j: int, out: np.ndarray) -> None:
    """out = a @ R.T, R the rotation by ``angle`` in the plane of axes i -> j (``_rot``'s)."""
    c, s = math.cos(angle), math.sin(angle)
    k = 3 - i - j
    for r in range(3):
        # R.T has [i, i] = [j, j] = c, [i, j] = s, [j, i] = -s, [k, k] = 1
        out[r, i] = a[r, i] * c + a[r, j] * -s
        out[r, j] = a[r, i] * s + a[r, j] * c
        out[r, k] = a[r, k]


@njit(cache=True)
def ik_into(legs: np.ndarray, soles: np.ndarray, feet: np.ndarray, out: np.ndarray) -> None:
    """``leg_ik`` of each row of ``soles`` (m, 3) and ``feet`` (m, 3, 3) into ``out`` (m, 6): row
    r the right leg's where ``legs[r % len(legs)]``, else the left's."""
    m1 = np.empty((3, 3))
    m2 = np.empty((3, 3))
    m = np.empty((3, 3))
    for r in range(len(soles)):
        f = feet[r]
        right = legs[r % len(legs)]
        ra0 = soles[r, 0] - f[0, 2] * _SOLE_Z
        ra1 = soles[r, 1] - f[1, 2] * _SOLE_Z
        ra2 = soles[r, 2] - f[2, 2] * _SOLE_Z
        a6 = 0.0
        q0 = q1 = q2 = 0.0
        for _ in range(_PASSES):
            c, s = math.cos(a6), math.sin(a6)
            # the pitch anchor: the roll anchor less (foot @ rot_y(a6).T) @ ANKLE_GAP
            pa0 = ra0 - (f[0, 0] * -s + f[0, 2] * c) * _GAP_Z
            pa1 = ra1 - (f[1, 0] * -s + f[1, 2] * c) * _GAP_Z
            pa2 = ra2 - (f[2, 0] * -s + f[2, 2] * c) * _GAP_Z
            # the ankle pitch axis -> hip, seen from the foot (negated)
            q0 = f[0, 0] * pa0 + f[1, 0] * pa1 + f[2, 0] * pa2
            q1 = f[0, 1] * pa0 + f[1, 1] * pa1 + f[2, 1] * pa2
            q2 = f[0, 2] * pa0 + f[1, 2] * pa1 + f[2, 2] * pa2
            down = 1.0 if q2 <= 0.0 else -1.0  # le6 within +-90 deg, whichever way the hip lies
            a6 = math.atan2(down * q0, -down * q2)
        c, s = math.cos(a6), math.sin(a6)
        w1 = q1  # w: q in the ankle's y-z plane
        w2 = -s * q0 + c * q2
        w0 = c * q0 + s * q2
        reach = min(max((w0 * w0 + w1 * w1 + w2 * w2 - _L1_SQ - _L2_SQ) / _TWO_L1_L2, -1.0), 1.0)
        bend = math.acos(reach)
        a4 = _DELTA - bend
        # v: the same vector as the leg's joints make it, before the ankle pitch turns it onto w
        vy = _L1 * math.sin(bend)
        vz = -_L1 * math.cos(bend) - _L2
        a5 = math.atan2(vz, vy) - math.atan2(w2, w1)
        a5 = (a5 + math.pi) % _TWO_PI - math.pi
        _times_rot_t(f, a6, 2, 0, m1)  # foot @ rot_y(a6).T
        _times_rot_t(m1, a5, 1, 2, m2)  # @ rot_x(a5).T
        _times_rot_t(m2, a4, 1, 2, m1)  # @ rot_x(a4).T: le1 * le2 * le3
        _times(_TURN_RIGHT if right else _TURN_LEFT, m1, m)  # = Rz(+-le1) Ry(le2 +- 45 deg) Rx(le3)
        yaw = math.atan2(m[1, 0], m[0, 0])
        pitch = -math.asin(min(max(m[2, 0], -1.0), 1.0))
        out[r, 0] = yaw if right else -yaw
        out[r, 1] = pitch - _Q if right else pitch + _Q
        out[r, 2] = math.atan2(m[2, 1], m[2, 2])
        out[r, 3] = a4
        out[r, 4] = a5
        out[r, 5] = a6
