"""Uniform random search in the gene box: the floor every method must beat."""

from __future__ import annotations

import numpy as np

from optimizer.compare.methods import Method, Problem
from optimizer.search.protocol import Batch, SearchProgram


def _program(problem: Problem) -> SearchProgram:
    rng = np.random.default_rng(problem.seed)
    low, high = problem.bounds[:, 0], problem.bounds[:, 1]
    batch = 0
    while True:  # batches of a population's size, so that workers stay busy alike
        raw = rng.uniform(low, high, size=(problem.population, len(low)))
        yield Batch(f"b{batch:03d}", np.array([problem.repair(row) for row in raw]))
        batch += 1


METHODS = (Method("random", "uniform random search in the gene box", _program),)
