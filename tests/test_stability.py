"""The stability check: repeats walk the checked gait from seeded moved starts, are logged with
their start and answered from the log on resume; the fastest stable gait is the fastest walk whose
check has no fall. A fake evaluator decides falls from the start, no physics."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.driver import Driver, ResumeMismatch
from optimizer.run.folder import EpisodeLog, read_episode_log
from optimizer.run.robust import ScoredGait, jittered_starts
from optimizer.run.stability import check, check_best, fastest_stable, fastest_walk
from optimizer.search.config import StabilityConfig
from optimizer.seeds import stable_seed

BASE = (-3.0, 1.0, 30.0)
CONFIG = StabilityConfig(repeats=6, jitter=(0.05, 0.05, 10.0), candidates=3)


class StartSensitive:
    """Distance = first gene; a gait whose first gene is in ``fragile`` falls from any start moved
    to the +x side of the base (about half of them), never from the base itself."""

    def __init__(self, fragile: Sequence[float] = ()) -> None:
        self.fragile = set(fragile)
        self.tasks: list[EpisodeTask] = []

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        for task in tasks:
            self.tasks.append(task)
            moved = task.start is not None and task.start[0] > BASE[0]
            fell = moved and task.genes[0] in self.fragile
            distance = task.genes[0]
            yield EpisodeOutcome(
                task,
                0,
                {
                    "distance": distance,
                    "fell": fell,
                    "time": 15.0,
                    "fitness": 10 * distance,
                    "mean_speed": distance / 15,
                    "status": "ok",
                    "reason": "",
                    "wall": 0.0,
                },
            )

    def close(self) -> None:
        pass


def search_walk(driver: Driver, key: str, *genes: float) -> ScoredGait:
    """A candidate scored by one walk, as a search scores it (``Driver.score``)."""
    return driver.score([(key, genes)], driver.race())[0]


def test_a_check_walks_the_gait_from_seeded_moved_starts_and_counts_falls(tmp_path: Path) -> None:
    evaluator = StartSensitive(fragile=[4.0])
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=3)
        walk = search_walk(driver, "pc0.8/final/g01/i002", 4.0, 0.5)
        report = check(driver, walk, BASE, CONFIG)
    repeats = report.repeats
    assert [r.key for r in repeats] == [f"check/pc0.8/final/g01/i002/r{j:02d}" for j in range(6)]
    assert all(r.genes == (4.0, 0.5) for r in repeats)
    starts = [r.start for r in repeats]
    assert starts == jittered_starts(BASE, CONFIG.jitter, 6, stable_seed(3, "check/pc0.8/final/g01/i002"))
    assert report.falls == sum(s[0] > BASE[0] for s in starts) and 0 < report.falls < 6
    assert not report.stable and report.failed == 0
    assert f"fell in {report.falls} of 6 check walks, 4.00-4.00 m (mean 4.00 m)" == report.summary()
    assert report.to_dict()["mean_distance"] == 4.0 and report.to_dict()["falls"] == report.falls
    logged = read_episode_log(tmp_path / "episodes.jsonl")[0]
    assert [logged[r.key].start for r in repeats] == starts
    assert [logged[r.key].kind for r in repeats] == [WalkKind.CHECK] * 6 and logged[walk.key].kind is WalkKind.SEARCH


def test_a_check_without_jitter_walks_from_the_runs_start_each_walk_its_own_dither_seed_traced(
    tmp_path: Path,
) -> None:
    evaluator = StartSensitive()
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=3)
        report = check(driver, search_walk(driver, "a/i000", 2.0), BASE, StabilityConfig(repeats=4, jitter=(0, 0, 0)))
    tasks = evaluator.tasks[1:]
    assert [t.key for t in tasks] == [r.key for r in report.repeats] and len(tasks) == 4
    assert all(t.start is None and t.trace and t.kind is WalkKind.CHECK for t in tasks)
    assert len({t.seed for t in tasks}) == 4 and not evaluator.tasks[0].trace


def test_the_fastest_stable_gait_is_the_farthest_checked_walk_that_held(tmp_path: Path) -> None:
    """Scored first is not checked farthest: of the candidates that hold, the one whose worst check
    walk went farthest wins, though its search score was lower."""

    class CheckFarther(StartSensitive):
        def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
            for outcome in super().evaluate(tasks):
                bonus = 3.0 if outcome.task.kind is WalkKind.CHECK and outcome.task.genes[0] == 6.0 else 0.0
                distance = outcome.result["distance"] + bonus
                yield EpisodeOutcome(
                    outcome.task, 0, {**outcome.result, "distance": distance, "fitness": 10 * distance}
                )

    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(CheckFarther(), log, run_seed=1)
        for key, first_gene in (("s/i000", 7.0), ("s/i001", 6.0)):
            search_walk(driver, key, first_gene)
        report = fastest_stable(driver, driver.scored, BASE, CONFIG)
    assert report is not None and report.gait.key == "s/i001" and report.mean_distance == 9.0


def test_a_searchs_best_is_checked_unless_there_is_none_or_checks_are_off(tmp_path: Path) -> None:
    evaluator = StartSensitive()
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=3)
        walk = search_walk(driver, "a/i000", 2.0)
        assert check_best(driver, None, BASE, CONFIG) is None
        assert check_best(driver, walk, BASE, StabilityConfig(repeats=0)) is None
        assert len(evaluator.tasks) == 1  # neither walked anything
        checked = check_best(driver, walk, BASE, CONFIG)
    assert checked is not None and len(checked.repeats) == CONFIG.repeats and len(evaluator.tasks) == 1 + CONFIG.repeats


def test_a_resumed_check_is_answered_from_the_log_and_another_start_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    with EpisodeLog(path) as log:
        driver = Driver(StartSensitive(), log, run_seed=3)
        first = check(driver, search_walk(driver, "a/i000", 2.0), BASE, CONFIG)
    again = StartSensitive()
    with EpisodeLog(path) as log:
        driver = Driver(again, log, run_seed=3)
        second = check(driver, search_walk(driver, "a/i000", 2.0), BASE, CONFIG)
        assert again.tasks == [] and second.repeats == first.repeats
        # the same keys from another base point are other walks: the log cannot answer them
        with pytest.raises(ResumeMismatch, match="another start"):
            check(driver, driver.scored["a/i000"], (0.0, 0.0, 0.0), CONFIG)
    other_seed = StartSensitive()
    with EpisodeLog(tmp_path / "other.jsonl") as log:
        driver = Driver(other_seed, log, run_seed=4)
        third = check(driver, search_walk(driver, "a/i000", 2.0), BASE, CONFIG)
    assert [r.start for r in third.repeats] != [r.start for r in first.repeats]


def test_the_fastest_stable_gait_skips_fast_walks_that_fall_from_moved_starts(tmp_path: Path) -> None:
    evaluator = StartSensitive(fragile=[9.0, 8.0])
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for key, first_gene in (("s/i000", 9.0), ("s/i001", 8.0), ("s/i002", 8.0), ("s/i003", 7.0), ("s/i004", 6.0)):
            search_walk(driver, key, first_gene)
        report = fastest_stable(driver, driver.scored, BASE, CONFIG)
    assert report is not None and report.stable and report.walk.key == "s/i003"
    checked = {t.key.rsplit("/", 1)[0] for t in evaluator.tasks if t.start is not None}
    # the 3 best-scored gaits, one check per gait (s/i002 has s/i001's genes)
    assert checked == {"check/s/i000", "check/s/i001", "check/s/i003"}


def test_when_no_candidate_passes_the_one_that_fell_least_is_kept(tmp_path: Path) -> None:
    evaluator = StartSensitive(fragile=[9.0, 8.0, 7.0, 6.0])
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for k, first_gene in enumerate((9.0, 8.0, 7.0, 6.0)):
            search_walk(driver, f"s/i{k:03d}", first_gene)
        report = fastest_stable(driver, driver.scored, BASE, CONFIG)
        records = dict(log.records)
    assert report is not None and not report.stable
    checked = sorted({t.key.rsplit("/", 1)[0] for t in evaluator.tasks if t.start is not None})
    assert checked == ["check/s/i000", "check/s/i001", "check/s/i002"]  # CONFIG.candidates = 3
    # each candidate's starts are its own draw, so their falls differ: the fewest win, then the faster
    falls = {k: sum(r.fell for key, r in records.items() if key.startswith(f"check/s/i{k:03d}/")) for k in range(3)}
    least = min(range(3), key=lambda k: (falls[k], -records[f"s/i{k:03d}"].fitness))
    assert report.walk.key == f"s/i{least:03d}" and report.falls == falls[least]


class FallsLate(StartSensitive):
    """As ``StartSensitive``, and a gait whose first gene is in ``late`` falls in its check walks
    from the seventh on (r06 ...): it holds a 6-walk check and fails its confirmation. ``later``
    maps a first gene to the first check walk it falls in."""

    def __init__(self, late: Sequence[float], later: dict[float, int] | None = None) -> None:
        super().__init__()
        self.late = {gene: 6 for gene in late} | (later or {})

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        for outcome in super().evaluate(tasks):
            task = outcome.task
            walk = int(task.key.rsplit("/r", 1)[1]) if task.kind is WalkKind.CHECK else -1
            late = task.genes[0] in self.late and walk >= self.late[task.genes[0]]
            yield EpisodeOutcome(task, 0, {**outcome.result, "fell": late or outcome.result["fell"]})


def test_candidates_that_held_their_check_walk_the_confirmation_and_the_luckiest_is_not_handed_over(
    tmp_path: Path,
) -> None:
    """The fastest candidate holds its 6 check walks and then falls: the confirmation walks of the
    same check (the same seeds and starts, r06 ... r09) find it, and the slower one that holds all 10
    is handed over. A candidate that fell in its check walks no confirmation."""
    config = StabilityConfig(repeats=6, jitter=(0.05, 0.05, 10.0), candidates=3, confirm=4)
    evaluator = FallsLate(late=[9.0])
    evaluator.fragile = {8.0}
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for key, first_gene in (("s/i000", 9.0), ("s/i001", 8.0), ("s/i002", 7.0)):
            search_walk(driver, key, first_gene)
        report = fastest_stable(driver, driver.scored, BASE, config)
        plain = check(driver, driver.scored["s/i002"], BASE, CONFIG)
        unconfirmed = fastest_stable(driver, driver.scored, BASE, replace(config, confirm=0))
    assert report is not None and report.stable and report.walk.key == "s/i002" and len(report.repeats) == 10
    assert report.repeats[:6] == plain.repeats  # the confirmation goes on with the check it had
    walked = [t.key for t in evaluator.tasks if t.kind is WalkKind.CHECK]
    assert len(walked) == len(set(walked)) == 6 + 4 + 6 + 6 + 4  # no walk asked twice
    assert not any(k.startswith("check/s/i001/") and int(k[-2:]) >= 6 for k in walked)  # fell in its check
    assert sum(1 for k in walked if k.startswith("check/s/i000/")) == 10
    assert unconfirmed is not None and unconfirmed.walk.key == "s/i000" and len(unconfirmed.repeats) == 6


def test_the_hand_over_walks_the_confirmed_candidates_on_until_one_holds_them_all(tmp_path: Path) -> None:
    """The fastest candidate holds its check and its confirmation (10 walks) and falls in its 13th
    walk: the hand-over walks it on to 16 (a batch of 6), then the next, which holds them all and is
    handed over;
    the third is not walked on. Without ``hand_over`` the fastest is still the pick."""
    config = StabilityConfig(repeats=6, jitter=(0.05, 0.05, 10.0), candidates=3, confirm=4, hand_over=16)
    evaluator = FallsLate(late=[], later={9.0: 12})
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for key, first_gene in (("s/i000", 9.0), ("s/i001", 8.0), ("s/i002", 7.0)):
            search_walk(driver, key, first_gene)
        confirmed = fastest_stable(driver, driver.scored, BASE, config)
        handed = fastest_stable(driver, driver.scored, BASE, config, hand_over=True)
    assert confirmed is not None and confirmed.walk.key == "s/i000" and len(confirmed.repeats) == 10
    assert handed is not None and handed.stable and handed.walk.key == "s/i001" and len(handed.repeats) == 16
    assert handed.repeats[:10] == check(driver, driver.scored["s/i001"], BASE, replace(config, repeats=10)).repeats
    walked = [t.key for t in evaluator.tasks if t.kind is WalkKind.CHECK]
    assert len(walked) == len(set(walked)) == 3 * 10 + 6 + 6  # no walk asked twice
    assert sum(1 for k in walked if k.startswith("check/s/i002/")) == 10


def test_when_no_candidate_holds_the_hand_over_the_one_that_fell_least_is_handed_over(tmp_path: Path) -> None:
    """Both confirmed candidates fall in the hand-over's walks, the faster in more of them: the
    slower is handed over, marked as falling."""
    config = StabilityConfig(repeats=6, jitter=(0.05, 0.05, 10.0), candidates=2, confirm=4, hand_over=20)
    evaluator = FallsLate(late=[], later={9.0: 12, 8.0: 17})
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for key, first_gene in (("s/i000", 9.0), ("s/i001", 8.0)):
            search_walk(driver, key, first_gene)
        handed = fastest_stable(driver, driver.scored, BASE, config, hand_over=True)
    assert handed is not None and handed.walk.key == "s/i001" and (handed.falls, len(handed.repeats)) == (3, 20)
    walked = [t.key for t in evaluator.tasks if t.kind is WalkKind.CHECK]
    # in batches of the check's 6: the faster stopped after the batch it fell in (r10-r15)
    assert sum(1 for k in walked if k.startswith("check/s/i000/")) == 16


def test_when_no_candidate_holds_the_hand_over_the_gait_the_search_started_from_may(tmp_path: Path) -> None:
    """Both candidates fall in the hand-over's walks; the fallback (a slower gait the search
    started from, scored but not among the candidates) holds them all and is handed over, with
    the steadiest faster one named as passed over. A run made before hand-over walks
    (``hand_over`` 0) walks no fallback."""
    config = StabilityConfig(repeats=6, jitter=(0.05, 0.05, 10.0), candidates=2, confirm=4, hand_over=20)
    evaluator = FallsLate(late=[], later={9.0: 12, 8.0: 17})
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(evaluator, log, run_seed=1)
        for key, first_gene in (("s/i000", 9.0), ("s/i001", 8.0), ("s/i002", 5.0)):
            search_walk(driver, key, first_gene)
        start = driver.scored["s/i002"]
        old = fastest_walk(driver, BASE, replace(config, hand_over=0), hand_over=True, fallback=[start])
        assert old is not None and old.gait.key == "s/i000" and old.faster is None
        assert not any(t.key.startswith("check/s/i002/") for t in evaluator.tasks)
        fastest = fastest_walk(driver, BASE, config, hand_over=True, fallback=[start])
    assert fastest is not None and fastest.gait.key == "s/i002" and fastest.check is not None
    assert fastest.check.stable and len(fastest.check.repeats) == 20
    assert fastest.faster is not None and fastest.faster.gait.key == "s/i001" and fastest.faster.falls == 3
    assert "faster, but it fell in 3 of 20 check walks" in fastest.describe()


def test_every_walk_fell_gives_no_fastest(tmp_path: Path) -> None:
    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(StartSensitive(), log, run_seed=1)
        walk = EpisodeRecord("s/i000", (1.0,), 3.0, seed=0, worker=0, distance=0.3, fell=True, time=2.0)
        driver.scored["s/i000"] = ScoredGait(walk.key, walk.genes, walk.fitness, (walk,))
        assert fastest_stable(driver, driver.scored, BASE, CONFIG) is None


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-10, 10), min_size=3, max_size=3),
    st.lists(st.floats(0, 2), min_size=3, max_size=3),
    st.integers(1, 20),
    st.integers(0, 2**32),
)
def test_jittered_starts_stay_within_the_jitter_and_follow_the_seed(base, jitter, count, seed) -> None:
    points = jittered_starts(base, jitter, count, seed)
    assert len(points) == count
    for point in points:
        assert all(abs(p - b) <= j + 1e-9 for p, b, j in zip(point, base, jitter))
    assert points == jittered_starts(base, jitter, count, seed)
    if not any(jitter):
        assert points == [tuple(base)] * count


def test_a_stability_config_refuses_impossible_values() -> None:
    for bad in (
        {"repeats": -1},
        {"jitter": (0.1, 0.1)},
        {"jitter": (0.1, -0.1, 0.0)},
        {"jitter": (0.1, float("inf"), 0.0)},
        {"candidates": 0},
        {"confirm": -1},
        {"hand_over": -1},
    ):
        with pytest.raises(ValueError, match="StabilityConfig"):
            StabilityConfig(**bad)
