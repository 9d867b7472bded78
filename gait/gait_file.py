"""Gait files: one gait's family and genes as a small JSON document with their units.

Walk parameters live in files, apart from code, so that the optimizer can write them and the agent
read them (``python -m agent --gait FILE``). Format::

    {"format": "gait/2",
     "family": "tfs",
     "units": {"c_h": "deg", ..., "t2": "s", "w": "rad/s"},
     "params": {"c_h": 15.0, "c_k": 30.0, "A": 10.0, "B": 10.0, "C": 20.0, "t2": 0.35, "w": 15.708},
     "notes": "free text (optional)"}

Files of the first format, ``"format": "tfs-gait/1"`` with no family, hold the paper's TFS gait and
still load. A family that gained a gene after files of it were written reads those files with the
gene at the value that walks as before (``ADDED_GENES``): an ``omni`` file of 19 genes, from before
``lag_comp``, loads as the same walk with ``lag_comp`` 0, and one from before the calibration with
gains of 1 and no ``side_turn``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from gait.families import family_named
from gait.family import Gait
from gait.tfs_family import TFS

FORMAT = "gait/2"
#: The first format: a TFS gait, no family named.
TFS_FORMAT_1 = "tfs-gait/1"

#: Shipped with the package: the slow TFS gait that walked 2.91-3.14 m in 15 s on a real
#: rcssserver3d 0.7.3 (tests/data/rcssserver3d/walk_calibration), a safe start for any search.
DEFAULT_GAIT_PATH: Path = Path(__file__).with_name("default_gait.json")
#: Per family, the genes it gained after files of it were written, each at the value that leaves
#: its walk as it was: a file without them loads with these (and without their units).
ADDED_GENES: dict[str, dict[str, float]] = {
    "omni": {
        "lag_comp": 0.0,
        "gain_forward": 1.0,
        "gain_backward": 1.0,
        "gain_left": 1.0,
        "gain_turn": 1.0,
        "side_turn": 0.0,
    }
}


class GaitFileError(ValueError):
    """A gait file that cannot be used; the message names the file and what is wrong."""


def load_gait(path: str | Path = DEFAULT_GAIT_PATH) -> Gait:
    path = Path(path)
    try:
        document: Any = json.loads(path.read_text())
    except OSError as exc:
        raise GaitFileError(f"cannot read gait file {path}: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise GaitFileError(f"gait file {path} is not valid JSON: {exc}") from None
    if not isinstance(document, dict) or document.get("format") not in (FORMAT, TFS_FORMAT_1):
        raise GaitFileError(f'gait file {path}: expected an object with "format": "{FORMAT}" (or "{TFS_FORMAT_1}")')
    try:
        family = TFS if document["format"] == TFS_FORMAT_1 else family_named(str(document.get("family")))
    except ValueError as exc:
        raise GaitFileError(f"gait file {path}: {exc}") from None
    params = document.get("params")
    if not isinstance(params, dict):
        raise GaitFileError(f'gait file {path}: missing the "params" object')
    params = {**ADDED_GENES.get(family.name, {}), **params}
    missing = [name for name in family.gene_names if name not in params]
    unknown = sorted(set(params) - set(family.gene_names))
    if missing or unknown:
        raise GaitFileError(
            f"gait file {path}: a {family.name} gait; missing parameters {missing}, unknown parameters {unknown}"
        )
    units = document.get("units", family.gene_units)
    wrong_units = {k: v for k, v in units.items() if family.gene_units.get(k) != v}
    if wrong_units:
        raise GaitFileError(f"gait file {path}: unsupported units {wrong_units}; expected {dict(family.gene_units)}")
    try:
        return Gait(family, tuple(params[name] for name in family.gene_names))
    except ValueError as exc:
        raise GaitFileError(f"gait file {path}: {exc}") from None


def save_gait(gait: Gait, path: str | Path, notes: str = "") -> Path:
    """Write ``gait`` as a gait file; returns the path written."""
    path = Path(path)
    family = gait.family
    document = {"format": FORMAT, "family": family.name, "units": dict(family.gene_units), "params": gait.params}
    if notes:
        document["notes"] = notes
    path.write_text(json.dumps(document, indent=2) + "\n")
    return path
