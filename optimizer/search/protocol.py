"""The search protocol: keyed ask/tell, which every search of the project speaks.

A search asks for candidates, each named by a key that is unique and stable within a run, and is
told their fitness by key. The run driver (``optimizer.run.driver``) logs every episode under its
key, so a resumed run answers a replayed search from the log: the same seed and the same answers
drive it through the same batches.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np

#: Keeps a chromosome inside its search box (a gait family's ``repair`` bound to the box).
Repair = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Candidate:
    """One individual to evaluate. ``key`` names it uniquely and stably within a run, so an
    evaluation log (key -> fitness) can answer a replayed search."""

    key: str
    genes: np.ndarray


class Batch(NamedTuple):
    """A generation to evaluate: candidate ``i`` of it is keyed ``f"{prefix}/i{i:03d}"``."""

    prefix: str
    genes: np.ndarray


#: A search written as a generator: it yields batches and is sent their fitness arrays.
SearchProgram = Generator[Batch, np.ndarray, None]


class KeyedSearch:
    """Ask/tell with keys on top of a search program (a generator of batches).

    Writing the search as a generator keeps its logic sequential and readable, and makes replay
    exact: the same seed and the same answers drive it through the same batches. Answers may come
    in any order and in parts; the program moves on once its whole batch is answered.
    """

    def __init__(self, program: SearchProgram) -> None:
        self._program = program
        #: every answer so far, in the order asked: what ``best_key`` reads
        self._answered: dict[str, float] = {}
        self._answers: dict[str, float] = {}
        self._batch: Batch | None = None
        self._keys: list[str] = []
        self._advance(None)

    @property
    def done(self) -> bool:
        return self._batch is None

    def ask(self) -> list[Candidate]:
        """The candidates of the current batch not answered yet (empty when done)."""
        if self._batch is None:
            return []
        return [
            Candidate(key, genes.copy())
            for key, genes in zip(self._keys, self._batch.genes)
            if key not in self._answers
        ]

    def tell(self, results: Mapping[str, float]) -> None:
        """Fitness by candidate key; every key must belong to the current batch, unanswered."""
        if self._batch is None:
            raise ValueError("tell() after the search is done")
        wanted = set(self._keys)
        for key, value in results.items():
            if key not in wanted:
                raise ValueError(f"candidate {key!r} is not part of the current batch {self._batch.prefix!r}")
            if key in self._answers:
                raise ValueError(f"candidate {key!r} was already answered")
            if not math.isfinite(float(value)):
                raise ValueError(f"fitness of candidate {key!r} must be finite, got {value!r}")
        self._answers.update({key: float(value) for key, value in results.items()})
        if len(self._answers) == len(self._keys):
            self._answered.update((key, self._answers[key]) for key in self._keys)
            self._advance(np.array([self._answers[key] for key in self._keys]))

    def best_key(self, prefix: str = "") -> str | None:
        """The key of the fittest candidate answered under ``prefix`` (the first asked of equals):
        which logged episode a search's best is, without comparing floats or genes."""
        keys = [key for key in self._answered if key.startswith(prefix)]
        return max(keys, key=self._answered.__getitem__) if keys else None

    def _advance(self, fitness: np.ndarray | None) -> None:
        try:
            self._batch = self._program.send(fitness)  # type: ignore[arg-type]
        except StopIteration:
            self._batch = None
            self._keys = []
        else:
            self._keys = [f"{self._batch.prefix}/i{i:03d}" for i in range(len(self._batch.genes))]
        self._answers = {}


class AskTellSearch(Protocol):
    """What ``run_sync`` and the run driver (``optimizer.run.driver``) need from a keyed search."""

    @property
    def done(self) -> bool: ...

    def ask(self) -> list[Candidate]: ...

    def tell(self, results: Mapping[str, float]) -> None: ...

    def result(self) -> Any: ...


def run_sync(search: AskTellSearch, evaluate: Callable[[np.ndarray], float]) -> Any:
    """Drive a keyed search to the end in this process and return its ``result()``: for tests,
    synthetic problems and the simplest single-process use."""
    while not search.done:
        search.tell({c.key: evaluate(c.genes) for c in search.ask()})
    return search.result()
