"""The GA with the paper's fixed rates, and GALA (the automaton learns the mutation rate).

Both run until the comparison's budget stops them: the GA for as many generations as the budget
holds, GALA's continuing population for as many iterations. GALA's final GA, which re-runs a
search with the learnt rate to fill Table I, is a reporting step, not part of the search, so a
fixed-budget comparison stops before it.
"""

from __future__ import annotations

import math
from dataclasses import replace

from optimizer.compare.budget import program_of
from optimizer.compare.methods import Method, Problem
from optimizer.search.config import (
    DE_JONG,
    GREFENSTETTE,
    PAPER_GALA_BEST,
    GAConfig,
    GALAConfig,
    RatePreset,
)
from optimizer.search.ga import GARun
from optimizer.search.gala import GALA
from optimizer.search.protocol import SearchProgram


def _generations(problem: Problem) -> int:
    """Enough generations to spend the budget (the comparison stops the search there)."""
    return 1 + math.ceil(problem.budget / max(1, problem.population - int(problem.elitism)))


def _ga(name: str, preset: RatePreset) -> Method:
    def program(problem: Problem) -> SearchProgram:
        config = GAConfig(
            population_size=problem.population,
            generations=_generations(problem),
            crossover_rate=preset.crossover_rate,
            mutation_rate=preset.mutation_rate,
            elitism=problem.elitism,
        )
        return program_of(GARun(problem.bounds, config, problem.seed, repair=problem.repair, prefix="ga"))

    return Method(
        name, f"GA, {preset.name}: crossover {preset.crossover_rate:g}, mutation {preset.mutation_rate:g}", program
    )


def _gala(problem: Problem) -> SearchProgram:
    paper = GALAConfig()
    config = replace(
        paper,
        ga=GAConfig(population_size=problem.population, elitism=problem.elitism),
        iterations=_generations(problem),
    )
    return program_of(GALA(problem.bounds, config, PAPER_GALA_BEST.crossover_rate, problem.seed, repair=problem.repair))


METHODS = (
    Method(
        "gala",
        "GALA at the paper's settings: crossover 0.8, automata(10) over mutation 0.00-0.09, "
        "L_R-P a 0.1 b 0.2, one continuing population",
        _gala,
    ),
    _ga("ga-dejong", DE_JONG),
    _ga("ga-grefenstette", GREFENSTETTE),
    _ga("ga-paper", PAPER_GALA_BEST),
)
