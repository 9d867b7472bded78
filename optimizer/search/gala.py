"""GALA: a learning automaton picks the GA's mutation rate (paper section V), for one crossover rate.

Reading of the paper (docs/optimizer.md), decided where it is silent:

- Continuing population (default): the random initial population is evaluated once before the
  first iteration (keys ``pc0.8/init/g00/iNNN``), so that every iteration's rate shapes what it
  evaluates. Each iteration the automaton picks a rate by roulette wheel, the GA breeds
  ``generations_per_iteration`` generations with it (keys ``pc0.8/it012/g00/iNNN``).
  ``restart_each_iteration`` instead runs a fresh GA of ``ga.generations`` generations per iteration.
- An iteration's best fitness is the best among the individuals *it evaluated*; a carried elite is
  not one of them, since its fitness says nothing about the rate just chosen.
- Feedback: reward when that best is strictly greater than the average of the preceding
  iterations' bests, penalty otherwise (a tie is a penalty: it is not "better").
- The first iteration has no preceding bests: it is logged with no feedback and only starts the
  average. Rewarding or penalising it would be a coin toss on the random start.
- The optimal mutation rate is the action of highest probability after the last iteration (the
  lowest rate on a tie). A final, fresh GA of ``ga.generations`` generations with
  (crossover, optimal rate) gives Table I's best fitness and genes (keys ``pc0.8/final/g03/iNNN``).

Random streams: the automaton, the search GA(s) and the final GA each get their own stream spawned
from the seed, so the same seed and the same fitness answers give the same asks in the same order;
that is what a resumed run relies on when it replays the episode log from the start.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from optimizer.search.config import GALAConfig
from optimizer.search.ga import GAOperators, GenerationStats, GeneticAlgorithm, check_bounds, evolve, spawn_rngs
from optimizer.search.la import LearningAutomaton, LearningScheme, LinearRewardPenalty
from optimizer.search.protocol import KeyedSearch, Repair, SearchProgram


@dataclass(frozen=True)
class IterationRecord:
    """One GALA iteration: a point of Fig. 6."""

    iteration: int
    action: int
    mutation: float
    best_fitness: float
    #: Average of the preceding iterations' bests the feedback compared with (None: first iteration).
    baseline: float | None
    #: True reward, False penalty, None no feedback (first iteration).
    rewarded: bool | None
    #: Action probabilities after this iteration's update.
    probabilities: tuple[float, ...]


@dataclass(frozen=True)
class GALAResult:
    """One row of Table I plus what Fig. 6 and Fig. 7 draw."""

    crossover: float
    optimal_mutation: float
    best_fitness: float
    best_genes: np.ndarray
    probabilities: tuple[float, ...]
    iteration_log: list[IterationRecord]
    final_ga_history: list[GenerationStats]
    #: The automaton's actions (mutation rates), in the order of ``probabilities``.
    mutation_rates: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "crossover": self.crossover,
            "optimal_mutation": self.optimal_mutation,
            "best_fitness": self.best_fitness,
            "best_genes": self.best_genes.tolist(),
            "probabilities": list(self.probabilities),
            "mutation_rates": list(self.mutation_rates),
            "iteration_log": [{**vars(r), "probabilities": list(r.probabilities)} for r in self.iteration_log],
            "final_ga_history": [s._asdict() for s in self.final_ga_history],
        }


class GALA(KeyedSearch):
    """GALA for one crossover rate, in ask/tell style with stable candidate keys.

    ``scheme`` defaults to L_R-P with the config's a and b; pass ``LinearRewardInaction(a)`` for
    eq. 6. ``operators`` and ``repair`` go to every GA this search creates.
    """

    def __init__(
        self,
        bounds: np.ndarray,
        config: GALAConfig,
        crossover: float,
        seed_or_rng: int | np.random.Generator,
        *,
        scheme: LearningScheme | None = None,
        operators: GAOperators | None = None,
        repair: Repair | None = None,
    ) -> None:
        if not 0.0 <= crossover <= 1.0:
            raise ValueError(f"crossover rate must be within [0, 1], got {crossover}")
        self.bounds = check_bounds(bounds)
        self.config = config
        self.crossover = crossover
        la_rng, self._search_rng, self._final_rng = spawn_rngs(seed_or_rng, 3)
        la = config.la
        self.automaton = LearningAutomaton(
            la.actions, scheme or LinearRewardPenalty(la.reward_step, la.penalty_step), la_rng
        )
        self._operators = operators
        self._repair = repair
        self.iteration_log: list[IterationRecord] = []
        self._result: GALAResult | None = None
        super().__init__(self._run())

    def result(self) -> GALAResult:
        if self._result is None:
            raise RuntimeError("GALA.result() called before the search is done")
        return self._result

    def _new_ga(self, mutation: float, rng: np.random.Generator) -> GeneticAlgorithm:
        ga_config = replace(self.config.ga, crossover_rate=self.crossover, mutation_rate=mutation)
        return GeneticAlgorithm(self.bounds, ga_config, rng, operators=self._operators, repair=self._repair)

    def _run(self) -> SearchProgram:
        config, automaton = self.config, self.automaton
        tag = f"pc{self.crossover:g}"
        population: GeneticAlgorithm | None = None
        if not config.restart_each_iteration:
            # the rate given here is never used: every iteration sets its own before breeding
            population = self._new_ga(automaton.actions[0], self._search_rng)
            yield from evolve(population, 1, f"{tag}/init")
        bests: list[float] = []
        for k in range(config.iterations):
            action = automaton.choose()
            mutation = automaton.actions[action]
            if population is None:
                ga, generations = self._new_ga(mutation, self._search_rng), config.ga.generations
            else:
                ga, generations = population, config.generations_per_iteration
                ga.mutation_rate = mutation
            best = yield from evolve(ga, generations, f"{tag}/it{k:03d}")
            preceding = bests[-config.baseline_window :] if config.baseline_window else bests
            baseline = float(np.mean(preceding)) if preceding else None
            rewarded = None if baseline is None else best > baseline
            if rewarded is not None:
                automaton.update(action, rewarded)
            bests.append(best)
            self.iteration_log.append(
                IterationRecord(
                    k, action, mutation, best, baseline, rewarded, tuple(float(p) for p in automaton.probabilities)
                )
            )
        optimal = automaton.actions[automaton.best_action()]
        final = self._new_ga(optimal, self._final_rng)
        yield from evolve(final, config.ga.generations, f"{tag}/final")
        assert final.best_genes is not None  # the final GA evaluated at least one generation
        self._result = GALAResult(
            crossover=self.crossover,
            optimal_mutation=optimal,
            best_fitness=final.best_fitness,
            best_genes=final.best_genes.copy(),
            probabilities=tuple(float(p) for p in automaton.probabilities),
            iteration_log=list(self.iteration_log),
            final_ga_history=list(final.history),
            mutation_rates=automaton.actions,
        )
