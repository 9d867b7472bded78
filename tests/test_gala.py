"""GALA: keys, determinism and replay (what resume relies on), the feedback rule, and learning."""

from __future__ import annotations

import json
from collections import defaultdict

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.search.config import GAConfig, GALAConfig, LAConfig
from optimizer.search.gala import GALA
from optimizer.search.la import LinearRewardInaction, LinearRewardPenalty
from optimizer.search.protocol import run_sync

BOUNDS = np.tile([0.0, 1.0], (7, 1))
OPTIMUM = np.linspace(0.2, 0.8, 7)


def sphere(genes: np.ndarray) -> float:
    return float(10.0 - 10.0 * np.sum((genes - OPTIMUM) ** 2))


SMALL = GALAConfig(ga=GAConfig(population_size=6, generations=3), iterations=5)


def drive(gala: GALA, fitness=sphere) -> list[tuple[str, tuple[float, ...]]]:
    """Run to the end; return every (key, genes) asked, in order."""
    asked = []
    while not gala.done:
        batch = gala.ask()
        asked += [(c.key, tuple(c.genes)) for c in batch]
        gala.tell({c.key: fitness(c.genes) for c in batch})
    return asked


def test_default_config_is_the_papers() -> None:
    config = GALAConfig()
    assert config.la.actions == (0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09)
    assert (config.la.reward_step, config.la.penalty_step, config.iterations) == (0.1, 0.2, 100)
    assert (config.ga.population_size, config.ga.generations, config.generations_per_iteration) == (100, 10, 1)
    assert config.crossover_rates == (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
    assert not config.restart_each_iteration


def test_keys_name_phase_iteration_generation_and_individual() -> None:
    keys = [key for key, _ in drive(GALA(BOUNDS, SMALL, 0.8, seed_or_rng=1))]
    assert len(keys) == len(set(keys))
    assert keys[0] == "pc0.8/init/g00/i000"
    assert keys[6] == "pc0.8/it000/g00/i000"  # after the 6 initial individuals; elite not re-asked
    assert keys[6 + 5 * 5] == "pc0.8/final/g00/i000"
    assert keys[-1] == "pc0.8/final/g02/i004"
    assert len(keys) == 6 + 5 * 5 + (6 + 2 * 5)


def test_restart_reading_runs_a_fresh_ga_per_iteration() -> None:
    config = GALAConfig(ga=GAConfig(population_size=4, generations=2), iterations=3, restart_each_iteration=True)
    keys = [key for key, _ in drive(GALA(BOUNDS, config, 0.3, 2))]
    assert keys[:5] == [
        "pc0.3/it000/g00/i000",
        "pc0.3/it000/g00/i001",
        "pc0.3/it000/g00/i002",
        "pc0.3/it000/g00/i003",
        "pc0.3/it000/g01/i000",
    ]
    assert not any("/init/" in k for k in keys)
    assert len(keys) == 3 * (4 + 3) + (4 + 3)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_same_seed_and_same_fitness_give_the_same_asks(seed: int, restart: bool) -> None:
    config = GALAConfig(ga=GAConfig(population_size=5, generations=2), iterations=4, restart_each_iteration=restart)
    first = drive(GALA(BOUNDS, config, 0.6, seed))
    second = drive(GALA(BOUNDS, config, 0.6, seed))
    assert first == second
    assert drive(GALA(BOUNDS, config, 0.6, seed + 1)) != first


def test_a_resumed_search_replays_the_log_and_ends_where_an_uninterrupted_one_does() -> None:
    config = GALAConfig(ga=GAConfig(population_size=8, generations=3), iterations=12)
    uninterrupted = run_sync(GALA(BOUNDS, config, 0.8, 7), sphere)

    log: dict[str, float] = {}
    interrupted = GALA(BOUNDS, config, 0.8, 7)
    for _ in range(6):  # some batches, the last one only half answered
        batch = interrupted.ask()
        log.update({c.key: sphere(c.genes) for c in batch})
        interrupted.tell({c.key: log[c.key] for c in batch})
    half = interrupted.ask()[:3]
    log.update({c.key: sphere(c.genes) for c in half})

    resumed, replayed = GALA(BOUNDS, config, 0.8, 7), 0
    while not resumed.done:
        batch = resumed.ask()
        known = {c.key: log[c.key] for c in batch if c.key in log}
        replayed += len(known)
        resumed.tell(known or {c.key: sphere(c.genes) for c in batch})
    assert replayed == len(log)
    result = resumed.result()
    assert result.optimal_mutation == uninterrupted.optimal_mutation
    assert result.best_fitness == uninterrupted.best_fitness
    assert np.array_equal(result.best_genes, uninterrupted.best_genes)
    assert result.iteration_log == uninterrupted.iteration_log


@pytest.mark.parametrize("restart", [False, True])
def test_feedback_is_best_against_the_average_of_preceding_bests(restart: bool) -> None:
    config = GALAConfig(ga=GAConfig(population_size=6, generations=2), iterations=15, restart_each_iteration=restart)
    told: dict[str, list[float]] = defaultdict(list)

    def noisy(genes: np.ndarray) -> float:  # the same genes can score differently, like a real episode
        return sphere(genes) + float(np.sin(1e4 * genes.sum()))

    gala = GALA(BOUNDS, config, 0.5, 3)
    while not gala.done:
        batch = gala.ask()
        answers = {c.key: noisy(c.genes) for c in batch}
        for key, value in answers.items():
            told[key.split("/")[1]].append(value)
        gala.tell(answers)
    log = gala.result().iteration_log
    assert [r.iteration for r in log] == list(range(15))
    assert log[0].baseline is None and log[0].rewarded is None
    scheme, p = LinearRewardPenalty(0.1, 0.2), np.full(10, 0.1)
    for k, record in enumerate(log):
        # the iteration's best is the best of what it evaluated (a carried elite is not asked)
        assert record.best_fitness == max(told[f"it{k:03d}"])
        assert record.mutation == config.la.actions[record.action]
        if k:
            assert record.baseline == pytest.approx(np.mean([r.best_fitness for r in log[:k]]), abs=1e-12)
            assert record.rewarded == (record.best_fitness > record.baseline)
            p = scheme.update(p, record.action, record.rewarded)
        assert np.allclose(record.probabilities, p, atol=1e-12)
    assert {r.rewarded for r in log[1:]} == {True, False}  # both branches exercised


@pytest.mark.parametrize("window", [1, 3])
def test_baseline_window_averages_only_the_last_bests(window: int) -> None:
    config = GALAConfig(ga=GAConfig(population_size=6, generations=2), iterations=12, baseline_window=window)
    gala = GALA(BOUNDS, config, 0.5, 5)
    drive(gala, lambda g: sphere(g) + float(np.sin(1e4 * g.sum())))
    log = gala.result().iteration_log
    for k, record in enumerate(log[1:], start=1):
        last = [r.best_fitness for r in log[max(0, k - window) : k]]
        assert record.baseline == pytest.approx(np.mean(last), abs=1e-12)
        assert record.rewarded == (record.best_fitness > record.baseline)
    with pytest.raises(ValueError, match="baseline_window"):
        GALAConfig(baseline_window=0)


def test_result_is_the_final_run_with_the_most_probable_rate() -> None:
    config = GALAConfig(ga=GAConfig(population_size=10, generations=4), iterations=20)
    result = run_sync(GALA(BOUNDS, config, 0.8, 4), sphere)
    p = np.array(result.probabilities)
    assert result.optimal_mutation == result.mutation_rates[int(np.argmax(p))]
    assert result.probabilities == result.iteration_log[-1].probabilities
    assert len(result.final_ga_history) == 4
    assert result.best_fitness == max(s.best for s in result.final_ga_history)
    assert result.best_fitness == pytest.approx(sphere(result.best_genes))
    assert result.crossover == 0.8
    json.dumps(result.to_dict())  # a run folder can store it as is


def test_lri_option_leaves_probabilities_alone_on_penalties() -> None:
    config = GALAConfig(ga=GAConfig(population_size=6, generations=2), iterations=25, restart_each_iteration=True)
    log = run_sync(GALA(BOUNDS, config, 0.7, 5, scheme=LinearRewardInaction(0.1)), sphere).iteration_log
    penalties = [k for k in range(1, 25) if log[k].rewarded is False]
    assert penalties
    for k in penalties:
        assert log[k].probabilities == log[k - 1].probabilities


def test_gala_learns_that_mutation_helps() -> None:
    """Maximise x on [0, 1] with one gene: crossover cannot create new values, so only mutation
    moves the population past its random start. Of the two rates {0, 0.5}, the automaton must
    come to favour 0.5 on average over the run (L_R-P with the paper's steps, restart reading)."""
    config = GALAConfig(
        ga=GAConfig(population_size=10, generations=5),
        la=LAConfig(actions=(0.0, 0.5)),
        iterations=60,
        restart_each_iteration=True,
    )
    for seed in range(5):
        result = run_sync(GALA(np.array([[0.0, 1.0]]), config, 0.8, seed), lambda g: float(g[0]))
        mean_p_mutation = np.mean([r.probabilities[1] for r in result.iteration_log[10:]])
        assert mean_p_mutation > 0.6, seed


def test_paper_size_search_on_a_synthetic_function_improves() -> None:
    """The defaults end to end (100 iterations of 100 individuals + a 10-generation final run)."""
    result = run_sync(GALA(BOUNDS, GALAConfig(), 0.8, 8), sphere)
    assert len(result.iteration_log) == 100
    assert result.final_ga_history[-1].best > result.final_ga_history[0].best
    assert result.iteration_log[-1].best_fitness > result.iteration_log[0].best_fitness


def test_misuse_is_named() -> None:
    with pytest.raises(ValueError, match="crossover rate"):
        GALA(BOUNDS, SMALL, 1.2, 0)
    gala = GALA(BOUNDS, SMALL, 0.8, 0)
    with pytest.raises(RuntimeError, match="before the search is done"):
        gala.result()
    drive(gala)
    assert gala.ask() == []
    with pytest.raises(ValueError, match="done"):
        gala.tell({"pc0.8/final/g00/i000": 1.0})
