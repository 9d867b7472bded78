"""Gait parameter files: the 7 genes as a small JSON document with their units.

Walk parameters live in files, apart from code, so that the optimizer can write them and the agent
read them (``python -m agent --gait FILE``). Format::

    {"format": "tfs-gait/1",
     "units": {"c_h": "deg", ..., "t2": "s", "w": "rad/s"},
     "params": {"c_h": 15.0, "c_k": 30.0, "A": 10.0, "B": 10.0, "C": 20.0, "t2": 0.35, "w": 15.708},
     "notes": "free text (optional)"}
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from gait.params import GENE_NAMES, GENE_UNITS, TFSParams

FORMAT = "tfs-gait/1"

#: Shipped with the package: the slow TFS gait that walked 2.91-3.14 m in 15 s on a real
#: rcssserver3d 0.7.3 (tests/data/rcssserver3d/walk_calibration), a safe start for any search.
DEFAULT_GAIT_PATH: Path = Path(__file__).with_name("default_gait.json")


class GaitFileError(ValueError):
    """A gait file that cannot be used; the message names the file and what is wrong."""


def load_gait(path: str | Path = DEFAULT_GAIT_PATH) -> TFSParams:
    path = Path(path)
    try:
        document: Any = json.loads(path.read_text())
    except OSError as exc:
        raise GaitFileError(f"cannot read gait file {path}: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise GaitFileError(f"gait file {path} is not valid JSON: {exc}") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise GaitFileError(f'gait file {path}: expected an object with "format": "{FORMAT}"')
    params = document.get("params")
    if not isinstance(params, dict):
        raise GaitFileError(f'gait file {path}: missing the "params" object')
    missing = [name for name in GENE_NAMES if name not in params]
    unknown = sorted(set(params) - set(GENE_NAMES))
    if missing or unknown:
        raise GaitFileError(f"gait file {path}: missing parameters {missing}, unknown parameters {unknown}")
    units = document.get("units", GENE_UNITS)
    wrong_units = {k: v for k, v in units.items() if GENE_UNITS.get(k) != v}
    if wrong_units:
        raise GaitFileError(f"gait file {path}: unsupported units {wrong_units}; expected {GENE_UNITS}")
    try:
        return TFSParams(**{name: params[name] for name in GENE_NAMES})
    except ValueError as exc:
        raise GaitFileError(f"gait file {path}: {exc}") from None


def save_gait(params: TFSParams, path: str | Path, notes: str = "") -> Path:
    """Write ``params`` as a gait file; returns the path written."""
    path = Path(path)
    document = {"format": FORMAT, "units": dict(GENE_UNITS), "params": asdict(params)}
    if notes:
        document["notes"] = notes
    path.write_text(json.dumps(document, indent=2) + "\n")
    return path
