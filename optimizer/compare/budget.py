"""A method's search held to an episode budget, and the drive that scores its candidates.

Every method is a search program (a generator of batches; ``optimizer.search.ga.SearchProgram``), so the
comparison drives them all the same way and counts their episodes the same way: ``budgeted``
stops a program once it has asked for its budget of candidates, cutting its last batch if need
be. A candidate is scored by one walk from the run's start (eq. 9), or, with a ``RobustScore``, by
``k`` walks from starts moved within the real server's beam noise, as their mean or a low
quantile: a search then cannot win by a gait that only walks from one exact start.
"""

from __future__ import annotations

from collections.abc import Generator, Sequence
from dataclasses import dataclass

import numpy as np

from optimizer.episode import Start
from optimizer.evaluation.pool import EpisodeTask, stable_seed
from optimizer.evaluation.record import EpisodeRecord
from optimizer.run.driver import Driver
from optimizer.run.stability import jittered_starts
from optimizer.search.ga import Batch, KeyedSearch, SearchProgram


def program_of(search: KeyedSearch) -> SearchProgram:
    """A keyed search (GA, GALA) as a plain search program: its batches, under their own keys'
    prefixes, sent back their fitness in order."""
    while not search.done:
        candidates = search.ask()
        prefix = candidates[0].key.rsplit("/", 1)[0]
        fitness = yield Batch(prefix, np.array([c.genes for c in candidates]))
        search.tell({c.key: float(f) for c, f in zip(candidates, fitness)})


def budgeted(program: SearchProgram, budget: int) -> Generator[Batch, np.ndarray | None, None]:
    """The batches ``program`` asks for, until ``budget`` candidates have been asked; the batch
    that crosses the budget is cut. Fitness sent in is passed on to the program."""
    asked = 0
    fitness = None
    while asked < budget:
        try:
            batch = program.send(fitness)  # type: ignore[arg-type]
        except StopIteration:
            return
        batch = Batch(batch.prefix, batch.genes[: budget - asked])
        asked += len(batch.genes)
        fitness = yield batch


@dataclass(frozen=True)
class RobustScore:
    """Score a candidate over ``walks`` starts moved within ``jitter`` (x m, y m, heading deg): the
    mean of their fitness, or its ``quantile`` (e.g. 0.25) when given."""

    walks: int
    jitter: tuple[float, float, float]
    quantile: float | None = None

    def __post_init__(self) -> None:
        if self.walks < 1:
            raise ValueError(f"RobustScore.walks must be >= 1, got {self.walks}")
        if self.quantile is not None and not 0.0 <= self.quantile <= 1.0:
            raise ValueError(f"RobustScore.quantile must be within [0, 1], got {self.quantile}")

    def combine(self, fitness: Sequence[float]) -> float:
        values = np.asarray(fitness, dtype=float)
        return float(values.mean() if self.quantile is None else np.quantile(values, self.quantile))


@dataclass(frozen=True)
class Scored:
    """One candidate of a drive: its key, genes, score and the walks it took."""

    key: str
    genes: tuple[float, ...]
    fitness: float
    records: tuple[EpisodeRecord, ...]


def _tasks(
    driver: Driver, key: str, genes: Sequence[float], base: Start, robust: RobustScore | None
) -> list[EpisodeTask]:
    if robust is None:
        return [driver.task(key, genes)]
    starts = jittered_starts(base, robust.jitter, robust.walks, stable_seed(driver.run_seed, "robust/" + key))
    return [driver.task(f"{key}/k{j}", genes, start) for j, start in enumerate(starts)]


def drive(
    driver: Driver, program: SearchProgram, budget: int, prefix: str, base: Start, robust: RobustScore | None = None
) -> list[Scored]:
    """Run ``program`` for ``budget`` candidates keyed under ``prefix``, every batch's episodes
    evaluated together (answered from the log on a resumed run); the candidates in order."""
    scored: list[Scored] = []
    batches = budgeted(program, budget)
    fitness: np.ndarray | None = None
    while True:
        try:
            batch = batches.send(fitness)
        except StopIteration:
            return scored
        keys = [f"{prefix}/{batch.prefix}/i{i:03d}" for i in range(len(batch.genes))]
        genes = [tuple(float(g) for g in row) for row in batch.genes]
        tasks = [_tasks(driver, key, g, base, robust) for key, g in zip(keys, genes)]
        records = driver.walk([task for group in tasks for task in group])
        values = []
        for key, g, group in zip(keys, genes, tasks):
            walks = tuple(records[task.key] for task in group)
            value = walks[0].fitness if robust is None else robust.combine([w.fitness for w in walks])
            values.append(value)
            scored.append(Scored(key, g, value, walks))
        fitness = np.array(values)
