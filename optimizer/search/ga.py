"""A real-valued genetic algorithm in ask/tell style (paper section IV-A and VI).

The search never evaluates anything itself: ``ask`` hands out the individuals of the current
generation, ``tell`` receives their fitness. So the same search runs against a synthetic function
in a test, a local process pool or a cluster, and a run can be resumed by replaying the answers.

Selection, crossover and mutation are plain callables (see the three Protocols below); a new scheme
is one new function or class handed to ``GAOperators``, with no registry to edit.

``GARun`` is a keyed search (``optimizer.search.protocol``): stable string keys on every individual
(``ga/g03/i012``), so that an evaluation log can be replayed.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np

from optimizer.search.config import GAConfig
from optimizer.search.protocol import Batch, KeyedSearch, Repair, SearchProgram


class Selection(Protocol):
    """Pick ``count`` parent indices from a population with the given fitness (higher is better)."""

    def __call__(self, fitness: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray: ...


class Crossover(Protocol):
    """Recombine two parents into two children (the GA decides *whether*, with probability pc)."""

    def __call__(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]: ...


class Mutation(Protocol):
    """Mutate each gene of ``genes`` (shape (m, n)) with probability ``rate``; stay within ``bounds``."""

    def __call__(self, genes: np.ndarray, rate: float, bounds: np.ndarray, rng: np.random.Generator) -> np.ndarray: ...


def roulette_weights(fitness: np.ndarray) -> np.ndarray:
    """Selection probabilities of the roulette wheel, shifted so that any fitness can be used.

    Eq. 9's fitness is ``10 * x`` and is negative for a robot that falls backwards, but a roulette
    wheel needs positive slices. The shift ``f - min(f) + 0.01 * (max(f) - min(f))`` keeps the
    slices proportional to how much better than the worst an individual is, and still gives the
    worst a small non-zero chance (1 % of the spread) so that one generation cannot wipe out
    diversity entirely. A population of equal fitness gets a uniform wheel.
    """
    f = np.asarray(fitness, dtype=float)
    spread = float(f.max() - f.min())
    if spread == 0.0:
        return np.full(f.shape, 1.0 / f.size)
    weights = f - f.min() + 0.01 * spread
    return weights / weights.sum()


def roulette_selection(fitness: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Fitness-proportional selection with replacement (the paper's selection method)."""
    return rng.choice(len(fitness), size=count, replace=True, p=roulette_weights(fitness))


