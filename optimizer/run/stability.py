"""Stability check: does a found gait still walk across the real server's run-to-run spread?

A search scores each gait by one walk, or by a few dithered walks (``optimizer.run.robust``); a
gait that came through them can still sit on the edge of a fall. A check walks the gait
``repeats`` more times, each with its own seed of the run's command dither (the perturbation that
reproduces the real server's spread on the stand-in) and, where asked, from a start moved within
+-jitter, and counts the falls. Check walks are traced: their drift, turn and track make the walk
card of every gait a run reports (``optimizer.run.walk_card``).

Check walks are episodes of the run like any other: keyed ``check/<checked key>/rNN``, logged with
their start, and answered from the log on ``--resume``. Their seeds and starts come from the run's
seed and the checked key, so a resumed run asks the same walks.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from optimizer.episode import Start
from optimizer.evaluation.record import CHECK_PREFIX, EpisodeRecord, WalkKind
from optimizer.run.driver import Driver
from optimizer.run.robust import ScoredGait, moved_starts
from optimizer.search.config import StabilityConfig
from optimizer.seeds import stable_seed


def ranked_gaits(scored: Mapping[str, ScoredGait]) -> list[ScoredGait]:
    """The gaits the searches were told of, one per genes, leaving out those whose every walk fell
    or could not be run: the raced ones first (a robust score; a gait scored by one walk was, where
    racing ran, at or below the bar of its search when it was scored, and one lucky walk is what
    a check most often undoes), each group best score first (by key on a tie)."""
    standing = (g for g in scored.values() if any(w.stood for w in g.walks))
    ranked = sorted(standing, key=lambda g: (not g.raced, -g.fitness, g.key))
    seen: set[tuple[float, ...]] = set()
    out = []
    for gait in ranked:
        if gait.genes not in seen:
            seen.add(gait.genes)
            out.append(gait)
    return out


def distance_spread(distances: Sequence[float]) -> tuple[float, float, float] | None:
    """(shortest, longest, mean) of walks' distances; None for no walk."""
    return (min(distances), max(distances), sum(distances) / len(distances)) if distances else None


@dataclass(frozen=True)
class StabilityReport:
    """The check of one scored gait: the gait and its repeats' log records."""

    gait: ScoredGait
    repeats: list[EpisodeRecord]

    @property
    def walk(self) -> EpisodeRecord:
        """The walk that found the gait (its first)."""
        return self.gait.walks[0]

    @property
    def falls(self) -> int:
        return sum(1 for r in self.repeats if r.ran and r.fell)

    @property
    def failed(self) -> int:
        """Repeats the infrastructure could not run (neither a walk nor a fall)."""
        return sum(1 for r in self.repeats if not r.ran)

    @property
    def stable(self) -> bool:
        """Every repeat ran and none fell."""
        return self.falls == 0 and self.failed == 0

    def spread(self) -> tuple[float, float, float] | None:
        """(shortest, longest, mean) distance of the repeats that ran; None when none did."""
        return distance_spread([r.distance for r in self.repeats if r.ran])

    @property
    def mean_distance(self) -> float:
        spread = self.spread()
        return 0.0 if spread is None else spread[2]

    def fitness_spread(self) -> tuple[float, float]:
        """(worst, mean) fitness of the repeats that ran (eq. 9: 10 x the distance, less any drift
        penalty of the run); (0, 0) when none did."""
        ran = [r.fitness for r in self.repeats if r.ran]
        return (min(ran), sum(ran) / len(ran)) if ran else (0.0, 0.0)

    def finish_times(self) -> list[float] | None:
        """A course check's finished walks' times (s); None for a check of walks scored by eq. 9."""
        if not any(r.on_course for r in self.repeats):
            return None
        return [r.time for r in self.repeats if r.ran and r.finished]

    def summary(self) -> str:
        times = self.finish_times()
        if times is not None:  # a course: a distance is metres of course done, the time is what counts
            text = f", finished {len(times)}" + (
                f" in {min(times):.2f}-{max(times):.2f} s (mean {sum(times) / len(times):.2f} s)" if times else ""
            )
            failed = f", {self.failed} could not be run" if self.failed else ""
            return f"fell in {self.falls} of {len(self.repeats)} check walks{text}{failed}"
        spread = self.spread()
        text = "" if spread is None else f", {spread[0]:.2f}-{spread[1]:.2f} m (mean {spread[2]:.2f} m)"
        failed = f", {self.failed} could not be run" if self.failed else ""
        return f"fell in {self.falls} of {len(self.repeats)} check walks{text}{failed}"

    def to_dict(self) -> dict[str, Any]:
        """The check for results.json; a course check adds how many finished and their mean time,
        and each walk whether it finished and the poses it reached (its distance: metres of course done)."""
        shortest, longest, mean = self.spread() or (None, None, None)
        ran = [r.distance for r in self.repeats if r.ran]
        times = self.finish_times()
        course = (
            {} if times is None else {"finished": len(times), "mean_time": sum(times) / len(times) if times else None}
        )
        return {
            "key": self.gait.key,
            "score": self.gait.fitness,
            "repeats": len(self.repeats),
            "falls": self.falls,
            "failed": self.failed,
            "min_distance": shortest,
            "max_distance": longest,
            "mean_distance": mean,
            "std_distance": float(np.std(ran, ddof=1)) if len(ran) > 1 else None,
            **course,
            "walks": [
                {
                    "key": r.key,
                    "start": list(r.start or ()),
                    "distance": r.distance,
                    "fell": r.fell,
                    "time": r.time,
                    "status": r.status,
                    **({} if r.finished is None else {"finished": r.finished, "reached": r.reached}),
                }
                for r in self.repeats
            ],
        }


