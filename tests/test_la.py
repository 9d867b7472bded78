"""Learning automata: eq. 6-8 against hand-computed values, and the probability vector's invariants."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.search.la import (
    LearningAutomaton,
    LinearRewardInaction,
    LinearRewardPenalty,
)

UNIFORM4 = np.full(4, 0.25)


def test_lrp_reward_is_eq_7() -> None:
    # chosen: 0.25 + 0.1 * (1 - 0.25) = 0.325; others: 0.25 * (1 - 0.1) = 0.225
    p = LinearRewardPenalty(a=0.1, b=0.2).update(UNIFORM4, 1, rewarded=True)
    assert np.allclose(p, [0.225, 0.325, 0.225, 0.225], rtol=0, atol=1e-15)


def test_lrp_penalty_is_eq_8() -> None:
    # chosen: 0.25 * (1 - 0.2) = 0.2; others: 0.2 / 3 + 0.8 * 0.25 = 0.2666...
    p = LinearRewardPenalty(a=0.1, b=0.2).update(UNIFORM4, 1, rewarded=False)
    assert np.allclose(p, [0.2 / 3 + 0.2, 0.2, 0.2 / 3 + 0.2, 0.2 / 3 + 0.2], rtol=0, atol=1e-15)


def test_lrp_on_an_uneven_vector() -> None:
    p0 = np.array([0.5, 0.3, 0.2])
    rewarded = LinearRewardPenalty(a=0.1, b=0.2).update(p0, 2, True)
    assert np.allclose(rewarded, [0.45, 0.27, 0.28], rtol=0, atol=1e-15)  # 0.2 + 0.1 * 0.8
    penalised = LinearRewardPenalty(a=0.1, b=0.2).update(p0, 0, False)
    assert np.allclose(penalised, [0.4, 0.1 + 0.24, 0.1 + 0.16], rtol=0, atol=1e-15)


def test_lri_reward_is_eq_6_and_penalty_is_inaction() -> None:
    scheme = LinearRewardInaction(a=0.1)
    p0 = np.array([0.5, 0.3, 0.2])
    assert np.allclose(scheme.update(p0, 1, True), [0.45, 0.37, 0.18], rtol=0, atol=1e-15)
    unchanged = scheme.update(p0, 1, False)
    assert np.array_equal(unchanged, p0)
    assert unchanged is not p0  # a new vector: the caller may keep the old one


def test_schemes_do_not_modify_their_input() -> None:
    p0 = UNIFORM4.copy()
    LinearRewardPenalty(0.1, 0.2).update(p0, 0, True)
    LinearRewardPenalty(0.1, 0.2).update(p0, 0, False)
    LinearRewardInaction(0.1).update(p0, 0, True)
    assert np.array_equal(p0, UNIFORM4)


feedback = st.lists(st.tuples(st.integers(0, 9), st.booleans()), max_size=300)
steps = st.floats(0.001, 1.0)


@settings(max_examples=60)
@given(feedback, steps, steps)
def test_lrp_keeps_a_distribution(sequence, a, b) -> None:
    scheme, p = LinearRewardPenalty(a, b), np.full(10, 0.1)
    for i, rewarded in sequence:
        p = scheme.update(p, i, rewarded)
        assert np.all(p >= 0.0)
        assert abs(p.sum() - 1.0) < 1e-12


@settings(max_examples=60)
@given(feedback, steps)
def test_lri_keeps_a_distribution_and_ignores_penalties(sequence, a) -> None:
    scheme, p = LinearRewardInaction(a), np.full(10, 0.1)
    for i, rewarded in sequence:
        new = scheme.update(p, i, rewarded)
        assert np.all(new >= 0.0)
        assert abs(new.sum() - 1.0) < 1e-12
        if not rewarded:
            assert np.array_equal(new, p)
        p = new


@settings(max_examples=30)
@given(st.integers(0, 2**32 - 1), feedback)
def test_automaton_keeps_a_distribution_and_chooses_valid_actions(seed, sequence) -> None:
    automaton = LearningAutomaton(
        [0.01 * k for k in range(10)], LinearRewardPenalty(0.1, 0.2), np.random.default_rng(seed)
    )
    for _, rewarded in sequence:
        i = automaton.choose()
        assert 0 <= i < 10
        automaton.update(i, rewarded)
        assert np.all(automaton.probabilities >= 0.0)
        assert abs(automaton.probabilities.sum() - 1.0) < 1e-12


def test_automaton_starts_uniform_and_chooses_by_roulette() -> None:
    automaton = LearningAutomaton([0.0, 0.1, 0.2], LinearRewardInaction(0.1), np.random.default_rng(0))
    assert np.allclose(automaton.probabilities, 1 / 3)
    automaton.probabilities = np.array([0.1, 0.6, 0.3])
    counts = np.bincount([automaton.choose() for _ in range(20000)], minlength=3) / 20000
    assert np.allclose(counts, [0.1, 0.6, 0.3], atol=0.02)


def run_stationary_environment(scheme, seed: int, steps: int = 3000) -> tuple[LearningAutomaton, np.ndarray]:
    """Reward action k with probability 0.2 + 0.06 k; return the automaton and its time-averaged
    probabilities."""
    rng = np.random.default_rng(seed)
    automaton = LearningAutomaton(list(range(10)), scheme, np.random.default_rng(seed + 100))
    visits = np.zeros(10)
    for _ in range(steps):
        i = automaton.choose()
        automaton.update(i, bool(rng.random() < 0.2 + 0.06 * i))
        visits += automaton.probabilities
    return automaton, visits / steps


def test_lrp_is_expedient_it_favours_the_actions_rewarded_more_often() -> None:
    _, mean_p = run_stationary_environment(LinearRewardPenalty(0.1, 0.2), seed=1)
    assert mean_p[5:].sum() > mean_p[:5].sum() + 0.1
    assert mean_p[9] > 1.3 * mean_p[0]


def test_lri_converges_to_one_of_the_best_actions() -> None:
    automaton, _ = run_stationary_environment(LinearRewardInaction(0.1), seed=1)
    assert automaton.probabilities.max() > 0.9
    assert automaton.best_action() in (8, 9)


def test_bad_steps_and_bad_actions_are_named() -> None:
    with pytest.raises(ValueError, match="penalty step b"):
        LinearRewardPenalty(0.1, 0.0)
    with pytest.raises(ValueError, match="reward step a"):
        LinearRewardInaction(1.5)
    with pytest.raises(ValueError, match="at least 2 actions"):
        LearningAutomaton([0.0], LinearRewardInaction(0.1), np.random.default_rng(0))
    automaton = LearningAutomaton([0.0, 0.1], LinearRewardInaction(0.1), np.random.default_rng(0))
    with pytest.raises(ValueError, match="out of range"):
        automaton.update(2, True)
