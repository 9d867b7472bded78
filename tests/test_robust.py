"""Robust scoring (``optimizer.run.robust``): a gait's score over dithered walks, raced. Property
tests on a fake evaluator whose walks vary with their seed, as dithered walks do."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask
from optimizer.evaluation.record import EpisodeRecord
from optimizer.run.driver import Driver
from optimizer.run.folder import EpisodeLog
from optimizer.run.robust import Race, extra_key
from optimizer.search.config import ScoringConfig


class NoisyEvaluator:
    """A walk goes ``genes[0]`` metres plus up to ``spread`` more, drawn from its seed (its dither);
    it falls when ``genes[1]`` > 0.5 and its draw is in the upper half."""

    def __init__(self, spread: float) -> None:
        self.spread = spread
        self.evaluated: list[str] = []

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        for task in tasks:
            self.evaluated.append(task.key)
            draw = (task.seed % 1000) / 1000.0
            fell = task.genes[1] > 0.5 and draw > 0.5
            distance = task.genes[0] + self.spread * draw
            result = {
                "distance": distance,
                "fell": fell,
                "time": 15.0,
                "fitness": 10.0 * distance,
                "mean_speed": distance / 15.0,
                "status": "ok",
                "reason": "",
                "wall": 0.0,
            }
            yield EpisodeOutcome(task, 0, result)


def _batches(gaits: int, batches: int) -> st.SearchStrategy[list[list[tuple[float, float]]]]:
    """Up to ``batches`` batches of up to ``gaits`` gaits each, genes (distance, fall chance) for
    ``NoisyEvaluator``."""
    gait = st.tuples(st.floats(0.0, 10.0), st.floats(0.0, 1.0))
    return st.lists(st.lists(gait, min_size=1, max_size=gaits), min_size=1, max_size=batches)


def _record(fitness: float, fell: bool = False, status: str = "ok") -> EpisodeRecord:
    return EpisodeRecord("k", (0.0,), fitness, distance=fitness / 10, fell=fell, status=status)


def test_one_walk_scores_as_the_paper_and_k_walks_by_their_quantile_or_mean() -> None:
    walks = [_record(v) for v in (50.0, 10.0, 40.0, 30.0, 20.0)]
    assert Race(ScoringConfig(walks=1)).score(walks[:1]) == 50.0
    assert Race(ScoringConfig(walks=5)).score(walks) == 20.0  # the 0.25 quantile of 5: the second-worst
    assert Race(ScoringConfig(walks=5, quantile=None)).score(walks) == 30.0
    assert Race(ScoringConfig(walks=5, quantile=0.0)).score(walks) == 10.0


def test_the_first_round_races_only_the_best_first_walks_and_a_failed_walk_never() -> None:
    race = Race(ScoringConfig(walks=3, top=2))
    firsts = [("a", _record(10.0)), ("b", _record(30.0)), ("c", _record(20.0)), ("d", _record(99.0, status="failed"))]
    assert race.choose(firsts) == ["b", "c"]
    race.enter(25.0)
    race.enter(15.0)
    assert race.choose([("a", _record(10.0)), ("e", _record(16.0))]) == ["e"]  # beats the bar's 15
    assert race.choose([("a", _record(15.0))]) == []  # equal is not better
    assert Race(ScoringConfig(walks=1)).choose(firsts) == []


def test_only_a_score_above_every_leader_walks_on() -> None:
    race = Race(ScoringConfig(walks=3, lead_walks=6))
    assert race.leaders([("a", 10.0), ("b", 30.0)]) == ["a", "b"]  # no leader yet: both could be the best
    race.lead(20.0)
    race.lead(12.0)  # a leader that fell in its later walks does not lower the bar
    assert race.leaders([("a", 10.0), ("b", 30.0), ("c", 20.0)]) == ["b"]
    assert Race(ScoringConfig(walks=3)).leaders([("b", 30.0)]) == []


def test_a_first_walk_above_the_best_leader_is_told_just_under_it() -> None:
    """Once a leader's later walks lower its score, a first walk left under the bar of k-walk
    scores may lie above it: it is told just under the best leader's score, so that one walk is
    never the search's best; a walk below it is told as it walked, and without leaders nothing
    is capped."""
    race = Race(ScoringConfig(walks=2, lead_walks=5, top=1))
    race.enter(105.0)
    assert race.choose([("x", _record(104.8))]) == []  # below the one raced score: not raced
    assert race.score([_record(104.8)]) == 104.8  # no leader yet
    race.lead(100.0)
    assert race.choose([("x", _record(104.8))]) == []  # the bar is still the k-walk score
    told = race.score([_record(104.8)])
    assert told < 100.0 and told == math.nextafter(100.0, -math.inf)
    assert race.score([_record(99.0)]) == 99.0
    assert race.score([_record(104.8), _record(98.0)]) == 98.0 + 0.25 * 6.8  # raced scores are not capped


def test_a_scoring_config_refuses_impossible_values() -> None:
    for bad in ({"walks": 0}, {"top": 0}, {"quantile": 1.5}, {"walks": 5, "lead_walks": 5}):
        with pytest.raises(ValueError):
            ScoringConfig(**bad)  # type: ignore[arg-type]


@settings(deadline=None, max_examples=30)
@given(
    _batches(gaits=8, batches=5),
    st.integers(2, 5),
    st.integers(1, 3),
    st.floats(0.0, 5.0),
)
def test_racing_keeps_single_walks_below_the_bar_and_walks_raced_gaits_k_times(
    tmp_path_factory: pytest.TempPathFactory, batches: list, walks: int, top: int, spread: float
) -> None:
    """Whatever the walks: a raced gait has exactly k walks (keys <key>/k1 ...) and is scored by
    them; after each batch, every gait left with one walk scores at most the top-th best raced
    score so far, so the search's best is a raced gait once ``top`` gaits were raced."""
    config = ScoringConfig(walks=walks, top=top)
    path = tmp_path_factory.mktemp("race") / "episodes.jsonl"
    evaluator = NoisyEvaluator(spread)
    with EpisodeLog(path) as log:
        driver = Driver(evaluator, log, run_seed=4, scoring=config)  # type: ignore[arg-type]
        race = driver.race()
        raced_scores: list[float] = []
        for b, batch in enumerate(batches):
            candidates = [(f"s/b{b}/i{i:03d}", np.array(genes)) for i, genes in enumerate(batch)]
            scored = driver.score(candidates, race)
            assert [s.key for s in scored] == [key for key, _ in candidates]
            for gait in scored:
                if gait.raced:
                    assert [w.key for w in gait.walks] == [gait.key] + [extra_key(gait.key, j) for j in range(1, walks)]
                    assert gait.fitness == race.score(gait.walks)
                    # the first walk from the run's start, the others moved within the jitter
                    assert gait.walks[0].start is None and all(w.start is not None for w in gait.walks[1:])
                    assert all(abs(w.start[2] - driver.start[2]) <= 10.0 for w in gait.walks[1:])  # type: ignore[index]
                    raced_scores.append(gait.fitness)
                else:
                    assert gait.fitness == gait.walks[0].fitness
            if len(raced_scores) >= top:
                bar = sorted(raced_scores)[-top]
                assert all(g.fitness <= bar for g in scored if not g.raced)
                assert max(driver.scored.values(), key=lambda g: g.fitness).raced
    assert len(evaluator.evaluated) == len(set(evaluator.evaluated))  # no walk twice


