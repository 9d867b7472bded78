"""What a walk is scored by, by name: the objectives there are.

An objective is a judge: fed the monitor states of one walk in order, it decides when the walk
ends and what it scored (``EpisodeResult.fitness``, higher better). Every search, check and card
works on the fitness alone, so a new objective is a module that builds an ``Objective`` and is
listed in ``OBJECTIVES``, as a gait family is listed in ``gait.families``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

from optimizer.episode.config import EpisodeConfig, EpisodeResult
from optimizer.episode.course import CourseJudge
from optimizer.episode.scoring import Judge, TracePoint
from protocol.monitor import MonitorState


class Judging(Protocol):
    """A judge of one walk: ``result`` is set once the walk has ended."""

    config: EpisodeConfig
    result: EpisodeResult | None
    trace: list[TracePoint] | None

    def feed(self, state: MonitorState) -> None: ...


@dataclass(frozen=True)
class Objective:
    name: str
    about: str
    #: the judge of one walk of an ``EpisodeConfig`` (and whether it keeps the torso's track)
    judge: Callable[[EpisodeConfig, bool], Judging]
    #: whether the objective walks a course file (``--course``)
    needs_course: bool = False


OBJECTIVES: Mapping[str, Objective] = {
    objective.name: objective
    for objective in (
        Objective("distance", "the paper's eq. 9: 10 x metres walked straight ahead in the walk time", Judge),
        Objective(
            "course", "the time to walk a course file's poses in order (optimizer.episode.course)", CourseJudge, True
        ),
    )
}

DEFAULT_OBJECTIVE = "distance"


def judge_for(config: EpisodeConfig, trace: bool = False) -> Judging:
    """The judge of one walk of ``config`` by its objective."""
    return OBJECTIVES[config.objective].judge(config, trace)
