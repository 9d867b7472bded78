"""The genetic algorithm: operators, invariants (hypothesis), convergence on a synthetic 7-D function."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.search.config import DE_JONG, GREFENSTETTE, GAConfig
from optimizer.search.ga import (
    BlendCrossover,
    GAOperators,
    GARun,
    GaussianMutation,
    GeneticAlgorithm,
    one_point_crossover,
    roulette_selection,
    roulette_weights,
    uniform_reset_mutation,
)
from optimizer.search.protocol import run_sync

# A box shaped like the TFS genes' (degrees, seconds, rad/s) so that per-gene scaling matters.
BOUNDS = np.array([[-10, 40], [0, 60], [0, 40], [0, 40], [0, 60], [0, 1], [6.28, 25.1]], dtype=float)
SPAN = BOUNDS[:, 1] - BOUNDS[:, 0]
OPTIMUM = BOUNDS[:, 0] + np.array([0.3, 0.7, 0.2, 0.8, 0.5, 0.4, 0.6]) * SPAN


def sphere(genes: np.ndarray) -> float:
    """Smooth, maximum 100 at OPTIMUM, negative far away (like a robot falling backwards)."""
    return float(100.0 - 400.0 * np.sum(((genes - OPTIMUM) / SPAN) ** 2))


def run_ga(config: GAConfig, seed: int, fitness=sphere, **kwargs) -> GeneticAlgorithm:
    ga = GeneticAlgorithm(BOUNDS, config, np.random.default_rng(seed), **kwargs)
    for _ in range(config.generations):
        ga.tell(np.array([fitness(g) for g in ga.ask()]))
    return ga


# --- roulette wheel -------------------------------------------------------------------------------


def test_roulette_weights_shift_negative_fitness_to_positive_slices() -> None:
    w = roulette_weights(np.array([-5.0, 0.0, 15.0]))
    # shift: f - min + 1 % of the spread (20) -> [0.2, 5.2, 20.2]
    expected = np.array([0.2, 5.2, 20.2]) / 25.6
    assert np.allclose(w, expected, rtol=0, atol=1e-15)
    assert np.all(w > 0)


def test_roulette_weights_of_equal_fitness_are_uniform() -> None:
    assert np.allclose(roulette_weights(np.full(4, -3.0)), 0.25)


def test_roulette_selection_favours_the_fitter() -> None:
    rng = np.random.default_rng(0)
    picks = roulette_selection(np.array([0.0, 10.0, 30.0]), 20000, rng)
    counts = np.bincount(picks, minlength=3) / 20000
    assert np.allclose(counts, roulette_weights(np.array([0.0, 10.0, 30.0])), atol=0.02)


# --- operators ------------------------------------------------------------------------------------


@given(st.integers(0, 2**32 - 1), st.integers(2, 9))
def test_one_point_crossover_swaps_tails(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(size=n), rng.uniform(size=n) + 2.0  # b's genes are all > a's
    ca, cb = one_point_crossover(a, b, rng)
    from_a = ca < 2.0
    cut = int(np.argmin(from_a))  # first gene taken from b
    assert 1 <= cut < n
    assert np.array_equal(ca, np.concatenate([a[:cut], b[cut:]]))
    assert np.array_equal(cb, np.concatenate([b[:cut], a[cut:]]))


def test_one_point_crossover_of_one_gene_copies_the_parents() -> None:
    ca, cb = one_point_crossover(np.array([1.0]), np.array([2.0]), np.random.default_rng(0))
    assert (ca[0], cb[0]) == (1.0, 2.0)


@given(st.integers(0, 2**32 - 1))
def test_blend_crossover_stays_in_the_widened_interval(seed: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(-5, 5, 7), rng.uniform(-5, 5, 7)
    low, high = np.minimum(a, b), np.maximum(a, b)
    for child in BlendCrossover(alpha=0.5)(a, b, rng):
        assert np.all(child >= low - 0.5 * (high - low) - 1e-12)
        assert np.all(child <= high + 0.5 * (high - low) + 1e-12)


@pytest.mark.parametrize("mutation", [GaussianMutation(0.1), uniform_reset_mutation])
def test_mutation_rate_zero_changes_nothing_and_rate_one_changes_every_gene(mutation) -> None:
    rng = np.random.default_rng(1)
    genes = rng.uniform(BOUNDS[:, 0], BOUNDS[:, 1], size=(50, 7))
    assert np.array_equal(mutation(genes, 0.0, BOUNDS, rng), genes)
    mutated = mutation(genes, 1.0, BOUNDS, rng)
    assert np.mean(mutated != genes) > 0.95  # only clipping at a bound can leave a gene unchanged
    assert np.all((mutated >= BOUNDS[:, 0]) & (mutated <= BOUNDS[:, 1]))


def test_gaussian_mutation_sigma_scales_with_each_genes_range() -> None:
    rng = np.random.default_rng(2)
    centre = np.tile(BOUNDS.mean(axis=1), (20000, 1))
    step = GaussianMutation(0.05)(centre, 1.0, BOUNDS, rng) - centre
    assert np.allclose(step.std(axis=0), 0.05 * SPAN, rtol=0.05)


# --- the GA ---------------------------------------------------------------------------------------


def test_ga_improves_and_gets_near_the_optimum() -> None:
    ga = run_ga(GAConfig(generations=30), seed=3)
    assert ga.history[-1].best > ga.history[0].best
    assert ga.history[-1].mean > ga.history[0].mean
    assert ga.history[0].best < 90.0 < 97.0 < ga.best_fitness  # random start vs. near the top (100)
    assert np.all(np.abs(ga.best_genes - OPTIMUM) / SPAN < 0.08)  # each gene within 8 % of its range
    assert ga.best_fitness == pytest.approx(sphere(ga.best_genes))


def test_default_run_has_the_papers_size_and_does_not_re_evaluate_the_elite() -> None:
    config = GAConfig()
    evaluated = []
    run = GARun(BOUNDS, config, seed_or_rng=4)
    result = run_sync(run, lambda g: evaluated.append(g) or sphere(g))
    assert len(evaluated) == 100 + 9 * 99
    assert [s.generation for s in result.history] == list(range(10))
    assert run.ga.generation == 10
    assert len(run.ga.population) == 100


def test_elitism_keeps_the_best_and_never_loses_it() -> None:
    ga = run_ga(GAConfig(generations=12, mutation_rate=0.5), seed=5)
    bests = [s.best for s in ga.history]
    assert bests == sorted(bests)
    assert ga.best_fitness == bests[-1]
    assert any(np.array_equal(ind, ga.best_genes) for ind in ga.population)


def test_without_elitism_every_individual_is_new_and_the_best_can_drop() -> None:
    config = GAConfig(population_size=20, generations=15, mutation_rate=1.0, elitism=False)
    ga = GeneticAlgorithm(BOUNDS, config, np.random.default_rng(6))
    for _ in range(config.generations):
        assert len(ga.ask()) == 20
        ga.tell(np.array([sphere(g) for g in ga.ask()]))
    bests = [s.best for s in ga.history]
    assert bests != sorted(bests)  # heavy mutation without elitism loses good individuals
    assert ga.best_fitness == max(bests)  # but the best ever seen is remembered


def test_no_crossover_and_no_mutation_only_copies_parents() -> None:
    config = GAConfig(population_size=10, crossover_rate=0.0, mutation_rate=0.0)
    ga = GeneticAlgorithm(BOUNDS, config, np.random.default_rng(7))
    first = ga.ask()
    ga.tell(np.arange(10.0))
    for child in ga.ask():
        assert any(np.array_equal(child, parent) for parent in first)


def test_ask_twice_returns_the_same_generation() -> None:
    ga = GeneticAlgorithm(BOUNDS, GAConfig(population_size=8), np.random.default_rng(8))
    assert np.array_equal(ga.ask(), ga.ask())
    ga.tell(np.zeros(8))
    assert np.array_equal(ga.ask(), ga.ask())


def test_same_seed_same_fitness_same_asks() -> None:
    a, b = run_ga(GAConfig(generations=4), seed=9), run_ga(GAConfig(generations=4), seed=9)
    assert np.array_equal(a.population, b.population)
    assert a.history == b.history


def test_tell_rejects_wrong_length_non_finite_and_tell_before_ask() -> None:
    ga = GeneticAlgorithm(BOUNDS, GAConfig(population_size=4), np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="before ask"):
        ga.tell(np.zeros(4))
    ga.ask()
    with pytest.raises(ValueError, match="expected 4 fitness values"):
        ga.tell(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        ga.tell(np.array([0.0, np.nan, 1.0, 2.0]))


def test_bad_bounds_and_bad_config_are_named() -> None:
    with pytest.raises(ValueError, match="shape"):
        GeneticAlgorithm(np.zeros(3), GAConfig(), np.random.default_rng(0))
    with pytest.raises(ValueError, match="low <= high"):
        GeneticAlgorithm(np.array([[1.0, 0.0]]), GAConfig(), np.random.default_rng(0))
    with pytest.raises(ValueError, match="mutation_rate"):
        GAConfig(mutation_rate=1.5)


def test_a_new_selection_scheme_is_just_a_callable() -> None:
    def truncation(fitness: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
        return np.resize(np.argsort(fitness)[-2:], count)  # always the two best

    config = GAConfig(population_size=10, crossover_rate=0.0, mutation_rate=0.0, elitism=False)
    ga = GeneticAlgorithm(BOUNDS, config, np.random.default_rng(10), operators=GAOperators(selection=truncation))
    first = ga.ask()
    ga.tell(np.arange(10.0))
    assert {tuple(c) for c in ga.ask()} == {tuple(first[8]), tuple(first[9])}


# --- invariants (hypothesis) ----------------------------------------------------------------------

bounds_strategy = st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(0.0, 1e3)), min_size=1, max_size=8).map(
    lambda rows: np.array([[lo, lo + width] for lo, width in rows])
)


@settings(max_examples=40, deadline=None)
@given(
    bounds_strategy,
    st.integers(0, 2**32 - 1),
    st.floats(0, 1),
    st.floats(0, 1),
    st.booleans(),
    st.sampled_from([one_point_crossover, BlendCrossover(0.5)]),
    st.sampled_from([GaussianMutation(0.3), uniform_reset_mutation]),
)
def test_genes_stay_within_bounds(bounds, seed, pc, pm, elitism, crossover, mutation) -> None:
    config = GAConfig(population_size=7, generations=4, crossover_rate=pc, mutation_rate=pm, elitism=elitism)
    ga = GeneticAlgorithm(
        bounds, config, np.random.default_rng(seed), operators=GAOperators(crossover=crossover, mutation=mutation)
    )
    fitness = np.random.default_rng(seed + 1)
    for _ in range(config.generations):
        genes = ga.ask()
        assert genes.shape[1] == len(bounds)
        assert np.all((genes >= bounds[:, 0]) & (genes <= bounds[:, 1]))
        ga.tell(fitness.normal(size=len(genes)) * 100)


def ordered_pair(genes: np.ndarray) -> np.ndarray:
    """A coupled constraint like the TFS's t2 < 2*pi/w: gene 0 must not exceed half of gene 1."""
    out = genes.copy()
    out[0] = min(out[0], 0.5 * out[1])
    return out


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0, 1))
def test_repair_is_applied_to_every_new_individual(seed: int, pm: float) -> None:
    bounds = np.array([[0.0, 10.0], [0.0, 10.0], [-1.0, 1.0]])
    config = GAConfig(population_size=9, generations=5, mutation_rate=pm)
    ga = GeneticAlgorithm(bounds, config, np.random.default_rng(seed), repair=ordered_pair)
    for _ in range(config.generations):
        genes = ga.ask()
        assert np.all(genes[:, 0] <= 0.5 * genes[:, 1])
        ga.tell(genes.sum(axis=1))


