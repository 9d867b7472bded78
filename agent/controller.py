"""Turning joint targets into the velocity commands the server's hinge effectors take.

The server applies a command two cycles after the perception it answers and keeps it until the
next one, so a proportional law towards the target *two cycles ahead*, clipped to the speed cap,
tracks the trajectory without overshooting the cap (the same law drove the real-server
calibration walk).

The law runs every cycle, so the agent takes it from a numba kernel over robot rows
(``velocities_into``): one compiled call a cycle instead of five array operations on 22 numbers
(``velocities_towards``, the same floats), each of which cost about as much as the whole kernel.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numba import njit

from protocol.nao import JOINT_BY_EFFECTOR, SPEED_CAP

_DEG = math.pi / 180.0
#: Every joint of any robot type (a type with toes adds two), in index order.
_NAMES = tuple((joint.effector, joint.perceptor) for joint in JOINT_BY_EFFECTOR.values())


@njit(cache=True)
def velocities_into(targets_deg: np.ndarray, perceived_deg: np.ndarray, gains: np.ndarray, out: np.ndarray) -> None:
    """``out[r]``: rad/s towards ``targets_deg[r]`` from ``perceived_deg[r]`` (degrees; a row per
    robot, a column per joint) by ``gains[r]``, clipped to the speed cap: ``min(max(v, -cap),
    cap)`` of ``v = gain (target - perceived) deg``, the scalar law's floats (the operations in its
    order; a NaN stays NaN, to be refused when sent)."""
    for r in range(targets_deg.shape[0]):
        gain = gains[r]
        for k in range(targets_deg.shape[1]):
            v = gain * (targets_deg[r, k] - perceived_deg[r, k]) * _DEG
            if v < -SPEED_CAP:
                v = -SPEED_CAP
            elif v > SPEED_CAP:
                v = SPEED_CAP
            out[r, k] = v


def velocities_towards(targets_deg: np.ndarray, perceived_deg: np.ndarray, gain: float) -> np.ndarray:
    """rad/s towards ``targets_deg`` from ``perceived_deg`` (degrees, joint by joint), clipped to
    the speed cap. The agent's law on arrays: a few array operations instead of a loop over 22
    joints, with the same floats (each element takes the same operations in the same order as the
    scalar law did); ``velocities_into`` is it again as a kernel, the same floats."""
    v = gain * (targets_deg - perceived_deg) * _DEG
    # min(max(v, -cap), cap); a NaN stays NaN (refused when sent)
    return np.minimum(np.maximum(v, -SPEED_CAP, out=v), SPEED_CAP, out=v)


def joint_velocities(
    targets_deg: Mapping[str, float],
    perceived_deg: Mapping[str, float],
    gain: float,
) -> dict[str, float]:
    """rad/s for every joint in ``targets_deg`` (effector names; ``perceived_deg`` by perceptor
    name), in ``protocol.nao.joints_of`` order (``velocities_towards`` by name).

    A joint missing from the perception gets 0, which the server treats as "hold".
    """
    names = [(effector, perceptor) for effector, perceptor in _NAMES if effector in targets_deg]
    targets = np.array([targets_deg[effector] for effector, _ in names], dtype=float)
    perceived = np.array([perceived_deg.get(perceptor, 0.0) for _, perceptor in names], dtype=float)
    velocities = velocities_towards(targets, perceived, gain)
    velocities[[i for i, (_, perceptor) in enumerate(names) if perceptor not in perceived_deg]] = 0.0
    return dict(zip((effector for effector, _ in names), velocities.tolist()))
