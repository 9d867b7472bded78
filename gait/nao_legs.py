"""Mapping TFS hip/knee angles onto the NAO's leg pitch joints, with the foot kept flat.

Signs follow the real server (docs/robot_and_server.md section 1): ``*le3 > 0`` swings the thigh
forward (= hip flexion), ``*le4 < 0`` bends the knee (so knee flexion enters negated), ``*le5 > 0``
lifts the toes. The ankle is not a gene: ``le5 = -(le3 + le4)`` cancels the thigh and shank pitch
so the sole stays parallel to the torso's ground plane; checked on the real server, where the
opposite sign tips the robot over within 0.7 s.

``leg_joint_targets`` maps one set of angles; ``leg_targets_into`` is the same arithmetic as a
numba kernel over robot rows, what a TFS walker evaluates every cycle (``gait.tfs_family``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from gait.tfs import LegAngles

#: The six joints the gait drives, in command order.
LEG_EFFECTORS: tuple[str, ...] = ("lle3", "lle4", "lle5", "rle3", "rle4", "rle5")
#: Each leg's (pitch, knee, ankle) effectors, left then right (a loop over them makes no names).
_LEGS = (LEG_EFFECTORS[0:3], LEG_EFFECTORS[3:6])

#: Targets stay this far inside each limit: the real server drops a command for a joint that is not
#: strictly inside (min, max), so a target sitting on a limit could leave the motor stuck.
LIMIT_MARGIN_DEG: float = 0.5


def clamped(value: float, low: float, high: float) -> float:
    """``min(max(value, low), high)``, the same float for any input (a NaN stays NaN, a tie
    keeps ``value``), at a fifth of the builtins' cost: every joint target passes here once a
    cycle."""
    value = low if low > value else value
    return high if high < value else value


def leg_limits(
    limits: Mapping[str, tuple[float, float]], margin: float = LIMIT_MARGIN_DEG
) -> tuple[np.ndarray, np.ndarray]:
    """The ranges (low, high; degrees, ``LEG_EFFECTORS`` order) ``leg_targets_into`` clamps into:
    ``margin`` inside ``limits``, which maps effector name -> (min_deg, max_deg)."""
    low = np.array([limits[name][0] for name in LEG_EFFECTORS]) + margin
    high = np.array([limits[name][1] for name in LEG_EFFECTORS]) - margin
    return low, high


@njit(cache=True)
def _clamped(value: float, low: float, high: float) -> float:
    """``clamped`` in a kernel."""
    value = low if low > value else value
    return high if high < value else value


@njit(cache=True)
def leg_targets_into(angles: np.ndarray, low: np.ndarray, high: np.ndarray, out: np.ndarray) -> None:
    """``out[r]``: the targets (``LEG_EFFECTORS`` order) of the ``LegAngles`` in ``angles[r]``,
    each clamped into [``low``, ``high``] (``leg_limits``); the ankle flattens the foot against
    the pitch and knee as they will really be, i.e. after clamping."""
    for r in range(angles.shape[0]):
        for leg in range(2):
            k = 3 * leg
            pitch = _clamped(angles[r, 2 * leg], low[k], high[k])
            knee = _clamped(-angles[r, 2 * leg + 1], low[k + 1], high[k + 1])
            out[r, k] = pitch
            out[r, k + 1] = knee
            out[r, k + 2] = _clamped(-(pitch + knee), low[k + 2], high[k + 2])


def leg_joint_targets(
    angles: LegAngles,
    limits: Mapping[str, tuple[float, float]],
    margin: float = LIMIT_MARGIN_DEG,
) -> dict[str, float]:
    """NAO joint targets in degrees for ``LEG_EFFECTORS`` (in that order), clamped ``margin``
    inside ``limits``.

    ``limits`` maps effector name -> (min_deg, max_deg); the agent passes the robot's real limits
    (``protocol.nao``), which this package does not import so it stays free of wire concerns.
    """
    targets: dict[str, float] = {}
    hips, knees = (angles.left_hip, angles.right_hip), (angles.left_knee, angles.right_knee)
    for (pitch_name, knee_name, ankle_name), hip, knee in zip(_LEGS, hips, knees):
        low, high = limits[pitch_name]
        pitch = clamped(hip, low + margin, high - margin)
        low, high = limits[knee_name]
        knee_angle = clamped(-knee, low + margin, high - margin)
        # flatten the foot against the joints as they will really be, i.e. after clamping
        targets[pitch_name] = pitch
        targets[knee_name] = knee_angle
        low, high = limits[ankle_name]
        targets[ankle_name] = clamped(-(pitch + knee_angle), low + margin, high - margin)
    return targets
