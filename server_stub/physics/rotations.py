"""Quaternions to rotation matrices, compiled: the stub turns every body part's orientation into a
matrix every cycle (the slip model) and every other cycle (the monitor's body-part poses)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
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


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the kernels before the first step needs them."""
    body_poses(np.zeros(3), np.eye(3), np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]))
