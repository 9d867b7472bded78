"""The episode record: one finished episode as the run's log keeps it, typed.

A record carries what kind of walk it was, so nothing downstream has to guess: a *search* walk is
one a search asked for to score a candidate (from the run's start, or from a moved start when a
comparison scores candidates robustly); a *check* walk repeats a found gait from a moved start to
see whether it falls (``optimizer.run.stability``). The kind decides which walks count as a
search's progress and which may be reported as its finds.

On disk a record is one JSON object per line of ``episodes.jsonl`` (``to_json``/``from_json``).
Logs written before records carried their kind are read by the key: check walks have always been
keyed ``check/...``. A course walk's record also carries whether it finished, the poses it reached
and when it reached each (``optimizer.episode.course``); other records leave them out.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from optimizer.episode import Start

#: Key prefix of every check walk (``optimizer.run.stability``).
CHECK_PREFIX = "check/"


class WalkKind(StrEnum):
    SEARCH = "search"
    CHECK = "check"


class RecordError(ValueError):
    """A logged line that is not a usable record; the message says which field and why."""


@dataclass(frozen=True)
class EpisodeRecord:
    """One finished episode: which candidate (key, genes, its seed and start), what kind of walk,
    which worker ran it, and the runner's result (``optimizer.episode.EpisodeResult``).

    ``start`` is None for a walk from the run's own start, ``family`` None for a gait of the run's
    own family (a run may walk gaits of another: the main job's refinement walks tfs-start gaits).
    ``seed`` and ``worker`` are None only in records of logs that did not keep them."""

    key: str
    genes: tuple[float, ...]
    fitness: float
    kind: WalkKind = WalkKind.SEARCH
    seed: int | None = None
    start: Start | None = None
    worker: int | None = None
    distance: float = 0.0
    fell: bool = False
    time: float = 0.0
    mean_speed: float = 0.0
    status: str = "ok"
    reason: str = ""
    wall: float = 0.0
    #: a traced walk's drift (m, left +), turn (deg, left +) and thinned torso track
    #: (``optimizer.episode.scoring.TRACK_FIELDS`` per point); None for an untraced walk
    drift: float | None = None
    heading_change: float | None = None
    track: tuple[tuple[float, ...], ...] | None = None
    family: str | None = None
    #: a course walk's outcome (``EpisodeResult.finished``, ``.reached``, ``.legs``: whether it reached
    #: every pose, how many it reached, the game time it reached each); None for other walks
    finished: bool | None = None
    reached: int | None = None
    legs: tuple[float, ...] | None = None

    @property
    def ran(self) -> bool:
        """The episode was walked (not lost to the infrastructure)."""
        return self.status == "ok"

    @property
    def stood(self) -> bool:
        """Walked to the end without a fall."""
        return self.ran and not self.fell

    @property
    def on_course(self) -> bool:
        """A course walk's record (``finished``, ``reached`` and ``legs`` set)."""
        return self.finished is not None

    @property
    def is_search(self) -> bool:
        return self.kind is WalkKind.SEARCH

    def to_json(self) -> dict[str, Any]:
        """The log line's object: fields that are None are left out, as they always were."""
        document: dict[str, Any] = {"key": self.key, "genes": list(self.genes), "kind": self.kind.value}
        if self.family is not None:
            document["family"] = self.family
        if self.seed is not None:
            document["seed"] = self.seed
        if self.start is not None:
            document["start"] = list(self.start)
        if self.worker is not None:
            document["worker"] = self.worker
        document.update(
            distance=self.distance,
            fell=self.fell,
            time=self.time,
            fitness=self.fitness,
            mean_speed=self.mean_speed,
            status=self.status,
            reason=self.reason,
            wall=self.wall,
        )
        if self.track is not None:
            document.update(drift=self.drift, heading_change=self.heading_change, track=[list(p) for p in self.track])
        if self.finished is not None:
            document.update(finished=self.finished, reached=self.reached, legs=list(self.legs or ()))
        return document

    @classmethod
    def from_json(cls, document: Any) -> EpisodeRecord:
        """A record from a log line's object. ``key``, ``genes`` and ``fitness`` are required, the
        other fields are checked when present (failed episodes and older runs may lack some);
        raises ``RecordError`` naming the first field that is wrong, so a resumed run stops at
        the line instead of failing later with a traceback far from the cause."""
        if not isinstance(document, dict):
            raise RecordError(f"expected a JSON object, found {_shown(document)}")
        key = document.get("key")
        if not isinstance(key, str) or not key:
            raise RecordError(f'"key" must be a non-empty string, found {_shown(key)}')
        genes = document.get("genes")
        if not isinstance(genes, list) or not all(_is_number(g) for g in genes):
            raise RecordError(f'"genes" must be a list of numbers, found {_shown(genes)}')
        start = document.get("start")
        if start is not None and not (isinstance(start, list) and len(start) == 3 and all(map(_is_number, start))):
            raise RecordError(f'"start" must be 3 numbers, found {_shown(start)}')
        track = document.get("track")
        if track is not None and not (
            isinstance(track, list) and all(isinstance(p, list) and all(map(_is_number, p)) for p in track)
        ):
            raise RecordError(f'"track" must be a list of lists of numbers, found {_shown(track)}')
        checks = {
            "fitness": ("a finite number", _is_number),
            "distance": ("a finite number", _is_number),
            "time": ("a finite number", _is_number),
            "mean_speed": ("a finite number", _is_number),
            "wall": ("a finite number", _is_number),
            "drift": ("a finite number", _is_number),
            "heading_change": ("a finite number", _is_number),
            "fell": ("true or false", lambda v: isinstance(v, bool)),
            "status": ("a string", lambda v: isinstance(v, str)),
            "reason": ("a string", lambda v: isinstance(v, str)),
            "seed": ("an integer", _is_int),
            "worker": ("an integer", _is_int),
            "kind": ("one of " + ", ".join(k.value for k in WalkKind), lambda v: v in {k.value for k in WalkKind}),
            "family": ("a family's name", lambda v: isinstance(v, str) and bool(v)),
        }
        if "fitness" not in document:
            raise RecordError(f'"fitness" must be a finite number, found {_shown(None)}')
        for name, (wanted, ok) in checks.items():
            if name in document and not ok(document[name]):
                raise RecordError(f'"{name}" must be {wanted}, found {_shown(document[name])}')
        finished, reached, legs = _course_fields(document)
        kind = document.get("kind")
        if kind is None:  # a log from before records carried their kind
            kind = WalkKind.CHECK if key.startswith(CHECK_PREFIX) else WalkKind.SEARCH
        return cls(
            key=key,
            genes=tuple(float(g) for g in genes),
            fitness=float(document["fitness"]),
            kind=WalkKind(kind),
            seed=document.get("seed"),
            start=None if start is None else (float(start[0]), float(start[1]), float(start[2])),
            worker=document.get("worker"),
            distance=float(document.get("distance", 0.0)),
            fell=document.get("fell", False),
            time=float(document.get("time", 0.0)),
            mean_speed=float(document.get("mean_speed", 0.0)),
            status=document.get("status", "ok"),
            reason=document.get("reason", ""),
            wall=float(document.get("wall", 0.0)),
            drift=_float_or_none(document.get("drift")),
            heading_change=_float_or_none(document.get("heading_change")),
            track=None if track is None else tuple(tuple(float(v) for v in p) for p in track),
            family=document.get("family"),
            finished=finished,
            reached=reached,
            legs=legs,
        )

    @classmethod
    def of(
        cls,
        key: str,
        genes: tuple[float, ...],
        seed: int,
        start: Start | None,
        kind: WalkKind,
        worker: int,
        result: Mapping[str, Any],
        family: str | None = None,
    ) -> EpisodeRecord:
        """The record of a task run by ``worker``, from the runner's result dict
        (``EpisodeResult.to_dict()``)."""
        return cls(
            key=key,
            genes=genes,
            fitness=float(result["fitness"]),
            kind=kind,
            seed=seed,
            start=start,
            worker=worker,
            distance=float(result["distance"]),
            fell=bool(result["fell"]),
            time=float(result["time"]),
            mean_speed=float(result["mean_speed"]),
            status=str(result["status"]),
            reason=str(result["reason"]),
            wall=float(result["wall"]),
            drift=_float_or_none(result.get("drift")),
            heading_change=_float_or_none(result.get("heading_change")),
            track=None if result.get("track") is None else tuple(tuple(map(float, p)) for p in result["track"]),
            family=family,
            finished=None if result.get("finished") is None else bool(result["finished"]),
            reached=None if result.get("reached") is None else int(result["reached"]),
            legs=None if result.get("legs") is None else tuple(map(float, result["legs"])),
        )


#: A course walk's fields (``EpisodeResult``): present together or not at all.
COURSE_FIELDS = ("finished", "reached", "legs")


def _course_fields(document: Mapping[str, Any]) -> tuple[bool | None, int | None, tuple[float, ...] | None]:
    """A log line's course fields, checked: all three or none; ``finished`` true or false, ``reached``
    a count, ``legs`` one non-decreasing game time per pose reached; finished only with a leg each."""
    present = [name for name in COURSE_FIELDS if name in document]
    if not present:
        return None, None, None
    if len(present) != len(COURSE_FIELDS):
        missing = ", ".join(f'"{n}"' for n in COURSE_FIELDS if n not in present)
        raise RecordError(f"a course walk's record lacks {missing}")
    finished, reached, legs = (document[name] for name in COURSE_FIELDS)
    if not isinstance(finished, bool):
        raise RecordError(f'"finished" must be true or false, found {_shown(finished)}')
    if not (_is_int(reached) and reached >= 0):
        raise RecordError(f'"reached" must be a whole number >= 0, found {_shown(reached)}')
    if not (isinstance(legs, list) and all(map(_is_number, legs))):
        raise RecordError(f'"legs" must be a list of numbers, found {_shown(legs)}')
    if len(legs) != reached or any(b < a for a, b in zip(legs, legs[1:])):
        raise RecordError(f'"legs" must hold the {reached} poses\' times in order, found {_shown(legs)}')
    if finished and reached == 0:
        raise RecordError('"finished" with no pose "reached"')
    return finished, reached, tuple(float(t) for t in legs)


def _float_or_none(value: Any) -> float | None:
    return None if value is None else float(value)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _shown(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."
