"""The paper's TFS as a gait family: the 7 genes of ``gait.params``, the generator of ``gait.tfs``,
the leg mapping of ``gait.nao_legs`` (hip and knee pitch, the foot kept flat)."""

from __future__ import annotations

from gait.family import GaitFamily, Limits
from gait.nao_legs import leg_joint_targets
from gait.params import BOUNDS_BY_NAME, GENE_NAMES, GENE_UNITS, TFSParams, repair_genes
from gait.tfs import TFSGait


class TFSWalker:
    """The paper's gait: hip and knee pitch from the TFS, the foot kept flat."""

    def __init__(self, params: TFSParams) -> None:
        self.params = params
        self._gait = TFSGait(params)

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]:
        return leg_joint_targets(self._gait.angles(t), limits)


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
