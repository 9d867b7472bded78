"""CMA-ES (Hansen's ``cma`` library, ``optimizer.search.cmaes``) from a seeded random point of the
unit-scaled gene box, sigma 0.3 of the box, restarting when it converges."""

from __future__ import annotations

import cma

from optimizer.compare.methods import Method, Problem
from optimizer.search.cmaes import SIGMA0, cmaes_program
from optimizer.search.protocol import SearchProgram


def _program(problem: Problem) -> SearchProgram:
    return cmaes_program(problem.bounds, problem.repair, problem.seed)


METHODS = (Method("cmaes", f"CMA-ES (cma {cma.__version__}), unit-cube scaling, sigma0 {SIGMA0}, restarts", _program),)
