"""The 7 TFS genes (paper eq. 3-5, one harmonic) and the box the optimizer searches in.

Angles are degrees in the *human* convention (hip flexion and knee flexion positive), because that
is how the paper's Fig. 2 draws them and how the real-server calibration walk is written down;
``gait.nao_legs`` turns them into NAO joint signs.
"""
from __future__ import annotations

import math
from dataclasses import astuple, dataclass, fields

import numpy as np

#: Gene order of a chromosome, a gait file and every table.
GENE_NAMES: tuple[str, ...] = ("c_h", "c_k", "A", "B", "C", "t2", "w")

#: Units of each gene, written into gait files so a reader never has to guess.
GENE_UNITS: dict[str, str] = {
    "c_h": "deg", "c_k": "deg", "A": "deg", "B": "deg", "C": "deg", "t2": "s", "w": "rad/s",
}

#: Search bounds (low, high) per gene. Chosen so that every corner is a posture the NAO's joints
#: can reach: hip pitch spans -25..100 deg and the knee 0..130 deg of flexion; periods from 0.25 s
#: (w = 25.1) to 1.0 s (w = 6.28) cover the paper's 0.41 s step and the calibration walk's 0.4 s.
#: t2 is bounded by the longest period and folded into (0, T) by ``repair_genes``.
GENE_BOUNDS: np.ndarray = np.array(
    [
        [-10.0, 40.0],   # c_h: hip offset
        [0.0, 60.0],     # c_k: knee offset (eq. 5: c_k >= 0)
        [0.0, 40.0],     # A: hip amplitude, first half period
        [0.0, 40.0],     # B: hip amplitude, second half period
        [0.0, 60.0],     # C: knee bump amplitude
        [0.0, 1.0],      # t2: start of the knee bump within the period (s)
        [2 * math.pi / 1.0, 2 * math.pi / 0.25],  # w: angular frequency (rad/s)
    ]
)


@dataclass(frozen=True)
class TFSParams:
    """One gait: the 7 genes. Construction enforces eq. 5, so an invalid gait never reaches a robot."""

    c_h: float
    c_k: float
    A: float
    B: float
    C: float
    t2: float
    w: float

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"TFS parameter {f.name} must be a finite number, got {value!r}")
        if self.w <= 0:
            raise ValueError(f"TFS parameter w must be > 0 rad/s (the period is 2*pi/w), got {self.w}")
        if not 0 < self.t2 < self.period:
            raise ValueError(
                f"TFS parameter t2 must satisfy 0 < t2 < T = 2*pi/w = {self.period:.4f} s (eq. 5), got {self.t2}"
            )
        if self.c_k < 0:
            raise ValueError(f"TFS parameter c_k must be >= 0 deg (eq. 5), got {self.c_k}")

    @property
    def period(self) -> float:
        """T = 2*pi/w, seconds: one full stride (both legs)."""
        return 2 * math.pi / self.w

    def as_array(self) -> np.ndarray:
        return np.array(astuple(self), dtype=float)

    @classmethod
    def from_array(cls, genes: np.ndarray) -> "TFSParams":
        values = [float(v) for v in genes]
        if len(values) != len(GENE_NAMES):
            raise ValueError(f"a TFS chromosome has {len(GENE_NAMES)} genes, got {len(values)}")
        return cls(*values)


def repair_genes(genes: np.ndarray) -> np.ndarray:
    """Move a chromosome onto the feasible set of eq. 5 without leaving ``GENE_BOUNDS``.

    The GA's operators work gene by gene inside a box, but ``t2 < T`` couples t2 to w; folding t2
    into (0, T) keeps the knee bump's phase meaning and avoids rejecting individuals.
    """
    out = np.clip(np.asarray(genes, dtype=float), GENE_BOUNDS[:, 0], GENE_BOUNDS[:, 1])
    period = 2 * math.pi / out[6]
    t2 = math.fmod(out[5], period)
    # keep t2 strictly inside (0, T): a zero phase would violate eq. 5's strict inequality
    out[5] = min(max(t2, 1e-3 * period), period * (1 - 1e-3))
    return out