def test_with_one_walk_nothing_is_raced(tmp_path: Path) -> None:
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(NoisyEvaluator(3.0), log, run_seed=1)  # type: ignore[arg-type]
        scored = driver.score([(f"s/i{i:03d}", np.array([float(i), 0.0])) for i in range(6)], driver.race())
    assert all(not g.raced for g in scored) and len(log.records) == 6


@settings(deadline=None, max_examples=25)
@given(
    _batches(gaits=6, batches=4),
    st.integers(2, 4),
    st.integers(1, 4),
)
# found by CI: a leader's later walks lowered its score below a first walk left under the k-walk bar
@example(batches=[[(0.0, 0.0), (10.0, 0.0)], [(8.0, 0.0), (9.0, 0.0), (0.0, 0.0), (8.75, 0.0)]], walks=2, more=3)
def test_a_search_best_is_always_a_leader_walked_on_from_the_same_first_walks(
    tmp_path_factory: pytest.TempPathFactory, batches: list, walks: int, more: int
) -> None:
    """With leaders' walks: after every batch the best score of the search is a gait's over all its
    ``lead_walks`` walks; each gait has 1, k or ``lead_walks`` walks; and a leader's first k walks
    are the very walks (keys, seeds, starts) the race without leaders gives it."""
    lead = walks + more
    folder = tmp_path_factory.mktemp("lead")
    with EpisodeLog(folder / "lead.jsonl") as log, EpisodeLog(folder / "plain.jsonl") as plain_log:
        driver = Driver(NoisyEvaluator(4.0), log, run_seed=9, scoring=ScoringConfig(walks=walks, lead_walks=lead))  # type: ignore[arg-type]
        plain = Driver(NoisyEvaluator(4.0), plain_log, run_seed=9, scoring=ScoringConfig(walks=walks))  # type: ignore[arg-type]
        race, plain_race = driver.race(), plain.race()
        for b, batch in enumerate(batches):
            candidates = [(f"s/b{b}/i{i:03d}", np.array(genes)) for i, genes in enumerate(batch)]
            scored = driver.score(candidates, race)
            plain.score(candidates, plain_race)
            assert all(len(g.walks) in (1, walks, lead) for g in scored)
            best = max(driver.scored.values(), key=lambda g: g.fitness)
            assert len(best.walks) == lead and best.fitness == race.score(best.walks)
            for gait in scored:
                assert [w.key for w in gait.walks] == [gait.key] + [
                    extra_key(gait.key, j) for j in range(1, len(gait.walks))
                ]
                # leaders change no race: the same gaits raced, from the same first k walks
                alone = plain.scored[gait.key]
                assert gait.walks[: len(alone.walks)] == alone.walks
                assert (len(gait.walks) == 1) == (len(alone.walks) == 1)
                if len(gait.walks) == 1:  # told as it walked, but never above a leader
                    assert gait.fitness == min(alone.fitness, math.nextafter(best.fitness, -math.inf))
