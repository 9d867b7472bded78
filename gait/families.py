"""The gait families the project knows, by name.

``tfs`` (the paper's 7 genes, ``gait.tfs_family``) is the default family of every command, so
Table I replicates the paper. A family is added by building a ``GaitFamily`` in its own module and
listing it in ``FAMILIES``.
"""

from __future__ import annotations

from collections.abc import Mapping

from gait.family import GaitFamily
from gait.omni import OMNI
from gait.tfs_family import TFS
from gait.tfs_plus import TFS_PLUS
from gait.tfs_start import TFS_START

#: Every family, by name; the first is the default.
FAMILIES: Mapping[str, GaitFamily] = {family.name: family for family in (TFS, TFS_PLUS, TFS_START, OMNI)}

DEFAULT_FAMILY: str = TFS.name


def family_named(name: str) -> GaitFamily:
    """The family called ``name``; a ValueError naming the known ones otherwise."""
    try:
        return FAMILIES[name]
    except KeyError:
        raise ValueError(f"unknown gait family {name!r}; known: {', '.join(FAMILIES)}") from None
