"""Gaits: families of genes -> joint targets, the paper's Truncated Fourier Series (TFS) the default.

Pure functions of time and genes: no sockets, no physics, and no import from the other packages,
so the agent, the optimizer and the tests all compute the same trajectories.
"""

from gait.families import DEFAULT_FAMILY, FAMILIES, family_named
from gait.family import ArrayWalker, Command, Gait, GaitFamily, Steerable, Walker
from gait.gait_file import DEFAULT_GAIT_PATH, GaitFileError, load_gait, save_gait
from gait.nao_legs import LEG_EFFECTORS, leg_joint_targets
from gait.omni import OMNI, OmniWalker
from gait.params import BOUNDS_BY_NAME, GENE_BOUNDS, GENE_NAMES, LEGACY_GENE_BOUNDS, TFSParams, repair_genes
from gait.tfs import LegAngles, TFSGait
from gait.tfs_family import TFS
from gait.tfs_plus import TFS_PLUS
from gait.tfs_start import TFS_START

__all__ = [
    "DEFAULT_FAMILY",
    "FAMILIES",
    "TFS",
    "TFS_PLUS",
    "TFS_START",
    "OMNI",
    "OmniWalker",
    "family_named",
    "Gait",
    "GaitFamily",
    "Walker",
    "ArrayWalker",
    "Command",
    "Steerable",
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
