"""Stability check: does a found gait still walk when its start moves a little?

A search scores each gait by one walk from one start (eq. 9). On the deterministic stub that walk
is the same every time, so a gait that happened to get through one walk can sit on the edge of a
fall: the fastest walks of a GALA run often do (measured on one crossover-0.8 row: the learning
phase's fastest, 9.23 m, fell in 2 of 10 walks from starts moved by up to 5 cm and 10 deg; the next,
8.93 m, in none). A check walks the gait ``repeats`` times from starts drawn within +-jitter of
the run's start and counts the falls.

Check walks are episodes of the run like any other: keyed ``check/<checked key>/rNN``, logged with
their start, and answered from the log on ``--resume``. Their starts come from a seed of the run
and the checked key, so a resumed run asks the same walks.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from optimizer.episode import Start
from optimizer.evaluation.pool import stable_seed
from optimizer.evaluation.record import CHECK_PREFIX, EpisodeRecord, WalkKind
from optimizer.run.driver import Driver
from optimizer.search.config import StabilityConfig


def jittered_starts(base: Sequence[float], jitter: Sequence[float], count: int, seed: int) -> list[Start]:
    """``count`` start points (x, y, heading): ``base`` itself without jitter, else each drawn
    uniformly within +-``jitter`` of it."""
    if not any(jitter):
        return [(base[0], base[1], base[2])] * count
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-1.0, 1.0, size=(count, 3)) * np.asarray(jitter, dtype=float)
    return [(base[0] + dx, base[1] + dy, base[2] + dh) for dx, dy, dh in offsets.tolist()]


def standing_walks(records: Mapping[str, EpisodeRecord]) -> list[EpisodeRecord]:
    """The search's walks that ran and did not fall, fastest first (by key on a tie)."""
    walks = [r for r in records.values() if r.is_search and r.stood]
    return sorted(walks, key=lambda r: (-r.fitness, r.key))


def distance_spread(distances: Sequence[float]) -> tuple[float, float, float] | None:
    """(shortest, longest, mean) of walks' distances; None for no walk."""
    return (min(distances), max(distances), sum(distances) / len(distances)) if distances else None


@dataclass(frozen=True)
class StabilityReport:
    """The check of one logged walk: the walk itself and its repeats' log records."""

    walk: EpisodeRecord
    repeats: list[EpisodeRecord]

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

    def summary(self) -> str:
        spread = self.spread()
        text = "" if spread is None else f", {spread[0]:.2f}-{spread[1]:.2f} m (mean {spread[2]:.2f} m)"
        failed = f", {self.failed} could not be run" if self.failed else ""
        return f"fell in {self.falls} of {len(self.repeats)} moved starts{text}{failed}"

    def to_dict(self) -> dict[str, Any]:
        shortest, longest, mean = self.spread() or (None, None, None)
        ran = [r.distance for r in self.repeats if r.ran]
        return {
            "key": self.walk.key,
            "repeats": len(self.repeats),
            "falls": self.falls,
            "failed": self.failed,
            "min_distance": shortest,
            "max_distance": longest,
            "mean_distance": mean,
            "std_distance": float(np.std(ran, ddof=1)) if len(ran) > 1 else None,
            "walks": [
                {
                    "key": r.key,
                    "start": list(r.start or ()),
                    "distance": r.distance,
                    "fell": r.fell,
                    "time": r.time,
                    "status": r.status,
                }
                for r in self.repeats
            ],
        }


def check(driver: Driver, walk: EpisodeRecord, base: Start, config: StabilityConfig) -> StabilityReport:
    """Walk the gait of the logged ``walk`` ``config.repeats`` times from moved starts."""
    key = walk.key
    starts = jittered_starts(base, config.jitter, config.repeats, stable_seed(driver.run_seed, CHECK_PREFIX + key))
    tasks = [
        driver.task(f"{CHECK_PREFIX}{key}/r{j:02d}", walk.genes, start, WalkKind.CHECK)
        for j, start in enumerate(starts)
    ]
    records = driver.walk(tasks)
    return StabilityReport(walk, [records[task.key] for task in tasks])


def check_best(
    driver: Driver, best: EpisodeRecord | None, base: Start, config: StabilityConfig
) -> StabilityReport | None:
    """The check of a search's best walk; None when the search has none (every episode failed)
    or checks are off (``repeats`` 0)."""
    return None if best is None or config.repeats == 0 else check(driver, best, base, config)


def fastest_stable(
    driver: Driver, records: Mapping[str, EpisodeRecord], base: Start, config: StabilityConfig
) -> StabilityReport | None:
    """The fastest stable gait of the search so far: of its walks that did not fall, fastest
    first (one per gait), the first of ``config.candidates`` whose check has no fall; when none
    passes, the one that fell least (the faster on a tie). None when every walk fell."""
    reports: list[StabilityReport] = []
    seen: set[tuple[float, ...]] = set()
    for walk in standing_walks(records):
        if walk.genes in seen:
            continue
        seen.add(walk.genes)
        report = check(driver, walk, base, config)
        if report.stable:
            return report
        reports.append(report)
        if len(reports) == config.candidates:
            break
    return min(reports, key=lambda r: (r.falls + r.failed, -r.walk.fitness), default=None)