def test_a_repair_that_leaves_the_bounds_is_an_error() -> None:
    ga = GeneticAlgorithm(BOUNDS, GAConfig(), np.random.default_rng(0), repair=lambda g: g + 1e3)
    with pytest.raises(ValueError, match="repair"):
        ga.ask()


# --- keyed runs -----------------------------------------------------------------------------------


def test_ga_run_keys_are_stable_unique_and_name_generation_and_individual() -> None:
    config = GAConfig(population_size=5, generations=3)
    run, keys = GARun(BOUNDS, config, 11), []
    while not run.done:
        batch = run.ask()
        keys += [c.key for c in batch]
        run.tell({c.key: sphere(c.genes) for c in batch})
    assert keys[:6] == ["ga/g00/i000", "ga/g00/i001", "ga/g00/i002", "ga/g00/i003", "ga/g00/i004", "ga/g01/i000"]
    assert keys[-1] == "ga/g02/i003"  # the elite is carried, 4 new individuals per later generation
    assert len(set(keys)) == len(keys) == 5 + 2 * 4


def test_ga_run_accepts_answers_in_parts_and_rejects_strangers() -> None:
    run = GARun(BOUNDS, GAConfig(population_size=4, generations=2), 12)
    batch = run.ask()
    run.tell({batch[2].key: 1.0})
    assert [c.key for c in run.ask()] == [batch[0].key, batch[1].key, batch[3].key]
    with pytest.raises(ValueError, match="already answered"):
        run.tell({batch[2].key: 1.0})
    with pytest.raises(ValueError, match="not part of the current batch"):
        run.tell({"ga/g05/i000": 1.0})
    with pytest.raises(ValueError, match="finite"):
        run.tell({batch[0].key: float("inf")})
    run.tell({c.key: 0.0 for c in run.ask()})
    assert run.ask()[0].key == "ga/g01/i000"


