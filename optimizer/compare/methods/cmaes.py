"""CMA-ES (Hansen's ``cma`` library), in the gene box scaled to the unit cube.

Scaling makes one step size fit genes in degrees, seconds and rad/s alike; ``cma``'s own bound
handling keeps samples in the cube, and the TFS repair (t2 folded into the period) is applied to
what is evaluated. It starts from a seeded random point with sigma 0.3 of the box.
"""

from __future__ import annotations

import cma
import numpy as np

from optimizer.compare.methods import Method, Problem
from optimizer.search.ga import Batch, SearchProgram

#: Initial step size, as a fraction of the box (the library's advice: about a quarter to a third
#: of the range the optimum may lie in).
SIGMA0 = 0.3


def _strategy(rng: np.random.Generator, dimension: int) -> cma.CMAEvolutionStrategy:
    """A fresh strategy from a random point of the cube, seeded from ``rng``."""
    return cma.CMAEvolutionStrategy(
        rng.uniform(0.0, 1.0, dimension),
        SIGMA0,
        {"bounds": [0.0, 1.0], "seed": int(rng.integers(1, 2**31 - 1)), "verbose": -9},
    )


def _program(problem: Problem) -> SearchProgram:
    low, high = problem.bounds[:, 0], problem.bounds[:, 1]
    rng = np.random.default_rng(problem.seed)
    strategy = _strategy(rng, len(low))
    generation = 0
    while True:
        unit = strategy.ask()
        genes = np.array([problem.repair(low + np.asarray(u) * (high - low)) for u in unit])
        fitness = yield Batch(f"g{generation:03d}", genes)
        strategy.tell(unit, [-float(f) for f in fitness])  # cma minimises
        generation += 1
        if strategy.stop():  # converged (a flat fitness, or sigma collapsed): start afresh
            strategy = _strategy(rng, len(low))


METHODS = (Method("cmaes", f"CMA-ES (cma {cma.__version__}), unit-cube scaling, sigma0 {SIGMA0}, restarts", _program),)
