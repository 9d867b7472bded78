"""The paper's TFS as a gait family: the 7 genes of ``gait.params``, the generator of ``gait.tfs``,
the leg mapping of ``gait.nao_legs`` (hip and knee pitch, the foot kept flat).

A walker gives its targets as an array too (``gait.family.ArrayWalker``): a cycle is the two
kernels (``gait.tfs.angles_into``, ``gait.nao_legs.leg_targets_into``) on arrays the walker keeps,
and no dict for the agent to read back into an array.
"""

from __future__ import annotations

import numpy as np

from gait.family import GaitFamily, Limits
from gait.nao_legs import LEG_EFFECTORS, leg_limits, leg_targets_into
from gait.params import BOUNDS_BY_NAME, GENE_NAMES, GENE_UNITS, TFSParams, repair_genes
from gait.tfs import angles_into, gait_rows


class TFSWalker:
    """The paper's gait: hip and knee pitch from the TFS, the foot kept flat."""

    #: the joints of ``joint_target_array``, in its order
    target_effectors: tuple[str, ...] = LEG_EFFECTORS

    def __init__(self, params: TFSParams) -> None:
        self.params = params
        self._rows = gait_rows(params)
        self._t = np.zeros(1)
        self._angles = np.zeros((1, 4))
        #: the limits last asked with and their clamping ranges (``leg_limits``): the same each cycle
        self._limits: tuple[Limits, tuple[np.ndarray, np.ndarray]] | None = None
        warm_up()

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        return dict(zip(LEG_EFFECTORS, self.joint_target_array(t, limits).tolist()))

    def joint_target_array(self, t: float, limits: Limits) -> np.ndarray:
        """``joint_targets``' values, in ``target_effectors`` order (a new array)."""
        if self._limits is None or self._limits[0] is not limits:
            self._limits = (limits, leg_limits(limits))
        low, high = self._limits[1]
        self._t[0] = t
        angles_into(self._rows, self._t, self._angles)
        out = np.empty((1, len(LEG_EFFECTORS)))
        leg_targets_into(self._angles, low, high, out)
        return out[0]


_warm = False


def warm_up() -> None:
    """Compile the kernels (or load them from numba's disk cache: once per checkout) as the first
    walker is made, rather than in a walk's first cycle."""
    global _warm
    if _warm:
        return
    _warm = True
    angles = np.zeros((1, 4))
    angles_into(np.ones((1, 9)), np.zeros(1), angles)
    leg_targets_into(angles, np.zeros(len(LEG_EFFECTORS)), np.zeros(len(LEG_EFFECTORS)), np.zeros((1, 6)))


def _check_tfs(genes: tuple[float, ...]) -> None:
    TFSParams.from_array(genes)  # eq. 5, with its own messages


def _tfs_walker(genes: tuple[float, ...]) -> TFSWalker:
    return TFSWalker(TFSParams.from_array(genes))


TFS = GaitFamily(
    name="tfs",
    about="the paper's Truncated Fourier Series: hip and knee pitch, one harmonic, foot kept flat (7 genes)",
    gene_names=GENE_NAMES,
    gene_units=GENE_UNITS,
    boxes=BOUNDS_BY_NAME,
    check=_check_tfs,
    repair=repair_genes,
    walker=_tfs_walker,
)
