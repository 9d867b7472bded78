"""``tfs-start``: a TFS walk begun by another TFS gait. For its first ``HOLD`` seconds the robot walks
the *start* gait, then over ``BLEND`` seconds every joint target moves linearly from the start
gait's to the *cruise* gait's, which it walks from then on. Genes: the cruise gait's 7 (the TFS's
names), then the start gait's 7 (``s_`` before each name).

Why: whether a TFS gait survives its first half second decides most of its fitness. The agent starts
walking 13 cycles after its repeated beam, while the robot is still settling, and a fast gait either
catches that motion or falls within 0.4-1.6 s. Measured on the stand-in and on the real server alike
(``python -m bench.start_sensitivity``; docs/optimizer.md, "The start-up decides"): a gait moved a
little from a fast walk mostly falls at the start, yet begun by the unmoved walk it mostly walks. So
the search space of a one-gait walk is made of narrow islands (gaits that happen to start), while
what makes a gait fast once it walks changes smoothly. Here a refinement holds the start gait (one
known to start: ``held``) and searches only the cruise gait.

Every TFS walk is a tfs-start walk: the same gait as start and cruise walks exactly as it does
alone (``extend``), so a search can begin from any TFS walk it has.
"""

from __future__ import annotations

import numpy as np

from gait.family import GaitFamily, Limits, Walker
from gait.params import GENE_NAMES, GENE_UNITS, TFSParams, repair_genes
from gait.tfs_family import TFS

#: Seconds the start gait is walked alone, then the seconds over which its joint targets blend
#: into the cruise gait's. One second of each: the moved gaits above walked when the first second
#: was the original gait's; the blend spreads the change of gait over five strides of a fast walk.
HOLD = 1.0
BLEND = 1.0

START_NAMES: tuple[str, ...] = tuple(f"s_{name}" for name in GENE_NAMES)
_N = len(GENE_NAMES)


class StartedWalker:
    """Joint targets of a tfs-start gait: the start gait, the blend, then the cruise gait. Both gaits
    run on the same clock, so the cruise gait enters at its own phase of gait time ``t``."""

    def __init__(self, genes: tuple[float, ...]) -> None:
        self.cruise: Walker = TFS.walker(genes[:_N])
        self.start: Walker = TFS.walker(genes[_N:])

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        if t >= HOLD + BLEND:
            return self.cruise.joint_targets(t, limits)
        start = self.start.joint_targets(t, limits)
        if t < HOLD:
            return start
        share = (t - HOLD) / BLEND
        cruise = self.cruise.joint_targets(t, limits)
        return {name: start[name] + share * (cruise[name] - start[name]) for name in cruise}


def _check(genes: tuple[float, ...]) -> None:
    TFSParams.from_array(genes[:_N])  # eq. 5 on each gait, with its own messages
    TFSParams.from_array(genes[_N:])


def _repair(genes: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    out = np.asarray(genes, dtype=float)
    return np.concatenate([repair_genes(out[:_N], bounds[:_N]), repair_genes(out[_N:], bounds[_N:])])


def _walker(genes: tuple[float, ...]) -> StartedWalker:
    return StartedWalker(genes)


def _extend(tfs_genes: tuple[float, ...]) -> tuple[float, ...]:
    return tfs_genes + tfs_genes  # the walk itself: its own start


TFS_START = GaitFamily(
    name="tfs-start",
    about="a TFS cruise gait begun by a TFS start gait (1 s alone, then a 1 s blend; 14 genes: cruise, then start)",
    gene_names=GENE_NAMES + START_NAMES,
    gene_units={**GENE_UNITS, **{f"s_{name}": unit for name, unit in GENE_UNITS.items()}},
    boxes={name: np.vstack([box, box]) for name, box in TFS.boxes.items()},  # each gait in the TFS's box
    check=_check,
    repair=_repair,
    walker=_walker,
    extends=TFS,
    extend=_extend,
    held=tuple(range(_N, 2 * _N)),
)