def test_presets_are_the_papers_rates() -> None:
    assert (DE_JONG.crossover_rate, DE_JONG.mutation_rate) == (0.6, 0.001)
    assert (GREFENSTETTE.crossover_rate, GREFENSTETTE.mutation_rate) == (0.95, 0.01)
    config = GAConfig(crossover_rate=GREFENSTETTE.crossover_rate, mutation_rate=GREFENSTETTE.mutation_rate)
    result = run_sync(GARun(BOUNDS, config, 13), sphere)
    assert result.best_fitness == max(s.best for s in result.history)


@settings(deadline=None, max_examples=25)
@given(st.integers(0, 2**31 - 1), st.booleans())
def test_a_search_names_the_key_of_its_best(seed: int, elitism: bool) -> None:
    """The best a GA run reports is the logged candidate ``best_key`` names: same genes, same
    fitness, found without comparing floats (ties included: coarse fitness levels force them)."""
    bounds = np.array([[0.0, 1.0]] * 3)
    answered: dict[str, tuple[np.ndarray, float]] = {}

    def fitness(genes: np.ndarray) -> float:
        return float(np.round(np.sum(genes), 1))  # coarse, so equal fitness happens

    search = GARun(bounds, GAConfig(population_size=6, generations=4, elitism=elitism), seed, prefix="ga")
    while not search.done:
        batch = search.ask()
        answered.update((c.key, (c.genes, fitness(c.genes))) for c in batch)
        search.tell({c.key: answered[c.key][1] for c in batch})
    result = search.result()
    key = search.best_key("ga/")
    assert key is not None and answered[key][1] == result.best_fitness
    assert np.array_equal(answered[key][0], result.best_genes)
    assert search.best_key("nothing/") is None


