"""Where a candidate gait is scored for a search: by one walk, or robustly over dithered walks, raced.

One walk of a gait on the stand-in is one draw of a chaotic process: the real server walks the
same gait a few per cent differently run to run, and a gait on the edge of a fall falls in some of
its walks. A search scored by one walk therefore rewards the luckiest draw it meets (measured: 8 of
the 12 farthest single walks of a 16,000-episode comparison fell on the real server). Here a gait
is scored over ``ScoringConfig.walks`` walks, each with its own seed of the agent's command
dither, calibrated to reproduce the real server's spread on the stand-in, and all but the first
from a start moved within the real server's beam noise (docs/optimizer.md).

The k walks' score is a low quantile of their eq. 9 fitness by default (``ScoringConfig``).

Racing keeps the cost low: every candidate walks once; only one whose first walk could put it
among the ``top`` best scores of its search so far walks the other k - 1 times (``Race.choose``,
asked again after each round of scores until no candidate left could enter). A candidate that
does not qualify keeps its one walk's value, which lies at or below the bar (and, where a search
races leaders, just under the best leader's score), so it is never taken for one of the search's
best.

A search may also race its leaders (``ScoringConfig.lead_walks``; the main job's refinement does):
a candidate whose score over k walks would make it the search's best walks on to ``lead_walks``
walks first, and is scored over all of them. k walks cannot see a gait that falls once in 30
walks; twenty catch it half the time, at the cost of the few gaits that ever lead.

The extra walks of a candidate are episodes of the run like any other, keyed ``<key>/kN``: a
resumed run replays the race from the log and reaches the same scores.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from optimizer.episode import Start
from optimizer.evaluation.record import EpisodeRecord
from optimizer.search.config import ScoringConfig


def jittered_starts(base: Sequence[float], jitter: Sequence[float], count: int, seed: int) -> list[Start]:
    """``count`` start points (x, y, heading): ``base`` itself without jitter, else each drawn
    uniformly within +-``jitter`` of it."""
    if not any(jitter):
        return [(base[0], base[1], base[2])] * count
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-1.0, 1.0, size=(count, 3)) * np.asarray(jitter, dtype=float)
    return [(base[0] + dx, base[1] + dy, base[2] + dh) for dx, dy, dh in offsets.tolist()]


def moved_starts(base: Sequence[float], jitter: Sequence[float], count: int, seed: int) -> list[Start | None]:
    """The starts of ``count`` walks of one gait: None (the run's own start, as a walk that was not
    moved is logged) without a jitter, else ``jittered_starts``."""
    return list(jittered_starts(base, jitter, count, seed)) if any(jitter) else [None] * count


def extra_key(key: str, walk: int) -> str:
    """The key of walk ``walk`` (1 ... k - 1, then a leader's on to ``lead_walks`` - 1) of the
    candidate ``key``; walk 0 is ``key`` itself."""
    return f"{key}/k{walk}"


@dataclass(frozen=True)
class ScoredGait:
    """A candidate as its search was told it: its key, genes, score and the walks behind it (one,
    or k when it was raced); ``family`` where its genes are not of the run's family."""

    key: str
    genes: tuple[float, ...]
    fitness: float
    walks: tuple[EpisodeRecord, ...]
    family: str | None = None

    @property
    def raced(self) -> bool:
        return len(self.walks) > 1

    @property
    def falls(self) -> int:
        return sum(1 for w in self.walks if w.ran and w.fell)

    @property
    def mean_distance(self) -> float:
        ran = [w.distance for w in self.walks if w.ran]
        return sum(ran) / len(ran) if ran else 0.0

    def describe(self) -> str:
        walks = self.walks
        if walks[0].on_course:
            return describe_course_walks(walks)
        if len(walks) == 1:
            w = walks[0]
            return f"{w.distance:.2f} m in {w.time:g} s" + (" (fell)" if w.fell else "")
        return f"{self.mean_distance:.2f} m mean of {len(walks)} walks, {self.falls} fell"


def describe_course_walks(walks: Sequence[EpisodeRecord]) -> str:
    """Course walks in a phrase: whether they finished and in what time, the poses an unfinished
    one reached (a course's distance is metres of course done, and its time the walk's own)."""
    ran = [w for w in walks if w.ran]
    falls = sum(1 for w in ran if w.fell)
    if len(walks) == 1:
        w = walks[0]
        if w.finished:
            return f"course finished in {w.time:.2f} s"
        return f"course not finished: {w.reached} poses reached in {w.time:.2f} s" + (" (fell)" if w.fell else "")
    times = [w.time for w in ran if w.finished]
    text = f"course finished in {len(times)} of {len(walks)} walks"
    if times:
        text += f", {sum(times) / len(times):.2f} s mean ({min(times):.2f}-{max(times):.2f} s)"
    return f"{text}, {falls} fell"


class Race:
    """One search's scoring: the bar a first walk must clear to earn the other walks (the
    ``top``-th best raced score of this search so far). Each search races on its own, so a Table I
    row does not depend on the rows before it."""

    def __init__(self, config: ScoringConfig) -> None:
        self.config = config
        self._best: list[float] = []  # the top raced scores, ascending
        self._lead = -math.inf  # the best score over ``lead_walks`` walks

    def score(self, walks: Sequence[EpisodeRecord]) -> float:
        """What the search is told: a single walk's eq. 9 fitness (the paper's, unchanged), else
        the quantile (or mean) of the walks' fitness, each walk counted as eq. 9 counts it (a
        fall at the distance it had reached). Once the search has a leader, a gait left at one
        walk is told at most just under the best leader's score (``lead``)."""
        values = [w.fitness for w in walks]
        if len(values) == 1:
            led = self._lead > -math.inf
            return min(values[0], math.nextafter(self._lead, -math.inf)) if led else values[0]
        if self.config.quantile is None:
            return float(np.mean(values))
        return float(np.quantile(values, self.config.quantile))

    def choose(self, firsts: Sequence[tuple[str, EpisodeRecord]]) -> list[str]:
        """Of these candidates' first walks (not raced yet), the keys that walk their other k - 1
        walks now: those that could enter the top, at most ``top`` of them (more on a tie), the
        best first. Asked again after their scores enter, until it names none; then every
        candidate left with one walk is at most the ``top``-th best raced score, so a single
        lucky walk is never a search's best once ``top`` gaits have been raced."""
        if not self.config.robust:
            return []
        open_ = [(key, walk.fitness) for key, walk in firsts if walk.ran]
        pool = sorted([*self._best, *(f for _, f in open_)], reverse=True)
        if not pool:
            return []
        threshold = pool[min(self.config.top, len(pool)) - 1]
        floor = self._best[0] if len(self._best) >= self.config.top else -math.inf
        return [key for key, f in open_ if f >= threshold and f > floor]

    def enter(self, fitness: float) -> None:
        """A raced score joins the bar."""
        bisect.insort(self._best, fitness)
        del self._best[: max(0, len(self._best) - self.config.top)]

    def leaders(self, raced: Sequence[tuple[str, float]]) -> list[str]:
        """Of these candidates' scores over k walks, the keys that walk on to ``lead_walks``: every
        one that would be its search's best (above the best score over ``lead_walks`` walks so
        far). Asked again after their scores enter (``lead``), until it names none; so a search's
        best is always a gait scored over ``lead_walks`` walks."""
        if not self.config.lead_walks:
            return []
        return [key for key, fitness in raced if fitness > self._lead]

    def lead(self, fitness: float) -> None:
        """A score over ``lead_walks`` walks joins the leaders' bar. The racing bar keeps the
        leader's k-walk score, which is mostly above it (the worst of 20 walks is lower than the
        worst of 5), so a first walk left under that bar may lie above every leader's score:
        ``score`` tells it just under the best, or it would be the search's best on one walk.
        Racing such walks instead cost a refinement many more walks (docs/optimizer.md, "Leaders")."""
        self._lead = max(self._lead, fitness)
