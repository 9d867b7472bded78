"""Turning joint targets into the velocity commands the server's hinge effectors take.

The server applies a command two cycles after the perception it answers and keeps it until the
next one, so a proportional law towards the target *two cycles ahead*, clipped to the speed cap,
tracks the trajectory without overshooting the cap (the same law drove the real-server
calibration walk).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from protocol.nao import JOINT_BY_EFFECTOR, SPEED_CAP

_DEG = math.pi / 180.0
#: Every joint of any robot type (a type with toes adds two), in index order.
_NAMES = tuple((joint.effector, joint.perceptor) for joint in JOINT_BY_EFFECTOR.values())


def joint_velocities(
    targets_deg: Mapping[str, float],
    perceived_deg: Mapping[str, float],
    gain: float,
) -> dict[str, float]:
    """rad/s for every joint in ``targets_deg`` (effector names; ``perceived_deg`` by perceptor
    name), in ``protocol.nao.joints_of`` order.

    A joint missing from the perception gets 0, which the server treats as "hold".
    """
    velocities: dict[str, float] = {}
    target_of, angle_of = targets_deg.get, perceived_deg.get
    for effector, perceptor in _NAMES:
        target = target_of(effector)
        if target is None:
            continue
        angle = angle_of(perceptor)
        v = 0.0 if angle is None else gain * (target - angle) * _DEG
        # min(max(v, -cap), cap) without the two calls: 22 joints every cycle
        velocities[effector] = SPEED_CAP if v > SPEED_CAP else -SPEED_CAP if v < -SPEED_CAP else v
    return velocities
