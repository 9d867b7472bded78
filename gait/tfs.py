"""The TFS generator (paper eq. 3-4 with one harmonic), as docs/gait_families.md reads it.

Hip: ``c_h + A sin(w t)`` while the phase is in the first half period (the "upper portion"),
``c_h + B sin(w t)`` in the second half (the "lower portion"); both portions are zero at the
boundaries, so the signal is continuous for any A and B.
Knee: locked at ``c_k`` (support phase) except a half-sine bump ``c_k + C sin(w (t - t2))`` lasting
half a period from ``t2`` (phase taken modulo T) -- the swing phase's knee flexion.
The right leg runs the same signal half a period later (``t + T/2``), as in the real-server
calibration walk, so one leg supports while the other swings.

``TFSGait`` evaluates it one number at a time; ``angles_into`` is the same arithmetic as a numba
kernel over gait rows (a row per robot, as ``gait_rows`` makes them), what a walker evaluates
every cycle: one compiled call costs less than the Python of one leg.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from gait.params import TFSParams

#: The columns of a gait row (``gait_rows``): the 7 genes, then the period and half period.
_C_H, _C_K, _A, _B, _C, _T2, _W, _PERIOD, _HALF = range(9)


class LegAngles(NamedTuple):
    """Hip and knee flexion of both legs, degrees, human convention (flexion positive)."""

    left_hip: float
    left_knee: float
    right_hip: float
    right_knee: float


def gait_rows(params: TFSParams) -> np.ndarray:
    """The kernels' row (1, 9) of one gait: its genes, then its period and half period."""
    period = params.period
    return np.array([[params.c_h, params.c_k, params.A, params.B, params.C, params.t2, params.w, period, period / 2]])


@njit(cache=True)
def _hip(g: np.ndarray, t: float) -> float:
    phase = np.fmod(t, g[_PERIOD])
    if phase < 0:
        phase += g[_PERIOD]
    amplitude = g[_A] if phase < g[_HALF] else g[_B]
    return g[_C_H] + amplitude * math.sin(g[_W] * phase)


@njit(cache=True)
def _knee(g: np.ndarray, t: float) -> float:
    since_bump_start = np.fmod(t - g[_T2], g[_PERIOD])
    if since_bump_start < 0:
        since_bump_start += g[_PERIOD]
    if since_bump_start < g[_HALF]:
        return g[_C_K] + g[_C] * math.sin(g[_W] * since_bump_start)
    return g[_C_K]


@njit(cache=True)
def angles_into(rows: np.ndarray, t: np.ndarray, out: np.ndarray) -> None:
    """``out[r]``: ``LegAngles`` of gait ``rows[r]`` at gait time ``t[r]`` (left hip, left knee,
    right hip, right knee; degrees). ``np.fmod`` is C's ``fmod``, exact as ``math.fmod`` is, and
    ``math.sin`` the C library's ``sin`` that Python's calls too."""
    for r in range(rows.shape[0]):
        g = rows[r]
        shifted = t[r] + g[_HALF]
        out[r, 0] = _hip(g, t[r])
        out[r, 1] = _knee(g, t[r])
        out[r, 2] = _hip(g, shifted)
        out[r, 3] = _knee(g, shifted)


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