def check(driver: Driver, gait: ScoredGait, base: Start, config: StabilityConfig) -> StabilityReport:
    """Walk ``gait`` ``config.repeats`` times, each walk with its own dither seed (and start, when
    the check moves starts), traced."""
    key = gait.key
    starts = moved_starts(base, config.jitter, config.repeats, stable_seed(driver.run_seed, CHECK_PREFIX + key))
    tasks = [
        driver.task(f"{CHECK_PREFIX}{key}/r{j:02d}", gait.genes, start, WalkKind.CHECK, trace=True, family=gait.family)
        for j, start in enumerate(starts)
    ]
    records = driver.walk(tasks)
    return StabilityReport(gait, [records[task.key] for task in tasks])


def check_best(driver: Driver, best: ScoredGait | None, base: Start, config: StabilityConfig) -> StabilityReport | None:
    """The check of a search's best gait; None when the search has none (every episode failed)
    or checks are off (``repeats`` 0)."""
    return None if best is None or config.repeats == 0 else check(driver, best, base, config)


def fastest_stable(
    driver: Driver,
    scored: Mapping[str, ScoredGait],
    base: Start,
    config: StabilityConfig,
    hand_over: bool = False,
    fallback: Sequence[ScoredGait] = (),
    by_family: bool = False,
) -> StabilityReport | None:
    """The fastest stable gait of the run so far: the ``config.candidates`` best-scored gaits
    (``ranked_gaits``; ``by_family``: of each gait family, ``check_candidates``) are each checked,
    those that held walk ``config.confirm`` more walks (their check goes on: the same seeds and
    starts, more of them), and of all the candidates the one that fell in the smallest share of its
    walks (none, when one holds) and whose worst walk scored highest is it (then the higher on
    average; a walk's score is 10 x its distance, less the run's drift penalty where it has one).
    Checking all of them, not stopping at the first that passes, lets a gait scored a little lower
    but steadier win. The worst walk, not the mean, because a wide spread on the stand-in is a
    margin the real server can cross (docs/optimizer.md, "The hand-over"). None when every gait
    fell.

    With ``hand_over`` (the gait the run hands over at its end) the winners then walk on, in that
    order, towards ``config.hand_over`` walks each, ``config.repeats`` at a time and no further once
    one fell, and the first that holds them all is it: a fall one walk in 30 hides in 30 walks
    a third of the time, and the stand-in shows such a gait's falls as often as the real server does
    (docs/optimizer.md, "The hand-over"). When none holds, the ``fallback`` gaits (what the search
    started from) walk the same, in order; when none of those holds either, the gait that fell in
    the smallest share of its walks is it."""
    return _pick(driver, scored, base, config, hand_over, fallback, by_family)[0]


def check_candidates(ranked: Sequence[ScoredGait], count: int, by_family: bool = False) -> list[ScoredGait]:
    """The gaits the checks walk, best-scored first: the ``count`` best; ``by_family``, the
    ``count`` best of each gait family. A refinement of several families gives each its own
    candidates: the ten best-scored of a quick run can all come from one CMA-ES run's ridge in one
    family and all fall, while the other family's walks were never checked (docs/optimizer.md)."""
    if not by_family:
        return list(ranked[:count])
    taken: dict[str | None, int] = {}
    out = []
    for gait in ranked:
        if taken.get(gait.family, 0) < count:
            taken[gait.family] = taken.get(gait.family, 0) + 1
            out.append(gait)
    return out