def one_point_crossover(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Swap the tails of two chromosomes after a random cut (Goldberg's classic operator, the
    paper's reference [16]). It makes no new gene values, which leaves exploring values to mutation:
    the rate GALA tunes matters the way the paper's comparisons assume."""
    if a.size < 2:
        return a.copy(), b.copy()
    cut = int(rng.integers(1, a.size))
    return np.concatenate([a[:cut], b[cut:]]), np.concatenate([b[:cut], a[cut:]])


@dataclass(frozen=True)
class BlendCrossover:
    """BLX-alpha: each child gene is drawn uniformly from the parents' interval widened by
    ``alpha`` times its length on both sides; explores between and around the parents."""

    alpha: float = 0.5

    def __call__(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        low, high = np.minimum(a, b), np.maximum(a, b)
        margin = self.alpha * (high - low)
        draw = rng.uniform(size=(2, a.size))
        children = low - margin + draw * (high - low + 2 * margin)
        return children[0], children[1]


@dataclass(frozen=True)
class GaussianMutation:
    """Add N(0, (sigma_fraction * gene range)^2) to each gene with probability ``rate``, then clip.

    Scaling sigma by each gene's range makes one setting fit genes of different units (degrees,
    seconds, rad/s). Noise is drawn for every gene whatever the rate, so the random stream does not
    depend on the rate the learning automaton chose.
    """

    sigma_fraction: float = 0.1

    def __call__(self, genes: np.ndarray, rate: float, bounds: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        span = bounds[:, 1] - bounds[:, 0]
        hit = rng.random(genes.shape) < rate
        noise = rng.normal(0.0, 1.0, genes.shape) * (self.sigma_fraction * span)
        return np.clip(np.where(hit, genes + noise, genes), bounds[:, 0], bounds[:, 1])


def uniform_reset_mutation(genes: np.ndarray, rate: float, bounds: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Redraw each gene with probability ``rate`` uniformly within its bounds (random resetting)."""
    hit = rng.random(genes.shape) < rate
    fresh = rng.uniform(bounds[:, 0], bounds[:, 1], size=genes.shape)
    return np.where(hit, fresh, genes)


@dataclass(frozen=True)
class GAOperators:
    """The GA's behaviour, apart from its numbers (which are in ``GAConfig``)."""

    selection: Selection = roulette_selection
    crossover: Crossover = one_point_crossover
    mutation: Mutation = field(default_factory=GaussianMutation)


class GenerationStats(NamedTuple):
    """Fitness of one evaluated population (carried elite included): a point of Fig. 4/5/7."""

    generation: int
    best: float
    mean: float
    worst: float


def check_bounds(bounds: np.ndarray) -> np.ndarray:
    """Validate an (n, 2) array of finite (low, high) rows with low <= high."""
    b = np.asarray(bounds, dtype=float)
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] < 1:
        raise ValueError(f"bounds must have shape (n, 2), got {b.shape}")
    if not np.all(np.isfinite(b)):
        raise ValueError("bounds must be finite")
    if np.any(b[:, 0] > b[:, 1]):
        raise ValueError(f"bounds rows must be (low, high) with low <= high, got {b.tolist()}")
    return b


def check_fitness(values: np.ndarray, expected: int) -> np.ndarray:
    """A fitness vector of the expected length with only finite numbers (NaN would poison the
    roulette wheel and every average after it)."""
    f = np.asarray(values, dtype=float).reshape(-1)
    if f.size != expected:
        raise ValueError(f"expected {expected} fitness values, got {f.size}")
    if not np.all(np.isfinite(f)):
        raise ValueError(f"fitness values must be finite, got {f[~np.isfinite(f)].tolist()}")
    return f


class GeneticAlgorithm:
    """One population evolving generation by generation; it never stops on its own.

    Generation 0 is drawn uniformly within ``bounds``. Each later generation is bred when it is
    first asked for, with the rates in force at that moment: this is what lets GALA set
    ``mutation_rate`` between generations of one continuing population. With elitism the best
    individual of the previous generation is carried with its fitness and is not asked again.
    Every new individual is clipped to ``bounds`` and then passed through ``repair`` (a problem
    constraint such as the TFS's 0 < t2 < 2*pi/w); a repair that leaves the bounds is an error.
    """

    def __init__(
        self,
        bounds: np.ndarray,
        config: GAConfig,
        rng: np.random.Generator,
        *,
        operators: GAOperators | None = None,
        repair: Repair | None = None,
    ) -> None:
        self.bounds = check_bounds(bounds)
        self.config = config
        self.crossover_rate = config.crossover_rate
        self.mutation_rate = config.mutation_rate
        self.operators = operators or GAOperators()
        self._repair = repair
        self._rng = rng
        #: Index of the generation ``ask`` returns; equals the number of generations evaluated.
        self.generation = 0
        #: The last evaluated population and its fitness (None before the first ``tell``).
        self.population: np.ndarray | None = None
        self.fitness: np.ndarray | None = None
        self.best_genes: np.ndarray | None = None
        self.best_fitness = -math.inf
        self.history: list[GenerationStats] = []
        self._pending: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        """The individuals of the current generation still to evaluate, shape (k, n); asking again
        before ``tell`` returns the same individuals."""
        if self._pending is None:
            self._pending = self._initial() if self.population is None else self._breed()
        return self._pending.copy()

    def tell(self, fitness: np.ndarray) -> None:
        """Fitness of the individuals of the last ``ask``, in the same order."""
        if self._pending is None:
            raise RuntimeError("tell() called before ask()")
        f = check_fitness(fitness, len(self._pending))
        population, values = self._pending, f
        if self.config.elitism and self.population is not None and self.fitness is not None:
            elite = int(np.argmax(self.fitness))
            population = np.vstack([self.population[elite], self._pending])
            values = np.concatenate([[self.fitness[elite]], f])
        self.population, self.fitness, self._pending = population, values, None
        best = int(np.argmax(values))
        if values[best] > self.best_fitness:
            self.best_fitness, self.best_genes = float(values[best]), population[best].copy()
        self.history.append(
            GenerationStats(self.generation, float(values.max()), float(values.mean()), float(values.min()))
        )
        self.generation += 1

    def _initial(self) -> np.ndarray:
        low, high = self.bounds[:, 0], self.bounds[:, 1]
        genes = self._rng.uniform(low, high, size=(self.config.population_size, len(self.bounds)))
        return self._finish(genes)

    def _breed(self) -> np.ndarray:
        assert self.population is not None and self.fitness is not None  # ask() breeds only after a tell()
        count = self.config.population_size - (1 if self.config.elitism else 0)
        pairs = (count + 1) // 2
        parents = self.operators.selection(self.fitness, 2 * pairs, self._rng)
        children: list[np.ndarray] = []
        for k in range(pairs):
            a, b = self.population[parents[2 * k]], self.population[parents[2 * k + 1]]
            if self._rng.random() < self.crossover_rate:
                a, b = self.operators.crossover(a, b, self._rng)
            children.extend((a.copy(), b.copy()))
        genes = self.operators.mutation(np.array(children[:count]), self.mutation_rate, self.bounds, self._rng)
        return self._finish(genes)

    def _finish(self, genes: np.ndarray) -> np.ndarray:
        genes = np.clip(genes, self.bounds[:, 0], self.bounds[:, 1])
        if self._repair is not None:
            genes = np.array([self._repair(g) for g in genes], dtype=float)
            inside = (genes >= self.bounds[:, 0]) & (genes <= self.bounds[:, 1])
            if not np.all(inside):
                raise ValueError("the repair hook moved genes outside the bounds")
        return genes


def evolve(ga: GeneticAlgorithm, generations: int, prefix: str) -> Generator[Batch, np.ndarray, float]:
    """Run ``generations`` generations of ``ga`` as batches keyed ``{prefix}/gNN``; return the best
    fitness among the individuals evaluated here (a carried elite is not one of them)."""
    best = -math.inf
    for g in range(generations):
        fitness = yield Batch(f"{prefix}/g{g:02d}", ga.ask())
        ga.tell(fitness)
        best = max(best, float(np.max(fitness)))
    return best


def spawn_rngs(seed_or_rng: int | np.random.Generator, count: int) -> list[np.random.Generator]:
    """Independent random streams for the parts of a search, so that e.g. the automaton's draws
    never shift the GA's: each part replays identically whatever the others consume."""
    if isinstance(seed_or_rng, np.random.Generator):
        return list(seed_or_rng.spawn(count))
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed_or_rng).spawn(count)]


@dataclass(frozen=True)
class GAResult:
    """Outcome of one GA run: the best individual ever evaluated and the convergence history."""

    best_fitness: float
    best_genes: np.ndarray
    history: list[GenerationStats]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "best_fitness": self.best_fitness,
            "best_genes": self.best_genes.tolist(),
            "history": [s._asdict() for s in self.history],
        }


def planned_episodes(config: GAConfig) -> int:
    """Episodes a GA run evaluates: the first generation whole, later ones without the carried elite."""
    return config.population_size + (config.generations - 1) * (config.population_size - int(config.elitism))


class GARun(KeyedSearch):
    """A plain GA of ``config.generations`` generations with keys ``{prefix}/gNN/iNNN`` (paper
    Fig. 4, 5, 7: a GA with fixed rates such as De Jong's or Grefenstette's)."""

    def __init__(
        self,
        bounds: np.ndarray,
        config: GAConfig,
        seed_or_rng: int | np.random.Generator,
        *,
        operators: GAOperators | None = None,
        repair: Repair | None = None,
        prefix: str = "ga",
    ) -> None:
        (rng,) = spawn_rngs(seed_or_rng, 1)
        self.ga = GeneticAlgorithm(bounds, config, rng, operators=operators, repair=repair)
        self._prefix = prefix
        super().__init__(self._run())

    def _run(self) -> SearchProgram:
        yield from evolve(self.ga, self.ga.config.generations, self._prefix)

    def result(self) -> GAResult:
        if not self.done:
            raise RuntimeError("GARun.result() called before the run is done")
        assert self.ga.best_genes is not None  # a finished run has evaluated at least one generation
        return GAResult(self.ga.best_fitness, self.ga.best_genes.copy(), list(self.ga.history))
