"""CMA-ES (Hansen's ``cma`` library) as a search program, in the gene box scaled to the unit cube.

Scaling makes one step size fit genes in degrees, seconds and rad/s alike; ``cma``'s own bound
handling keeps samples in the cube, and the gait's repair (t2 folded into the period) is applied to
what is evaluated. A strategy that stops (converged, or its step size collapsed) starts again:
from a random point when it was started from one, else from the best gait it has met, so a
refinement keeps climbing from where it got to. With a ``patience``, a strategy whose best has not
gained ``GAIN`` in that many generations also starts again, with twice the gaits a generation
(IPOP-CMA-ES, Auger and Hansen 2005): a robust score is noisy, so ``cma``'s own tests of
convergence rarely fire, and a refinement that has levelled off would spend the rest of its budget
where it is (docs/optimizer.md, "Restarts").

Two uses: the optimizer comparison starts it from a random point with sigma 0.3 of the box
(``optimizer.compare.methods.cmaes``); the main job's refinement phase starts it from the best gait
the Table I rows found, with a smaller step (``optimizer.job``, ``--refine``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import cma
import numpy as np

from optimizer.search.protocol import Batch, KeyedSearch, Repair, SearchProgram

#: Initial step size from a random point, as a fraction of the box (the library's advice: about a
#: quarter to a third of the range the optimum may lie in).
SIGMA0 = 0.3
#: What counts as a gain for ``patience``: the best score up by this fraction of itself.
GAIN = 0.01


class _OwnRandom:
    """numpy's global random state, kept apart for one strategy: ``cma`` draws its samples from
    numpy's global generator, which its ``seed`` option seeds, so strategies asked in turn (the
    refinement's race) would draw from each other's streams. Swapped in around every call into
    the library, so a strategy draws what it would draw alone."""

    def __init__(self) -> None:
        self._state: Any = None

    @contextmanager
    def active(self) -> Iterator[None]:
        outer = np.random.get_state()
        if self._state is not None:
            np.random.set_state(self._state)
        try:
            yield
        finally:
            self._state = np.random.get_state()
            np.random.set_state(outer)


def population_size(genes: int, population: int | None) -> int:
    """Gaits per generation: ``population``, or the library's own 4 + 3 ln n when None."""
    return population if population is not None else 4 + int(3 * np.log(genes))


def _strategy(
    rng: np.random.Generator, x0: np.ndarray, sigma0: float, population: int | None
) -> cma.CMAEvolutionStrategy:
    options = {"bounds": [0.0, 1.0], "seed": int(rng.integers(1, 2**31 - 1)), "verbose": -9}
    if population is not None:
        options["popsize"] = population
    return cma.CMAEvolutionStrategy(x0, sigma0, options)


def cmaes_program(
    bounds: np.ndarray,
    repair: Repair,
    seed: int,
    start: Sequence[float] | None = None,
    sigma0: float = SIGMA0,
    candidates: int | None = None,
    population: int | None = None,
    patience: int | None = None,
    held: Sequence[int] = (),
) -> SearchProgram:
    """CMA-ES from ``start`` (genes; None: a seeded random point) with step ``sigma0`` (a fraction
    of the box) and ``population`` gaits a generation (None: the library's 4 + 3 ln n), batches
    keyed ``gNNN``, for ``candidates`` candidates in all (None: for ever; the last batch is cut
    to fit); started again, with twice the gaits a generation, after ``patience`` generations
    without a gain (None: only when ``cma`` stops it). The genes ``held`` (indices) keep the
    start's values throughout (``GaitFamily.held``): the strategy searches only the others."""
    if held and start is None:
        raise ValueError("held genes need a start gait to hold them at")
    low, high = bounds[:, 0], bounds[:, 1]
    rng = np.random.default_rng(seed)
    own = _OwnRandom()
    x0 = None if start is None else np.clip((np.asarray(start, dtype=float) - low) / (high - low), 0.0, 1.0)
    kept = sorted({int(k) for k in held})
    free = [k for k in range(len(low)) if k not in kept]
    with own.active():
        strategy = _strategy(rng, rng.uniform(0.0, 1.0, len(low)) if x0 is None else x0[free], sigma0, population)
    generation, asked = 0, 0
    best: tuple[float, np.ndarray] | None = None
    mark: float | None = None  # the best score at the last gain of GAIN
    marked = 0  # that gain's generation
    while candidates is None or asked < candidates:
        with own.active():
            unit = strategy.ask()
        if candidates is not None:
            unit = unit[: candidates - asked]
        genes = np.array([repair(low + _whole(u, x0, free) * (high - low)) for u in unit])
        if kept:  # exactly the start's values, not their round trip through the unit cube
            genes[:, kept] = np.asarray(start, dtype=float)[kept]
        fitness = yield Batch(f"g{generation:03d}", genes)
        asked += len(unit)
        generation += 1
        if len(unit) < strategy.popsize:
            return  # the budget cut this batch: cma takes only whole generations
        with own.active():
            strategy.tell(unit, [-float(f) for f in fitness])  # cma minimises
        k = int(np.argmax(fitness))
        if best is None or fitness[k] > best[0]:
            best = (float(fitness[k]), np.clip((genes[k] - low) / (high - low), 0.0, 1.0))
        if mark is None or best[0] >= mark + GAIN * abs(mark):
            mark, marked = best[0], generation
        stalled = patience is not None and generation - marked >= patience
        if strategy.stop() or stalled:  # a refinement starts again from the best it met, a search from anywhere
            if stalled:
                population, marked = 2 * strategy.popsize, generation
            restart = rng.uniform(0.0, 1.0, len(low)) if x0 is None else best[1][free]
            with own.active():
                strategy = _strategy(rng, restart, sigma0, population)


def _whole(unit: Sequence[float], x0: np.ndarray | None, free: list[int]) -> np.ndarray:
    """A point the strategy asked (its free genes) as a point of the whole unit cube, the held
    genes at the start's."""
    if x0 is None or len(free) == len(x0):
        return np.asarray(unit)
    whole = x0.copy()
    whole[free] = unit
    return whole


class CMAESRun(KeyedSearch):
    """CMA-ES as a keyed search, keys ``{prefix}/gNNN/iNNN``: the main job's refinement phase."""

    def __init__(
        self,
        bounds: np.ndarray,
        repair: Repair,
        seed: int,
        start: Sequence[float],
        sigma0: float,
        candidates: int,
        prefix: str,
        population: int | None = None,
        patience: int | None = None,
        held: Sequence[int] = (),
    ) -> None:
        self._best: tuple[float, np.ndarray] | None = None
        self._prefix = prefix
        program = cmaes_program(bounds, repair, seed, start, sigma0, candidates, population, patience, held)
        super().__init__(self._run(program))

    def _run(self, program: SearchProgram) -> SearchProgram:
        fitness = None
        while True:
            try:
                batch = program.send(fitness)  # type: ignore[arg-type]
            except StopIteration:
                return
            fitness = yield Batch(f"{self._prefix}/{batch.prefix}", batch.genes)
            k = int(np.argmax(fitness))
            if self._best is None or fitness[k] > self._best[0]:
                self._best = (float(fitness[k]), batch.genes[k].copy())

    def result(self) -> tuple[float, np.ndarray] | None:
        """The best score and genes the refinement met (None if it asked nothing)."""
        return self._best