def test_cma_es_restarts_with_twice_the_population_after_its_patience_without_a_gain() -> None:
    """A best that creeps up by less than 1% a generation is no gain: with a patience of 3 the
    strategy starts again after 3 generations, with twice the gaits; without one it goes on as it
    was. A gain of 1% or more a generation never lets the count reach the patience."""
    from optimizer.search.cmaes import cmaes_program

    bounds = np.array([[0.0, 1.0]] * 3)

    def sizes(patience, gain: float) -> list[int]:
        program = cmaes_program(bounds, lambda g: g, 7, start=[0.5] * 3, sigma0=0.1, population=6, patience=patience)
        batch, out = next(program), []
        for generation in range(10):
            out.append(len(batch.genes))
            batch = program.send(100.0 * (1.0 + gain) ** generation + batch.genes[:, 0] * 1e-3)
        return out

    assert sizes(None, 0.001) == [6] * 10
    assert sizes(3, 0.001) == [6, 6, 6, 6, 12, 12, 12, 24, 24, 24]
    assert sizes(3, 0.02) == [6] * 10


def test_cma_es_strategies_asked_in_turn_draw_what_each_draws_alone() -> None:
    """``cma`` samples from numpy's global generator; two strategies asked in turn (the refinement's
    race) must not draw from each other's streams."""
    from optimizer.search.cmaes import cmaes_program

    bounds = np.array([[0.0, 1.0]] * 3)

    def batches(programs, rounds: int) -> list[list[np.ndarray]]:
        out = [[next(p).genes] for p in programs]
        for _ in range(rounds):
            for p, seen in zip(programs, out):
                seen.append(p.send(-np.sum((seen[-1] - 0.3) ** 2, axis=1)).genes)
        return out

    def program(seed: int):
        return cmaes_program(bounds, lambda g: g, seed, start=[0.5, 0.5, 0.5], sigma0=0.2, population=6)

    alone = [batches([program(seed)], 4)[0] for seed in (1, 2)]
    together = batches([program(1), program(2)], 4)
    for a, b in zip(alone, together):
        assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(together[0][1], together[1][1])


def test_held_genes_keep_the_start_values_through_generations_and_restarts() -> None:
    """A tfs-start refinement holds the start gait: every gait CMA-ES asks has the held genes at
    exactly the start's values, also after a restart (patience 2), while the others move and climb."""
    from optimizer.search.cmaes import cmaes_program

    bounds = np.array([[0.0, 10.0]] * 4)
    start = [5.0, 5.0, 1.2345678901, 7.1]
    program = cmaes_program(bounds, lambda g: g, 3, start=start, sigma0=0.2, population=6, patience=2, held=[2, 3])
    batch, sizes, firsts = next(program), [], []
    for _ in range(12):
        assert np.array_equal(batch.genes[:, 2:], np.tile(start[2:], (len(batch.genes), 1)))
        sizes.append(len(batch.genes))
        firsts.append(batch.genes[:, 0])
        batch = program.send(-((batch.genes[:, 0] - 9.0) ** 2) - batch.genes[:, 1] * 1e-9)
    assert max(sizes) > min(sizes)  # a restart happened, and held the genes too
    assert np.ptp(np.concatenate(firsts)) > 0.5 and np.mean(firsts[-1]) > 6.0


def test_held_genes_need_a_start() -> None:
    from optimizer.search.cmaes import cmaes_program

    with pytest.raises(ValueError, match="held genes need a start"):
        next(cmaes_program(np.array([[0.0, 1.0]] * 2), lambda g: g, 1, held=[1]))
