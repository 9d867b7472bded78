"""The TFS generator (paper eq. 3-4 with one harmonic), as docs/gait_families.md reads it.

Hip: ``c_h + A sin(w t)`` while the phase is in the first half period (the "upper portion"),
``c_h + B sin(w t)`` in the second half (the "lower portion"); both portions are zero at the
boundaries, so the signal is continuous for any A and B.
Knee: locked at ``c_k`` (support phase) except a half-sine bump ``c_k + C sin(w (t - t2))`` lasting
half a period from ``t2`` (phase taken modulo T) -- the swing phase's knee flexion.
The right leg runs the same signal half a period later (``t + T/2``), as in the real-server
calibration walk, so one leg supports while the other swings.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from gait.params import TFSParams


class LegAngles(NamedTuple):
    """Hip and knee flexion of both legs, degrees, human convention (flexion positive)."""

    left_hip: float
    left_knee: float
    right_hip: float
    right_knee: float


class TFSGait:
    """Evaluates one parameter set at any time; stateless so that lookahead (latency) is free."""

    def __init__(self, params: TFSParams) -> None:
        self.params = params
        self._period = params.period
        self._half = params.period / 2

    def hip(self, t: float) -> float:
        p = self.params
        phase = math.fmod(t, self._period)
        if phase < 0:
            phase += self._period
        amplitude = p.A if phase < self._half else p.B
        return p.c_h + amplitude * math.sin(p.w * phase)

    def knee(self, t: float) -> float:
        p = self.params
        since_bump_start = math.fmod(t - p.t2, self._period)
        if since_bump_start < 0:
            since_bump_start += self._period
        if since_bump_start < self._half:
            return p.c_k + p.C * math.sin(p.w * since_bump_start)
        return p.c_k

    def angles(self, t: float) -> LegAngles:
        """Both legs at gait time ``t`` (seconds since the gait started)."""
        shifted = t + self._half
        return LegAngles(self.hip(t), self.knee(t), self.hip(shifted), self.knee(shifted))
