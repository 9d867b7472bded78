"""The 7 TFS genes (paper eq. 3-5, one harmonic) and the box the optimizer searches in.

Angles are degrees in the *human* convention (hip flexion and knee flexion positive), because that
is how the paper's Fig. 2 draws them and how the real-server calibration walk is written down;
``gait.nao_legs`` turns them into NAO joint signs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass, fields

import numpy as np

#: Gene order of a chromosome, a gait file and every table.
GENE_NAMES: tuple[str, ...] = ("c_h", "c_k", "A", "B", "C", "t2", "w")

#: Units of each gene, written into gait files so a reader never has to guess.
GENE_UNITS: dict[str, str] = {
    "c_h": "deg",
    "c_k": "deg",
    "A": "deg",
    "B": "deg",
    "C": "deg",
    "t2": "s",
    "w": "rad/s",
}

# The robot facts the box is derived from (the NAO of rcssserver3d 0.7.3; ``tests/test_gait.py``
# checks them against ``protocol.nao``, which this package does not import): hip pitch ``le3``
# -25..100 deg of flexion, knee ``le4`` -130..1 deg (0..130 deg of flexion), every hinge capped at
# 6.1395 rad/s, one command per 0.02 s cycle.
_HIP_RANGE = (-25.0, 100.0)
_KNEE_FLEXION_RANGE = (0.0, 130.0)
_SPEED_CAP_DEG = math.degrees(6.1395)
_CYCLE = 0.02

#: The fastest stride the box holds: 8 control cycles, so each leg's half stride gets 4 commands,
#: twice the server's 2-cycle action latency. The fastest walks known on the real server step
#: every 0.08 s (a 0.16 s stride) and sit just inside it.
_SHORTEST_PERIOD = 8 * _CYCLE
#: The widest hip swing of the box: half the hip's range each way (A + B can then span the whole
#: 125 deg range, from some offset, without forcing a joint stop).
_WIDEST_SWING = (_HIP_RANGE[1] - _HIP_RANGE[0]) / 2
#: The slowest stride the box holds: the one at which the widest swing just reaches the speed cap
#: (A w = cap). Below it every joint of every gait in the box moves slower than the cap, and a
#: slower stride only walks slower; above it the cap starts to shape the widest swings.
_LONGEST_PERIOD = 2 * math.pi * _WIDEST_SWING / _SPEED_CAP_DEG

#: Search bounds (low, high) per gene, from the robot rather than from habit: every offset is a
#: posture the joints can hold, every amplitude one the joints can follow at the slowest stride,
#: and the strides span what the control cycle and the speed cap allow (above). It holds the
#: fastest TFS walks known on the real server (C up to 89 deg: a knee bump that large is clipped by
#: the speed cap into a fast triangle, which is what makes those walks fast). t2 is bounded by the
#: longest period and folded into (0, T) by ``repair_genes``.
GENE_BOUNDS: np.ndarray = np.array(
    [
        list(_HIP_RANGE),  # c_h: hip offset, the hip pitch range
        list(_KNEE_FLEXION_RANGE),  # c_k: knee offset, the knee range (eq. 5: c_k >= 0)
        [0.0, _WIDEST_SWING],  # A: hip amplitude, first half period
        [0.0, _WIDEST_SWING],  # B: hip amplitude, second half period
        [0.0, _KNEE_FLEXION_RANGE[1]],  # C: knee bump, up to the whole knee range
        [0.0, _LONGEST_PERIOD],  # t2: start of the knee bump within the period (s)
        [2 * math.pi / _LONGEST_PERIOD, 2 * math.pi / _SHORTEST_PERIOD],  # w: angular frequency (rad/s)
    ]
)

#: The box of runs made before the bounds were derived from the robot (c_h -10..40, c_k 0..60,
#: A and B 0..40, C 0..60, periods 0.25-1 s). It stopped short of the fast real walks (their knee
#: bump is 70-89 deg); a run folder that does not name its bounds was searched in it.
LEGACY_GENE_BOUNDS: np.ndarray = np.array(
    [
        [-10.0, 40.0],
        [0.0, 60.0],
        [0.0, 40.0],
        [0.0, 40.0],
        [0.0, 60.0],
        [0.0, 1.0],
        [2 * math.pi / 1.0, 2 * math.pi / 0.25],
    ]
)

#: Named boxes a run folder records (``--bounds``), so a resumed run searches the box it began in.
BOUNDS_BY_NAME: dict[str, np.ndarray] = {"robot": GENE_BOUNDS, "legacy": LEGACY_GENE_BOUNDS}


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
    def from_array(cls, genes: np.ndarray | Sequence[float]) -> TFSParams:
        values = [float(v) for v in genes]
        if len(values) != len(GENE_NAMES):
            raise ValueError(f"a TFS chromosome has {len(GENE_NAMES)} genes, got {len(values)}")
        return cls(*values)


def repair_genes(genes: np.ndarray, bounds: np.ndarray = GENE_BOUNDS) -> np.ndarray:
    """Move a chromosome onto the feasible set of eq. 5 without leaving ``bounds``.

    The GA's operators work gene by gene inside a box, but ``t2 < T`` couples t2 to w; folding t2
    into (0, T) keeps the knee bump's phase meaning and avoids rejecting individuals.
    """
    out = np.clip(np.asarray(genes, dtype=float), bounds[:, 0], bounds[:, 1])
    period = 2 * math.pi / out[6]
    t2 = math.fmod(out[5], period)
    # keep t2 strictly inside (0, T): a zero phase would violate eq. 5's strict inequality
    out[5] = min(max(t2, 1e-3 * period), period * (1 - 1e-3))
    return out
