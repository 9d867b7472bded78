"""Search methods for the comparison, found by looking: every module of this package that defines
``METHODS`` (a sequence of ``Method``) contributes them, so adding a method is adding a module."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from optimizer.search.protocol import Repair, SearchProgram


@dataclass(frozen=True)
class Problem:
    """What a method is given: the gene box and its repair, a seed of its own, and its budget in
    candidates (the comparison stops it there, mid-batch if need be). ``population`` and
    ``elitism`` are the run's GA settings, for the methods that have a population."""

    bounds: np.ndarray
    repair: Repair
    seed: int
    budget: int
    population: int
    elitism: bool


@dataclass(frozen=True)
class Method:
    """A search method: a name for the command line and the tables, and the search program it
    runs on a problem (a generator of batches, sent their fitness)."""

    name: str
    summary: str
    program: Callable[[Problem], SearchProgram]


def discover() -> dict[str, Method]:
    """Every method of every module in this package, by name (a name given twice is an error)."""
    found: dict[str, Method] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        module = importlib.import_module(f"{__name__}.{info.name}")
        methods: Sequence[Method] = getattr(module, "METHODS", ())
        for method in methods:
            if method.name in found:
                raise ValueError(f"search method {method.name!r} is defined twice ({module.__name__})")
            found[method.name] = method
    return found
