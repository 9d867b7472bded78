"""The Truncated Fourier Series (TFS) gait: 7 parameters -> hip and knee angles -> NAO leg joint targets.

Pure functions of time and parameters: no sockets, no physics, and no import from the other packages,
so the agent, the optimizer and the tests all compute the same trajectories.
"""

from gait.gait_file import DEFAULT_GAIT_PATH, GaitFileError, load_gait, save_gait
from gait.nao_legs import LEG_EFFECTORS, leg_joint_targets
from gait.params import BOUNDS_BY_NAME, GENE_BOUNDS, GENE_NAMES, LEGACY_GENE_BOUNDS, TFSParams, repair_genes
from gait.tfs import LegAngles, TFSGait

__all__ = [
    "BOUNDS_BY_NAME",
    "GENE_NAMES",
    "GENE_BOUNDS",
    "LEGACY_GENE_BOUNDS",
    "TFSParams",
    "repair_genes",
    "LegAngles",
    "TFSGait",
    "LEG_EFFECTORS",
    "leg_joint_targets",
    "DEFAULT_GAIT_PATH",
    "GaitFileError",
    "load_gait",
    "save_gait",
]
