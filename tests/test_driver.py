"""The driver: every episode logged as it finishes, and a resumed run (kill -9 included) replays
the log to exactly the uninterrupted result without running any episode twice."""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pytest

from gait import GENE_BOUNDS, repair_genes
from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.driver import BarProgress, Driver, ResumeMismatch
from optimizer.run.folder import EpisodeLog, read_episode_log
from optimizer.search.config import GAConfig, GALAConfig
from optimizer.search.ga import GARun
from optimizer.search.gala import GALA
from optimizer.seeds import stable_seed

TARGET = GENE_BOUNDS.mean(axis=1)
SPAN = GENE_BOUNDS[:, 1] - GENE_BOUNDS[:, 0]


def synthetic_fitness(genes: Sequence[float]) -> float:
    """A smooth hill over the TFS gene box: a stand-in for walking distance, no physics (a larger
    family's further genes do not move it)."""
    return float(50.0 - 40.0 * np.sum(((np.asarray(genes)[: len(TARGET)] - TARGET) / SPAN) ** 2))


class Killed(Exception):
    """What a kill -9 looks like to the test: the run stops between two episodes."""


class FakeEvaluator:
    """In-process evaluator with a synthetic fitness; remembers every key it evaluated and can be
    told to die after a number of episodes."""

    def __init__(self, die_after: int | None = None) -> None:
        self.evaluated: list[str] = []
        self.die_after = die_after

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        for task in reversed(tasks):  # any order is allowed
            if self.die_after is not None and len(self.evaluated) >= self.die_after:
                raise Killed()
            self.evaluated.append(task.key)
            fitness = synthetic_fitness(task.genes)
            yield EpisodeOutcome(
                task,
                0,
                {
                    "distance": fitness / 10,
                    "fell": False,
                    "time": 15.0,
                    "fitness": fitness,
                    "mean_speed": fitness / 150,
                    "status": "ok",
                    "reason": "",
                    "wall": 0.01,
                },
            )

    def close(self) -> None:
        pass


CONFIG = GALAConfig(ga=GAConfig(population_size=8, generations=3), iterations=6)


def gala(seed: int = 5) -> GALA:
    return GALA(GENE_BOUNDS, CONFIG, 0.8, seed, repair=repair_genes)


def drive(log_path: Path, evaluator: FakeEvaluator, seed: int = 5):
    with EpisodeLog(log_path) as log:
        return Driver(evaluator, log, run_seed=seed).run(gala(seed))


def same_result(a, b) -> None:
    assert a.best_fitness == b.best_fitness
    assert np.array_equal(a.best_genes, b.best_genes)
    assert a.optimal_mutation == b.optimal_mutation
    assert a.probabilities == b.probabilities
    assert a.iteration_log == b.iteration_log
    assert a.final_ga_history == b.final_ga_history


def test_every_episode_is_logged_once_with_its_seed(tmp_path: Path) -> None:
    evaluator = FakeEvaluator()
    result = drive(tmp_path / "episodes.jsonl", evaluator)
    records, warnings, _ = read_episode_log(tmp_path / "episodes.jsonl")
    assert warnings == [] and len(records) == len(evaluator.evaluated) == len(set(evaluator.evaluated))
    for key, record in records.items():
        assert record.seed == stable_seed(5, key)
        assert record.fitness == synthetic_fitness(record.genes)
    assert result.best_fitness == max(r.fitness for k, r in records.items() if k.startswith("pc0.8/final/"))


@pytest.mark.parametrize("die_after", [1, 17, 40, 70])
def test_a_killed_run_resumes_to_the_uninterrupted_result(tmp_path: Path, die_after: int) -> None:
    uninterrupted = drive(tmp_path / "whole.jsonl", FakeEvaluator())
    whole_log = read_episode_log(tmp_path / "whole.jsonl")[0]

    path = tmp_path / "episodes.jsonl"
    with pytest.raises(Killed):
        drive(path, FakeEvaluator(die_after=die_after))
    path.write_bytes(path.read_bytes() + b'{"key": "pc0.8/it0')  # and killed in the middle of a write
    logged = set(read_episode_log(path)[0])
    assert len(logged) == die_after

    resumed_evaluator = FakeEvaluator()
    resumed = drive(path, resumed_evaluator)
    same_result(resumed, uninterrupted)
    assert not logged & set(resumed_evaluator.evaluated)  # no logged episode ran again
    assert len(resumed_evaluator.evaluated) == len(set(resumed_evaluator.evaluated))
    final_log, warnings, _ = read_episode_log(path)
    assert warnings == []
    assert final_log.keys() == whole_log.keys()
    assert [r.genes for r in final_log.values()] == [whole_log[k].genes for k in final_log]


