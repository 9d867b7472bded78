"""Noticing a fall from the robot's own sensors (the server sends no "fallen" flag).

Upright and quasi-static, the accelerometer reads the reaction to gravity along the torso's up
axis, so ``acc_z / |acc|`` estimates the z component of the torso's up vector. The community's
walk benchmark calls a robot fallen when that is below 0.6; a short moving average rides out the
one-cycle spikes of a beam or a foot strike.
"""

from __future__ import annotations

import math
from collections import deque

UP_Z_FALLEN: float = 0.6
WINDOW_CYCLES: int = 5


class FallDetector:
    def __init__(self, threshold: float = UP_Z_FALLEN, window: int = WINDOW_CYCLES) -> None:
        self.threshold = threshold
        self._recent: deque[float] = deque(maxlen=window)
        self.fallen = False

    def update(self, acc: tuple[float, float, float] | None) -> bool:
        """Feed one cycle's accelerometer; returns True on the cycle the fall is first detected."""
        if acc is None or self.fallen:
            return False
        norm = math.sqrt(acc[0] ** 2 + acc[1] ** 2 + acc[2] ** 2)
        if norm < 1.0:  # free fall or a measurement glitch: no orientation information
            return False
        self._recent.append(acc[2] / norm)
        if len(self._recent) == self._recent.maxlen and sum(self._recent) / len(self._recent) < self.threshold:
            self.fallen = True
            return True
        return False
