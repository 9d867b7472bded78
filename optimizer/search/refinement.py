"""The refinement: CMA-ES from walks that hold, raced, to make a walk faster and keep it standing.

The main job runs it after its Table I rows (``optimizer.job``), and ``python -m optimizer.refine``
on a gait file of one's own. GALA's population levels off below what the gait family holds; CMA-ES
from its walks climbs on (docs/optimizer.md, "Why a refinement phase").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from optimizer.run.driver import Driver
from optimizer.run.robust import Race
from optimizer.run.stability import Fastest, ranked_gaits
from optimizer.search.cmaes import CMAESRun, population_size
from optimizer.search.config import ScoringConfig
from optimizer.search.protocol import Batch, Candidate, KeyedSearch, Repair, SearchProgram
from optimizer.seeds import stable_seed
from optimizer.settings import RefinementSettings, stored_quantile

#: Keys of the refinement's episodes start with this (in the main job too).
REFINE_PREFIX = "refine"


#: The start gait's episodes are keyed under this.
START_KEY = "start"


@dataclass(frozen=True)
class Arm:
    """One CMA-ES run of the refinement: its key prefix, start (genes) and first step."""

    prefix: str
    start: tuple[float, ...]
    sigma: float


def refinement_arms(settings: RefinementSettings, starts: Sequence[Sequence[float]], first: int = 0) -> list[Arm]:
    """The refinement's CMA-ES runs: one per start and step of ``settings.sigma``, the
    starts in the order given, keyed ``refine<j>`` from j = ``first`` (a refinement of several
    families numbers on from the previous family's runs). A run from before several steps stored
    one number: one run keyed ``refine``, as it was made."""
    sigmas = settings.sigma
    if isinstance(sigmas, (int, float)):
        return [Arm(REFINE_PREFIX, tuple(starts[0]), float(sigmas))]
    pairs = [(tuple(start), float(sigma)) for start in starts for sigma in sigmas]
    return [Arm(f"{REFINE_PREFIX}{first + j}", start, sigma) for j, (start, sigma) in enumerate(pairs)]


def refine_scoring(settings: RefinementSettings, scoring: ScoringConfig) -> ScoringConfig:
    """How the refinement scores a gait: as the run scores (``scoring``), but by the
    ``settings.quantile`` of its walks (in the main job ``--refine-quantile``; in
    ``optimizer.refine``, whose whole run is a refinement, the run's own ``--robust-quantile``).

    The rows forgive one fall in five walks, which gives a population of falling gaits its slope
    towards walking. The refinement starts from walks that hold, and what it finds is handed over,
    so it forgives none: scored by the second-worst of 5 it climbed to where the walk falls on the
    real server, by the worst it did not (docs/optimizer.md, "The hand-over").

    A gait that would be the refinement's best walks on to ``settings.lead_walks`` walks first
    (``ScoringConfig.lead_walks``): the best is where a CMA-ES run starts again, which run wins the
    race, and the hand-over's first candidate."""
    return replace(scoring, quantile=stored_quantile(settings.quantile), lead_walks=settings.lead_walks)


def heat_gaits(settings: RefinementSettings, arms: int, genes: int) -> int:
    """Gaits each run walks in the race's heat: whole generations, a quarter of the budget over two
    runs (half of it over all of them), so the winner keeps half for itself. 0 where the settings
    do not race or the budget is too small for a generation each: then every run takes its share
    (the first ones one more where they do not divide)."""
    population = population_size(genes, settings.population)
    if arms < 2 or not settings.race:
        return 0
    return settings.budget // (2 * arms * population) * population


def refine(
    driver: Driver,
    settings: RefinementSettings,
    seed: int,
    bounds: np.ndarray,
    repair: Repair,
    starts: Sequence[Sequence[float]],
    held: Sequence[int] = (),
    family: str | None = None,
    first: int = 0,
) -> int:
    """CMA-ES from each of ``starts`` (genes) with each step of the settings (``refinement_arms``,
    numbered from ``first``), each run seeded from the run's seed and its prefix; every gait scored
    as the run scores. The genes ``held`` keep each start's values (the family's ``held``: a
    tfs-start search holds the start gait and searches the cruise gait). ``family`` names the
    genes' family where it is not the run's (the main job refines its TFS rows' walks as tfs-start
    walks). Returns the number of CMA-ES runs, where the next family's numbering goes on.

    The runs race: each walks a heat (``heat_gaits``), then the one whose best score is highest
    (the first on a tie) walks the rest of the budget, going on where it stopped, with its own
    racing bar. A start on a narrow ridge loses a large step's first generations to falls while one
    on a broad ridge climbs further with it, and a start the checks trusted can sit in a lower
    basin than the best-scored gait, which fell once (docs/optimizer.md, "Why a refinement
    phase"). The heat costs each loser what it would have cost to know.

    The main job starts it from the fastest gait of the rows that held its check and from the
    best-scored gait (``refine_starts``): a fragile start's neighbourhood falls almost everywhere,
    and CMA-ES learns nothing from a population of falls (measured: from a gait that fell in 4 of
    its 10 check walks, 2,997 of 3,000 refined gaits fell), so such a run loses its heat. With
    ``--refine-reference`` the reference walk is one more start, for when every walk of the rows
    sits where gaits fall (``optimizer.job``)."""
    arms = refinement_arms(settings, starts, first)
    scoring = refine_scoring(settings, driver.scoring)
    total, population, patience = settings.budget, settings.population, settings.patience
    heat = heat_gaits(settings, len(arms), len(bounds))

    def cmaes(arm: Arm, gaits: int) -> CMAESRun:
        seeded = stable_seed(seed, arm.prefix)
        return CMAESRun(bounds, repair, seeded, arm.start, arm.sigma, gaits, arm.prefix, population, patience, held)

    if heat == 0:
        share, extra = divmod(total, len(arms))
        for j, arm in enumerate(arms):
            driver.run(cmaes(arm, share + (j < extra)), Race(scoring), family)
        return len(arms)
    whole = total - (len(arms) - 1) * heat  # what the winner walks in all
    runs = [cmaes(arm, whole) for arm in arms]
    races = [Race(scoring) for _ in runs]
    for run, race in zip(runs, races):
        driver.run(Heat(run, heat), race, family)
    winner = max(range(len(runs)), key=lambda j: (_best_score(runs[j]), -j))
    driver.run(runs[winner], races[winner], family)
    return len(arms)


def refine_starts(driver: Driver, fastest: Fastest) -> list[tuple[float, ...]]:
    """Where the main job's refinement starts: the fastest gait that held its check, and the
    best-scored gait of the run when that is another (it may have fallen in its check)."""
    starts = [fastest.gait.genes]
    ranked = ranked_gaits(driver.scored)
    if ranked and ranked[0].genes != fastest.gait.genes:
        starts.append(ranked[0].genes)
    return [tuple(start) for start in starts]


def _best_score(run: CMAESRun) -> float:
    best = run.result()
    return -math.inf if best is None else best[0]


class Heat:
    """A search's next ``gaits`` gaits (whole batches), for the race of ``refine``."""

    def __init__(self, search: CMAESRun, gaits: int) -> None:
        self._search = search
        self._left = gaits

    @property
    def done(self) -> bool:
        return self._search.done or self._left <= 0

    def ask(self) -> list[Candidate]:
        return self._search.ask()

    def tell(self, results: Mapping[str, float]) -> None:
        self._left -= len(results)
        self._search.tell(results)

    def result(self) -> Any:
        return self._search.result()


class StartGait(KeyedSearch):
    """The start gait, scored as a search of one candidate (keyed ``start/i000``), so that it can be
    handed back if nothing beats it."""

    def __init__(self, genes: Sequence[float]) -> None:
        super().__init__(self._one(np.array([list(genes)], dtype=float)))

    @staticmethod
    def _one(genes: np.ndarray) -> SearchProgram:
        yield Batch(START_KEY, genes)

    def result(self) -> None:
        return None
