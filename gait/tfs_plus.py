"""``tfs-plus``: the paper's TFS and what fast bipeds add to it, each addition a gene that is 0 in
the TFS, so every TFS walk is a tfs-plus walk (the 7 TFS genes, the additions at 0) and a search
can start from the best TFS walk it has.

The additions, one stride period T = 2 pi / w like the TFS, the right leg half a period later:

- **Ankle pitch** (``c_a``, ``P``, ``phi_a``): the TFS holds the sole parallel to the torso's
  ground plane. Here the ankle adds an offset ``c_a`` and a wave ``P sin(w t + phi_a)``: with the
  right phase, a push-off that plantar-flexes the stance foot before it leaves the ground (toes
  down is ``le5 < 0``).
- **Sideways sway** (``S``, ``phi_s``): both hip rolls ``le2`` tilt the legs sideways by
  ``S sin(w t + phi_s)`` and both ankle rolls ``le6`` take the opposite angle, so the soles stay
  flat while the torso shifts over the stance foot, once a stride (the NAO's roll joints share one
  sign convention for this: the same angle on both legs moves both feet the same way).
- **Arm swing** (``R``): the shoulder pitches ``ae1`` swing by ``-R sin(w t)`` (left) and
  ``+R sin(w t)`` (right) about the arms-down posture (-90 deg), each arm in step with the other
  side's leg, against the legs' yaw moment. ``R`` takes either sign, so which way is "against"
  is the search's to find, not an assumption of ours about the joint's axis.

The gene box is derived from the robot (``protocol.nao`` facts, restated here; tests check them):
the ankle pitch offset and wave stay within the 45 deg the ankle can plantar-flex, the sway within
the 25 deg each hip rolls inwards, the arm swing within the 90 deg from arms down to horizontal,
either way.
"""

from __future__ import annotations

import math

import numpy as np

from gait.family import GaitFamily, Limits
from gait.nao_legs import LIMIT_MARGIN_DEG, clamped
from gait.params import GENE_BOUNDS, GENE_NAMES, GENE_UNITS, TFSParams, repair_genes
from gait.tfs_family import TFS, TFSWalker

#: The additions' genes, after the TFS's 7.
EXTRA_NAMES: tuple[str, ...] = ("c_a", "P", "phi_a", "S", "phi_s", "R")
EXTRA_UNITS: dict[str, str] = {"c_a": "deg", "P": "deg", "phi_a": "rad", "S": "deg", "phi_s": "rad", "R": "deg"}

# Robot facts (rcssserver3d 0.7.3's NAO): ankle pitch le5 -45..75 deg (toes down negative), hip
# roll le2 -25..45 (left) / -45..25 (right): 25 deg inwards; shoulder pitch ae1 -120..120 with
# the arms hanging at -90.
_ANKLE_PLANTAR = 45.0
_HIP_ROLL_INWARD = 25.0
_ARMS_DOWN = -90.0
_ARM_TO_HORIZONTAL = 90.0

#: The phases' positions among the genes: they wrap around instead of being clipped.
_PHASES = (GENE_NAMES + EXTRA_NAMES).index("phi_a"), (GENE_NAMES + EXTRA_NAMES).index("phi_s")

#: The box: the TFS's own, then the additions (offset +-half the plantar range, a wave up to it,
#: phases all round, the sway up to the inward hip roll, the arm swing up to horizontal either way).
BOUNDS: np.ndarray = np.vstack(
    [
        GENE_BOUNDS,
        [
            [-_ANKLE_PLANTAR / 2, _ANKLE_PLANTAR / 2],  # c_a
            [0.0, _ANKLE_PLANTAR],  # P
            [0.0, 2 * math.pi],  # phi_a
            [0.0, _HIP_ROLL_INWARD],  # S
            [0.0, 2 * math.pi],  # phi_s
            [-_ARM_TO_HORIZONTAL, _ARM_TO_HORIZONTAL],  # R
        ],
    ]
)


def _clamp(limits: Limits, name: str, value: float) -> float:
    low, high = limits[name]
    return clamped(value, low + LIMIT_MARGIN_DEG, high - LIMIT_MARGIN_DEG)


class TFSPlusWalker:
    """Joint targets of one tfs-plus gait: the TFS's legs, then the additions on top."""

    def __init__(self, genes: tuple[float, ...]) -> None:
        self.tfs = TFSParams.from_array(genes[: len(GENE_NAMES)])
        self._legs = TFSWalker(self.tfs)
        self.c_a, self.P, self.phi_a, self.S, self.phi_s, self.R = genes[len(GENE_NAMES) :]

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        targets = self._legs.joint_targets(t, limits)
        w, half = self.tfs.w, self.tfs.period / 2
        for side, shift in (("l", 0.0), ("r", half)):
            push = self.P * math.sin(w * (t + shift) + self.phi_a)
            targets[f"{side}le5"] = _clamp(limits, f"{side}le5", targets[f"{side}le5"] + self.c_a + push)
        sway = self.S * math.sin(w * t + self.phi_s)
        swing = self.R * math.sin(w * t)
        for side in "lr":
            targets[f"{side}le2"] = _clamp(limits, f"{side}le2", sway)
            targets[f"{side}le6"] = _clamp(limits, f"{side}le6", -sway)
        targets["lae1"] = _clamp(limits, "lae1", _ARMS_DOWN - swing)  # the left arm with the right leg
        targets["rae1"] = _clamp(limits, "rae1", _ARMS_DOWN + swing)
        return targets


def _check(genes: tuple[float, ...]) -> None:
    TFSParams.from_array(genes[: len(GENE_NAMES)])  # eq. 5 on the TFS part
    for name, value, (low, high) in zip(EXTRA_NAMES, genes[len(GENE_NAMES) :], BOUNDS[len(GENE_NAMES) :]):
        if name.startswith("phi"):
            continue  # any phase is a phase
        if not low <= value <= high:
            raise ValueError(f"tfs-plus gene {name} must lie in [{low:g}, {high:g}], got {value}")


def _repair(genes: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    out = np.asarray(genes, dtype=float).copy()
    for k in _PHASES:
        out[k] = math.fmod(out[k], 2 * math.pi) % (2 * math.pi)
    tfs = repair_genes(out[: len(GENE_NAMES)], bounds[: len(GENE_NAMES)])
    extra = np.clip(out[len(GENE_NAMES) :], bounds[len(GENE_NAMES) :, 0], bounds[len(GENE_NAMES) :, 1])
    return np.concatenate([tfs, extra])


def _walker(genes: tuple[float, ...]) -> TFSPlusWalker:
    return TFSPlusWalker(genes)


#: The additions' values at which a tfs-plus gait walks exactly as its TFS part.
NEUTRAL: tuple[float, ...] = (0.0,) * len(EXTRA_NAMES)


def _extend(tfs_genes: tuple[float, ...]) -> tuple[float, ...]:
    return tfs_genes + NEUTRAL


TFS_PLUS = GaitFamily(
    name="tfs-plus",
    about="the TFS plus ankle push-off, sideways sway and arm swing (13 genes; the additions at 0 are the TFS)",
    gene_names=GENE_NAMES + EXTRA_NAMES,
    gene_units={**GENE_UNITS, **EXTRA_UNITS},
    boxes={"robot": BOUNDS},
    check=_check,
    repair=_repair,
    walker=_walker,
    extends=TFS,
    extend=_extend,
)