def test_a_complete_log_replays_without_any_episode(tmp_path: Path) -> None:
    first = drive(tmp_path / "episodes.jsonl", FakeEvaluator())
    again = FakeEvaluator()
    same_result(drive(tmp_path / "episodes.jsonl", again), first)
    assert again.evaluated == []


def test_a_log_of_another_search_is_refused(tmp_path: Path) -> None:
    drive(tmp_path / "episodes.jsonl", FakeEvaluator(), seed=5)
    with pytest.raises(ResumeMismatch, match="other genes, another start or another family"):
        drive(tmp_path / "episodes.jsonl", FakeEvaluator(), seed=6)


def test_a_logged_episode_of_another_family_is_refused_and_its_family_is_kept(tmp_path: Path) -> None:
    """The same key and genes walked as another family's gait are another walk: a log that holds
    it as a TFS gait does not answer it as a tfs-start gait. The family goes into the record."""
    genes = [15.0, 30.0, 10.0, 10.0, 20.0, 0.35, 15.708] * 2
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(FakeEvaluator(), log, run_seed=1)
        record = driver.walk([driver.task("refine/g000/i000", genes, family="tfs-start")])["refine/g000/i000"]
        assert record.family == "tfs-start"
        assert driver.walk([driver.task("refine/g000/i000", genes, family="tfs-start")])["refine/g000/i000"] == record
        with pytest.raises(ResumeMismatch, match="family tfs-start vs genes"):
            driver.walk([driver.task("refine/g000/i000", genes)])
    records, warnings, _ = read_episode_log(tmp_path / "episodes.jsonl")
    assert warnings == [] and records["refine/g000/i000"].family == "tfs-start"


def test_a_key_logged_twice_counts_once(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    uninterrupted = drive(tmp_path / "whole.jsonl", FakeEvaluator())
    with pytest.raises(Killed):
        drive(path, FakeEvaluator(die_after=12))
    lines = path.read_text().splitlines()
    duplicate = json.loads(lines[3])
    duplicate["fitness"] = 1e6  # a second record must never be the one the search is told
    path.write_text("\n".join(lines + [json.dumps(duplicate)]) + "\n")
    with EpisodeLog(path) as log:
        assert len(log.warnings) == 1
        resumed = Driver(FakeEvaluator(), log, run_seed=5).run(gala())
    same_result(resumed, uninterrupted)


def test_several_searches_share_one_log_and_the_progress_bar_counts_them(tmp_path: Path) -> None:
    bar = BarProgress(total=100, quiet=True)
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(FakeEvaluator(), log, run_seed=1, progress=bar)
        first = driver.run(GARun(GENE_BOUNDS, GAConfig(population_size=5, generations=2), 1, prefix="a"))
        driver.run(GARun(GENE_BOUNDS, GAConfig(population_size=5, generations=2), 1, prefix="b"))
    assert driver.evaluated == 2 * (5 + 4) == len(log.records)
    assert bar.best == max(r.fitness for r in log.records.values()) >= first.best_fitness
    assert bar.failed == 0


def test_the_bar_keeps_the_search_best_and_ends_full(capsys) -> None:
    bar = BarProgress(total=10)
    bar.episode(EpisodeRecord("a/i000", (1.0,), 3.0))
    bar.scored(3.0)
    bar.episode(EpisodeRecord("check/a/i000/r00", (1.0,), 9.0, WalkKind.CHECK, start=(0.1, 0.0, 2.0)))
    bar.episode(EpisodeRecord("a/i001", (2.0,), 0.0, status="failed"))
    bar.scored(0.0)
    assert bar.best == 3.0  # only scores told to a search count, not a check's walk
    assert bar.failed == 1
    bar.close(finished=True)
    shown = capsys.readouterr().err.split("\r")[-1]
    assert "100%" in shown and "3/3" in shown  # the planned 10 was an estimate; the run is done


def test_the_bar_plans_again_and_never_shows_more_walked_than_its_total(capsys) -> None:
    bar = BarProgress(total=2)
    for i in range(3):
        bar.episode(EpisodeRecord(f"a/i00{i}", (1.0,), 1.0))
        assert bar._bar.n <= bar._bar.total  # the estimate was 2: the total grows with the walks
    bar.plan(10)
    assert (bar._bar.n, bar._bar.total) == (3, 13)  # a later stage's estimate, after the walks so far
    bar.close()
    assert "3/13" in capsys.readouterr().err.split("\r")[-1]
