"""Result files every search command writes: gait files of the family searched, walk cards of
checked gaits, and the run's fastest walk handed over as fastest_gait.json.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from gait import family_named, save_gait
from optimizer.run.driver import Driver
from optimizer.run.robust import ScoredGait
from optimizer.run.session import EvaluationSetup, Run
from optimizer.run.stability import Fastest, StabilityReport, scored_summary
from optimizer.run.walk_card import REAL_SERVER, STAND_IN, CardWalk, WalkCard, write_card


def best_gait(driver: Driver, key: str | None) -> ScoredGait | None:
    """The scored gait of a search's best (``KeyedSearch.best_key``): its walks' distance and
    speed go into the tables. None when the search has no best (every episode failed)."""
    return None if key is None else driver.scored.get(key)


def write_gait(
    run: Run, path: Path, genes: Sequence[float] | np.ndarray, notes: str, family: str | None = None
) -> None:
    """A gait the run found, as a gait file of its family (the run's, unless ``family`` names
    another) that the agent takes with ``--gait``."""
    save_gait((run.family if family is None else family_named(family)).gait(genes), path, notes)


def walked_on(setup: EvaluationSetup) -> str:
    """The walk-card side of a run's own walks: the real server's when it walked on one."""
    return REAL_SERVER if setup.real_command is not None or setup.servers else STAND_IN


def card_of(run: Run, name: str, check: StabilityReport) -> WalkCard:
    """The walk card of a checked gait: its check walks, on the server the run walked on (a course
    card where the run walks a course)."""
    walks = tuple(map(CardWalk.from_record, check.repeats))
    family = check.gait.family or run.setup.family
    setup = run.setup
    return WalkCard(
        name, check.gait.genes, setup.walk_time, setup.start[2], {walked_on(setup): walks}, family, setup.course
    )


def hand_over(run: Run, fastest: Fastest | None, what: str) -> dict[str, Any]:
    """Write the run's fastest walk as fastest_gait.json (notes: ``what`` and its verdict) with its
    walk card beside it; returns its entries of results.json."""
    if fastest is not None:
        path = run.folder.path / "fastest_gait.json"
        write_gait(run, path, fastest.gait.genes, f"{what}: {fastest.describe()}", fastest.gait.family)
        if fastest.check is not None:
            write_card(card_of(run, "fastest walk", fastest.check), path)
    return {
        "fastest_episode": None if fastest is None else fastest.gait.walks[0].to_json(),
        "fastest_score": None if fastest is None else scored_summary(fastest.gait),
        "fastest_check": None if fastest is None or fastest.check is None else fastest.check.to_dict(),
    }