def _pick(
    driver: Driver,
    scored: Mapping[str, ScoredGait],
    base: Start,
    config: StabilityConfig,
    hand_over: bool,
    fallback: Sequence[ScoredGait],
    by_family: bool = False,
) -> tuple[StabilityReport | None, list[StabilityReport]]:
    """``fastest_stable``'s pick, and the candidates' reports."""
    candidates = check_candidates(ranked_gaits(scored), config.candidates, by_family)
    reports = [check(driver, gait, base, config) for gait in candidates]
    if config.confirm:
        longer = replace(config, repeats=config.repeats + config.confirm)
        reports = [check(driver, r.gait, base, longer) if r.stable else r for r in reports]
    reports.sort(key=_steadiest_first)
    if not (hand_over and config.hand_over):  # no hand-over walks (--hand-over-walks 0, or an older run)
        return (reports[0] if reports else None), reports
    for i, report in enumerate(reports):
        if not report.stable:
            break
        reports[i] = _walk_on(driver, report, base, config)
        if reports[i].stable:
            return reports[i], reports
    walked = {(r.gait.genes, r.gait.family) for r in reports}
    tried = []
    for gait in fallback:
        if (gait.genes, gait.family) not in walked:
            tried.append(_walk_on(driver, check(driver, gait, base, config), base, config))
            if tried[-1].stable:
                return tried[-1], reports
    return min(reports + tried, key=_steadiest_first, default=None), reports


def _walk_on(driver: Driver, report: StabilityReport, base: Start, config: StabilityConfig) -> StabilityReport:
    """``report``'s check gone on towards ``config.hand_over`` walks in batches of
    ``config.repeats``, stopped after the batch of its first fall: the walks a failing candidate
    is asked depend on the settings alone, not on how many workers walk them."""
    while report.stable and len(report.repeats) < config.hand_over:
        walks = min(len(report.repeats) + max(config.repeats, 1), config.hand_over)
        report = check(driver, report.gait, base, replace(config, repeats=walks))
    return report


def _steadiest_first(report: StabilityReport) -> tuple[Any, ...]:
    """The hand-over's order: the smallest share of walks fallen or not run, then the best worst
    walk, then the best mean, then the key."""
    share = (report.falls + report.failed) / len(report.repeats)
    return (share, *(-f for f in report.fitness_spread()), report.gait.key)


def scored_summary(gait: ScoredGait) -> dict[str, Any]:
    """A scored gait for results.json: its score and the walks behind it."""
    return {
        "key": gait.key,
        "score": gait.fitness,
        "walks": len(gait.walks),
        "falls": gait.falls,
        "mean_distance": gait.mean_distance,
    }


@dataclass
class Fastest:
    """The fastest gait of a run so far and its check (None when checks are off): what the run
    hands over as fastest_gait.json. ``faster``: when the hand-over fell back to a gait the search
    started from, the steadiest of the faster candidates that did not hold."""

    gait: ScoredGait
    check: StabilityReport | None
    faster: StabilityReport | None = None

    def describe(self) -> str:
        gait, check = self.gait, self.check
        text = f"{gait.describe()} ({gait.key})"
        if check is None:
            return f"best-scored gait (unchecked): {text}"
        verdict = "fastest walk that held" if check.stable else "NO FAST WALK HELD; the steadiest, which FALLS"
        passed = ""
        if self.faster is not None:
            faster = self.faster
            passed = f"; faster, but it {faster.summary()} ({faster.gait.key}), so not handed over"
        return f"{verdict}: {check.summary()}; scored {text}{passed}"


def fastest_walk(
    driver: Driver,
    base: Start,
    config: StabilityConfig,
    hand_over: bool = False,
    fallback: Sequence[ScoredGait] = (),
    by_family: bool = False,
) -> Fastest | None:
    """The run's fastest walk: ``fastest_stable`` over everything it scored (``hand_over``: the one
    the run ends with, ``fallback`` the gaits its search started from, ``by_family`` candidates of
    each gait family), or with checks off the best-scored gait. None before any gait was scored."""
    if config.repeats == 0:
        ranked = ranked_gaits(driver.scored)
        return Fastest(ranked[0], None) if ranked else None
    report, candidates = _pick(driver, driver.scored, base, config, hand_over, fallback, by_family)
    if report is None:
        return None
    fell_back = bool(candidates) and report.stable and not any(report is r for r in candidates)
    return Fastest(report.gait, report, min(candidates, key=_steadiest_first) if fell_back else None)
