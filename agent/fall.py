"""Noticing a fall from the robot's own sensors (the server sends no "fallen" flag).

A fall is the torso's up axis tipping: the community's walk benchmark calls a robot fallen when the
up axis's z component is below 0.6. The accelerometer alone cannot tell that while walking: it reads
gravity plus the torso's own acceleration, and a fast gait's steps tip its reading past 0.6 for many
cycles while the torso stays upright (docs/history/notebook-2026.md, "Where `init` puts a robot").
So the up axis is tracked the way an attitude filter does: the gyro (exact in the server) turns it
every cycle, and where the accelerometer reads about 1 g (the torso not accelerating much) it pulls
the estimate slowly towards the gravity it reads.
"""

from __future__ import annotations

import math

from protocol.nao import CYCLE

UP_Z_FALLEN: float = 0.6
#: how far each cycle's estimate moves towards the accelerometer's gravity (a 1-s time constant)
ACC_WEIGHT: float = 0.02
#: accelerometer readings this far from 1 g (as a fraction) say more about motion than about gravity
ACC_TRUSTED: float = 0.3
_G = 9.81

Vec3 = tuple[float, float, float]


class FallDetector:
    """The world's up direction in the torso frame, from GYR and ACC; fallen when its z (the
    torso's up axis's z in the world) drops below ``threshold``."""

    def __init__(self, threshold: float = UP_Z_FALLEN, weight: float = ACC_WEIGHT, cycle: float = CYCLE) -> None:
        self.threshold = threshold
        self._weight = weight
        self._cycle = cycle
        #: the world's z axis in the torso frame (unit), None until the first reading
        self._up: Vec3 | None = None
        self.fallen = False

    @property
    def up_z(self) -> float:
        """The estimated z of the torso's up axis in the world (1 upright, 0 lying)."""
        return 1.0 if self._up is None else self._up[2]

    def update(self, acc: Vec3 | None, gyro: Vec3 | None = None) -> bool:
        """Feed one cycle's accelerometer (m/s^2) and gyro (deg/s, torso frame); returns True on
        the cycle the fall is first detected."""
        if self.fallen:
            return False
        gravity = _gravity_direction(acc)
        if self._up is None:
            self._up = gravity or (0.0, 0.0, 1.0)
        else:
            up = self._up
            if gyro is not None:  # a direction fixed in the world turns by -w x up in the torso frame
                dt = self._cycle
                wx, wy, wz = math.radians(gyro[0]) * dt, math.radians(gyro[1]) * dt, math.radians(gyro[2]) * dt
                ux, uy, uz = up
                up = (ux - (wy * uz - wz * uy), uy - (wz * ux - wx * uz), uz - (wx * uy - wy * ux))
            if gravity is not None:
                k, keep = self._weight, 1.0 - self._weight
                up = (keep * up[0] + k * gravity[0], keep * up[1] + k * gravity[1], keep * up[2] + k * gravity[2])
            self._up = _unit(up)
        if self._up[2] < self.threshold:
            self.fallen = True
            return True
        return False


def _gravity_direction(acc: Vec3 | None) -> Vec3 | None:
    """The accelerometer's reading as the world's up direction, when it reads about 1 g."""
    if acc is None:
        return None
    norm = math.sqrt(acc[0] ** 2 + acc[1] ** 2 + acc[2] ** 2)
    if abs(norm - _G) > ACC_TRUSTED * _G:
        return None
    return (acc[0] / norm, acc[1] / norm, acc[2] / norm)


def _unit(v: Vec3) -> Vec3:
    norm = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / norm, v[1] / norm, v[2] / norm)
