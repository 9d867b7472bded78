"""A method's search held to an episode budget, and the drive that scores its candidates.

Every method is a search program (a generator of batches; ``optimizer.search.protocol.SearchProgram``), so the
comparison drives them all the same way and counts their episodes the same way: ``drive`` stops a
program once it has spent its budget of episodes, cutting its last batch if need be. Candidates
are scored as every search of the project is (``optimizer.run.robust``): by default over k dithered
walks, raced, so a method cannot win by a gait that only walks once; ``--robust-walks 1`` scores by
one walk (eq. 9).
"""

from __future__ import annotations

import numpy as np

from optimizer.run.driver import Driver
from optimizer.run.robust import ScoredGait
from optimizer.search.protocol import Batch, KeyedSearch, SearchProgram


def program_of(search: KeyedSearch) -> SearchProgram:
    """A keyed search (GA, GALA) as a plain search program: its batches, under their own keys'
    prefixes, sent back their fitness in order."""
    while not search.done:
        candidates = search.ask()
        prefix = candidates[0].key.rsplit("/", 1)[0]
        fitness = yield Batch(prefix, np.array([c.genes for c in candidates]))
        search.tell({c.key: float(f) for c, f in zip(candidates, fitness)})


def drive(driver: Driver, program: SearchProgram, budget: int, prefix: str) -> list[ScoredGait]:
    """Run ``program`` keyed under ``prefix`` until it has spent ``budget`` episodes, every
    candidate scored by the driver (one walk, or k raced walks: ``optimizer.run.robust``) in one
    race, every batch evaluated together (answered from the log on a resumed run); the candidates
    in order. The batch that would overrun the budget is cut to the episodes left, and the program
    is not sent its answers then, since a cut batch is not one it asked for."""
    race = driver.race()
    scored: list[ScoredGait] = []
    spent = 0
    fitness: np.ndarray | None = None
    while spent < budget:
        try:
            batch = program.send(fitness)  # type: ignore[arg-type]
        except StopIteration:
            break
        genes = batch.genes[: budget - spent]
        keys = [f"{prefix}/{batch.prefix}/i{i:03d}" for i in range(len(genes))]
        got = driver.score(list(zip(keys, genes)), race)
        scored.extend(got)
        spent += sum(len(g.walks) for g in got)
        fitness = np.array([g.fitness for g in got])
    return scored
