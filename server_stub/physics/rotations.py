"""Quaternions to rotation matrices, compiled: the step turns every body's orientation into a matrix
every cycle, and the monitor every body part's every other cycle; and the orientation pybullet
gives back once handed a quaternion (``read_back``, ``stored_matrix``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def rotation_into(q: np.ndarray, out: np.ndarray) -> None:
    """``out`` (3x3) = the rotation of a unit quaternion (x, y, z, w), pybullet's order: columns
    are the turned x, y and z axes. Into a given array: the step's per-body loops need no new one."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    out[0, 0] = 1 - 2 * (y * y + z * z)
    out[0, 1] = 2 * (x * y - z * w)
    out[0, 2] = 2 * (x * z + y * w)
    out[1, 0] = 2 * (x * y + z * w)
    out[1, 1] = 1 - 2 * (x * x + z * z)
    out[1, 2] = 2 * (y * z - x * w)
    out[2, 0] = 2 * (x * z - y * w)
    out[2, 1] = 2 * (y * z + x * w)
    out[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True)
def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """The 3x3 rotation of a unit quaternion (x, y, z, w) (``rotation_into``), as a new array."""
    out = np.empty((3, 3))
    rotation_into(q, out)
    return out


@njit(cache=True)
def body_poses(base_position: np.ndarray, base_rotation: np.ndarray, links: np.ndarray) -> np.ndarray:
    """4x4 world poses, base first, then one per row of ``links``, which starts with the centre
    and orientation (x, y, z, qx, qy, qz, qw; more columns are ignored): a robot's body parts for
    the monitor, in one pass."""
    out = np.zeros((links.shape[0] + 1, 4, 4))
    out[0, :3, :3] = base_rotation
    out[0, :3, 3] = base_position
    for i in range(links.shape[0]):
        out[i + 1, :3, :3] = rotation_matrix(links[i, 3:7])
        out[i + 1, :3, 3] = links[i, :3]
    for i in range(out.shape[0]):
        out[i, 3, 3] = 1.0
    return out


def stored_matrix(q: tuple[float, ...]) -> tuple[float, ...]:
    """The rotation (9 floats, row-major) pybullet stores for a base orientation ``q`` (x, y, z, w)
    and gives back from ``getMatrixFromQuaternion``: the same products in the same order, so the
    same last bits (``tests/test_stub_speed.py`` checks this against pybullet)."""
    x, y, z, w = q
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    return (
        1.0 - (yy + zz), xy - wz, xz + wy,
        xy + wz, 1.0 - (xx + zz), yz - wx,
        xz - wy, yz + wx, 1.0 - (xx + yy),
    )  # fmt: skip


def read_back(q: tuple[float, ...]) -> tuple[float, ...]:
    """The orientation pybullet gives back after being handed ``q``: the quaternion it rebuilds
    from its stored matrix (largest of trace and diagonal first), which may differ from ``q`` in
    the last bits or in sign. A robot whose state is not written into pybullet every step
    (``Robot.hold``) reads its orientation through this, so its sensors see what pybullet's would."""
    m = stored_matrix(q)
    trace = m[0] + m[4] + m[8]
    out = [0.0, 0.0, 0.0, 0.0]
    if trace > 0.0:
        r = math.sqrt(trace + 1.0)
        out[3] = r * 0.5
        r = 0.5 / r
        out[0] = (m[7] - m[5]) * r
        out[1] = (m[2] - m[6]) * r
        out[2] = (m[3] - m[1]) * r
        return tuple(out)
    if m[0] < m[4]:
        i = 2 if m[4] < m[8] else 1
    else:
        i = 2 if m[0] < m[8] else 0
    j, k = (i + 1) % 3, (i + 2) % 3
    r = math.sqrt(m[4 * i] - m[4 * j] - m[4 * k] + 1.0)
    out[i] = r * 0.5
    r = 0.5 / r
    out[3] = (m[3 * k + j] - m[3 * j + k]) * r
    out[j] = (m[3 * j + i] + m[3 * i + j]) * r
    out[k] = (m[3 * k + i] + m[3 * i + k]) * r
    return tuple(out)


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the kernels before the first step needs them."""
    body_poses(np.zeros(3), np.eye(3), np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]))
